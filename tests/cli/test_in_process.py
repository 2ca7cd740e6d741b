"""``design.cli.main`` called again and again in one process (a script, a notebook, the tests): every call answers
as the first did, on the same commands."""

from __future__ import annotations

import sys

import pytest

from design.cli import main
from design.cli.common import app

COMMANDS = ["reproduce", "simulate", "fit", "diagnose", "coupling", "excite", "synth", "sweep", "report", "mouse-run",
            "planar-run", "planar-synth", "export"]


def _main(capsys, monkeypatch, *args) -> tuple[int, str]:
    monkeypatch.setattr(sys, "argv", ["gantry", *args])
    with pytest.raises(SystemExit) as end:
        main()
    return end.value.code, capsys.readouterr().out


def test_repeated_calls_answer_alike_on_the_same_commands(capsys, monkeypatch):
    first = _main(capsys, monkeypatch, "--help")
    for _ in range(4):
        assert _main(capsys, monkeypatch, "--help") == first
        assert [c.name for c in app.registered_commands] == COMMANDS
    assert first[0] == 0 and all(name in first[1] for name in COMMANDS)
    code, out = _main(capsys, monkeypatch, "--version")
    assert code == 0 and out.startswith("gantry ")


def test_a_registration_cut_short_is_redone(capsys, monkeypatch):
    from design.cli import _command

    _command.cache_clear()
    del app.registered_commands[3:]         # as a Ctrl-C in the middle of registering leaves it
    code, out = _main(capsys, monkeypatch, "--help")
    assert code == 0 and all(name in out for name in COMMANDS)
    assert [c.name for c in app.registered_commands] == COMMANDS
