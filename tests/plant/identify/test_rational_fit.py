"""Reliability and flags of the tfest-like rational fit (plant/identify/rational_fit.py).

Data are closed forms evaluated on the grid plus seeded circular complex Gaussian noise of 5 %
relative standard deviation: G(s) = 20/(35 s + 440) (s^2/wa^2 + 2 za s/wa + 1) /
(s^2/wr^2 + 2 zr s/wr + 1), thesis Eq. 3.15 (Stage X, M = 35 kg, b = 440 N s/m, K_t = 20 N/A)
with a lightly damped mode fr = 55 Hz, zr = 0.03 and antiresonance fa = 38 Hz, za = 0.02, on 40
log-spaced frequencies 1-75 Hz. python-control's ``tf`` is the reference for the truth.
"""

from __future__ import annotations

import json

import control
import numpy as np
import pytest
from typer.testing import CliRunner

import design.cli.common
from plant.errors import DataError, ParameterError
from plant.identify import rational_fit
from plant.identify.rational_fit import fit_rational, thesis_weights

F_HZ = np.logspace(0.0, np.log10(75.0), 40)
W = 2 * np.pi * F_HZ
WR, ZR, WA, ZA = 2 * np.pi * 55.0, 0.03, 2 * np.pi * 38.0, 0.02
DRAWS = 40


def g_closed_form(s):
    """The test plant in closed form (s in rad/s)."""
    return 20 / (35 * s + 440) * (s**2 / WA**2 + 2 * ZA * s / WA + 1) / (s**2 / WR**2 + 2 * ZR * s / WR + 1)


TRUTH = control.tf([20.0], [35.0, 440.0]) * control.tf([1 / WA**2, 2 * ZA / WA, 1], [1 / WR**2, 2 * ZR / WR, 1])
G0 = g_closed_form(1j * W)
VAR = (0.05 * np.abs(G0)) ** 2


def draw(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return G0 + np.sqrt(VAR / 2) * (rng.standard_normal(W.size) + 1j * rng.standard_normal(W.size))


def finds_mode(fit) -> bool:
    """A complex pole within 3 % of the resonance frequency of python-control's truth."""
    wr = np.abs(TRUTH.poles()[np.iscomplex(TRUTH.poles())][0])
    p = fit.poles[np.abs(fit.poles.imag) > 0]
    return bool(p.size) and float(np.min(np.abs(np.abs(p) - wr))) < 0.03 * wr


def test_truth_agrees_with_python_control():
    np.testing.assert_allclose(TRUTH(1j * W), G0, rtol=1e-12)


def test_default_weighting_finds_the_mode_in_95_percent_of_draws():
    fits = [fit_rational(W, draw(seed), n_poles=3, n_zeros=2, variance=VAR) for seed in range(DRAWS)]
    hits = [finds_mode(f) for f in fits]
    assert sum(hits) >= 0.95 * DRAWS, f"mode found in {sum(hits)}/{DRAWS} draws"     # measured: 40/40
    assert all(f.weighting == "inverse_sigma" for f in fits)
    np.testing.assert_allclose(fits[0].weights, 1 / np.sqrt(VAR))
    for f, hit in zip(fits, hits):
        assert hit or not f.success
    assert sum(f.success for f in fits) >= 0.9 * DRAWS                                # measured: 40/40


def test_thesis_weighting_misses_are_the_optimum_and_are_flagged():
    # with 5 % noise the weight 20 below 20 Hz lets the low-frequency noise outweigh the 55 Hz mode:
    # the fit's thesis-weighted cost is at or below the truth's, so no start can rescue the mode;
    # the chi-square against the variance must say so
    wt = thesis_weights(F_HZ)
    for seed in range(10):
        g = draw(seed)
        fit = fit_rational(W, g, n_poles=3, n_zeros=2, weights="thesis", variance=VAR)
        assert fit.weighting == "thesis"
        assert fit.cost <= np.sum(np.abs(wt * (g - G0)) ** 2) * (1 + 1e-9)
        if not finds_mode(fit):
            assert not fit.success and any(f.startswith("residual larger than the noise") for f in fit.flags)


def test_uniform_default_without_variance_and_no_chi2():
    fit = fit_rational(W, draw(0), n_poles=3, n_zeros=2)
    assert fit.weighting == "uniform" and np.isnan(fit.chi2) and np.isnan(fit.chi2_p)
    assert fit.dof == 2 * W.size - 6 and finds_mode(fit)


@pytest.mark.parametrize("n_poles, n_zeros", [(4, 3), (5, 4)])
def test_overparameterised_noise_free_fit_flags_pole_zero_cancellation(n_poles, n_zeros):
    fit = fit_rational(W, G0, n_poles=n_poles, n_zeros=n_zeros)
    assert not fit.success
    assert any(f.startswith("pole-zero cancellation") for f in fit.flags), fit.flags


def test_overparameterised_noisy_fit_is_flagged():
    # one pole and zero too many twice over (5/4 for a 3/2 truth); measured: 3/3 flagged here,
    # 37/40 over 40 draws (the others fit the noise with a pair a few % apart: not detectable
    # without a nested-model test)
    for seed in range(3):
        fit = fit_rational(W, draw(seed), n_poles=5, n_zeros=4, variance=VAR)
        assert not fit.success and fit.flags


def test_delay_at_its_upper_bound_is_flagged():
    g = G0 * np.exp(-1j * W * 3e-3)
    fit = fit_rational(W, g, n_poles=3, n_zeros=2, delay=True, max_delay_s=1e-3)
    assert fit.delay_s == pytest.approx(1e-3, rel=1e-3)
    assert not fit.success and any(f.startswith("delay at its upper bound") for f in fit.flags)
    free = fit_rational(W, g, n_poles=3, n_zeros=2, delay=True, max_delay_s=5e-3)
    assert free.delay_s == pytest.approx(3e-3, rel=1e-6) and free.success and free.flags == ()
    # a converged optimiser whose result is flagged says both, not "success = False (... satisfied.)" alone
    assert fit.message.startswith("the optimiser converged: ") and fit.message.endswith("1 flag(s) below")
    assert f"success            = False ({fit.message})" in fit.report() and "[[Flags]]" in fit.report()


def test_delay_at_its_lower_bound_is_flagged():
    fit = fit_rational(W, G0, n_poles=3, n_zeros=2, delay=True)
    assert fit.delay_s < 1e-8
    assert any(f.startswith("delay at its lower bound") for f in fit.flags)


def test_unstable_poles_reflected_are_flagged():
    # closed form unstable pair (python-control tf): 100 / (s^2 - 5 s + 400)
    unstable = control.tf([100.0], [1.0, -5.0, 400.0])
    fit = fit_rational(W, unstable(1j * W), n_poles=2, n_zeros=0)
    assert fit.stable and not fit.success
    assert any(f.startswith("unstable poles reflected") for f in fit.flags)
    free = fit_rational(W, unstable(1j * W), n_poles=2, n_zeros=0, enforce_stability=False)
    np.testing.assert_allclose(free.den, [1.0, -5.0, 400.0], rtol=1e-7)
    assert not free.stable and free.flags == ()


def test_optimiser_not_converged_is_flagged(monkeypatch):
    monkeypatch.setattr(rational_fit, "_MAX_NFEV", 1)
    fit = fit_rational(W, draw(0), n_poles=3, n_zeros=2, variance=VAR)
    assert not fit.success and any(f.startswith("optimiser did not converge") for f in fit.flags)


def test_too_low_order_fails_the_chi_square():
    fit = fit_rational(W, draw(0), n_poles=1, n_zeros=0, variance=VAR)
    assert fit.chi2_p < rational_fit.CHI2_P_FLAG and not fit.success
    assert any(f.startswith("residual larger than the noise") for f in fit.flags)


def test_variance_overestimated_is_flagged():
    fit = fit_rational(W, draw(0), n_poles=3, n_zeros=2, variance=100 * VAR)
    assert any(f.startswith("residual smaller than the noise") for f in fit.flags)


@pytest.mark.parametrize("kwargs, error, words", [
    ({"variance": np.ones(3)}, DataError, "one value per frequency"),
    ({"variance": np.r_[np.ones(39), 0.0]}, DataError, "element 39 is 0.0"),
    ({"weights": "inverse_sigma"}, ParameterError, "needs variance"),
])
def test_bad_variance(kwargs, error, words):
    with pytest.raises(error, match=words):
        fit_rational(W, G0, n_poles=3, n_zeros=2, **kwargs)


def test_cli_rational_json_has_flags(tmp_path):
    # in process (typer's CliRunner): a subprocess would spend seconds importing
    design.cli._register()
    rec = tmp_path / "rec.csv"
    out = CliRunner().invoke(design.cli.common.app, ["simulate", "--stage", "x", "--f-hz", "2:40:8",
                                                     "--duration-s", "2",
                                              "--seed", "1", "--out", str(rec)])
    assert out.exit_code == 0, out.output
    out = CliRunner().invoke(design.cli.common.app, ["fit", str(rec), "--stage", "x", "--rational", "2,1", "--json"])
    assert out.exit_code == 0, out.output
    rat = json.loads(out.stdout, parse_constant=lambda c: pytest.fail(f"non-strict JSON constant {c}"))["rational"]
    assert {"num", "den", "fit_percent", "flags", "success", "weighting", "chi2", "dof", "chi2_p"} <= set(rat)
    # a first-order plant fitted with 2 poles: the extra pole is flagged
    assert rat["weighting"] == "inverse_sigma" and rat["flags"] and rat["success"] is False


def test_report_gives_the_truths_mode_and_antiresonance_in_hz_and_damping():
    """The report's [[Poles and zeros]] on noise-free data name the closed form's 55 Hz mode (damping 0.03), its
    38 Hz antiresonance (0.02) and the rigid body's real pole 440/35 rad/s = 2.0 Hz."""
    fit = fit_rational(W, G0, n_poles=3, n_zeros=2)
    text = fit.report()
    assert "[[Model]]\n    rational: 3 poles, 2 zeros; uniform weighting" in text
    assert f"# data points      = {2 * W.size} ({W.size} weighted frequencies x re/im)" in text
    assert "# variables        = 6" in text
    rows = [line.split(":")[1] for line in text.splitlines() if line.startswith(("    pole", "    zero"))]
    found = sorted((float(r.split()[0]), float(r.split()[-1])) for r in rows)
    expected = sorted([(440 / 35 / (2 * np.pi), 1.0), (38.0, ZA), (55.0, ZR)])
    np.testing.assert_allclose(found, expected, rtol=2e-3)
