"""The notebook example (``examples/notebook_api.py``, documented in ``docs/api.md``) runs from a clean
checkout and does what it says: the hidden delay found and fitted, a verified design, its files written."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_notebook_example_runs_end_to_end(tmp_path):
    out = subprocess.run([sys.executable, str(ROOT / "examples" / "notebook_api.py"), str(tmp_path)],
                         capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "diagnosis: explained; effects added: delay" in out.stdout
    delay = float(re.search(r"delay.seconds = ([0-9.e+-]+)", out.stdout).group(1))
    assert abs(delay - 0.001) < 1e-5                          # the simulated truth
    assert "design: optimal" in out.stdout and "verified: True" in out.stdout
    for name in ("rec.csv", "response.mat", "loop.png", "design.mat", "design.html"):
        assert (tmp_path / name).stat().st_size > 0, name
