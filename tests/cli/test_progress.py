"""Progress on a terminal: a command a user waits on shows its stage on stderr when stderr is a terminal,
and nothing when it is piped or --json is given."""

import os
import pty
import subprocess
import sys
from pathlib import Path

from in_process import gantry as in_process

ROOT = Path(__file__).resolve().parents[2]


def gantry(*args, stderr=subprocess.PIPE):
    # progress from the first stage on (design.views.progress): the test does not hang on how fast the machine is
    return subprocess.run([sys.executable, "-m", "design", *map(str, args)], stdout=subprocess.PIPE,
                          stderr=stderr, text=True, timeout=600, env={**os.environ, "GANTRY_PROGRESS_AFTER_S": "0"})


def _on_a_terminal(*args) -> tuple[int, str]:
    """Exit status and what the command wrote to stderr, stderr being a pseudo-terminal."""
    master, slave = pty.openpty()
    try:
        out = gantry(*args, stderr=slave)
        os.close(slave)
        chunks = []
        while True:
            try:
                chunk = os.read(master, 65536)
            except OSError:           # the terminal closed: everything was read
                break
            if not chunk:
                break
            chunks.append(chunk)
    finally:
        os.close(master)
    return out.returncode, b"".join(chunks).decode(errors="replace")


def test_diagnose_shows_the_models_it_fits_on_a_terminal_only(tmp_path):
    rec = tmp_path / "rec.csv"
    made = in_process("simulate", "--stage", "x", "--f-hz", "1:75:20", "--duration-s", "2", "--out", rec)
    assert made.returncode == 0
    # two candidates: the display is what is tested, not the search (the full search is the diagnosis tests')
    few = ("--stage", "x", "--effects", "delay,current_loop")
    status, terminal = _on_a_terminal("diagnose", rec, *few)
    assert status == 0
    assert "diagnose" in terminal and "models" in terminal
    piped = gantry("diagnose", rec, *few)
    assert piped.returncode == 0 and piped.stderr == ""
    status, terminal = _on_a_terminal("diagnose", rec, *few, "--json")
    assert status == 0 and terminal == ""


def test_fit_shows_its_stage_on_a_terminal_only(tmp_path):
    rec = tmp_path / "rec.csv"
    assert in_process("simulate", "--stage", "x", "--form", "chirp", "--f-hz", "0.5:20:2", "--duration-s", "15",
                      "--out", rec).returncode == 0
    status, terminal = _on_a_terminal("fit", rec, "--stage", "x", "--method", "output-error")
    assert status == 0 and "fitting" in terminal
    piped = gantry("fit", rec, "--stage", "x", "--method", "output-error", "--json")
    assert piped.returncode == 0 and piped.stderr == ""


def test_simulate_shows_its_time_steps_on_a_terminal_only(tmp_path):
    # Coulomb friction is simulated step by step (a few seconds for the thesis-size recording)
    args = ("simulate", "--stage", "x", "--effects", "coulomb_friction.force_n=3", "--out", tmp_path / "rec.csv")
    status, terminal = _on_a_terminal(*args)
    assert status == 0 and "simulate" in terminal and "steps" in terminal
    status, terminal = _on_a_terminal(*args, "--json")
    assert status == 0 and terminal == ""


def test_report_shows_the_stages_of_its_synthesis_and_figures_on_a_terminal(tmp_path):
    status, terminal = _on_a_terminal("report", ROOT / "specs" / "stage_x_synth.toml", "--samples", "0", "--out",
                                      tmp_path / "design.html")
    assert status == 0
    for stage in ("design on", "independent check of the design (python-control)", "drawing the figures"):
        assert stage in terminal
