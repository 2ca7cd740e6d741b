"""The ``--json`` output of every command on the bundled specs and recordings is the stable contract
(``docs/formats.md``: keys are added, never renamed): the files in ``tests/golden/`` were
written by ``tests/golden/commands.py`` before ``design/`` was reorganised, and the commands must
still print the same keys and values (relative 1e-4: solver round-off differs between machines;
wall times and file paths are skipped). A new key is allowed; a missing or changed one fails. The commands run in
this process (``in_process.gantry``); ``tests/golden/commands.py`` writes the files from new processes."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
from in_process import gantry

TESTS = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(TESTS / "golden"))
from commands import COMMANDS, GOLDEN, differences, run  # noqa: E402


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    return tmp_path_factory.mktemp("golden")


#: the admittance design is run by default by its own tests' fixture (tests/design/admittance): its contract is
#: checked in the slow pass
SLOW = ("synth_admittance",)


@pytest.mark.parametrize("name", [pytest.param(n, marks=[pytest.mark.slow] if n in SLOW else []) for n in COMMANDS])
def test_command_prints_the_same_json(name, scratch):
    if name in ("fit_x", "diagnose_x") and not (scratch / "golden_recording.csv").exists():
        run("simulate_x", scratch, gantry)
    old = json.loads((GOLDEN / f"{name}.json").read_text())
    new = run(name, scratch, gantry)
    diffs = differences(new, old, rel=1e-4)
    assert not diffs, "\n".join(diffs[:20])
