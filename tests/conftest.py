"""Test set-up: the independent reference simulators and the fuzz inputs (``tests/reference/``) are imported
by name from every test folder."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent / "reference"))
