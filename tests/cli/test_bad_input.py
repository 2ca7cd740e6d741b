"""Bytes, paths and usage as users have them: every failure is one line on stderr with exit status 2,
and text in UTF-16, Latin-1 or gzip reads as the UTF-8 original does."""

from __future__ import annotations

import bz2
import gzip
import json
import lzma
import os
import signal
import stat
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from bundled_specs import admittance_text
from in_process import gantry

from plant import Delay, stage_x
from plant.data.writers import recording_csv_text, write_recording_csv
from plant.errors import DataError
from plant.experiment.simulate import simulate_stepped_sine
from plant.host import text_io
from plant.host.text_io import decode

ROOT = Path(__file__).resolve().parents[2]
THESIS_X = ROOT / "specs" / "thesis_stage_x.toml"




def one_line(out, status=2):
    return out.returncode == status and out.stderr.count("\n") == 1 and out.stderr.startswith("gantry: error:") \
        and "Traceback" not in out.stderr


@pytest.mark.parametrize("text", ["frequency_hz,current_a\n1.0,0.5\n", "µ-stage, 5 µm\n", "# Stufe µ\nkp = 1\n"])
def test_decoding_round_trips_utf8_utf16_and_latin1(text):
    for raw in (text.encode("utf-8"), b"\xef\xbb\xbf" + text.encode("utf-8"), text.encode("utf-16"),
                text.encode("utf-16-le"), text.encode("latin-1")):
        assert decode(raw, source="t")[0] == text


@pytest.mark.parametrize("raw", [bytes(range(256)) * 4, b"\x00\x00\x00\x01PK\x03\x04" * 50,
                                 b"\x7fELF\x02\x01\x01" + b"\x00" * 64])
def test_binary_data_is_refused(raw):
    with pytest.raises(DataError, match="not a text file|UTF-16"):
        decode(raw, source="blob.csv")


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "rec.csv"
    rec = simulate_stepped_sine(stage_x(mass_kg=20.0) * Delay(0.001), f_hz=np.geomspace(2, 80, 10),
                                current_amplitude_a=0.5, duration_s=1.0, noise_fraction=0.01, seed=3)
    write_recording_csv(rec, path)
    return path


def test_a_recording_reads_the_same_in_utf16_and_gzip(recording, tmp_path):
    text = recording.read_text()
    variants = {"utf16.csv": text.encode("utf-16"), "rec.csv.gz": gzip.compress(text.encode())}
    fits = []
    for name, raw in {"rec.csv": text.encode(), **variants}.items():
        (tmp_path / name).write_bytes(raw)
        out = gantry("fit", tmp_path / name, "--stage", "x", "--effects", "delay", "--json")
        assert out.returncode == 0, out.stderr
        fits.append(json.loads(out.stdout)["parameters"])
    assert fits[0] == fits[1] == fits[2]


def test_a_latin1_comment_in_a_spec_is_read(tmp_path):
    spec = tmp_path / "latin1.toml"
    spec.write_bytes(("# Stufe X, Auflösung 1 µm\n" + THESIS_X.read_text()).encode("latin-1"))
    out = gantry("sweep", spec, "--payload", "5:40:3", "--json")
    assert out.returncode == 0, out.stderr


@pytest.mark.parametrize("args", [
    ["synth", "BINARY"], ["fit", "BINARY", "--stage", "x"], ["synth", "MISSING"],
    ["sweep", str(THESIS_X), "--csv", "NODIR/x.csv"], ["sweep", str(THESIS_X), "--csv", "DIR"],
    ["synth", str(THESIS_X), "--no-such-option"], ["no-such-command"], ["synth"],
])
def test_every_failure_is_one_line_with_status_2(tmp_path, args):
    (tmp_path / "blob.csv").write_bytes(bytes(range(256)) * 8)
    subs = {"BINARY": tmp_path / "blob.csv", "MISSING": tmp_path / "missing.toml", "NODIR": tmp_path / "nodir",
            "DIR": tmp_path}
    args = [str(subs[a]) if a in subs else a.replace("NODIR", str(tmp_path / "nodir")) for a in args]
    out = gantry(*args)
    assert one_line(out), (out.returncode, out.stderr)
    assert not (tmp_path / "nodir").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blob.csv"]      # nothing half-written left behind


def test_ctrl_c_during_the_admittance_solve_ends_with_130_and_no_output(tmp_path):
    # the admittance synthesis spends seconds in IPOPT, which traps Ctrl-C itself
    out = tmp_path / "design.html"
    p = subprocess.Popen([sys.executable, "-m", "design", "synth", str(ROOT / "specs" / "stage_x_admittance.toml"),
                          "--report", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(3.0)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=120)
    assert (p.returncode, err) == (130, "gantry: error: interrupted\n")
    assert list(tmp_path.iterdir()) == []


def run_with_patched_command(tmp_path, name: str, run: str) -> subprocess.CompletedProcess:
    """``gantry reproduce`` as ``python -m`` runs it, its command replaced by ``run`` (the source of a function
    ``_run()`` returning the exit status; ``cli`` is ``design.cli``)."""
    (tmp_path / f"{name}.py").write_text(
        "import runpy, sys\n"
        "import design.cli as cli\n"
        f"{run}"
        "cli._run = _run\n"
        "sys.argv = ['gantry', 'reproduce']\n"
        "runpy.run_module('design', run_name='__main__')\n")
    return subprocess.run([sys.executable, "-m", name], cwd=tmp_path, capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(tmp_path)])}, timeout=120)


def test_what_a_library_prints_about_the_interrupt_it_caught_is_not_shown(tmp_path):
    # casadi catches the KeyboardInterrupt inside IPOPT and prints its own warning on stderr: the one line only
    p = run_with_patched_command(tmp_path, "ctrl_c_in_ipopt", (
        "import os, signal, threading\n"
        "import casadi as ca\n"
        "def _run():\n"
        "    x = ca.SX.sym('x', 200)\n"
        "    f = ca.sumsqr(x - 1) + ca.sum1(ca.sin(x) ** 4 * ca.cos(x) ** 2)\n"
        "    g = ca.vertcat(*[x[i] * x[i + 1] for i in range(199)])\n"
        "    solver = ca.nlpsol('s', 'ipopt', {'x': x, 'f': f, 'g': g},\n"
        "                       {'print_time': False, 'ipopt': {'print_level': 0, 'sb': 'yes', 'tol': 1e-14}})\n"
        "    threading.Timer(0.05, lambda: os.kill(os.getpid(), signal.SIGINT)).start()\n"
        "    for _ in range(200):\n"
        "        solver(x0=ca.DM.rand(200) * 3, lbg=-1, ubg=1)\n"
        "    return 0\n"))
    assert p.returncode == 130 and p.stderr == "gantry: error: interrupted\n", (p.returncode, p.stderr)


def test_ctrl_c_inside_an_executed_string_still_ends_with_130(tmp_path):
    # a Ctrl-C that lands while an import runs a dataclass's generated code (exec of a string) is handled by
    # main, yet CPython's `python -m` would still end the process by SIGINT (status -2) unless that is undone
    p = run_with_patched_command(tmp_path, "ctrl_c_in_exec", (
        "run = cli._run\n"
        "def _run():\n"
        "    exec('import os, signal; os.kill(os.getpid(), signal.SIGINT)')\n"
        "    return run()\n"))
    assert p.returncode == 130 and p.stderr == "gantry: error: interrupted\n", (p.returncode, p.stderr)


INT, TERM = (signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")


@pytest.mark.parametrize("after_s,sig,status,word", [
    (0.5, *INT), (0.7, *TERM), (0.9, *INT), (1.2, *TERM), (1.6, *INT), (2.0, *TERM), (3.0, *INT),
    *(pytest.param(t, *s, marks=pytest.mark.slow) for t, s in ((0.5, TERM), (0.7, INT), (0.9, TERM), (1.2, INT),
                                                             (1.6, TERM), (2.0, INT), (3.0, TERM)))])
def test_a_signal_anywhere_in_a_synthesis_ends_with_its_status_and_no_output(tmp_path, sig, status, word, after_s):
    # start-up, the imports (numpy, scipy, cvxpy, python-control, casadi), the PI synthesis (Clarabel, IPOPT,
    # casadi's SWIG wrappers, which swallow exceptions) and the robustness checks: wherever the signal lands,
    # the status is the signal's, one line, and nothing is written. Not earlier than 0.5 s: the interpreter's
    # own start-up (its site module, before any code of the tool runs) takes up to ~0.5 s on a busy machine,
    # and a signal then gets CPython's default handling (measured idle: the first ~60 ms)
    out = tmp_path / "design.html"
    p = subprocess.Popen([sys.executable, "-m", "design", "synth", str(ROOT / "specs" / "stage_x_synth.toml"),
                          "--report", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(after_s)
    p.send_signal(sig)
    _, err = p.communicate(timeout=120)
    assert p.returncode == status and err == f"gantry: error: {word}\n", err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("args,words", [([], "no command given"), (["sweep", "--payload"], "'--payload' requires"),
                                        (["report", str(THESIS_X)], "Missing option '--out'"),
                                        (["sweep", str(THESIS_X), "--bogus"], "No such option: --bogus")])
def test_a_usage_error_is_one_line_naming_what_is_wrong(args, words):
    out = gantry(*args)
    assert one_line(out) and words in out.stderr, out.stderr
    assert "Usage:" not in out.stderr and "╭" not in out.stderr      # no box
    assert ("Usage:" in out.stdout) == (args == [])        # the bare command shows the help


@pytest.mark.parametrize("args", [["sweep", "SPEC", "--csv", "SPEC"], ["report", "SPEC", "--out", "SPEC", "--no-synth"],
                                  ["synth", "SPEC", "--report", "SPEC"]])
def test_an_output_never_replaces_an_input(tmp_path, args):
    spec = tmp_path / "spec.toml"
    spec.write_text(THESIS_X.read_text())
    out = gantry(*[str(spec) if a == "SPEC" else a for a in args])
    assert one_line(out) and "is an input of this command" in out.stderr
    assert spec.read_text() == THESIS_X.read_text()


@pytest.mark.parametrize("old,new,key", [
    ("damping_n_s_per_m = 440.0", "damping_n_s_per_m = true", "plant.damping_n_s_per_m: true is not a number"),
    ("kp = { value = 236.0, min = 0.0, max = 10000.0 }", "kp = { value = 236.0, min = 0.0, max = inf }",
     "controller.kp.max"),
    ("points = 8", "points = 10000", "plant.payload_kg.points"),
    ("{ min = 330.0, max = 550.0 }", "{ min = 330.0, max = nan }", "plant.uncertainty.damping_n_s_per_m.max"),
])
def test_non_finite_boolean_and_oversized_spec_values_are_refused(tmp_path, old, new, key):
    text = (ROOT / "specs" / "stage_x_synth.toml").read_text()
    assert old in text
    spec = tmp_path / "bad.toml"
    spec.write_text(text.replace(old, new, 1))
    out = gantry("sweep", spec, "--payload", "5:40:3")
    assert one_line(out) and key in out.stderr, out.stderr


@pytest.mark.parametrize("args,word", [
    (["simulate", "--stage", "x", "--f-hz", "1:10:1e9", "--out", "OUT"], "2000"),
    (["simulate", "--stage", "x", "--duration-s", "1e5", "--out", "OUT"], "GB"),
    (["simulate", "--stage", "x", "--f-hz", "1_0:1e308:2", "--sample-rate-hz", "20", "--out", "OUT"], "lower --f-hz"),
    (["sweep", str(THESIS_X), "--payload", "1e9:1e9:1"], "outside [0.5, 500] kg"),
])
def test_sizes_are_refused_before_any_work(tmp_path, args, word):
    out = gantry(*[str(tmp_path / "rec.csv") if a == "OUT" else a for a in args])
    assert one_line(out) and word in out.stderr, out.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("compress", [gzip.compress, bz2.compress, lzma.compress], ids=["gzip", "bzip2", "xz"])
def test_a_compressed_file_is_refused_as_it_passes_the_size_cap(tmp_path, monkeypatch, compress):
    monkeypatch.setattr(text_io, "MAX_TEXT_BYTES", 2**20)
    bomb = tmp_path / "bomb.csv.gz"
    bomb.write_bytes(compress(b"0" * 2**25))      # 32 MiB of text in a few kB
    tracemalloc.start()
    try:
        with pytest.raises(DataError, match="bomb.csv.gz: .*expands to more than the 1 MiB"):
            text_io.read_text(bomb)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 2**24      # in pieces (xz keeps an 8 MiB dictionary), never the 32 MiB whole


def test_a_compressed_file_below_the_cap_reads_whole(tmp_path, monkeypatch):
    monkeypatch.setattr(text_io, "MAX_TEXT_BYTES", 2**20)
    text = "frequency_hz,current_a\n" + "1.0,0.5\n" * 100_000     # 800 kB, several pieces
    (tmp_path / "rec.csv.xz").write_bytes(lzma.compress(text.encode()))
    assert text_io.read_text(tmp_path / "rec.csv.xz") == text


def test_an_output_that_is_a_link_is_written_through_it_with_its_permissions(tmp_path):
    (tmp_path / "results").mkdir()
    target = tmp_path / "results" / "sweep.csv"
    target.write_text("old\n")
    target.chmod(0o640)
    link = tmp_path / "sweep.csv"
    link.symlink_to(target)
    out = gantry("sweep", THESIS_X, "--payload", "5:40:3", "--csv", link)
    assert out.returncode == 0, out.stderr
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert target.read_text().startswith("payload_kg,") and stat.S_IMODE(target.stat().st_mode) == 0o640
    assert sorted(p.name for p in target.parent.iterdir()) == ["sweep.csv"]


def test_report_reads_a_spreadsheet_with_the_column_map_its_error_asks_for(tmp_path):
    openpyxl = pytest.importorskip("openpyxl")
    rec = simulate_stepped_sine(stage_x(mass_kg=35.0), f_hz=[3.0, 10.0, 30.0], current_amplitude_a=0.5,
                                duration_s=1.0, noise_fraction=0.01, seed=1)
    wb = openpyxl.Workbook()
    for b in rec.blocks:        # thesis layout: no header, no time; frequency, current, velocity in columns 2, 3, 6
        for i, v in zip(b.current_a, b.velocity_m_per_s[0]):
            wb.active.append([0, b.f_hz, float(i), 0, 0, float(v)])
    sheet = tmp_path / "stage_x.xlsx"
    wb.save(sheet)
    html = tmp_path / "report.html"
    out = gantry("report", THESIS_X, "--no-synth", "--data", sheet, "--out", html)
    assert one_line(out) and "--columns frequency=2" in out.stderr and not html.exists(), out.stderr
    out = gantry("report", THESIS_X, "--no-synth", "--data", sheet, "--out", html, "--columns",
                 "frequency=2,current=3,velocity=6")
    assert one_line(out) and "--sample-rate-hz" in out.stderr and not html.exists(), out.stderr
    out = gantry("report", THESIS_X, "--no-synth", "--samples", "0", "--data", sheet, "--out", html, "--columns",
                 "frequency=2,current=3,velocity=6", "--sample-rate-hz", "2000")
    assert out.returncode == 0, out.stderr
    assert "stage_x.xlsx" in html.read_text()


def in_process(monkeypatch, capsys, *args) -> tuple[int, str, str]:
    """Exit status, stderr and stdout of the console entry point, run in this process (faster than a
    subprocess)."""
    from design.cli import main

    monkeypatch.setattr(sys, "argv", ["gantry", *map(str, args)])
    with pytest.raises(SystemExit) as exc:
        main()
    out, err = capsys.readouterr()
    return exc.value.code, err, out


def test_a_command_run_in_process_leaves_no_numpy_error_state_behind(monkeypatch, capsys):
    # an interrupt that lands inside numpy's errstate, after it set its state and before its with block,
    # never restores that state (found when the in-process fuzz interrupts made later tests raise underflow)
    import design.cli as cli

    def leaky_run():
        np.errstate(under="raise").__enter__()
        return 0

    before = np.geterr()
    monkeypatch.setattr(cli, "_run", leaky_run)
    monkeypatch.setattr(sys, "argv", ["gantry", "reproduce"])
    try:
        cli.main()
    except SystemExit:
        pass
    assert np.geterr() == before


SYNTH_X = ROOT / "specs" / "stage_x_synth.toml"


@pytest.mark.parametrize("old,new,message", [
    ('stage = "x"', 'stgae = "x"', "plant.stgae: unknown key (did you mean plant.stage?)"),
    ('[requirements]', '[requirments]', "requirments: unknown key (did you mean requirements?)"),
    ("points = 8", "pionts = 8", "plant.payload_kg.pionts: unknown key (did you mean plant.payload_kg.points?)"),
    ("delay = { seconds", "dealy = { seconds", "plant.effects.dealy: unknown key (did you mean plant.effects.delay?)"),
    ("delay = { seconds", "delay = { secnds",
     "plant.effects.delay.secnds: unknown key (did you mean plant.effects.delay.seconds?)"),
    ('"delay.seconds" =', '"delay.second" =',
     "plant.uncertainty.delay.second: unknown key (did you mean plant.uncertainty.delay.seconds?)"),
    ("kp = { value", "kp = { vale", "controller.kp.vale: unknown key (did you mean controller.kp.value?)"),
    ('maximise = "', 'zzz = "', "objective.zzz: unknown key; objective takes maximise"),
])
def test_an_unknown_key_is_named_with_the_closest_known_one(tmp_path, monkeypatch, capsys, old, new, message):
    text = SYNTH_X.read_text()
    assert old in text
    spec = tmp_path / "spec.toml"
    spec.write_text(text.replace(old, new, 1))
    code, err, _ = in_process(monkeypatch, capsys, "sweep", spec, "--payload", "5:40:3")
    assert code == 2 and err == f"gantry: error: {spec}: {message}\n"


@pytest.mark.parametrize("value,message", [
    ('"heavy"', "plant.payload_kg = 'heavy': must be a table or a number"),
    ("[5, 40]", "plant.payload_kg = [5, 40]: must be a table or a number"),
])
def test_a_value_of_the_wrong_kind_says_what_the_key_takes(tmp_path, monkeypatch, capsys, value, message):
    text = SYNTH_X.read_text()
    old = "{ min = 5.0, max = 40.0, points = 8, nominal = 35.0 }"
    assert old in text
    spec = tmp_path / "spec.toml"
    spec.write_text(text.replace(old, value, 1))
    code, err, _ = in_process(monkeypatch, capsys, "synth", spec)
    assert code == 2 and err == f"gantry: error: {spec}: {message}\n"


@pytest.mark.parametrize("old,new,message", [
    ("max = 40.0, points", "max = 600, points", "plant.payload_kg.max = 600: must be <= 500"),
    ("{ min = 5.0, max = 40.0, points = 8, nominal = 35.0 }", "1e-9", "plant.payload_kg = 1e-09: must be >= 0.5"),
    ("delay = { seconds = 0.0005 }", "delay = { seconds = 0.5 }",
     "plant.effects.delay.seconds = 0.5: outside its limits [0, 0.02] s"),
    ("damping_n_s_per_m = { min = 330.0, max = 550.0 }", "damping_n_s_per_m = { min = 330.0, max = 5e4 }",
     "plant.uncertainty.damping_n_s_per_m.max = 50000.0: outside its limits [1, 10000] N*s/m"),
])
@pytest.mark.parametrize("command", [["synth"], ["sweep"], ["report", "--no-synth", "--out", "OUT"]])
def test_every_command_holds_a_spec_to_the_same_limits_naming_the_key(tmp_path, monkeypatch, capsys, old, new,
                                                                      message, command):
    text = SYNTH_X.read_text()
    assert old in text
    spec = tmp_path / "spec.toml"
    spec.write_text(text.replace(old, new, 1))
    args = [str(tmp_path / "r.html") if a == "OUT" else a for a in command]
    code, err, _ = in_process(monkeypatch, capsys, args[0], spec, *args[1:])
    assert code == 2 and err == f"gantry: error: {spec}: {message}\n"
    assert [p.name for p in tmp_path.iterdir()] == ["spec.toml"]


def test_the_payload_option_and_a_simulation_hold_to_the_same_limits(tmp_path, monkeypatch, capsys):
    code, err, _ = in_process(monkeypatch, capsys, "sweep", THESIS_X, "--payload", "0.1:40:3")
    assert code == 2 and "0.1 kg is outside [0.5, 500] kg" in err
    code, err, _ = in_process(monkeypatch, capsys, "simulate", "--stage", "x", "--set", "mass_kg=600", "--out",
                           tmp_path / "r.csv")
    assert code == 2 and "mass_kg = 600 kg is outside its bounds [0.5, 500]" in err
    assert list(tmp_path.iterdir()) == []


def test_simulate_refuses_blocks_the_estimate_cannot_use_and_fit_uses_every_block_it_writes(tmp_path, monkeypatch,
                                                                                            capsys):
    rec = tmp_path / "rec.csv"
    code, err, _ = in_process(monkeypatch, capsys, "simulate", "--stage", "x", "--f-hz", "1:75:10",
                              "--duration-s", "0.5", "--out", rec)
    assert code == 2 and err.count("\n") == 1, err
    assert "--duration-s 0.5: the 1 Hz block would hold 0.5 periods" in err and "--duration-s 1.5 or more" in err
    assert list(tmp_path.iterdir()) == []
    code, _, _ = in_process(monkeypatch, capsys, "simulate", "--stage", "x", "--f-hz", "1:75:10",
                            "--duration-s", "1.5", "--out", rec)
    assert code == 0
    code, _, out = in_process(monkeypatch, capsys, "fit", rec, "--stage", "x", "--json")
    assert code == 0
    assert json.loads(out)["n_data"] == 2 * 10        # no block left out


def test_simulate_refuses_a_stage_stuck_in_its_friction_and_diagnose_finds_the_friction_it_writes(tmp_path,
                                                                                                  monkeypatch, capsys):
    rec = tmp_path / "rec.csv"
    args = ["simulate", "--stage", "x", "--effects", "coulomb_friction.force_n=20", "--f-hz", "2:40:6",
            "--duration-s", "1", "--out", rec]
    code, err, _ = in_process(monkeypatch, capsys, *args)      # 0.5 A x 20 N/A = 10 N < 20 N: never moves
    assert code == 2 and err.count("\n") == 1, err
    assert "--amplitude-a 0.5 A: the stage never breaks loose" in err and "6 blocks at 2-40 Hz" in err
    assert "raise --amplitude-a above 1 A" in err
    assert list(tmp_path.iterdir()) == []
    code, _, _ = in_process(monkeypatch, capsys, *args, "--amplitude-a", "2")
    assert code == 0
    code, _, out = in_process(monkeypatch, capsys, "diagnose", rec, "--stage", "x", "--json")
    assert code == 0
    found = json.loads(out)
    assert found["added_effects"] == ["coulomb_friction"]
    friction = found["parameters"]["coulomb_friction.force_n"]
    assert abs(friction["value"] - 20.0) < 3 * friction["stderr"]


def test_a_corrupt_time_value_is_named_with_its_row(tmp_path):
    # a time far beyond the block (1e308 s) would overflow the settling search; a gap of a few missing
    # samples is data, so only steps over a thousand sample steps are refused
    rec = simulate_stepped_sine(stage_x(mass_kg=35.0), f_hz=[3.0, 10.0, 30.0], current_amplitude_a=0.5,
                                duration_s=1.0, noise_fraction=0.01, seed=1)
    lines = recording_csv_text(rec).splitlines()
    first = next(i for i, line in enumerate(lines) if line[:1].isdigit())
    last = max(i for i, line in enumerate(lines) if line.split(",")[0] == lines[first].split(",")[0])
    fields = lines[last].split(",")
    fields[1] = "1e308"
    bad = tmp_path / "rec.csv"
    bad.write_text("\n".join(lines[:last] + [",".join(fields)] + lines[last + 1:]) + "\n")
    out = gantry("diagnose", bad, "--stage", "x", "--json")
    assert one_line(out) and f"row {last + 1}" in out.stderr and "time_s" in out.stderr, out.stderr
    gapped = tmp_path / "gap.csv"           # ten samples missing: still a recording
    gapped.write_text("\n".join(lines[:first + 50] + lines[first + 60:]) + "\n")
    assert gantry("diagnose", gapped, "--stage", "x", "--json").returncode == 0


@pytest.mark.parametrize("old,new,key", [
    ("motor_peak_force_n = 300.0", 'motor_peak_force_n = 300.0\nmotor_force_criterion = "sine"',
     "admittance.hardware.motor_force_criterion"),
    ('law = "forward_euler"', 'law = "bilinear"', "admittance.rig.law"),
    ("computation_delay_samples = 0", "computation_delay_samples = { min = 2, max = 1 }",
     "admittance.rig.computation_delay_samples"),
    ("computation_delay_samples = 0", "computation_delay_samples = 0.5", "admittance.rig.computation_delay_samples"),
])
def test_an_unknown_admittance_rule_is_one_line_naming_its_key(tmp_path, monkeypatch, capsys, old, new, key):
    text = admittance_text()
    assert old in text
    spec = tmp_path / "spec.toml"
    spec.write_text(text.replace(old, new, 1))
    code, err, _ = in_process(monkeypatch, capsys, "synth", spec)
    assert code == 2 and err.count("\n") == 1 and err.startswith(f"gantry: error: {spec}: {key}")
    assert "Traceback" not in err


def test_a_mouse_run_refuses_an_effect_it_cannot_simulate_by_name(tmp_path, monkeypatch, capsys):
    # the run simulates the plant's linear model; an encoder's differencing, which it would replace by a rational
    # approximation, is refused in one line that names it (never simulated without it)
    text = admittance_text()
    old = "current_loop = { bandwidth_hz = 1000.0 }"
    assert old in text
    spec = tmp_path / "spec.toml"
    spec.write_text(text.replace(old, old + "\nencoder_velocity = { rate_hz = 4000.0 }", 1))
    code, err, _ = in_process(monkeypatch, capsys, "mouse-run", spec, "--lab")
    assert code == 2 and err.count("\n") == 1 and "plant.effects" in err and "encoder_velocity" in err, err


def test_an_unknown_loop_structure_is_one_line_naming_the_known_ones(tmp_path, monkeypatch, capsys):
    # the structures a spec may name are the classes of design.loop.dual (each with its gain search)
    from design.loop.dual import BY_NAME
    from design.synth.dual import SEARCHES

    assert set(SEARCHES) == set(BY_NAME)
    text = (ROOT / "specs" / "stage_y_dual.toml").read_text()
    spec = tmp_path / "spec.toml"
    old = 'structures = ["per_motor", "common_differential", "master_slave"]'
    assert old in text
    spec.write_text(text.replace(old, 'structures = ["per_motor", "crossed"]', 1))
    code, err, _ = in_process(monkeypatch, capsys, "synth", spec)
    assert code == 2 and err.count("\n") == 1 and "dual_drive.structures" in err and "'crossed'" in err, err
    assert all(name in err for name in BY_NAME), err


def test_yaw_coupling_without_both_rails_is_refused_by_name(tmp_path):
    t = np.arange(0.0, 4.0, 0.001)
    rec = tmp_path / "one_rail.csv"
    np.savetxt(rec, np.column_stack([t, np.sin(2 * np.pi * t), 1e-5 * np.cumsum(np.sin(2 * np.pi * t))]),
               delimiter=",", header="time_s,current_a,position_m", comments="")
    one_output = gantry("fit", rec, "--stage", "y", "--effects", "yaw_coupling")
    assert one_line(one_output) and "yaw_coupling follows the rails' difference" in one_output.stderr
    stage_x = gantry("fit", rec, "--stage", "x", "--effects", "yaw_coupling")
    assert one_line(stage_x) and "yaw_coupling applies to Stage Y only" in stage_x.stderr
