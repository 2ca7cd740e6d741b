"""Files written as a set or not at all: a temporary file per target, renamed only when every one was
written, and nothing once a stop was requested (``plant.host.interrupts``)."""

from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path

from plant.errors import DataError
from plant.host.interrupts import raise_if_requested


def atomic_write_texts(files: dict[Path, str | bytes]) -> None:
    """Write each text (or bytes) to its path as a set: every file goes to a temporary file first, and the renames
    happen only when all were written, so a failure leaves none of them half-written or new.

    A path that is a symbolic link is written through to the file it points to (the link stays); a
    file that is replaced keeps its permission bits, a new one gets the usual ``0666`` less the umask.
    Nothing is written once Ctrl-C or SIGTERM was requested (``plant.host.interrupts``)."""
    raise_if_requested()
    given = {Path(os.path.realpath(path)): Path(path) for path in files}
    targets = {target: files[path] for target, path in given.items()}
    for target, path in given.items():
        if target.is_dir():
            raise DataError(f"{path}: is a directory; give a file name to write")
        if not target.parent.is_dir():
            parent = next(p for p in target.parents if p.exists())
            raise DataError(f"{path}: cannot write: {parent} is a file, not a directory" if not parent.is_dir()
                            else f"{path}: cannot write: directory {target.parent} does not exist")
    tmps: list[tuple[str, Path]] = []
    umask = os.umask(0)
    os.umask(umask)
    path = next(iter(targets))
    try:
        for path, text in targets.items():
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
            tmps.append((tmp, path))
            try:
                mode = stat.S_IMODE(path.stat().st_mode)
            except FileNotFoundError:
                mode = 0o666 & ~umask       # mkstemp makes 0600; a new file gets the usual permissions
            os.chmod(tmp, mode)
            with (os.fdopen(fd, "wb") if isinstance(text, bytes) else os.fdopen(fd, "w", newline="")) as fh:
                fh.write(text)
        raise_if_requested()          # a stop that a library swallowed: nothing is committed
        for tmp, path in tmps:
            os.replace(tmp, path)
    except OSError as exc:
        for tmp, _ in tmps:
            Path(tmp).unlink(missing_ok=True)
        raise DataError(f"{given[path]}: cannot write ({exc.strerror or exc})") from None
    except BaseException:
        for tmp, _ in tmps:
            Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and a rename (never half-written)."""
    atomic_write_texts({Path(path): text})
