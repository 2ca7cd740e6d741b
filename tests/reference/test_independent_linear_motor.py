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


def test_drifting_force_constant_and_damping_match_the_exact_ramp_responses():
    """A constant current i0 on a force constant K (1 + r t): m v' + b v = K i0 (1 + r t), v(0) = 0, has
    v = (K i0 / b) (1 + r t - r m / b - (1 - r m / b) e^{-b t / m}); the damping drifting as b (1 + q t) against
    Heun's method on the same equation at a step 40x finer than the samples."""
    m, b, kt, i0, r = 35.0, 440.0, 20.0, 2.0, -0.01
    t = np.arange(2000) / 500.0
    _, v = lm.LinearMotorAxis(mass_kg=m, damping_n_s_per_m=b, kt_n_per_a=kt, kt_rate_per_s=r).run(
        lambda s: i0, t)
    exact = kt * i0 / b * (1 + r * t - r * m / b - (1 - r * m / b) * np.exp(-b * t / m))
    assert np.max(np.abs(v[:, 0] - exact)) < 1e-7 * np.max(np.abs(exact))
    q = 0.02
    t = t[:1000]
    _, v = lm.LinearMotorAxis(mass_kg=m, damping_n_s_per_m=b, kt_n_per_a=kt, damping_rate_per_s=q).run(
        lambda s: i0, t)
    h, vv, fine = 5e-5, 0.0, np.empty(t.size)
    for k in range(t.size):                 # Heun's method at a step 40x finer than a sample
        fine[k] = vv
        for j in range(40):
            s = t[k] + j * h
            f1 = (kt * i0 - b * (1 + q * s) * vv) / m
            f2 = (kt * i0 - b * (1 + q * (s + h)) * (vv + h * f1)) / m
            vv += h / 2 * (f1 + f2)
    assert np.max(np.abs(v[:, 0] - fine)) < 1e-6 * np.max(np.abs(fine))
