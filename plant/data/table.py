"""The one reader of a CSV table, whatever the recording's kind: the header, blank lines skipped, each data
row's number in the file, and numeric columns read fast (``numpy.loadtxt``) or, when a cell is not a
number, cell by cell so that the error names its row and column. ``streamed_numbers`` reads a plain,
all-numeric CSV straight from the file in numpy's chunks (memory about that of the numbers, below the file's
size), and leaves every other file to ``CsvTable``; ``NumericCsv`` puts the two behind one reader."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from plant.errors import DataError
from plant.host.text_io import CHUNK_BYTES, MAX_TEXT_BYTES, read_text


def csv_header(path: str | Path) -> list[str]:
    """The header of a CSV file (its column names, stripped): from the first line of a plain UTF-8 file, or else
    from the whole file as ``read_text`` decodes it."""
    try:
        with Path(path).open("rb") as fh:
            head = fh.read(CHUNK_BYTES)
        if b"\n" in head and b"\x00" not in head and not any(head.startswith(m) for m in _NOT_PLAIN):
            return [h.strip() for h in next(csv.reader([head.split(b"\n", 1)[0].decode("utf-8")]))]
    except (OSError, UnicodeDecodeError):
        pass
    try:
        return [h.strip() for h in next(csv.reader(read_text(Path(path)).splitlines()[:1]))]
    except StopIteration:
        raise DataError(f"{path}: the file is empty") from None


#: first bytes of files ``streamed_numbers`` leaves to the careful reader: UTF-8, UTF-16 and UTF-32 byte-order
#: marks and the compressed formats ``plant.host.text_io`` opens
_NOT_PLAIN = (b"\xef\xbb\xbf", b"\xff\xfe", b"\xfe\xff", b"\x00\x00\xfe\xff", b"\x1f\x8b", b"BZh",
              b"\xfd7zXZ\x00")


def streamed_numbers(path: str | Path) -> tuple[list[str], dict[str, np.ndarray]] | None:
    """The header and every column of ``path`` as floats, parsed by ``numpy.loadtxt`` from the file itself,
    when it is plain UTF-8 text below ``MAX_TEXT_BYTES``, every cell a number and no line blank (its data row
    k then sits on line k + 2); None for any other file, which ``CsvTable`` reads and names what is wrong."""
    path = Path(path)
    try:
        if path.stat().st_size > MAX_TEXT_BYTES:
            return None
        with path.open("rb") as fh:
            head = fh.read(CHUNK_BYTES)
            newlines, ends_with_newline = head.count(b"\n"), head.endswith(b"\n")
            if not head or any(head.startswith(m) for m in _NOT_PLAIN) or b"\x00" in head:
                return None
            while chunk := fh.read(CHUNK_BYTES):
                newlines += chunk.count(b"\n")
                ends_with_newline = chunk.endswith(b"\n")
        lines = newlines + (0 if ends_with_newline else 1)
        if lines < 2:
            return None
        first = head.split(b"\n", 1)[0].decode("utf-8").strip()
        header = [h.strip() for h in next(csv.reader([first]))]
        data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, comments=None, encoding="utf-8")
    except (OSError, UnicodeDecodeError, ValueError, StopIteration):
        return None
    if data.shape[0] != lines - 1 or data.shape[0] == 0 or data.shape[1] != len(header) or len(set(header)) != \
            len(header):
        return None
    return header, {name: data[:, k] for k, name in enumerate(header)}


def require_columns(path: str | Path, header: list[str], names) -> None:
    """A ``DataError`` naming the first of ``names`` that ``header`` (of ``path``) lacks."""
    for name in names:
        if name not in header:
            raise DataError(f"{path}: missing column {name!r} (header: {', '.join(header)})")


@dataclass(frozen=True)
class CsvTable:
    """A CSV file's header and its data lines (blank lines left out) with their row numbers (header = 1)."""

    path: Path
    header: list[str]
    lines: list[str]
    rows: np.ndarray

    @classmethod
    def read(cls, path: str | Path) -> CsvTable:
        """Read ``path`` (any text encoding ``plant.host.text_io`` takes; a byte-order mark is ignored)."""
        path = Path(path)
        text = read_text(path).splitlines()
        if not text:
            raise DataError(f"{path}: the file is empty")
        header = [h.strip() for h in next(csv.reader(text[:1]))]
        kept = [k for k, line in enumerate(text[1:]) if line.strip()]
        if not kept:
            raise DataError(f"{path}: no data rows below the header")
        return cls(path, header, [text[1 + k] for k in kept], np.asarray(kept, dtype=int) + 2)

    def require(self, names) -> None:
        """A ``DataError`` naming the first of ``names`` the header lacks."""
        require_columns(self.path, self.header, names)

    def numbers(self, names, *, optional=()) -> dict[str, np.ndarray]:
        """The columns ``names`` as floats: a cell that is not a number is a ``DataError`` naming its row and
        column. ``optional`` columns are kept only when every cell of theirs is a number."""
        names, optional = list(names), [o for o in optional if o not in names]
        self.require(names + optional)
        cols = names + optional
        try:                    # fast path; on failure the cells are read one by one
            data = np.loadtxt(self.lines, delimiter=",", usecols=[self.header.index(c) for c in cols], ndmin=2,
                              comments=None)
            return {c: data[:, k] for k, c in enumerate(cols)}
        except ValueError:
            pass
        raw = list(csv.reader(self.lines))
        out = {}
        for name in cols:
            j = self.header.index(name)
            values = np.empty(len(raw))
            for i, row in enumerate(raw):
                try:
                    values[i] = float(row[j])
                except (IndexError, ValueError):
                    if name in optional:
                        values = None
                        break
                    cell = row[j] if j < len(row) else "<missing>"
                    raise DataError(f"{self.path}: row {self.rows[i]}, column {name!r}: {cell!r} is not a "
                                    "number") from None
            if values is not None:
                out[name] = values
        return out


@dataclass(frozen=True)
class NumericCsv:
    """A CSV file's header, its numeric columns and their row numbers in the file: parsed straight from the file
    when it is plain numbers (``streamed_numbers``), else through ``CsvTable``, whose errors name row and column."""

    header: list[str]
    _streamed: dict[str, np.ndarray] | None
    _table: CsvTable | None
    _path: Path

    @classmethod
    def read(cls, path: str | Path) -> NumericCsv:
        streamed = streamed_numbers(path)
        if streamed is not None:
            return cls(streamed[0], streamed[1], None, Path(path))
        table = CsvTable.read(path)
        return cls(table.header, None, table, Path(path))

    @property
    def rows(self) -> np.ndarray:
        """Each data row's line in the file (header = 1)."""
        if self._table is not None:
            return self._table.rows
        return np.arange(2, next(iter(self._streamed.values())).size + 2)    # no blank line: row k on line k + 2

    def numbers(self, names, *, optional=()) -> dict[str, np.ndarray]:
        """``CsvTable.numbers``: the columns ``names`` as floats, and the ``optional`` ones whose cells all are."""
        if self._table is not None:
            return self._table.numbers(names, optional=optional)
        require_columns(self._path, self.header, list(names) + [o for o in optional if o not in names])
        return {c: self._streamed[c] for c in dict.fromkeys([*names, *optional])}

