"""The inverse model's columns carry the measurement's noise: the acceleration, differentiated twice from a noisy
position, pulls ordinary least squares' mass towards zero by var(a) / (var(a) + var(noise)), and on a record whose
acceleration grows over time (a chirp) that error lands on a drift's pattern. The fit subtracts the noise's Gram
matrix (bias-compensated least squares, ``time_fit._bias_compensated``). Recordings of the independent linear motor
(tests/reference/independent_linear_motor.py); the ordinary least squares' errors are computed here beside it."""

import dataclasses

import independent_linear_motor as lm
import numpy as np
import pytest

from plant import stage_x
from plant.data.recordings import TimeRecording
from plant.identify import inverse_model, time_fit
from plant.identify.inverse_model import Preprocessing, inverse_model_data
from plant.physics.effects import make_effect


def _fit(form: str, axis, noise_m: float, effects=(), plain: bool = False):
    t, current, position = getattr(lm, form)(axis, seed=1, current_noise_a=0.0, position_noise_m=noise_m)
    data = inverse_model_data(TimeRecording(t, current, position[None], "position", ("x",)), axis.kt_n_per_a)
    plant = dataclasses.replace(stage_x(), effects=tuple(make_effect(n).configured(time_fit.fit_samples(data), None)
                                                         for n in effects), excitation_current_a=1.0)
    if not plain:
        return time_fit.fit_inverse_model(plant, data)
    gram = time_fit._noise_gram
    time_fit._noise_gram = lambda plant, data, free, n: np.zeros((len(free), len(free)))
    try:
        return time_fit.fit_inverse_model(plant, data)
    finally:
        time_fit._noise_gram = gram


def test_a_noisy_position_leaves_the_mass_where_it_is():
    """A slow sweep (0.25 Hz, rms acceleration 0.36 m/s^2) with 10 um of position noise (0.12 m/s^2 of acceleration
    noise in the band): ordinary least squares' mass falls by about 1 / (1 + (0.12 / 0.36)^2), 10 %; compensated,
    within 2 % (noise-free: +0.1 %)."""
    axis = lm.LinearMotorAxis()
    plain = _fit("slow_sweep", axis, 1e-5, plain=True).values["mass_kg"] / axis.mass_kg - 1
    fitted = _fit("slow_sweep", axis, 1e-5).values["mass_kg"] / axis.mass_kg - 1
    assert plain < -0.07
    assert abs(fitted) < 0.02


def test_a_drifts_rate_on_a_chirp_is_not_moved_by_the_position_noise():
    """A force constant falling 6 % over a 24 s chirp: with 4 um of position noise, ordinary least squares puts the
    attenuated mass of the chirp's fast end on the drift (its rate 17 % high); compensated, within 4 % of the truth,
    as on the noise-free record (+2.4 %)."""
    axis = lm.LinearMotorAxis(kt_rate_per_s=-0.0025)

    def error(fit):
        d = fit.plant.effect("force_constant_drift")
        return d.change / d.half_s / (axis.kt_rate_per_s / (1 + axis.kt_rate_per_s * d.mid_s)) - 1

    assert error(_fit("chirp", axis, 4e-6, ("force_constant_drift",), plain=True)) > 0.1
    assert error(_fit("chirp", axis, 4e-6, ("force_constant_drift",))) == pytest.approx(0.0, abs=0.04)


def test_the_acceleration_noise_does_not_make_a_pattern_of_the_residual():
    """The pattern tests project F u and F x onto the model's columns, the noisy acceleration among them, so the
    projection carries the acceleration's noise that the residual carries too: on a stepped sine with nothing missing
    (7.5 mA and 3.4 um of noise) plain projections found current x time at p 1e-7 and current x position at p 1e-19;
    with the noise taken out, neither stands out."""
    t, current, position = lm.stepped(lm.LinearMotorAxis(), seed=0, current_noise_a=0.0075, position_noise_m=3.4e-6)
    fit = time_fit.fit_inverse_model(dataclasses.replace(stage_x(), excitation_current_a=1.0),
                                     TimeRecording(t, current, position[None], "position", ("x",)))
    shown = {s.variable: s for s in fit.structure}
    assert shown["current x time"].p_value > 0.01 and shown["current x position"].p_value > 0.01
    assert fit.explained


def test_a_damping_drift_under_a_chirp_with_position_noise_is_named_as_itself():
    """The guides' damping rising 10 % over a 24 s chirp with 4 um of position noise: the true model's residual no
    longer shows a force-constant drift through the noisy projection, so ``damping_drift`` is selected (before, its
    model was "not explained" and a force-constant drift was named)."""
    from plant.diagnose.time_diagnosis import diagnose_time

    axis = lm.LinearMotorAxis(damping_rate_per_s=0.10 / 24)
    t, current, position = lm.chirp(axis, seed=0, current_noise_a=0.0, position_noise_m=4e-6)
    diag = diagnose_time(stage_x(), TimeRecording(t, current, position[None], "position", ("x",)))
    assert diag.selected == ("damping_drift",) and diag.verdict == "explained"
    drift = diag.final.plant.effect("damping_drift")
    assert drift.change_n_s_per_m / drift.half_s == pytest.approx(
        axis.damping_rate_per_s * axis.damping_n_s_per_m, rel=0.05)


@pytest.mark.parametrize("kind", ["position", "velocity"])
@pytest.mark.parametrize(("filter_hz", "band_hz"), [(100.0, 40.0), (5.0, 5.0), (100.0, 100.0)],
                         ids=["script", "slow_filter", "no_decimation"])
def test_the_noise_moments_are_the_chains_expectation(kind, filter_hz, band_hz):
    """``InverseModelData.noise_moments`` (the chain's impulse response summed over every lag, cut at
    ``IMPULSE_SPAN`` filter periods) against the mean over 300 seeded realisations of white noise through the same
    chain (within 3 of their standard errors), where the response is longest (a 5 Hz corner at 1 kHz) and with no
    decimation; and against the impulse response cut twice as far (within a part in a million)."""
    rng = np.random.default_rng(7)
    n, fs, sigma = 4000, 1000.0, 1e-6
    t = np.arange(n) / fs
    prep = Preprocessing(filter_hz=filter_hz, decimate_band_hz=band_hz)
    data = inverse_model_data(TimeRecording(t, np.sin(t), (np.sin(t) * 1e-3 + sigma * rng.standard_normal(n))[None],
                                            kind, ("x",)), 20.0, prep)
    exact = data.noise_moments
    draws = []
    for _ in range(300):
        _, nv, na, *_ = inverse_model._chain(fs, data.output_noise * rng.standard_normal(n), np.zeros(n), kind,
                                             filter_hz, data.decimation)
        # away from the edges, where the chain is stationary
        V = np.stack([nv, na])[:, nv.size // 8: -nv.size // 8]
        draws.append((V @ V.T / V.shape[1]).ravel())
    draws = np.array(draws)
    mean, se = draws.mean(axis=0), draws.std(axis=0) / np.sqrt(len(draws))
    for k in (0, 3):              # E[v^2], E[a^2]; the cross moment is zero by the filters' symmetry
        assert abs(exact.ravel()[k] - mean[k]) < 3 * se[k]
    # the realisations' mean squares scatter as a chi^2 of n / F samples (F: ``noise_lag_factor``)
    used = data.time_s.size - 2 * (data.time_s.size // 8)
    scatter = max(draws[:, k].var() / draws[:, k].mean() ** 2 * used / 2 for k in (0, 3))
    assert 0.7 < scatter / data.noise_lag_factor < 1.4
    assert abs(exact[0, 1]) < 1e-9 * np.sqrt(exact[0, 0] * exact[1, 1])
    longer = dataclasses.replace(data)
    inverse_model.IMPULSE_SPAN, span = 2 * inverse_model.IMPULSE_SPAN, inverse_model.IMPULSE_SPAN
    try:
        np.testing.assert_allclose(longer.noise_moments, exact, rtol=1e-6, atol=1e-9 * exact.max())
    finally:
        inverse_model.IMPULSE_SPAN = span


def test_the_compensation_is_refused_only_where_the_noisy_columns_signal_is_lost_in_their_noise():
    """``_bias_compensated`` on synthetic columns: a noisy acceleration beside two noise-free columns almost
    collinear (correlation 0.999999) is compensated (its signal stands 7 times above its noise once they are projected
    out; plain least squares would be 13 % short), and a column of noise alone is not."""
    rng = np.random.default_rng(3)
    n = 4000
    t = np.linspace(0.0, 40.0, n)
    a_true = np.sin(0.7 * t) + 0.5 * np.sin(2.3 * t)
    sigma = 0.3
    a = a_true + sigma * rng.standard_normal(n)
    c1 = np.cos(0.1 * t)
    c2 = c1 + 1e-3 * np.sin(5.0 * t)
    X = np.column_stack([a, c1, c2])
    gram = np.zeros((3, 3))
    gram[0, 0] = n * sigma**2
    y = 10.0 * a_true + 2.0 * c1 + 0.1 * rng.standard_normal(n)
    A, target, taken = time_fit._bias_compensated(X, y, gram)
    assert taken is not None
    assert abs(np.linalg.lstsq(A, target, rcond=None)[0][0] / 10.0 - 1) < 0.02
    assert np.linalg.lstsq(X, y, rcond=None)[0][0] / 10.0 - 1 < -0.1
    # a column of noise alone next to the acceleration: refused, plain least squares
    z = sigma * rng.standard_normal(n)
    gram2 = np.diag([n * sigma**2, n * sigma**2])
    assert time_fit._bias_compensated(np.column_stack([a, z]), y, gram2)[2] is None
