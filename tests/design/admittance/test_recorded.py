"""The motor on a recorded force (``design.admittance.recorded``) against a fine-step Runge-Kutta simulation of the
sampled loop that shares no code with it (``independent_recorded_force``: a true, buffered drive delay, no Pade),
on the lab's own record at the bundled spec's corners where the motor's transient is sharpest; a constant force
against its closed form; and the spec key's errors."""

import subprocess
import sys
from pathlib import Path

import independent_recorded_force as ref
import numpy as np
import pytest

from design.admittance.model import PiLoops
from design.admittance.recorded import RecordedMotor
from design.admittance.rig import RigTiming
from design.loop.controller import PI
from design.problem import ForceRecord
from design.spec.schema import load_spec, parse_spec
from design.synth.scenarios import Scenarios
from plant.errors import SpecError

ROOT = Path(__file__).resolve().parents[3]
SPEC = ROOT / "specs" / "stage_x_admittance.toml"
RECORD = ROOT / "examples" / "data" / "lab_mouse_track.csv"
KP, KI, M_V, B_V = 209.9, 14.12, 0.0414, 4.96


def _segment(t0=46.0, t1=48.0) -> ForceRecord:
    """The 2 s of the lab's record around its hardest push (the motor's peak on the whole record is at 47.35 s)."""
    d = np.loadtxt(RECORD, delimiter=",", skiprows=1)
    keep = (d[:, 0] >= t0) & (d[:, 0] <= t1)
    return ForceRecord("segment", tuple(d[keep, 0]), tuple(d[keep, 3]))


def _row(payload, damping, delay, current):
    return {"payload_kg": payload, "damping_n_s_per_m": damping, "delay.seconds": delay,
            "current_loop.bandwidth_hz": current}


def _tool(record, row, timing, m_v=M_V, b_v=B_V):
    sc = Scenarios(np.array([row["payload_kg"]]), {k: np.array([v]) for k, v in row.items() if k != "payload_kg"})
    loops = PiLoops.of(load_spec(SPEC).problem(), PI(KP, KI))
    return RecordedMotor(record, sc, loops=loops, timing=timing).peaks(m_v, b_v)


@pytest.mark.parametrize("row, rule, delay_samples, filter_hz", [
    (_row(5.0, 330.0, 0.0003, 1300.0), "forward_euler", 0, None),      # the sharpest transient: light, fast drive
    (_row(40.0, 550.0, 0.0003, 1300.0), "forward_euler", 0, None),     # the worst case on the whole record
    (_row(40.0, 550.0, 0.0008, 700.0), "tustin", 1, 30.0),             # slow drive, a filter and a sample's delay
    (_row(5.0, 330.0, 0.0008, 1300.0), "backward_euler", 1, 30.0),
])
def test_motor_peak_agrees_with_a_fine_step_simulation(row, rule, delay_samples, filter_hz):
    record = _segment()
    timing = RigTiming(0.01, delay_samples=delay_samples, filter_hz=filter_hz, filter_order=2, rule=rule)
    tool = _tool(record, row, timing)
    t, force = ref.motor_force(record.time_s, record.force_n, mass_kg=row["payload_kg"],
                               damping=row["damping_n_s_per_m"], kt=20.0, kp=KP, ki=KI, delay_s=row["delay.seconds"],
                               current_hz=row["current_loop.bandwidth_hz"], m_v=M_V, b_v=B_V, period_s=0.01, law=rule,
                               delay_samples=delay_samples, filter_hz=filter_hz)
    k = int(np.argmax(np.abs(force)))
    assert tool.peak_n[0] == pytest.approx(abs(force[k]), rel=2e-3)
    assert tool.at_s[0] == pytest.approx(t[k] - t[0], abs=2e-4)


def test_a_force_held_since_long_before_asks_the_closed_form():
    """Under a constant push F the gantry runs at F / b_v and the motor holds b v - F against the rails' damping."""
    record = ForceRecord("constant", (0.0, 1.0), (0.8, 0.8))
    row = _row(20.0, 440.0, 0.0005, 1000.0)
    for rule in ("forward_euler", "tustin", "zoh"):
        peak = _tool(record, row, RigTiming(0.01, delay_samples=1, filter_hz=30.0, rule=rule)).peak_n[0]
        assert peak == pytest.approx((440.0 / B_V - 1.0) * 0.8, rel=1e-9)


def test_the_lab_record_asks_more_of_the_motor_than_the_trapezoid_at_the_bundled_design():
    """The lab's mouse pushes up to 1.38 N, faster than the 0.2 m/s envelope at b_v 4.96: a figure the trapezoid
    cannot show (its motor peak is 162 N there)."""
    d = np.loadtxt(RECORD, delimiter=",", skiprows=1)
    record = ForceRecord("lab", tuple(d[:, 0]), tuple(d[:, 3]))
    peak = _tool(record, _row(40.0, 550.0, 0.0003, 1300.0), RigTiming(0.01, rule="forward_euler"))
    assert 250.0 < peak.peak_n[0] < 270.0
    assert peak.at_s[0] == pytest.approx(47.35, abs=0.01)


def _spec_with(record_line: str, extra: str = "") -> str:
    """The bundled spec with its ``force_record`` line replaced."""
    lines = [record_line if line.startswith("force_record") else line for line in SPEC.read_text().splitlines()]
    return "\n".join(lines) + "\n" + extra


def test_an_inline_record_is_read_and_a_file_relative_to_the_spec(tmp_path):
    (tmp_path / "f.csv").write_text("time_s,force_n\n0,0.1\n0.05,0.2\n0.1,0.15\n")
    path = tmp_path / "s.toml"
    path.write_text(_spec_with('force_record = "f.csv"'))
    rec = load_spec(path).problem().admittance.locomotion.force_record
    assert (rec.file, rec.time_s, rec.force_n) == ("f.csv", (0.0, 0.05, 0.1), (0.1, 0.2, 0.15))
    path.write_text(_spec_with("force_record = { time_s = [0.0, 1.0], force_n = [0.5, 0.5] }"))
    rec = load_spec(path).problem().admittance.locomotion.force_record
    assert (rec.file, rec.duration_s) == ("inline", 1.0)


@pytest.mark.parametrize("csv, record_line, extra, needle", [
    ("time_s,force_n\n0,0.1\n0.05,0.2\n0.05,0.3\n", 'force_record = "f.csv"', "",
     "f.csv: row 4, column 'time_s': 0.05 does not follow 0.05"),
    ("time_s,force\n0,0.1\n", 'force_record = "f.csv"', "", "missing column 'force_n'"),
    ("time_s,force_n\n0,0.1\n0.05,abc\n", 'force_record = "f.csv"', "", "row 3, column 'force_n': 'abc'"),
    (None, 'force_record = "absent.csv"', "", "absent.csv"),
    (None, "force_record = { time_s = [0.0, 1.0], force_n = [0.5] }", "", "time_s has 2 values and force_n 1"),
])
def test_a_bad_record_is_one_line_naming_the_file_row_and_column(tmp_path, csv, record_line, extra, needle):
    if csv is not None:
        (tmp_path / "f.csv").write_text(csv)
    path = tmp_path / "s.toml"
    path.write_text(_spec_with(record_line, extra))
    with pytest.raises(SpecError) as err:
        load_spec(path)
    assert needle in str(err.value) and "admittance.locomotion.force_record" in str(err.value)


def test_a_record_needs_a_sampled_law():
    import tomllib

    data = tomllib.loads(_spec_with("force_record = { time_s = [0.0, 1.0], force_n = [0.5, 0.5] }"))
    del data["admittance"]["rig"]
    with pytest.raises(SpecError, match="admittance.rig.update_rate_hz"):
        parse_spec(data)


def test_the_command_refuses_a_bad_record_with_exit_2_and_one_line(tmp_path):
    (tmp_path / "f.csv").write_text("time_s,force_n\n1,0.1\n0.5,0.2\n")
    path = tmp_path / "s.toml"
    path.write_text(_spec_with('force_record = "f.csv"'))
    out = subprocess.run([sys.executable, "-m", "design", "synth", str(path)], capture_output=True, text=True)
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1 and "row 3, column 'time_s'" in out.stderr and "Traceback" not in out.stderr


@pytest.mark.slow
def test_a_record_that_asks_too_much_moves_the_design_until_the_motor_holds_it_and_is_named():
    from bundled_specs import admittance_data

    from design.admittance.synthesis import synthesise_admittance

    data = admittance_data()
    data["admittance"]["hardware"]["motor_peak_force_n"] = 240.0
    res = synthesise_admittance(parse_spec(data).problem(), tradeoff=False)
    peak, _, _ = res.check.recorded_worst()
    assert res.status == "optimal" and peak <= 240.0 * (1 + 1e-6)
    assert "force_record" in res.binding.detail and res.b_v > 4.96
