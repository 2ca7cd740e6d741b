"""Text files as users have them: UTF-8 with or without a byte-order mark, UTF-16 (Excel's "Unicode
text"), Latin-1 from older instruments, compressed with gzip, bzip2 or xz; binary data is refused in
one line. Every reader of CSV, TOML and JSON in the tool goes through ``read_text``."""

from __future__ import annotations

import bz2
import gzip
import lzma
from pathlib import Path

from plant.errors import DataError

#: larger files, and compressed files that expand beyond it, are refused (bytes)
MAX_TEXT_BYTES = 2 * 1024**3
#: bytes decompressed at a time: a compressed file is inflated in pieces and refused at the cap
CHUNK_BYTES = 1024**2

_COMPRESSED = {b"\x1f\x8b": ("gzip", gzip.open), b"BZh": ("bzip2", bz2.open), b"\xfd7zXZ\x00": ("xz", lzma.open)}


def decode(raw: bytes, *, source: str) -> tuple[str, str]:
    """(text, encoding) of ``raw``: a BOM decides (UTF-8, UTF-16); else UTF-8, then UTF-16 when every
    other byte is NUL, then Latin-1. ``DataError`` naming ``source`` for binary data."""
    if raw.startswith(b"\xef\xbb\xbf"):
        try:
            return _checked(raw[3:].decode("utf-8"), "utf-8 (BOM)", source)
        except UnicodeDecodeError as exc:
            raise DataError(f"{source}: starts with a UTF-8 byte-order mark but is not UTF-8 text (byte "
                            f"{exc.start + 3})") from None
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        try:
            return _checked(raw.decode("utf-16"), "utf-16", source)
        except UnicodeDecodeError:
            raise DataError(f"{source}: starts with a UTF-16 byte-order mark but is not UTF-16 text") from None
    if len(raw) >= 4 and raw.count(b"\x00") >= len(raw) // 3:      # UTF-16 without a BOM (ASCII is half NULs)
        enc = "utf-16-le" if raw[1:2] == b"\x00" else "utf-16-be"
        try:
            return _checked(raw.decode(enc), enc, source)
        except (UnicodeDecodeError, DataError):
            pass
    try:
        return _checked(raw.decode("utf-8"), "utf-8", source)
    except UnicodeDecodeError:
        pass
    return _checked(raw.decode("latin-1"), "latin-1", source)


def _checked(text: str, encoding: str, source: str) -> tuple[str, str]:
    """Refuse text with NUL or many control characters: binary data decoded as text."""
    if "\x00" in text:
        raise DataError(f"{source}: not a text file (binary data: a NUL character at character "
                        f"{text.index(chr(0))})")
    sample = text[:65536]
    control = sum(1 for ch in sample if ord(ch) < 32 and ch not in "\t\n\r\f\v")
    if sample and control > 0.01 * len(sample):
        raise DataError(f"{source}: not a text file ({control} control characters in the first "
                        f"{len(sample)} characters)")
    return text, encoding


def read_text(path: str | Path, *, what: str = "file") -> str:
    """The text of ``path`` (see the module doc); ``DataError`` for a missing, unreadable, too large
    (also once decompressed), binary or undecodable file, naming it (and ``what`` it is)."""
    path = Path(path)
    try:
        size = path.stat().st_size
        if size > MAX_TEXT_BYTES:
            raise DataError(f"{path}: {_size(size)} is more than the {_size(MAX_TEXT_BYTES)} a text input may have")
        with path.open("rb") as fh:
            magic = fh.read(6)
        compression = next(((name, opener) for m, (name, opener) in _COMPRESSED.items() if magic.startswith(m)),
                           None)
        raw = path.read_bytes() if compression is None else _inflate(path, *compression)
    except IsADirectoryError:
        raise DataError(f"{path}: is a directory, not a file") from None
    except OSError as exc:
        raise DataError(f"{path}: cannot read {what} ({exc.strerror})") from None
    return decode(raw, source=str(path))[0]


def _inflate(path: Path, name: str, opener) -> bytes:
    """The decompressed bytes of ``path``, read ``CHUNK_BYTES`` at a time and refused as soon as they
    pass ``MAX_TEXT_BYTES`` (a small file may expand a thousandfold)."""
    chunks: list[bytes] = []
    total = 0
    try:
        with opener(path, "rb") as fh:
            while chunk := fh.read(CHUNK_BYTES):
                total += len(chunk)
                if total > MAX_TEXT_BYTES:
                    raise DataError(f"{path}: {name}-compressed text that expands to more than the "
                                    f"{_size(MAX_TEXT_BYTES)} a text input may have")
                chunks.append(chunk)
    except DataError:
        raise
    except (EOFError, lzma.LZMAError, ValueError, OSError) as exc:
        if isinstance(exc, OSError) and exc.strerror is not None:     # the file system, not the stream
            raise
        raise DataError(f"{path}: {name}-compressed but cannot be decompressed ({exc})") from None
    return b"".join(chunks)


def _size(n: int) -> str:
    """Bytes in the largest binary unit that keeps a number >= 1 (``2 GiB``, ``1.5 MiB``)."""
    for unit, factor in (("GiB", 1024**3), ("MiB", 1024**2), ("KiB", 1024)):
        if n >= factor:
            return f"{n / factor:.3g} {unit}"
    return f"{n} bytes"


def data_suffix(path: str | Path) -> str:
    """The file type under any compression suffix: ``run.csv.gz`` -> ``.csv``."""
    suffixes = [x.lower() for x in Path(path).suffixes]
    while suffixes and suffixes[-1] in (".gz", ".bz2", ".xz"):
        suffixes.pop()
    return suffixes[-1] if suffixes else ""
