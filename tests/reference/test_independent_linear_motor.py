"""The linear-motor simulator's integration against closed forms (its own check; no tool code)."""

import independent_linear_motor as lm
import numpy as np


def test_linear_axis_matches_the_exact_sine_response_from_rest():
    """m v' + b v = Kt A sin(w t), v(0) = 0: v = Kt A (b sin - m w cos + m w e^{-b t / m}) / (b^2 + m^2 w^2)."""
    axis = lm.LinearMotorAxis()
    m, b, kt, amp = axis.mass_kg, axis.damping_n_s_per_m, axis.kt_n_per_a, 0.8
    f = np.array([1.0, 7.0, 60.0])
    t = np.arange(2000) / 1000.0
    _, v = axis.run(lambda s: amp * np.sin(2 * np.pi * f * s), t, f.size)
    w = 2 * np.pi * f
    exact = kt * amp * (b * np.sin(np.outer(t, w)) - m * w * np.cos(np.outer(t, w))
                        + m * w * np.exp(-b * t / m)[:, None]) / (b**2 + (m * w) ** 2)
    assert np.max(np.abs(v - exact)) < 1e-7 * np.max(np.abs(exact))


def test_current_limit_clips_the_force_and_ripple_follows_position():
    axis = lm.LinearMotorAxis(current_limit_a=0.5, ripple_n=(2.0,), ripple_phase_rad=(0.0,), ripple_pitch_m=0.04)
    assert axis.force_n(np.array([2.0]), np.array([0.0]))[0] == 0.5 * axis.kt_n_per_a
    assert np.isclose(axis.force_n(np.array([0.0]), np.array([0.01]))[0], 2.0)
    droop = lm.LinearMotorAxis(kt_droop=0.2, travel_m=0.5)
    assert np.isclose(droop.force_n(np.array([1.0]), np.array([0.25]))[0], 0.8 * droop.kt_n_per_a)
