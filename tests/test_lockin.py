"""Lock-in estimation (issue 3): exact on clean sinusoids, efficient and calibrated in noise."""

import numpy as np
import pytest

from plant.errors import DataError
from plant.lockin import amplitude_dependence, estimate_response
from plant.recording import Block, Recording

FS, SECONDS = 1000.0, 3.0
T = np.arange(int(FS * SECONDS)) / FS
G_TRUE = 0.04 * np.exp(-0.7j)       # velocity per current of the synthetic "plant"


def recording(f_hz, *, amp_i=0.5, noise=0.0, rng=None, h2=0.0, h3=0.0, transient=0.0, tau_s=0.1, outputs=1):
    wt = 2 * np.pi * f_hz * T
    i = amp_i * np.cos(wt)
    v = np.real(G_TRUE * amp_i * np.exp(1j * wt)) + h2 * abs(G_TRUE) * amp_i * np.cos(2 * wt) \
        + h3 * abs(G_TRUE) * amp_i * np.cos(3 * wt) + transient * np.exp(-T / tau_s)
    vel = np.vstack([v * (k + 1) for k in range(outputs)])
    if noise:
        vel = vel + rng.normal(0, noise, vel.shape)
    names = ("velocity_m_per_s",) if outputs == 1 else tuple(f"velocity_y{k + 1}_m_per_s" for k in range(outputs))
    return Recording((Block(f_hz, T, i, vel),), names)


def test_clean_sinusoid_exact_with_harmonics_and_two_outputs():
    m = estimate_response(recording(10.0, h2=0.05, h3=0.02, outputs=2))
    assert np.allclose(m.response[:, 0], [G_TRUE, 2 * G_TRUE], rtol=1e-9)        # closed form
    assert np.allclose(m.harmonic_distortion[0, 0], [0.05, 0.02], rtol=1e-6)
    assert m.current_amplitude_a[0] == pytest.approx(0.5)
    frd = m.to_frd(1)
    assert np.allclose(frd(1j * m.w_rad_s), m.response[1])


def test_start_up_transient_is_removed():
    rng = np.random.default_rng(1)
    noise = 2e-4
    m = estimate_response(recording(10.0, transient=0.02, tau_s=0.1, noise=noise, rng=rng))
    # the transient (100 x the noise at t = 0, time constant 0.1 s) is cut, the estimate unbiased
    assert m.metadata["settle_s"][0] >= 0.5
    assert abs(m.response[0, 0] - G_TRUE) < 4 * np.sqrt(m.variance[0, 0])


def test_rms_method_loses_phase_and_inflates_with_noise_and_harmonics():
    clean = estimate_response(recording(10.0), method="rms")
    assert clean.response[0, 0] == pytest.approx(abs(G_TRUE), rel=1e-6)      # whole periods: exact magnitude
    assert clean.response[0, 0].imag == 0
    rng = np.random.default_rng(0)
    sigma = 0.01
    noisy = estimate_response(recording(10.0, noise=sigma, rng=rng), method="rms")
    a = abs(G_TRUE) * 0.5
    # closed form: sqrt(2) RMS of (sinusoid + noise) = sqrt(a^2 + 2 sigma^2)
    assert noisy.response[0, 0] * 0.5 == pytest.approx(np.sqrt(a**2 + 2 * sigma**2), rel=0.01)
    assert estimate_response(recording(10.0, h3=0.3), method="rms").response[0, 0] > 1.04 * abs(G_TRUE)


@pytest.mark.parametrize("f", [2.0, 10.0, 50.0])
def test_variance_is_efficient_and_calibrated(f):
    """300 noisy realisations: the scatter of G is within 1.5x the Cramer-Rao bound and the
    reported sub-block variance matches the scatter (ratio in [0.7, 1.4])."""
    rng = np.random.default_rng(42)
    amp_i, sigma = 0.5, 0.05 * abs(G_TRUE) * 0.5
    est, rep = [], []
    for _ in range(300):
        m = estimate_response(recording(f, amp_i=amp_i, noise=sigma, rng=rng))
        est.append(m.response[0, 0])
        rep.append(m.variance[0, 0])
        settle = m.metadata["settle_s"][0]
    n_used = np.floor((T[-1] - settle) * f + 1e-9) / f * FS
    crb = 4 * sigma**2 / n_used / amp_i**2            # E|a_hat - a|^2 = 4 sigma^2 / N, divided by |I|^2
    scatter = np.mean(np.abs(np.asarray(est) - G_TRUE) ** 2)
    assert 0.8 < scatter / crb < 1.5
    # mean of 300 sub-block variances (18 dof each) vs the scatter of 300 estimates: +-20 % is > 3 sigma
    assert 0.7 < np.mean(rep) / scatter < 1.4


def test_amplitude_dependence():
    lin = [estimate_response(recording(f_hz, amp_i=a, noise=1e-5, rng=np.random.default_rng(k)))
           for k, (f_hz, a) in enumerate([(10.0, 0.5), (10.0, 1.0)])]
    assert not amplitude_dependence(lin).significant
    bent = recording(10.0, amp_i=1.0)
    bent = Recording((Block(10.0, T, bent.blocks[0].current_a, 1.1 * bent.blocks[0].velocity_m_per_s
                            + np.random.default_rng(5).normal(0, 1e-5, T.size)),), bent.output_names)
    dep = amplitude_dependence([lin[0], estimate_response(bent)])
    assert dep.significant and dep.relative_magnitude_change[0, 0, 0] == pytest.approx(0.1, abs=0.01)
    with pytest.raises(DataError, match="two or more amplitudes"):
        amplitude_dependence(lin[:1])


def test_bad_estimation_input():
    with pytest.raises(DataError, match="method must be"):
        estimate_response(recording(10.0), method="fft")
    with pytest.raises(DataError, match=r"block 10 Hz: 1.\d+ periods left after settling"):
        estimate_response(recording(10.0), settle_s=2.85)
