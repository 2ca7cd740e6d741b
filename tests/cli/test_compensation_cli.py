"""`gantry diagnose --compensation`: the table of a time-domain recording's position-dependent forces, and a clear
refusal where there is none. Recordings from the independent linear-motor simulator."""


import independent_linear_motor as lm
import numpy as np
from in_process import gantry


def _sweep_csv(path, axis):
    t, current, position = lm.slow_sweep(axis, seed=11)
    np.savetxt(path, np.column_stack([t, current, position]), delimiter=",", header="time_s,current_a,position_m",
               comments="", fmt="%.9g")
    return path


def test_compensation_table_is_written_for_a_ripple(tmp_path):
    rec = _sweep_csv(tmp_path / "sweep.csv", lm.LinearMotorAxis(ripple_n=(3.0,), ripple_pitch_m=0.02))
    table = tmp_path / "table.csv"
    out = gantry("diagnose", rec, "--stage", "x", "--compensation", table)
    assert out.returncode == 0, out.stderr
    assert "force_ripple" in out.stdout and f"compensation table written to {table}" in out.stdout
    x, scale, offset = np.loadtxt(table, delimiter=",", comments="#", skiprows=2).T
    assert np.allclose(scale, 1.0)                          # no force-constant profile selected
    assert 5.5 < np.ptp(offset) * 20.0 < 6.5               # peak to peak of a 3 N ripple, in N


def test_compensation_without_a_position_dependent_force_is_refused_in_one_line(tmp_path):
    rec = _sweep_csv(tmp_path / "sweep.csv", lm.LinearMotorAxis())
    table = tmp_path / "table.csv"
    out = gantry("diagnose", rec, "--stage", "x", "--compensation", table)
    assert out.returncode == 2
    assert "nothing to compensate" in out.stderr and out.stderr.count("\n") == 1
    assert not table.exists()


def test_stepped_sine_simulation_refuses_forces_it_does_not_model(tmp_path):
    for effect in ("force_ripple.sin1_n=3", "force_constant_profile.slope=0.1", "offset.force_n=2"):
        out = gantry("simulate", "--stage", "x", "--effects", effect, "--f-hz", "2:40:4", "--duration-s", "2",
                     "--out", tmp_path / "rec.csv")
        assert out.returncode == 2, effect
        assert "do not model it" in out.stderr and "--form continuous" in out.stderr
        assert out.stderr.count("\n") == 1
        assert not (tmp_path / "rec.csv").exists()
