"""``gantry ARGS`` run in the test's own process (``fuzz_inputs.call``: ``design.cli.main`` with the console
script's warning filters, stdout and stderr captured, from a given folder), for tests of what a command
computes, writes and prints. It saves each test the 1-2 s a fresh interpreter spends importing numpy, scipy,
cvxpy, casadi and python-control. Tests of the process itself (signals, start-up, imports, the environment, a
terminal) start one with ``subprocess``."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

from fuzz_inputs import call


def gantry(*args, cwd: str | Path | None = None, timeout: float = 600.0) -> subprocess.CompletedProcess:
    """Exit status, stdout and stderr of ``gantry ARGS`` as ``subprocess.run(..., capture_output=True,
    text=True)`` returns them; an exception that escapes ``main()`` gives status 1 and its traceback on stderr,
    as Python's would."""
    r = call([str(a) for a in args], cwd=Path(cwd or os.getcwd()), timeout=timeout)
    if r.hung:
        raise AssertionError(f"gantry {' '.join(map(str, args))} still running after {timeout:g} s")
    return subprocess.CompletedProcess(["gantry", *map(str, args)], 1 if r.status == "escaped" else r.status,
                                       r.out, r.err)
