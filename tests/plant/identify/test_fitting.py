"""Plant fitting (plant/identify/fitting.py) and the tfest-like rational fit (plant/identify/rational_fit.py).

Truth comes from models evaluated in closed form (``Plant.frd_outputs``, python-control
transfer functions) plus seeded circular complex Gaussian noise of known variance, the
noise model ``MeasuredResponse.variance`` describes.
"""

from __future__ import annotations

import dataclasses
import math

import control
import numpy as np
import pytest
from in_process import gantry

from plant import CoulombFriction, CurrentLoop, Delay, Plant, Resonance, stage_x, stage_y
from plant.data.frequency_response import MeasuredResponse
from plant.errors import DataError, EffectError, ParameterError
from plant.identify.fitting import FitResult, default_free, fit_plant, output_map
from plant.identify.rational_fit import fit_rational, thesis_weights
from plant.physics.effects import make_effect

# thesis section 4.1: stepped sine 1..75 Hz
F_HZ = np.linspace(1.0, 75.0, 50)
W = 2 * np.pi * F_HZ


def measured(plant, *, seed: int | None, noise: float = 0.01, f_hz=F_HZ, output_names=None,
             mean_only: bool = False, current_a=1.0) -> MeasuredResponse:
    """Response of ``plant`` plus circular complex noise. Its standard deviation is ``noise`` times
    |G| at the lowest frequency, constant over frequency (velocity-sensor noise); seed None: no noise."""
    w = 2 * np.pi * f_hz
    g = plant.frd(w)[None] if mean_only else plant.frd_outputs(w)
    var = np.full(g.shape, (noise * np.abs(g[:, :1])) ** 2)
    if seed is not None:
        rng = np.random.default_rng(seed)
        g = g + np.sqrt(var / 2) * (rng.standard_normal(g.shape) + 1j * rng.standard_normal(g.shape))
    names = output_names or (("velocity",) if mean_only else plant.output_names)
    return MeasuredResponse(f_hz=np.asarray(f_hz, float), response=g, variance=var, output_names=tuple(names),
                            current_amplitude_a=np.broadcast_to(np.asarray(current_a, float), f_hz.shape).copy(),
                            snr_db=np.zeros(g.shape), harmonic_distortion=np.zeros(g.shape + (2,)))


# --- fit_rational ---------------------------------------------------------------------------
def test_rational_recovers_two_poles_one_zero():
    # closed form: G = (10 s + 50) / (s^2 + 2 s + 100): the thesis's tfest order (2 poles, 1 zero)
    truth = control.tf([10.0, 50.0], [1.0, 2.0, 100.0])
    fit = fit_rational(W, truth(1j * W), n_poles=2, n_zeros=1)
    np.testing.assert_allclose(fit.num, [10.0, 50.0], rtol=1e-7)
    np.testing.assert_allclose(fit.den, [1.0, 2.0, 100.0], rtol=1e-7)
    assert fit.delay_s == 0.0 and fit.stable and fit.fit_percent > 99.999


def test_rational_recovers_lightly_damped_resonance_and_delay():
    # closed form: 4 poles / 2 zeros with a 45 Hz resonance, delay 1.5 ms
    wr, wa = 2 * np.pi * 45, 2 * np.pi * 30
    truth = control.tf([20.0], [40.0, 440.0]) * control.tf([1 / wa**2, 0.1 / wa, 1], [1 / wr**2, 0.1 / wr, 1]) \
        * control.tf([1.0], [1 / (2 * np.pi * 200), 1])
    g = truth(1j * W) * np.exp(-1j * W * 1.5e-3)
    fit = fit_rational(W, g, n_poles=4, n_zeros=2, delay=True)
    assert fit.delay_s == pytest.approx(1.5e-3, rel=1e-5)
    np.testing.assert_allclose(np.sort_complex(fit.poles), np.sort_complex(truth.poles()), rtol=1e-5)
    np.testing.assert_allclose(fit.tf(1j * W), truth(1j * W), rtol=1e-6)


def test_rational_first_order_with_delay_gives_mass_and_damping():
    # closed form: K_t/(M s + b) e^(-s tau), thesis Eq. 3.15 with M = 40 kg, b = 440, tau = 1 ms
    g = 20.0 / (40.0 * 1j * W + 440.0) * np.exp(-1j * W * 1e-3)
    fit = fit_rational(W, g, n_poles=1, n_zeros=0, delay=True)
    assert 20.0 / fit.num[-1] == pytest.approx(40.0, rel=1e-7)            # M = K_t / b_0
    assert 20.0 * fit.den[-1] / fit.num[-1] == pytest.approx(440.0, rel=1e-7)  # b = K_t a_0 / b_0
    assert fit.delay_s == pytest.approx(1e-3, rel=1e-7)


def test_thesis_weights_are_appendix_b():
    # thesis Appendix B (Stage Y code): Weight = 20 for freq_Hz < 20, else ones/2
    np.testing.assert_array_equal(thesis_weights([1.0, 19.9, 20.0, 75.0]), [20.0, 20.0, 0.5, 0.5])
    fit = fit_rational(W, stage_x().frd(W), n_poles=1, n_zeros=0, weights="thesis")
    np.testing.assert_array_equal(fit.weights, thesis_weights(F_HZ))


def test_rational_zero_weight_ignores_corrupted_band():
    # closed form truth 20/(35 s + 440) (thesis Eq. 3.15, thesis values); points above 50 Hz
    # corrupted by a factor 3 and given weight 0, so the fit must recover the truth exactly
    g = stage_x().frd(W)
    bad = F_HZ > 50
    corrupted = np.where(bad, 3 * g, g)
    fit = fit_rational(W, corrupted, n_poles=1, n_zeros=0, weights=np.where(bad, 0.0, 1.0))
    np.testing.assert_allclose(fit.den, [1.0, 440.0 / 35.0], rtol=1e-7)
    unweighted = fit_rational(W, corrupted, n_poles=1, n_zeros=0)
    assert abs(unweighted.den[-1] - 440.0 / 35.0) > 0.1      # the weights mattered


@pytest.mark.parametrize("kwargs, error, words", [
    ({"n_poles": 1, "n_zeros": 2}, ParameterError, "n_zeros"),
    ({"n_poles": 2, "n_zeros": 1, "weights": np.ones(3)}, ParameterError, "one value per frequency"),
    ({"n_poles": 2, "n_zeros": 1, "weights": "matlab"}, ParameterError, "'matlab'"),
    ({"n_poles": 2, "n_zeros": 1, "weights": np.r_[np.ones(49), -1.0]}, ParameterError, "element 49 is -1.0"),
    ({"n_poles": 2, "n_zeros": 1, "weights": np.zeros(50)}, ParameterError, "all zero"),
])
def test_rational_bad_arguments(kwargs, error, words):
    with pytest.raises(error, match=words):
        fit_rational(W, stage_x().frd(W), **kwargs)


def test_rational_bad_response():
    g = stage_x().frd(W)
    g[7] = np.nan
    with pytest.raises(DataError, match="index 7"):
        fit_rational(W, g, n_poles=1, n_zeros=0)


# --- fit_plant: recovery ----------------------------------------------------------------------
def test_noise_free_recovery_stage_x_with_delay():
    truth = stage_x(mass_kg=40.0, damping_n_s_per_m=500.0) * Delay(1e-3)
    r = fit_plant(stage_x() * Delay(), measured(truth, seed=None))
    assert r.values["mass_kg"] == pytest.approx(40.0, rel=1e-6)
    assert r.values["damping_n_s_per_m"] == pytest.approx(500.0, rel=1e-6)
    assert r.values["delay.seconds"] == pytest.approx(1e-3, rel=1e-6)
    assert r.values["force_constant_n_per_a"] == 20.0          # fixed by default (thesis section 3.1)
    assert r.free == ("mass_kg", "damping_n_s_per_m", "delay.seconds")
    assert r.chi2 < 1e-6 and r.success


def test_start_far_from_truth_does_not_matter():
    # the plant handed in is a poor start (5 kg, 5000 N s/m); data-derived starts find the truth
    truth = stage_x(mass_kg=40.0) * CurrentLoop(120.0)
    r = fit_plant(stage_x(mass_kg=5.0, damping_n_s_per_m=5000.0) * CurrentLoop(5000.0), measured(truth, seed=None))
    assert r.values["mass_kg"] == pytest.approx(40.0, rel=1e-6)
    assert r.values["current_loop.bandwidth_hz"] == pytest.approx(120.0, rel=1e-6)


def test_stage_y_both_rails_jointly_and_single_output_against_mean():
    truth = stage_y(mass_kg=30.0) * Resonance(45.0, 30.0, 0.05)
    both = fit_plant(stage_y() * Resonance(), measured(truth, seed=None,
                                                      output_names=("velocity_y1_m_per_s", "velocity_y2_m_per_s")))
    assert both.n_data == 2 * 2 * F_HZ.size and both.residuals.shape == (2, F_HZ.size)
    one = fit_plant(stage_y() * Resonance(), measured(truth, seed=None, mean_only=True))
    assert one.n_data == 2 * F_HZ.size
    for r in (both, one):
        assert r.values["mass_kg"] == pytest.approx(30.0, rel=1e-6)
        assert r.values["resonance.frequency_hz"] == pytest.approx(45.0, rel=1e-6)
        assert r.values["resonance.antiresonance_hz"] == pytest.approx(30.0, rel=1e-6)


def test_output_map():
    assert output_map(stage_y(), ("velocity_y2_m_per_s", "velocity_y1_m_per_s")) == (1, 0)
    assert output_map(stage_y(), ("velocity_m_per_s",)) == (-1,)          # mean of the rails
    assert output_map(stage_x(), ("velocity_a", "velocity_b")) == (0, 0)
    with pytest.raises(DataError, match="cannot match"):
        output_map(stage_y(), ("a", "b", "c"))


def test_coulomb_friction_uses_the_data_current_amplitude():
    amp = np.linspace(1.0, 3.0, F_HZ.size)
    truth = stage_x(excitation_current_a=amp) * CoulombFriction(15.0)
    data = measured(truth, seed=None, current_a=amp)
    r = fit_plant(stage_x(excitation_current_a=1.0) * CoulombFriction(5.0), data)
    np.testing.assert_array_equal(r.plant.excitation_current_a, amp)
    assert r.values["coulomb_friction.force_n"] == pytest.approx(15.0, rel=1e-5)
    assert r.values["mass_kg"] == pytest.approx(35.0, rel=1e-5)


def test_refit_with_an_extra_effect_is_one_call_and_wins_on_bic():
    truth = stage_x(mass_kg=40.0) * Delay(2e-3)
    data = measured(truth, seed=3)
    base = fit_plant(stage_x(), data)
    with_delay = fit_plant(base.plant * Delay(), data)
    assert base.reduced_chi2 > 3                               # 2 ms is 54 deg at 75 Hz: visible
    assert with_delay.reduced_chi2 < 1.5
    assert with_delay.bic < base.bic - 100
    assert any("does not explain the data" in f for f in base.flags)
    assert not with_delay.flags


# --- fit_plant: uncertainty and flags ------------------------------------------------------------
def test_delay_and_fast_current_loop_are_flagged_as_inseparable():
    # a 0.5 ms delay and a 1 kHz lag are both ~ a pure phase slope below 75 Hz
    truth = stage_x() * Delay(5e-4) * CurrentLoop(1000.0)
    r = fit_plant(stage_x() * Delay() * CurrentLoop(), measured(truth, seed=1))
    # the data cannot split the lag: either the two trade off (|correlation| > 0.95) or the fit puts
    # all of it in the delay and leaves the current loop undetermined; the flags say which
    c = r.correlation_of("delay.seconds", "current_loop.bandwidth_hz")
    assert (abs(c) > 0.95 and any("delay.seconds and current_loop.bandwidth_hz cannot be told apart" in f
                                  for f in r.flags)) or \
        any("current_loop.bandwidth_hz is not determined by the data" in f for f in r.flags)
    # the total lag is measured: 0.5 ms + 1/(2 pi 1 kHz) = 0.66 ms of equivalent delay
    tau = r.values["delay.seconds"] + 1 / (2 * np.pi * r.values["current_loop.bandwidth_hz"])
    assert tau == pytest.approx(5e-4 + 1 / (2 * np.pi * 1000.0), rel=0.1)


def test_parameter_at_bound_is_flagged():
    r = fit_plant(stage_x() * Delay(), measured(stage_x(), seed=None))   # no delay in the data
    assert r.values["delay.seconds"] == pytest.approx(0.0, abs=1e-9)
    assert any("delay.seconds is at its lower bound" in f for f in r.flags)


def test_force_constant_mass_and_damping_together_are_not_determined():
    # G = K_t/(M s + b) depends on M/K_t and b/K_t only (thesis Eq. 3.15)
    r = fit_plant(stage_x(), measured(stage_x(), seed=2),
                  free=["mass_kg", "damping_n_s_per_m", "force_constant_n_per_a"])
    assert any("not determined" in f or "cannot be told apart" in f for f in r.flags)


def test_stderr_matches_the_linearised_closed_form_for_a_first_order_plant():
    # For G = K_t/(M s + b) with known noise the Fisher information is sum over points of
    # 2 Re(dG/dp dG/dq*) / var (closed form). Compare the reported stderr with it.
    plant = stage_x(mass_kg=40.0)
    data = measured(plant, seed=None)
    r = fit_plant(stage_x(), data)
    s = 1j * W
    g = 20.0 / (40.0 * s + 440.0)
    dm, db = -g * s / (40.0 * s + 440.0), -g / (40.0 * s + 440.0)
    var = data.variance[0]
    fisher = np.array([[np.sum(2 * (a * np.conj(b)).real / var) for b in (dm, db)] for a in (dm, db)])
    expected = np.sqrt(np.diag(np.linalg.inv(fisher)))
    assert r.stderr["mass_kg"] == pytest.approx(expected[0], rel=1e-4)
    assert r.stderr["damping_n_s_per_m"] == pytest.approx(expected[1], rel=1e-4)


def test_result_is_immutable_and_reports():
    r = fit_plant(stage_x() * Delay(), measured(stage_x() * Delay(1e-3), seed=4))
    assert isinstance(r, FitResult)
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.chi2 = 0.0  # type: ignore[misc]
    text = r.report()
    for word in ("reduced chi-square", "mass_kg:", "delay.seconds:", "+/-", "force_constant_n_per_a: 20 N·A⁻¹ (fixed)"):
        assert word in text
    assert r.dof == r.n_data - r.n_params == 100 - 3
    assert r.aic == pytest.approx(r.chi2 + 2 * 3)                       # -2 ln L + 2k
    assert r.bic == pytest.approx(r.chi2 + 3 * np.log(100))             # -2 ln L + k ln n
    assert r.stderr_scaled["mass_kg"] == pytest.approx(r.stderr["mass_kg"] * np.sqrt(r.reduced_chi2))
    assert r.chi2_per_frequency.sum() == pytest.approx(r.chi2)


def test_default_free_set():
    assert default_free(stage_x() * Delay() * Resonance()) == (
        "mass_kg", "damping_n_s_per_m", "delay.seconds", "resonance.frequency_hz",
        "resonance.antiresonance_hz", "resonance.damping_ratio")


def test_estimated_variances_widen_the_errors_by_nu_over_nu_minus_4():
    # variance from k = 10 sub-blocks: nu = 2 (k - 1) = 18 real degrees of freedom; for weights
    # 1/s^2 with s^2 ~ sigma^2 chi^2_nu / nu the covariance grows by nu / (nu - 4) and a correct
    # model's chi^2 per residual has expectation nu / (nu - 2) (closed form, module doc)
    data = measured(stage_x() * Delay(1e-3), seed=5)
    known = fit_plant(stage_x() * Delay(), data)
    from_meta = fit_plant(stage_x() * Delay(), dataclasses.replace(data, metadata={"subblocks": [10] * F_HZ.size}))
    assert from_meta.expected_reduced_chi2 == pytest.approx(18 / 16)
    assert known.expected_reduced_chi2 == 1.0 and np.all(np.isinf(known.variance_dof))
    np.testing.assert_array_equal(from_meta.variance_dof, 18.0)
    for name in known.free:
        assert from_meta.stderr[name] == pytest.approx(known.stderr[name] * np.sqrt(18 / 14), rel=1e-6)
        assert from_meta.stderr_scaled[name] == pytest.approx(known.stderr_scaled[name], rel=1e-9)
    few = fit_plant(stage_x() * Delay(), data, variance_dof=np.r_[np.full(F_HZ.size - 1, 18.0), 4.0])
    assert any("1 frequencies have variances from fewer than 4 sub-blocks" in f for f in few.flags)
    with pytest.raises(DataError, match="variance_dof"):
        fit_plant(stage_x(), data, variance_dof=[1.0, 2.0])


# --- fit_plant: bad input --------------------------------------------------------------------------
def test_unknown_parameter_and_effect_names():
    data = measured(stage_x(), seed=None)
    with pytest.raises(ParameterError, match="'mass'"):
        fit_plant(stage_x(), data, free=["mass"])
    with pytest.raises(EffectError, match="'delay.seconds'"):
        fit_plant(stage_x(), data, free=["mass_kg", "delay.seconds"])
    with pytest.raises(ParameterError, match="'delay.seconds'.*not free"):
        fit_plant(stage_x() * Delay(), data, free=["mass_kg"], start={"delay.seconds": 1e-3})


def test_bad_variance_names_output_and_frequency():
    data = measured(stage_x(), seed=None)
    var = data.variance.copy()
    var[0, 4] = 0.0
    with pytest.raises(DataError, match=r"output velocity has variance 0\.0 at 7\.04082 Hz"):
        fit_plant(stage_x(), dataclasses.replace(data, variance=var))


# --- calibration: +-2 sigma coverage over seeded noise ----------------------------------------------
@pytest.mark.parametrize("truth, model", [
    (stage_x(mass_kg=40.0) * Delay(1e-3), stage_x() * Delay()),
    (stage_y(mass_kg=30.0, damping_n_s_per_m=400.0) * CurrentLoop(80.0), stage_y() * CurrentLoop()),
])
def test_calibration_two_sigma_coverage_fast(truth, model):
    """Over 200 seeds each true parameter lies within +-2 reported sigma in >= 90 % of fits
    (Gaussian theory: 95.4 %), and the mean reduced chi-square is ~1."""
    true = truth.parameters()
    inside, reduced = {}, []
    for seed in range(200):
        r = fit_plant(model, measured(truth, seed=seed, noise=0.02))
        reduced.append(r.reduced_chi2)
        for name in r.free:
            inside.setdefault(name, []).append(abs(r.values[name] - true[name].value) <= 2 * r.stderr[name])
    coverage = {n: float(np.mean(v)) for n, v in inside.items()}
    assert min(coverage.values()) >= 0.90, coverage
    # mean of 200 reduced chi-squares with ~100 dof: 1 +- 3 * sqrt(2/dof/200)
    assert np.mean(reduced) == pytest.approx(1.0, abs=3 * np.sqrt(2 / 97 / 200))


# --- calibration through the whole pipeline: simulate_stepped_sine -> estimate_response -> fit_plant ----
def _pipeline_coverage(truth, model, *, seeds, f_hz, duration_s, sample_rate_hz, current_amplitude_a):
    from plant.estimate.lockin import estimate_response
    from plant.experiment.simulate import simulate_stepped_sine

    true = truth.parameters()
    inside, reduced = {}, []
    for seed in range(seeds):
        rec = simulate_stepped_sine(truth, f_hz=f_hz, current_amplitude_a=current_amplitude_a, duration_s=duration_s,
                                    sample_rate_hz=sample_rate_hz, velocity_noise_m_per_s=1e-3, current_noise_a=5e-3,
                                    seed=seed)
        r = fit_plant(model, estimate_response(rec))
        reduced.append(r.reduced_chi2)
        for name in r.free:
            inside.setdefault(name, []).append(abs(r.values[name] - true[name].value) <= 2 * r.stderr[name])
    return {n: float(np.mean(v)) for n, v in inside.items()}, float(np.mean(reduced))


def test_calibration_two_sigma_coverage_pipeline_fast():
    """100 simulated recordings (short 3 s blocks at 500 Hz, 12 frequencies 2-75 Hz, noisy current
    and velocity), each estimated with its sub-block variances and fitted: mass, damping and delay
    inside +-2 sigma in >= 90 % of fits (measured 95-98 %; 92-96 % without the variance-dof
    correction of the standard errors)."""
    coverage, reduced = _pipeline_coverage(stage_x(mass_kg=40.0) * Delay(1e-3), stage_x() * Delay(), seeds=100,
                                           f_hz=np.linspace(2.0, 75.0, 12), duration_s=3.0, sample_rate_hz=500.0,
                                           current_amplitude_a=0.5)
    assert min(coverage.values()) >= 0.90, coverage
    assert 0.9 < reduced < 1.3, reduced   # variances estimated from ~10 sub-blocks: E[1/s^2] > 1/sigma^2


@pytest.mark.slow
@pytest.mark.parametrize("truth, model, amp", [
    (stage_x(mass_kg=40.0) * Delay(1e-3), stage_x() * Delay(), 0.5),
    (stage_y(mass_kg=30.0) * CurrentLoop(80.0), stage_y() * CurrentLoop(), 1.75),
])
def test_calibration_two_sigma_coverage_pipeline_thesis_protocol(truth, model, amp):
    """Thesis section 4.1 protocol (5 s per frequency, 25 frequencies 1-75 Hz, 2 kHz; 0.5 A Stage X,
    1.75 A Stage Y), 100 recordings each: every true parameter inside +-2 sigma in >= 90 % of fits
    (measured: X 96-97 %, Y 93-99 %; ~2 min per case on 2 loaded cores)."""
    coverage, reduced = _pipeline_coverage(truth, model, seeds=100, f_hz=np.linspace(1.0, 75.0, 25), duration_s=5.0,
                                           sample_rate_hz=2000.0, current_amplitude_a=amp)
    assert min(coverage.values()) >= 0.90, coverage
    assert 0.9 < reduced < 1.3, reduced


# --- gantry fit (CLI) ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def small_recording(tmp_path_factory):
    from plant.data.writers import write_recording_csv
    from plant.experiment.simulate import simulate_stepped_sine

    path = tmp_path_factory.mktemp("fit") / "rec.csv"
    rec = simulate_stepped_sine(stage_x(mass_kg=40.0) * Delay(1e-3), f_hz=np.linspace(2.0, 75.0, 8),
                                current_amplitude_a=0.5, duration_s=2.0, sample_rate_hz=500.0,
                                velocity_noise_m_per_s=1e-3, current_noise_a=5e-3, seed=1)
    write_recording_csv(rec, path)
    return path


def test_cli_unknown_effect_is_named(small_recording):
    out = gantry("fit", small_recording, "--stage", "x", "--effects", "delay,backlash")
    assert out.returncode == 2
    assert "'backlash'" in out.stderr and out.stderr.count("\n") == 1


def test_cli_json_contract(small_recording):
    import json

    out = gantry("fit", small_recording, "--stage", "x", "--effects", "delay", "--json")
    assert out.returncode == 0, out.stderr
    res = json.loads(out.stdout)
    assert set(res["parameters"]) == {"mass_kg", "damping_n_s_per_m", "delay.seconds"}
    for p in res["parameters"].values():
        assert set(p) >= {"value", "stderr"} and p["stderr"] > 0
    assert res["dof"] == 2 * 8 - 3 and isinstance(res["flags"], list)
    assert res["bic"] - res["aic"] == pytest.approx(3 * (math.log(res["n_data"]) - 2))  # -2 ln L + k ln n / + 2k
    assert res["correlation"]["names"] == list(res["parameters"])


def test_likelihood_of_residuals_with_estimated_variances_is_the_f_density():
    """Reference: scipy.stats.f. With variances estimated on nu degrees of freedom, |r|^2 / 2 of a correct
    model's normalised residual is F(2, nu); -2 ln L is -2 sum ln f(|r|^2 / 2), and chi^2 for nu = inf."""
    from scipy import stats

    from plant.identify.fitting import minus_two_log_likelihood

    rng = np.random.default_rng(3)
    r = rng.normal(size=(2, 9)) + 1j * rng.normal(size=(2, 9))
    nu = np.array([4.0, 6.0, 10.0, 18.0, 18.0, 40.0, 100.0, 1e4, 12.0])
    expected = -2 * np.sum(stats.f.logpdf(np.abs(r) ** 2 / 2, 2, nu))
    assert minus_two_log_likelihood(r, nu) == pytest.approx(expected, rel=1e-12)
    assert minus_two_log_likelihood(r, np.full(9, np.inf)) == pytest.approx(np.sum(np.abs(r) ** 2), rel=1e-12)


# --- arguments at the library's boundary ----------------------------------------------------
def test_fit_plant_refuses_what_it_cannot_fit_with_a_clear_exception():
    plant = stage_x(mass_kg=40.0)
    data = measured(plant, seed=1)
    with pytest.raises(ParameterError, match="plant must be a Plant"):
        fit_plant(None, data)
    with pytest.raises(DataError, match="must be a MeasuredResponse"):
        fit_plant(plant, None)
    with pytest.raises(ParameterError, match="mass_kg .start.* finite"):
        fit_plant(plant, data, start={"mass_kg": float("nan")})
    with pytest.raises(ParameterError, match="damping_n_s_per_m .start 1.* number"):
        fit_plant(plant, data, starts=[{"damping_n_s_per_m": "400"}])
    # magnitudes where the complex response belongs: no phase, refused rather than fitted to a wrong mass
    magnitude = dataclasses.replace(data, response=np.abs(data.response))
    with pytest.raises(DataError, match="magnitudes only"):
        fit_plant(plant, magnitude)


@pytest.mark.parametrize("bad", ["40", True, None, [5.0, "a"]])
def test_plants_and_effects_refuse_values_that_are_not_numbers(bad):
    with pytest.raises(ParameterError, match="must be a"):
        Plant("x", mass_kg=bad)
    with pytest.raises(ParameterError, match="must be a"):
        make_effect("delay", seconds=bad)
