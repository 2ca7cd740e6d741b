"""Residual tests that see what bins of one variable average out: a force constant that falls off towards
the ends of the magnet track (the residual is current x position: zero mean in every position bin) and a
force ripple periodic in position, each named with its size in the base model's residual (the diagnosis
then adds the effect: ``test_motor_forces``); a control with neither, in which no effect is added.

Recordings from the independent linear-motor simulator (``tests/reference/independent_linear_motor.py``):
a slow sweep over 0.17 m of travel, position recorded.
"""

import independent_linear_motor as lm
import pytest

from plant import stage_x
from plant.data.recordings import TimeRecording
from plant.diagnose.evidence import EXPLAINED
from plant.diagnose.time_diagnosis import diagnose_time


def _diagnose(axis, seed):
    t, current, position = lm.slow_sweep(axis, seed=seed)
    return diagnose_time(stage_x(), TimeRecording(t, current, position[None, :], "position", ("x",), source="sweep"))


def _structure(diag, name):
    return next(st for st in diag.models[()].structure if st.variable == name)


def test_force_constant_profile_is_named_as_current_times_position():
    """Truth: K(x) = K0 (1 - 0.3 (2 x / 0.3 m)^2): relative to its value mid-travel (0.086 m), -32 % at 0.17 m
    and +11 % at 0 m; the first-order description must have the right signs and size."""
    diag = _diagnose(lm.LinearMotorAxis(kt_droop=0.3, travel_m=0.3), seed=1)
    kt = _structure(diag, "current x position")
    assert kt.significant and kt.share > 0.8
    assert not _structure(diag, "position, periodic").significant
    assert "force constant that varies along the travel" in kt.summary
    at_end, at_start = (float(w.split(" % at ")[0].split()[-1]) for w in kt.summary.split(": ")[1].split(", "))
    assert -45 < at_end < -15 and 5 < at_start < 30


def test_force_ripple_is_named_with_its_pitch_and_amplitude():
    diag = _diagnose(lm.LinearMotorAxis(ripple_n=(3.0,), ripple_phase_rad=(0.4,), ripple_pitch_m=0.02), seed=2)
    ripple = _structure(diag, "position, periodic")
    assert ripple.significant
    assert not _structure(diag, "current x position").significant
    pitch_mm = float(ripple.summary.split("pitch ")[1].split(" mm")[0])
    amplitude_n = float(ripple.summary.split("amplitude ")[1].split(" N")[0])
    assert pitch_mm == pytest.approx(20.0, rel=0.03)
    assert amplitude_n == pytest.approx(3.0, rel=0.1)


def test_axis_without_either_is_explained_and_flags_nothing():
    diag = _diagnose(lm.LinearMotorAxis(), seed=3)
    assert diag.verdict == EXPLAINED
    assert diag.selected == ()
    assert not any(st.significant for st in diag.models[()].structure)
