"""Files written as a set or not at all: a temporary file per target, renamed only when every one was
written, and nothing once a stop was requested (``plant.host.interrupts``)."""

from __future__ import annotations

import os
import stat
import sys
import tempfile
from glob import escape as glob_escape
from pathlib import Path

from plant.errors import DataError
from plant.host.interrupts import raise_if_requested


def atomic_write_texts(files: dict[Path, str | bytes]) -> None:
    """Write each text (or bytes) to its path as a set: every file goes to a temporary file first, and the renames
    happen only when all were written, so a failure leaves none of them half-written or new.

    A path that is a symbolic link is written through to the file it points to (the link stays); a
    file that is replaced keeps its permission bits, a new one gets the usual ``0666`` less the umask.
    Only regular files are written (a device, pipe or socket is refused, never replaced); the path ``-`` is
    standard output, for a command that writes one file. Nothing is written once Ctrl-C or SIGTERM was
    requested (``plant.host.interrupts``)."""
    raise_if_requested()
    if any(is_stdout(path) for path in files):
        if len(files) > 1:
            raise DataError(f"-: standard output takes one file, but this writes {len(files)} "
                            f"({', '.join(str(p) for p in files if not is_stdout(p))} with it); give a file name")
        text = next(iter(files.values()))
        if isinstance(text, bytes):
            sys.stdout.buffer.write(text)
        else:
            sys.stdout.write(text)
        sys.stdout.flush()
        return
    given = {Path(os.path.realpath(path)): Path(path) for path in files}
    targets = {target: files[path] for target, path in given.items()}
    for target, path in given.items():
        if target.is_dir():
            raise DataError(f"{path}: is a directory; give a file name to write")
        if target.exists() and not target.is_file():
            raise DataError(f"{path}: is not a regular file (a device, pipe or socket); give a file name, or - "
                            "for standard output")
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
            _remove_stale(path)
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.{os.getpid()}.", suffix=".tmp")
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


def _remove_stale(path: Path) -> None:
    """Delete the temporary files of ``path`` that a writer killed outright (SIGKILL, power loss) left: each
    is named ``.<name>.<pid>.<random>.tmp``, and its process is gone."""
    for tmp in path.parent.glob(f".{glob_escape(path.name)}.*.tmp"):
        pid = tmp.name[len(path.name) + 2:].split(".", 1)[0]
        if not pid.isdigit() or int(pid) == os.getpid():
            continue
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            tmp.unlink(missing_ok=True)
        except OSError:         # alive, another user's
            pass


def is_stdout(path: str | Path) -> bool:
    """Whether an output path is ``-``: standard output."""
    return str(path) == "-"


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and a rename (never half-written)."""
    atomic_write_texts({Path(path): text})
