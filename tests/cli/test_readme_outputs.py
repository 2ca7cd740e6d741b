"""The outputs the README quotes come out of the commands it quotes, so they cannot drift: every ```text
block that starts with ``$ COMMAND`` and shows output is run from the repository root, and each quoted line
must appear in what the command prints, in order, whitespace (terminal wrapping) and table borders aside;
``...`` in a quoted line stands for text left out, a line of ``...`` alone for lines left out."""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from in_process import gantry

ROOT = Path(__file__).resolve().parents[2]


def quoted_runs() -> list[tuple[str, list[str]]]:
    """(command, quoted output lines) of every README block that quotes a command's output."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    runs = []
    for block in re.findall(r"```text\n(.*?)```", text, flags=re.S):
        lines = block.rstrip("\n").split("\n")
        if lines[0].startswith("$ ") and len(lines) > 1 and not lines[1].startswith("$ "):
            runs.append((lines[0][2:], lines[1:]))
    return runs


def _argv(command: str) -> list[str]:
    argv = shlex.split(command)
    if argv[0] == "python":
        return [sys.executable, *argv[1:]]
    raise AssertionError(f"README quotes an unknown command: {command}")


def _flat(text: str) -> str:
    """Words in order: whitespace collapsed, a table's box-drawing borders dropped."""
    return " ".join(re.sub("[\u2500-\u257f]", " ", text).split())


#: commands whose computation a default test already runs (the JSON contract, the admittance and dual design
#: fixtures): their README quotes are checked in the slow pass
SLOW = ("stage_x_admittance.toml", "stage_y_dual.toml")


@pytest.mark.parametrize("command,quoted", [
    pytest.param(c, q, id=c, marks=[pytest.mark.slow] if any(k in c for k in SLOW) else [])
    for c, q in quoted_runs()])
def test_readme_quotes_what_the_command_prints(command, quoted, monkeypatch):
    env = {"COLUMNS": "200", "PATH": "/usr/bin:/bin", "HOME": str(Path.home())}
    if command.startswith("gantry "):       # in this process, with the same environment
        for key, value in env.items():
            monkeypatch.setenv(key, value)
        out = gantry(*shlex.split(command)[1:], cwd=ROOT)
    else:
        out = subprocess.run(_argv(command), capture_output=True, text=True, cwd=ROOT, timeout=600, env=env)
    assert out.returncode in (0, 3), out.stderr[-2000:]
    printed = _flat(out.stdout)
    at = 0
    for line in quoted:
        for piece in (p.strip() for p in _flat(line).split("...")):
            if not piece:
                continue
            found = printed.find(piece, at)
            assert found >= 0, f"README quotes {piece!r} from `{command}`; it printed:\n{out.stdout[:4000]}"
            at = found + len(piece)


def test_the_readme_quotes_outputs():
    assert len(quoted_runs()) >= 4
