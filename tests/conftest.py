"""Test set-up: the independent reference simulators and the fuzz inputs (``tests/reference/``) are imported
by name from every test folder; BLAS runs on each test process's own thread, as in a command
(``design.parallel.one_blas_thread``, set before numpy loads)."""

import sys
from pathlib import Path

from design.parallel import one_blas_thread

one_blas_thread()

sys.path.insert(0, str(Path(__file__).resolve().parent / "reference"))
