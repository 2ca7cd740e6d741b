"""Continuous time-domain simulator (plant/experiment/simulate_time.py).

References share no code with it: the Runge-Kutta linear-motor axis and the event-located stick-slip axis of
``tests/reference/`` (NumPy/SciPy only), and python-control's ``forced_response`` for the linear chain.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import control
import independent_stick_slip
import numpy as np
import pytest
from independent_linear_motor import LinearMotorAxis, record

from plant import (
    CoulombFriction,
    CurrentLimit,
    CurrentLoop,
    Delay,
    EffectError,
    ForceConstantProfile,
    ForceRipple,
    Offset,
    ParameterError,
    Sampling,
    StribeckFriction,
    TiltCoupling,
    stage_x,
    stage_y,
)
from plant.experiment.simulate_time import INTERNAL_RATE_HZ, chirp, simulate_time_domain, stepped_sine
from plant.physics.effects import make_effect

AXIS = dict(mass_kg=35.0, damping_n_s_per_m=440.0, force_constant_n_per_a=20.0)


def test_linear_motor_forces_match_an_independent_runge_kutta_axis():
    """Ripple (two harmonics with phases), a force constant falling off towards the track's ends and a hard
    current limit, over a 12 s stepped sine that carries the carriage 0.16 m: the positions agree with the
    independent axis (RK4, 8 substeps at 500 Hz) to 1e-7 of the travel."""
    axis = LinearMotorAxis(current_limit_a=2.5, kt_droop=0.2, ripple_n=(3.0, 1.0), ripple_phase_rad=(0.4, -1.0))
    excitation = stepped_sine([0.25, 1, 4], amplitude_a=3.0, block_s=4.0)
    t, _, x_ref = record(axis, excitation.current_a, excitation.duration_s, sample_rate_hz=500.0,
                         current_noise_a=0.0, position_noise_m=0.0, substeps=8)
    # the independent ripple a sin(theta + phi) pushes the carriage; the tool's is the force the motor must supply
    ripple = ForceRipple(0.03, sin1_n=-3.0 * math.cos(0.4), cos1_n=-3.0 * math.sin(0.4),
                         sin2_n=-1.0 * math.cos(-1.0), cos2_n=-1.0 * math.sin(-1.0))
    plant = (stage_x(**AXIS, excitation_current_a=3.0) * CurrentLimit(50.0) * ripple
             * ForceConstantProfile(0.0, 0.25, curvature=-0.2))
    rec = simulate_time_domain(plant, excitation, sample_rate_hz=500.0)
    assert rec.output_kind == "position" and rec.output_names == ("position_m",)
    np.testing.assert_allclose(rec.time_s, t)
    assert np.ptp(x_ref) > 0.15
    assert np.max(np.abs(rec.output[0] - x_ref)) < 1e-7 * np.ptp(x_ref)


def _cable_drag_error(monkeypatch, v_d: float, substeps: int) -> float:
    """Largest position difference, over the travel, between the tool's continuous run of a cable's drag growing
    from its fixed end (40 N/m (x + 0.25 m): its Coulomb friction at mid-travel plus its drag slope, stuck exactly
    at rest) and the independent axis's regularised friction (RK4, tanh of v over ``v_d``)."""
    import independent_linear_motor

    excitation = stepped_sine([0.25, 1, 4], amplitude_a=3.0, block_s=4.0)
    centre = 0.05
    plant = (stage_x(**AXIS, excitation_current_a=3.0) * CoulombFriction(40.0 * (centre + 0.25))
             * make_effect("cable_force", stiffness_n_per_m=0.0, centre_m=centre, drag_n_per_m=40.0))
    rec = simulate_time_domain(plant, excitation, sample_rate_hz=500.0)
    monkeypatch.setattr(independent_linear_motor, "DRAG_VELOCITY_M_PER_S", v_d)
    _, _, x_ref = record(LinearMotorAxis(cable_drag_n_per_m=40.0, cable_fixed_m=-0.25), excitation.current_a,
                         excitation.duration_s, sample_rate_hz=500.0, current_noise_a=0.0, position_noise_m=0.0,
                         substeps=substeps)
    return float(np.max(np.abs(rec.output[0] - x_ref)) / np.ptp(x_ref))


def test_a_cable_drag_along_the_travel_matches_the_independent_axis(monkeypatch):
    """At the independent simulator's v_d the positions agree to 5e-4 of the travel (measured 4.0e-4)."""
    import independent_linear_motor

    assert _cable_drag_error(monkeypatch, independent_linear_motor.DRAG_VELOCITY_M_PER_S, 16) < 5e-4


@pytest.mark.slow
def test_a_cable_drag_converges_as_the_independent_friction_sharpens(monkeypatch):
    """At a quarter of v_d (64 steps per sample) the difference falls below 2e-4 of the travel (measured 1.2e-4;
    1.1e-4 at a sixteenth: the independent axis's creep while stuck shrinks with v_d, the rest is the friction
    law's own step, 0.2 % of the velocity in the stick-slip test below)."""
    import independent_linear_motor

    assert _cable_drag_error(monkeypatch, independent_linear_motor.DRAG_VELOCITY_M_PER_S / 4, 64) < 2e-4


@pytest.mark.parametrize("stribeck_n", [0.0, 1.5])
@pytest.mark.parametrize("f_hz, sticks", [(0.7, True), (6.0, False)])
def test_coulomb_and_stribeck_friction_match_an_event_located_stick_slip_axis(f_hz, sticks, stribeck_n):
    """Breakaway from rest, then reversals that stick (0.7 Hz) or slide through (6 Hz): a sine of 8 N against
    2 N of Coulomb friction (plus a Stribeck rise to 3.5 N static); the velocity agrees with the exact
    event-located solution to 0.2 % of its peak."""
    fc, fs, vs, force = 2.0, stribeck_n, 0.002, 8.0
    excitation = stepped_sine([f_hz], amplitude_a=force / AXIS["force_constant_n_per_a"], block_s=3.0 / f_hz + 1.0)
    plant = stage_x(**AXIS, excitation_current_a=0.4) * CoulombFriction(fc)
    if fs:
        plant = plant * StribeckFriction(fs, vs)
    rec = simulate_time_domain(plant, excitation, output="velocity", internal_rate_hz=20000.0)
    v_ref = independent_stick_slip.velocity(rec.time_s, mass_kg=AXIS["mass_kg"],
                                            damping_n_s_per_m=AXIS["damping_n_s_per_m"], friction_n=fc,
                                            force_n=force, f_hz=f_hz, stribeck_n=fs, stribeck_m_per_s=vs)
    peak = np.max(np.abs(v_ref))
    assert (np.count_nonzero(v_ref[v_ref.size // 2:] == 0.0) > 0) == sticks
    assert np.max(np.abs(rec.output[0] - v_ref)) < 2e-3 * peak


def test_linear_chain_with_delay_current_loop_and_offset_matches_python_control():
    """A chirp through a 1.3 ms delay, a 150 Hz current loop and a 4 N offset: python-control's forced
    responses of the current loop and mechanics to the shifted command, plus the mechanics' to -4 N."""
    plant = stage_x(**AXIS) * Delay(0.0013) * CurrentLoop(150.0) * Offset(4.0)
    excitation = chirp(f0_hz=0.5, f1_hz=40.0, amplitude_a=1.0, duration_s=4.0)
    rec = simulate_time_domain(plant, excitation, output="velocity")
    t = np.arange(0, 4.0, 1e-5)
    command = np.where(t >= 0.0013, excitation.current_a(np.maximum(t - 0.0013, 0.0)), 0.0)
    m, b, kt = AXIS["mass_kg"], AXIS["damping_n_s_per_m"], AXIS["force_constant_n_per_a"]
    wc = 2 * math.pi * 150.0
    mechanics = control.tf([1.0], [m, b])
    _, v_drive = control.forced_response(control.tf([kt * wc], [1.0, wc]) * mechanics, t, command)
    _, v_offset = control.forced_response(mechanics, t, np.full(t.size, -4.0))
    v = v_drive + v_offset
    v_ref = np.interp(rec.time_s, t, v)
    assert np.max(np.abs(rec.output[0] - v_ref)) < 1e-4 * np.max(np.abs(v_ref))


def test_sampling_holds_the_command_one_controller_period_late():
    """With a 1 kHz controller the mechanics see the command sampled at k T and held over [(k+1) T, (k+2) T):
    python-control's response to that staircase."""
    plant = stage_x(**AXIS) * Sampling(1000.0)
    excitation = stepped_sine([3.0], amplitude_a=1.0, block_s=2.0)
    rec = simulate_time_domain(plant, excitation, output="velocity", sample_rate_hz=2000.0)
    t = np.arange(0, 2.0, 1e-5)
    k = np.floor(t * 1000.0 + 1e-9) - 1
    staircase = np.where(k >= 0, excitation.current_a(np.maximum(k, 0) / 1000.0), 0.0)
    _, v = control.forced_response(control.tf([AXIS["force_constant_n_per_a"]], [AXIS["mass_kg"],
                                                                                AXIS["damping_n_s_per_m"]]),
                                   t, staircase)
    v_ref = np.interp(rec.time_s, t, v)
    assert np.max(np.abs(rec.output[0] - v_ref)) < 2e-3 * np.max(np.abs(v_ref))


def test_noise_and_metadata():
    plant = stage_x() * ForceRipple(0.03, sin1_n=2.0)
    excitation = stepped_sine([1.0], amplitude_a=0.5, block_s=2.0)
    clean = simulate_time_domain(plant, excitation)
    noisy = simulate_time_domain(plant, excitation, current_noise_a=0.01, noise=1e-6, seed=3)
    assert np.std(noisy.output[0] - clean.output[0]) == pytest.approx(1e-6, rel=0.1)
    assert np.std(noisy.current_a - clean.current_a) == pytest.approx(0.01, rel=0.1)
    assert noisy.metadata["seed"] == 3 and noisy.metadata["parameters"]["force_ripple.sin1_n"] == 2.0
    assert noisy.metadata["excitation"]["f_hz"] == [1.0]


def test_stage_y_records_both_sides_and_tilt_is_refused():
    excitation = stepped_sine([2.0], amplitude_a=1.0, block_s=1.0)
    rec = simulate_time_domain(stage_y(), excitation)
    assert rec.output_names == ("position_y1_m", "position_y2_m")
    np.testing.assert_allclose(rec.output[0], rec.output[1])
    with pytest.raises(EffectError, match="tilt_coupling"):
        simulate_time_domain(stage_y() * TiltCoupling(), excitation)


@pytest.mark.parametrize("kwargs, match", [
    (dict(output="acceleration"), "output"),
    (dict(sample_rate_hz=-1.0), "sample_rate_hz"),
    (dict(noise=float("nan")), "noise"),
    (dict(seed=-1), "seed"),
])
def test_bad_arguments_are_named(kwargs, match):
    with pytest.raises(ParameterError, match=match):
        simulate_time_domain(stage_x(), stepped_sine([1.0], amplitude_a=1.0, block_s=1.0), **kwargs)


def test_bad_excitations_are_named():
    with pytest.raises(ParameterError, match="f1_hz"):
        chirp(f0_hz=5.0, f1_hz=1.0, amplitude_a=1.0, duration_s=1.0)
    with pytest.raises(ParameterError, match="block_s"):
        stepped_sine([1.0], amplitude_a=1.0, block_s=0.0)


@dataclass(frozen=True)
class _Drag(Offset):
    """A rail force that depends on the velocity only: a viscous drag -c v (N), the form of a cable carrier's."""

    drag_n_s_per_m: float = 0.0

    def rail_force_n(self, position_m, velocity_m_per_s, motor_force_n):
        return -self.drag_n_s_per_m * velocity_m_per_s


def test_a_rail_force_sees_the_rails_velocity():
    """A drag of 300 N*s/m applied as a rail force against python-control's axis with that much more damping
    (the force is held at its value at the step's predicted midpoint: the error is second order in the step,
    about 4e-6 of the peak at the default internal rate and a quarter of that at twice the rate)."""
    plant = stage_x(**AXIS) * CurrentLoop(150.0) * _Drag(0.0, drag_n_s_per_m=300.0)
    excitation = chirp(f0_hz=0.5, f1_hz=40.0, amplitude_a=1.0, duration_s=2.0)
    t = np.arange(0, 2.0, 1e-5)
    m, b, kt = AXIS["mass_kg"], AXIS["damping_n_s_per_m"], AXIS["force_constant_n_per_a"]
    wc = 2 * math.pi * 150.0
    _, v = control.forced_response(control.tf([kt * wc], [1.0, wc]) * control.tf([1.0], [m, b + 300.0]), t,
                                   excitation.current_a(t))
    errors = []
    for rate_hz in (INTERNAL_RATE_HZ, 2 * INTERNAL_RATE_HZ):
        rec = simulate_time_domain(plant, excitation, output="velocity", internal_rate_hz=rate_hz)
        v_ref = np.interp(rec.time_s, t, v)
        errors.append(np.max(np.abs(rec.output[0] - v_ref)) / np.max(np.abs(v_ref)))
    assert errors[0] < 2e-5
    assert errors[1] < 0.35 * errors[0]
    # and the drag matters by far more than that tolerance
    assert np.max(np.abs(simulate_time_domain(stage_x(**AXIS) * CurrentLoop(150.0), excitation,
                                              output="velocity").output[0] - v_ref)) > 0.1 * np.max(np.abs(v_ref))
