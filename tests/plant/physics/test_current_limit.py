"""The drive's current limit in the frequency domain: its describing function against the first Fourier
coefficient of a clipped sine computed numerically, and the plant's stepped-sine response against the
independent linear-motor simulator (``tests/reference/independent_linear_motor.py``), whose clip acts on the
command of a linear axis, so that the fundamental is exactly the describing gain times the linear response."""

import dataclasses

import independent_linear_motor as lm
import numpy as np
import pytest

from plant import stage_x
from plant.errors import EffectError, ParameterError
from plant.physics.effects import make_effect


@pytest.mark.parametrize("ratio", [0.1, 0.35, 0.6, 0.9, 1.0, 2.0])
@pytest.mark.parametrize("fraction", [1.0, 0.4])
def test_describing_gain_is_the_first_fourier_coefficient_of_the_clipped_sine(ratio, fraction):
    limit = make_effect("current_limit", limit_n=ratio * 50.0, fraction_lost=fraction)
    phase = np.linspace(0, 2 * np.pi, 200_000, endpoint=False)
    command = 50.0 * np.sin(phase)
    delivered = command - fraction * (command - np.clip(command, -ratio * 50.0, ratio * 50.0))
    first = 2 * np.mean(delivered * np.sin(phase)) / 50.0
    assert limit.describing_gain(50.0) == pytest.approx(first, abs=1e-8)


@pytest.mark.parametrize("amplitude_a", [0.8, pytest.param(1.5, marks=pytest.mark.slow)])
def test_stepped_sine_fundamental_is_the_describing_gain_times_the_linear_response(amplitude_a):
    """Commands of 0.8 A (unclipped) and 1.5 A against a 1 A limit, Stage X defaults in both."""
    axis = lm.LinearMotorAxis(current_limit_a=1.0)
    f_hz = np.array([2.0, 9.0, 40.0])
    rec = lm.stepped_sine(axis, f_hz, amplitude_a=amplitude_a, block_s=2.0, sample_rate_hz=2000.0)
    measured = []
    for f, t, v in zip(f_hz, rec.time_s, rec.velocity_m_per_s):
        late = t >= 1.0                     # the start-up transient (time constant m / b = 80 ms) has died
        basis = np.column_stack([np.sin(2 * np.pi * f * t[late]), np.cos(2 * np.pi * f * t[late])])
        s, c = np.linalg.lstsq(basis, v[late, 0], rcond=None)[0]
        measured.append(complex(s, c) / amplitude_a)
    plant = dataclasses.replace(stage_x(), excitation_current_a=amplitude_a) * make_effect(
        "current_limit", limit_n=axis.kt_n_per_a * 1.0)
    model = plant.frd(2 * np.pi * f_hz)
    # RK4 through the clip's corners: 1e-5 at 40 Hz; a describing function's usual error is 10 %
    np.testing.assert_allclose(model, measured, rtol=1e-4)


def test_the_limit_rejects_values_outside_its_physics():
    with pytest.raises(ParameterError, match="fraction_lost"):
        make_effect("current_limit", limit_n=10.0, fraction_lost=1.5)
    with pytest.raises(ParameterError, match="limit_n"):
        make_effect("current_limit", limit_n=0.0)
    with pytest.raises(EffectError, match="excitation_current_a"):
        stage_x() * make_effect("current_limit", limit_n=10.0)


def test_a_stribeck_rise_has_no_frequency_response_and_says_so():
    plant = dataclasses.replace(stage_x(), excitation_current_a=1.0) * make_effect(
        "coulomb_friction", force_n=5.0) * make_effect("stribeck_friction", excess_n=3.0)
    with pytest.raises(EffectError, match="stribeck_friction has no frequency-response model"):
        plant.frd(np.array([10.0]))
    with pytest.raises(ParameterError, match="excess_n must be >= 0"):
        make_effect("stribeck_friction", excess_n=-1.0)
