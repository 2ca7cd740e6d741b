"""The one reader of a CSV table, whatever the recording's kind: the header, blank lines skipped, each data
row's number in the file, and numeric columns read fast (``numpy.loadtxt``) or, when a cell is not a
number, cell by cell so that the error names its row and column."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from plant.errors import DataError
from plant.host.text_io import read_text


def csv_header(path: str | Path) -> list[str]:
    """The header of a CSV file (its column names, stripped)."""
    try:
        return [h.strip() for h in next(csv.reader(read_text(Path(path)).splitlines()[:1]))]
    except StopIteration:
        raise DataError(f"{path}: the file is empty") from None


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
        for name in names:
            if name not in self.header:
                raise DataError(f"{self.path}: missing column {name!r} (header: {', '.join(self.header)})")

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
