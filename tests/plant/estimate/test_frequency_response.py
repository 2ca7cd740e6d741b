"""Lock-in uncertainty where it is hardest: few sub-blocks (short, low-frequency blocks),
harmonics the sampling aliases, the sub-block count, the thesis-length 1 Hz block, the RMS
method's own scatter, and amplitude comparisons across recordings.

Signals are synthesised here with known truth (closed form); the bound is the Cramer-Rao bound
of a known-frequency sinusoid in white Gaussian noise, E|a_hat - a|^2 = 4 sigma^2 / N.
"""

import numpy as np
import pytest

from plant.data.frequency_response import MeasuredResponse
from plant.data.recordings import Block, Recording
from plant.errors import DataError
from plant.estimate.lockin import (
    _basis,
    _white_noise_factor,
    amplitude_dependence,
    estimate_response,
)

FS = 1000.0
G = 0.04 * np.exp(-0.7j)
AMP_I = 0.5


def block(f_hz, seconds, *, sigma_v=0.0, rng=None, h3=0.0, phase=0.3):
    t = np.arange(int(round(seconds * FS))) / FS
    wt = 2 * np.pi * f_hz * t + phase
    v = np.real(G * AMP_I * np.exp(1j * wt)) + h3 * abs(G) * AMP_I * np.cos(3 * wt)
    if sigma_v:
        v = v + rng.normal(0.0, sigma_v, t.size)
    return Block(f_hz, t, AMP_I * np.cos(wt), v[None, :])


def rec(*blocks):
    return Recording(tuple(blocks), ("velocity_m_per_s",))


def test_white_noise_factor_is_one_for_whole_periods_and_below_one_for_half_periods():
    """Closed form: over whole periods every sub-block's normal matrix is diag(n, n/2, n/2, ...), so
    leaving one out is a balanced design and the delete-a-group jackknife is exact (factor 1).
    Over half periods the offset and the sine are correlated within each sub-block; the jackknife
    then overestimates, most with few sub-blocks."""
    t = np.arange(3000) / FS
    B = _basis(t, 10.0, (1, 2, 3))                     # 10 Hz: 100 samples per period
    for unit, k in ((100, 10), (50, 10), (50, 4)):
        starts = np.arange(k) * unit
        sizes = np.full(k, float(unit))
        A_j = np.array([B[a:a + unit].T @ B[a:a + unit] for a in starts])
        factor = _white_noise_factor(A_j.sum(axis=0), A_j, sizes)
        if unit == 100:
            assert factor == pytest.approx(1.0, abs=1e-9)
        else:
            assert 0.5 < factor < 1.0


@pytest.mark.parametrize("f_hz, seconds, settle_s, k", [
    (1.0, 3.0, 1.0, 4),       # 2 periods left: 4 half-period sub-blocks (a raw jackknife reads ~1.4x)
    (1.5, 3.0, 1.0, 6),       # 3 periods: 6 sub-blocks
    (10.0, 3.0, 0.5, 10),
])
def test_reported_variance_is_calibrated_with_few_subblocks(f_hz, seconds, settle_s, k):
    """400 realisations, white noise 5 % of the output amplitude. Bands: the scatter (mean of 400
    exponentials) has relative sd 5 %; the mean reported variance, from 2 (k - 1) >= 6 real dof each,
    2.9 %; their ratio 5.8 %. [0.8, 1.25] is about +-3.9 sd, while the two natural mistakes sit
    outside it: separate half-period fits without the offset read (k - 2) / (k - 1) = 0.67 at k = 4,
    the uncorrected jackknife about 1.4."""
    rng = np.random.default_rng(17)
    sigma_v = 0.05 * abs(G) * AMP_I
    g, var = np.empty(400, complex), np.empty(400)
    for n in range(400):
        m = estimate_response(rec(block(f_hz, seconds, sigma_v=sigma_v, rng=rng)), settle_s=settle_s)
        g[n], var[n] = m.response[0, 0], m.variance[0, 0]
    assert m.metadata["subblocks"] == [k]
    n_used = m.metadata["periods_used"][0] / f_hz * FS
    scatter = np.mean(np.abs(g - G) ** 2)
    assert 0.8 < scatter / (4 * sigma_v**2 / n_used / AMP_I**2) < 1.25      # efficient (CRB, closed form)
    assert 0.8 < np.mean(var) / scatter < 1.25


def test_thesis_length_low_frequency_block_keeps_most_of_its_data():
    """A 5 s block at 1 Hz (thesis section 4.1) without a transient: the settling search may not throw
    periods away on noise alone (a per-period search with a 3-point tail scatter cut 2.2 s on average)."""
    rng = np.random.default_rng(8)
    used = [estimate_response(rec(block(1.0, 5.0, sigma_v=0.02 * abs(G) * AMP_I, rng=rng))).metadata["periods_used"][0]
            for _ in range(40)]
    assert np.mean(used) >= 4.0
    assert min(used) >= 3.0


def test_aliased_harmonics_are_not_fitted():
    """4 samples per period (250 Hz at 1 kHz): the 3rd harmonic's columns equal the fundamental's, the
    2nd is at Nyquist. Neither is fitted, so no false distortion is reported and G stays exact."""
    m = estimate_response(rec(block(250.0, 1.0)))
    assert m.response[0, 0] == pytest.approx(G, rel=1e-9)
    assert np.all(np.isnan(m.harmonic_distortion[0, 0]))
    m = estimate_response(rec(block(160.0, 1.0, h3=0.1)))     # 3rd at 480 Hz > 0.45 fs: aliased to 520 - 1000
    assert np.isnan(m.harmonic_distortion[0, 0, 1]) and m.harmonic_distortion[0, 0, 0] < 1e-9


def test_subblocks_keyword():
    r = rec(block(10.0, 3.0, sigma_v=1e-4, rng=np.random.default_rng(1)))
    assert estimate_response(r, subblocks=4).metadata["subblocks"] == [4]
    assert estimate_response(r, subblocks=1000, settle_s=0.5).metadata["subblocks"] == [50]   # 25 periods
    for bad in (1, 2.5, True):
        with pytest.raises(DataError, match=f"subblocks must be an integer >= 2, got {bad!r}"):
            estimate_response(r, subblocks=bad)


def test_rms_variance_describes_its_own_scatter():
    """The RMS method is biased (noise inflates it) but its reported variance should still describe
    how much it scatters about its own mean: 300 realisations, same bands as above."""
    rng = np.random.default_rng(23)
    est, var = np.empty(300), np.empty(300)
    for n in range(300):
        m = estimate_response(rec(block(10.0, 3.0, sigma_v=0.1 * abs(G) * AMP_I, rng=rng)), method="rms")
        est[n], var[n] = m.response[0, 0].real, m.variance[0, 0]
    assert 0.75 < np.mean(var) / np.var(est) < 1.33
    # closed form of the inflation: sqrt(|G|^2 + 2 sigma^2 / A^2)
    assert np.mean(est) == pytest.approx(np.sqrt(abs(G) ** 2 + 2 * (0.1 * abs(G)) ** 2), rel=3e-3)


def _response(f_hz, g, var=1e-8, amp=0.5, name="velocity_m_per_s"):
    f = np.asarray(f_hz, float)
    return MeasuredResponse(f, np.asarray(g, complex)[None, :], np.full((1, f.size), var), (name,),
                            np.full(f.size, amp), np.zeros((1, f.size)), np.zeros((1, f.size, 2)), source=f"{amp} A")


def test_amplitude_dependence_matches_frequencies_and_flags_points():
    low = _response([2.0, 5.0, 10.0], [G, G, G])
    # frequencies written with rounding (5.0000000001), one missing, one extra; only 10 Hz changes by 3 %
    high = _response([2.0, 5.0000000001, 10.0, 20.0], [G, G, 1.03 * G, G], amp=1.0)
    dep = amplitude_dependence([low, high])
    assert dep.f_hz.tolist() == [2.0, 5.0, 10.0]
    assert dep.significant_points.tolist() == [[[False, False, True]]]
    assert dep.relative_magnitude_change[0, 0, 2] == pytest.approx(0.03, rel=1e-9)     # closed form
    assert dep.z[0, 0, 2] == pytest.approx(0.03 * abs(G) / np.sqrt(2e-8), rel=1e-9)
    assert np.allclose(dep.current_amplitude_a, [[0.5] * 3, [1.0] * 3])
    # a 0.3 % change is below the 0.5 % floor however small the variance
    assert not amplitude_dependence([low, _response([2.0, 5.0, 10.0], [G, G, 1.003 * G], var=1e-14)]).significant
    with pytest.raises(DataError, match=r"the recordings share no frequency \(0.5 A, 1.0 A\)"):
        amplitude_dependence([low, _response([3.0], [G], amp=1.0)])
    two = MeasuredResponse(low.f_hz, np.vstack([low.response, low.response]), np.vstack([low.variance] * 2),
                           ("a", "b"), low.current_amplitude_a, np.zeros((2, 3)), np.zeros((2, 3, 2)), source="two")
    with pytest.raises(DataError, match="two: 2 outputs, 0.5 A has 1"):
        amplitude_dependence([low, two])
