"""A force constant drifting over a time-domain recording shows in the residual against current x time, and only
there, and is fitted (``force_constant_drift``); a damping drifting (the independent linear motor's guides,
b (1 + r t)) against velocity x time, and only there. The closed-loop friction axis of
tests/reference/independent_friction_sim.py (it imports nothing of the tool) applies gain x command; a logged command
divided by 1 + d u (u running from -1 to 1 over the record) is what a drive whose force constant is K (1 + d u) logs
for the same motion, seen with a constant K."""

import numpy as np
import pytest
from independent_friction_sim import Axis, simulate

from plant.data.recordings import TimeRecording
from plant.diagnose.time_diagnosis import diagnose_time
from plant.identify.inverse_model import Preprocessing
from plant.physics.models import Plant

AXIS = Axis(offset_n=-3.0)


def structure(drift: float):
    log = simulate(AXIS, seed=3)
    u = np.linspace(-1.0, 1.0, log.time_s.size)
    rec = TimeRecording(log.time_s, log.command_v / (1 + drift * u), log.position_m[None], "position",
                        ("position_m",), reference=log.reference_m)
    diag = diagnose_time(Plant("x", force_constant_n_per_a=AXIS.gain_n_per_v), rec,
                         prep=Preprocessing(input_hold=True))
    return diag, next(st for st in diag.final.structure if st.variable == "current x time")


def test_a_force_constant_drifting_4_percent_is_fitted_and_named():
    """Shown against current x time (not velocity x time) by the model without it, then fitted:
    ``force_constant_drift`` with its change, the recording explained."""
    diag, st = structure(0.02)                         # K(t) / K from 0.98 to 1.02 over the record
    parent = diag.models[tuple(n for n in diag.selected if n != "force_constant_drift")]
    shown = {s.variable: s for s in parent.structure}
    assert shown["current x time"].significant and "drifting" in shown["current x time"].summary
    assert not shown["velocity x time"].significant
    change = float(shown["current x time"].summary.split(": ")[-1].split(" %")[0])
    assert abs(change - 4.0) < 0.6, shown["current x time"].summary      # +4 % from the first sample to the last
    assert set(diag.selected) == {"coulomb_friction", "offset", "force_constant_drift"}
    assert diag.verdict == "explained"
    assert diag.final.plant.effect("force_constant_drift").change == pytest.approx(0.02, abs=0.002)


def test_a_constant_force_constant_shows_no_drift():
    diag, st = structure(0.0)
    assert not st.significant and diag.verdict == "explained"
    assert "force_constant_drift" not in diag.selected


def _sweep_with_damping_rising(change: float):
    """The independent linear motor's guides' damping rising by ``change`` over a 16 s open-loop sweep."""
    import independent_linear_motor as lm

    from plant import stage_x

    t, current, position = lm.slow_sweep(lm.LinearMotorAxis(damping_rate_per_s=change / 16.0), seed=2)
    diag = diagnose_time(stage_x(), TimeRecording(t, current, position[None], "position", ("x",)))
    return diag, {st.variable: st for st in diag.final.structure}


def test_a_damping_rising_10_percent_shows_against_velocity_x_time_with_its_size():
    diag, st = _sweep_with_damping_rising(0.10)
    damping = st["velocity x time"]
    assert damping.significant and not st["current x time"].significant
    change = float(damping.summary.split(": ")[-1].split(" %")[0])
    assert abs(change - 10.0) < 1.0, damping.summary       # +9.4 % between the first and last kept samples
    assert diag.verdict == "not_explained" and "damping drifting" in diag.explanation


def test_a_constant_damping_shows_no_drift():
    diag, st = _sweep_with_damping_rising(0.0)
    assert not st["velocity x time"].significant and diag.verdict == "explained"
