"""Lock-in estimation: exact on clean sinusoids, harmonics, settling, the thesis's RMS
method, amplitude dependence, and the uncertainty against the Cramer-Rao bound.

Signals are synthesised here with known truth (closed form); ``plant.experiment.simulate`` is used once,
for the end-to-end check.
"""

import numpy as np
import pytest
import scipy.stats

from plant.data.recordings import Block, Recording
from plant.errors import DataError
from plant.estimate.lockin import amplitude_dependence, estimate_response

FS = 1000.0
G1 = 0.04 * np.exp(-0.7j)          # velocity per current of the synthetic "plant", output 1
G2 = 0.013 * np.exp(2.1j)          # output 2


def make_block(f_hz, *, seconds=3.0, fs=FS, amp_i=0.5, gains=(G1,), phi_i=0.4, sigma_v=0.0, sigma_i=0.0,
               rng=None, h2=0.0, h3=0.0, transient=0.0, tau_s=0.1):
    """Current A cos(w t + phi_i); output k: Re(G_k A e^{j(w t + phi_i)}) plus harmonics h2, h3 (relative to
    the output's fundamental, with phases 1.0 and -2.0 rad), a transient ``transient`` * e^{-t/tau} and white
    Gaussian noise (sigma_v on every output, sigma_i on the current)."""
    t = np.arange(int(round(seconds * fs))) / fs
    e = np.exp(1j * (2 * np.pi * f_hz * t + phi_i))
    i = amp_i * e.real
    v = []
    for g in gains:
        a = abs(g) * amp_i
        v.append(np.real(g * amp_i * e) + h2 * a * np.cos(2 * np.angle(e) + 1.0)
                 + h3 * a * np.cos(3 * np.angle(e) - 2.0) + transient * np.exp(-t / tau_s))
    v = np.array(v)
    if sigma_v:
        v = v + rng.normal(0.0, sigma_v, v.shape)
    if sigma_i:
        i = i + rng.normal(0.0, sigma_i, i.shape)
    return Block(f_hz, t, i, v)


def rec(*blocks, outputs=1):
    names = ("velocity_m_per_s",) if outputs == 1 else tuple(f"velocity_y{k + 1}_m_per_s" for k in range(outputs))
    return Recording(tuple(blocks), names)


# --- noise-free: exact ----------------------------------------------------------------------

@pytest.mark.parametrize("f_hz", [1.0, 7.3, 75.0, 250.0])   # 7.3 Hz: 137.0 samples per period; 250 Hz: 4
def test_clean_sinusoid_exact_amplitude_and_phase(f_hz):
    m = estimate_response(rec(make_block(f_hz, gains=(G1, G2)), outputs=2))
    # closed form: G_k = V_k / I exactly, whatever the current's phase
    assert np.allclose(m.response[:, 0], [G1, G2], rtol=1e-9, atol=0)
    assert np.abs(m.response[0, 0]) == pytest.approx(0.04, rel=1e-9)
    assert np.angle(m.response[1, 0]) == pytest.approx(2.1, abs=1e-9)
    assert m.current_amplitude_a[0] == pytest.approx(0.5, rel=1e-9)
    assert m.output_names == ("velocity_y1_m_per_s", "velocity_y2_m_per_s")
    assert np.all(m.variance < 1e-20 * abs(G1) ** 2)           # no scatter between sub-blocks


def test_harmonic_ratios_and_an_offset_do_not_bias_the_fundamental():
    b = make_block(10.0, h2=0.05, h3=0.02)
    b = Block(b.f_hz, b.time_s, b.current_a + 0.1, b.velocity_m_per_s - 0.003)     # DC offsets on both
    m = estimate_response(rec(b))
    assert m.response[0, 0] == pytest.approx(G1, rel=1e-9)                         # closed form
    assert np.allclose(m.harmonic_distortion[0, 0], [0.05, 0.02], rtol=1e-9)       # injected
    # 200 Hz at 1 kHz: the 3rd harmonic (600 Hz) is above Nyquist and cannot be measured
    m = estimate_response(rec(make_block(200.0, h2=0.05)))
    assert m.harmonic_distortion[0, 0, 0] == pytest.approx(0.05, rel=1e-6)
    assert np.isnan(m.harmonic_distortion[0, 0, 1])


def test_snr_matches_closed_form():
    rng = np.random.default_rng(3)
    sigma = 0.002
    m = estimate_response(rec(make_block(10.0, sigma_v=sigma, rng=rng)))
    # closed form: fundamental RMS over noise RMS, |G| A / sqrt(2) / sigma
    expected_db = 20 * np.log10(abs(G1) * 0.5 / np.sqrt(2) / sigma)
    assert m.snr_db[0, 0] == pytest.approx(expected_db, abs=0.3)       # noise RMS from ~3000 samples: +-0.1 dB


def test_to_frd_has_the_same_values():
    m = estimate_response(rec(*(make_block(f, gains=(G1, G2 * f)) for f in (2.0, 5.0, 20.0)), outputs=2))
    for k, key in enumerate([0, "velocity_y2_m_per_s"]):
        frd = m.to_frd(key)
        assert np.allclose(frd.omega, 2 * np.pi * np.array([2.0, 5.0, 20.0]))
        assert np.allclose(frd.frdata[0, 0], m.response[k], rtol=1e-12)
        assert np.allclose(frd(1j * frd.omega), m.response[k], rtol=1e-12)
    assert np.allclose(m.to_frd(1).frdata[0, 0], G2 * np.array([2.0, 5.0, 20.0]), rtol=1e-9)   # closed form
    with pytest.raises(DataError, match="no output 'velocity_x'; outputs: velocity_y1_m_per_s"):
        m.to_frd("velocity_x")
    with pytest.raises(DataError, match="output index 2"):
        m.to_frd(2)


def test_settle_zero_uses_every_whole_period():
    # 5000 samples at 1 kHz stand for 5 s (each sample for [t - 0.5 ms, t + 0.5 ms)): 10 whole periods at 2 Hz
    for method in ("lock-in", "rms"):
        m = estimate_response(rec(make_block(2.0, seconds=5.0)), settle_s=0.0, method=method)
        assert m.metadata["periods_used"] == [10.0]
        assert abs(m.response[0, 0]) == pytest.approx(abs(G1), rel=1e-9)


# --- settling -------------------------------------------------------------------------------

def test_start_up_transient_is_cut_where_it_no_longer_biases():
    """A decaying exponential c e^{-t/tau} at the start of a 5 s block at 2 Hz (c = 2.5x the output
    amplitude, 100x the noise): the settling time estimated from the noisy data removes it."""
    tau, c, sigma, amp_i, w = 0.2, 0.05, 5e-4, 0.5, 2 * np.pi * 2.0
    kw = dict(seconds=5.0, amp_i=amp_i, transient=c, tau_s=tau)
    noisy = estimate_response(rec(make_block(2.0, sigma_v=sigma, rng=np.random.default_rng(11), **kw)))
    settle = noisy.metadata["settle_s"][0]
    sd = np.sqrt(crb((5.0 - settle) * FS, amp_i, sigma))          # noise of the estimate (closed form, below)
    assert np.sqrt(noisy.variance[0, 0]) == pytest.approx(sd, rel=0.5)
    # bias left by the transient after that cut: the same block without noise, same settling time;
    # closed form over the window [t0, T]: |2/(T - t0) int c e^{-t/tau} e^{-jwt} dt| / A
    #                                       = 2 c tau e^{-t0/tau} / ((T - t0) sqrt(1 + (w tau)^2) A)
    bias = abs(estimate_response(rec(make_block(2.0, **kw)), settle_s=settle).response[0, 0] - G1)
    predicted = 2 * c * tau * np.exp(-settle / tau) / ((5.0 - settle) * np.sqrt(1 + (w * tau) ** 2) * amp_i)
    assert bias == pytest.approx(predicted, rel=0.2)
    assert bias < 0.25 * sd
    # not cut, the transient biases the estimate by many standard deviations ...
    assert abs(estimate_response(rec(make_block(2.0, **kw)), settle_s=0.0).response[0, 0] - G1) > 10 * sd
    # ... and the cut does not throw the block away: the bias falls below 0.1 sd at t0 ~ 7 tau (closed form)
    assert settle < 10 * tau
    assert not any("decay" in note for note in noisy.notes)      # it saw the decay end: nothing left to fit


def test_a_transient_too_slow_for_a_short_block_is_fitted_with_its_uncertainty():
    """1 s blocks of a first-order response from rest (time constant 0.25 s, as a 40 kg stage on 160 N s/m):
    the settling search cannot see the decay end, so it is fitted, and tau's own uncertainty enters the
    variance: over 200 noisy blocks the estimate is unbiased and its reported variance calibrated."""
    f_hz, seconds, amp_i, tau = 3.0, 1.0, 0.5, 0.25
    t = np.arange(int(seconds * FS)) / FS
    w = 2 * np.pi * f_hz
    g = 1 / (160.0 * (1 + 1j * w * tau))                       # K / (1 + j w tau), velocity per current
    steady = np.real(g * amp_i * np.exp(1j * w * t))
    v_clean = steady - np.real(g * amp_i) * np.exp(-t / tau)       # from rest: v(0) = 0
    sigma = 0.01 * abs(g) * amp_i
    rng = np.random.default_rng(5)
    est = [estimate_response(rec(Block(f_hz, t, amp_i * np.cos(w * t), (v_clean + rng.normal(0, sigma, t.size))[None])))
           for _ in range(200)]
    err = np.array([e.response[0, 0] for e in est]) - g
    var = np.array([e.variance[0, 0] for e in est])
    scatter = np.mean(np.abs(err) ** 2)
    assert abs(np.mean(err)) < 4 * np.sqrt(scatter / err.size)        # unbiased
    assert 0.7 < np.mean(var) / scatter < 1.4                           # calibrated (bands as below)
    assert all(any("decay of time constant" in note for note in e.notes) for e in est)


@pytest.mark.parametrize("snr_db, current_noise", [(20.0, False), (-10.0, False), (0.0, True), (-10.0, True)])
def test_no_transient_little_data_dropped(snr_db, current_noise):
    """Steady sinusoids from t = 0 in white noise (per-sample SNR: RMS over sigma), also on the current:
    nothing to cut, the settling stays at its floor (``MIN_SETTLE_S`` = 0.05 s of a 5 s block)."""
    rng = np.random.default_rng(4)
    amp_i, fs = 0.5, 2000.0
    sigma_v = abs(G1) * amp_i / np.sqrt(2) / 10 ** (snr_db / 20)
    sigma_i = amp_i / np.sqrt(2) / 10 ** (snr_db / 20) if current_noise else 0.0
    settles = [estimate_response(rec(make_block(20.0, seconds=5.0, fs=fs, amp_i=amp_i, sigma_v=sigma_v,
                                                sigma_i=sigma_i, rng=rng))).metadata["settle_s"][0]
               for _ in range(10)]
    assert max(settles) <= 0.1


# --- the thesis's RMS method (Appendix B) ---------------------------------------------------

def test_rms_equals_magnitude_on_whole_periods_and_has_no_phase():
    m = estimate_response(rec(make_block(10.0, gains=(G1, G2)), outputs=2), method="rms")
    assert np.allclose(m.response[:, 0], [abs(G1), abs(G2)], rtol=1e-9)     # closed form: sqrt(2) RMS = amplitude
    assert np.all(m.response.imag == 0)                                     # no phase
    assert m.method == "rms"
    lock = estimate_response(rec(make_block(10.0)))
    assert np.angle(lock.response[0, 0]) == pytest.approx(-0.7, abs=1e-9)   # the phase the RMS method loses


def test_rms_is_inflated_by_noise_and_harmonics():
    rng = np.random.default_rng(0)
    amp_i, sigma, a = 0.5, 0.01, abs(G1) * 0.5           # output noise half the output amplitude
    blk = make_block(10.0, seconds=20.0, amp_i=amp_i, sigma_v=sigma, rng=rng)
    rms = estimate_response(rec(blk), method="rms").response[0, 0].real
    # closed form: E[v^2] = a^2 / 2 + sigma^2, so sqrt(2 mean v^2) / A = sqrt(|G|^2 A^2 + 2 sigma^2) / A  (+22 %)
    # sampling scatter of mean(v^2) over 20000 samples: sqrt((2 a^2 sigma^2 + 2 sigma^4) / N) / E[v^2] = 0.7 %
    expected = np.sqrt(a**2 + 2 * sigma**2) / amp_i
    assert rms == pytest.approx(expected, rel=0.02)
    assert rms > 1.15 * abs(G1)
    lock = estimate_response(rec(blk))
    assert abs(lock.response[0, 0] - G1) < 4 * np.sqrt(lock.variance[0, 0])        # the lock-in is not inflated
    h = estimate_response(rec(make_block(10.0, h2=0.2, h3=0.3)), method="rms").response[0, 0].real
    assert h == pytest.approx(abs(G1) * np.sqrt(1 + 0.2**2 + 0.3**2), rel=1e-9)     # closed form (Parseval)


# --- uncertainty: Cramer-Rao bound and calibration ------------------------------------------

def crb(n_samples, amp_i, sigma_v, sigma_i=0.0, g=G1):
    """Cramer-Rao bound of E|G_hat - G|^2 for G = V / I from N samples of known-frequency sinusoids in white
    Gaussian noise: each quadrature of a phasor has variance 2 sigma^2 / N, so E|a_hat - a|^2 = 4 sigma^2 / N;
    G_hat = V_hat / I_hat is the ML estimate (invariance), dG = (dV - G dI) / I to first order."""
    return 4 * (sigma_v**2 + abs(g) ** 2 * sigma_i**2) / n_samples / amp_i**2


def realisations(n, f_hz, *, seconds, amp_i, sigma_v, sigma_i=0.0, seed=0, fs=FS):
    """Estimates of R = ``n`` noisy blocks: G, its reported variance, the current amplitude and its variance."""
    rng = np.random.default_rng(seed)
    g, v, a, va = np.empty(n, complex), np.empty(n), np.empty(n), np.empty(n)
    for k in range(n):
        m = estimate_response(rec(make_block(f_hz, seconds=seconds, fs=fs, amp_i=amp_i, sigma_v=sigma_v,
                                             sigma_i=sigma_i, rng=rng)))
        g[k], v[k] = m.response[0, 0], m.variance[0, 0]
        a[k], va[k] = m.current_amplitude_a[0], m.current_amplitude_variance[0]
    return g, v, a, va


# Statistical reasoning for the bands (R realisations):
# * scatter = mean |G_hat - G|^2 is a mean of R squared moduli of circular complex Gaussian errors
#   (each exponential: 2 dof), relative sd 1 / sqrt(R) = 7 % for R = 200. The CRB ratio of an
#   efficient estimator using all N samples is 1, using N_used < N it is N / N_used; the band
#   [0.75, 1.5] has the lower edge 3.5 sd below 1 (a scatter below the bound means a wrong test).
# * each reported variance comes from k = 10 sub-blocks, 2 (k - 1) = 18 real dof, so mean(reported)
#   over R has relative sd sqrt(2 / 18 / R) = 2.4 %; the ratio mean(reported) / scatter then has
#   relative sd sqrt(1 / R + 1 / (9 R)) = 7.5 %. [0.7, 1.4] is -4.8 / +4.5 sd in log terms, so a
#   calibrated estimator fails with probability < 1e-5, while the usual mistakes (a factor 2 between
#   complex and per-quadrature variance, not dividing by the number of sub-blocks) are far outside.
@pytest.mark.parametrize("sigma_i_rel", [0.0, 0.05])
def test_variance_within_crb_and_calibrated(sigma_i_rel):
    f_hz, seconds, amp_i = 20.0, 1.0, 0.5
    sigma_v = 0.05 * abs(G1) * amp_i                   # SNR 26 dB per sample on the velocity
    sigma_i = sigma_i_rel * amp_i
    g, v, a, va = realisations(200, f_hz, seconds=seconds, amp_i=amp_i, sigma_v=sigma_v, sigma_i=sigma_i,
                               seed=42)
    scatter = np.mean(np.abs(g - G1) ** 2)
    ratio = scatter / crb(seconds * FS, amp_i, sigma_v, sigma_i)     # N: every sample of the block
    assert 0.75 < ratio < 1.5
    assert 0.7 < np.mean(v) / scatter < 1.4
    assert abs(np.mean(g) - G1) < 4 * np.sqrt(scatter / g.size)      # unbiased
    if sigma_i:
        # the current amplitude: one real (radial) quadrature, CRB 2 sigma_i^2 / N; its scatter over R = 200
        # has relative sd sqrt(2 / R) = 10 %, so [0.65, 1.5] is about -4 / +4 sd in log terms
        amp_scatter = np.mean((a - amp_i) ** 2)
        assert 0.65 < amp_scatter / (2 * sigma_i**2 / (seconds * FS)) < 1.5
        assert 0.65 < np.mean(va) / amp_scatter < 1.5


@pytest.mark.slow
@pytest.mark.parametrize("f_hz, seconds, fs", [(1.0, 5.0, 1000.0), (7.3, 5.0, 1000.0), (75.0, 5.0, 1000.0),
                                               (2.0, 1.5, 1000.0), (240.0, 1.0, 1000.0)])
def test_variance_within_crb_and_calibrated_slow(f_hz, seconds, fs):
    """The same check as above, 400 realisations, on thesis-like 5 s blocks from 1 Hz, a non-integer number of
    samples per period, 3 periods only, and 4.2 samples per period."""
    amp_i = 0.5
    sigma_v = 0.05 * abs(G1) * amp_i
    g, v, _, _ = realisations(400, f_hz, seconds=seconds, amp_i=amp_i, sigma_v=sigma_v, seed=7, fs=fs)
    scatter = np.mean(np.abs(g - G1) ** 2)
    assert 0.8 < scatter / crb(seconds * fs, amp_i, sigma_v) < 1.5
    assert 0.75 < np.mean(v) / scatter < 1.33


# --- amplitude dependence -------------------------------------------------------------------

def test_amplitude_dependence_linear_vs_amplitude_dependent_gain():
    rng = np.random.default_rng(5)
    freqs = (2.0, 10.0, 40.0)
    sigma = 1e-4

    def run(amp_i, gain_of_amp):
        return estimate_response(rec(*(make_block(f, amp_i=amp_i, gains=(gain_of_amp(amp_i) * G1,), sigma_v=sigma,
                                                  rng=rng) for f in freqs)))
    linear = [run(a, lambda a: 1.0) for a in (0.5, 1.0)]
    dep = amplitude_dependence(linear)
    assert not dep.significant
    assert dep.f_hz.tolist() == list(freqs)
    assert np.allclose(dep.current_amplitude_a, [[0.5] * 3, [1.0] * 3])
    assert np.all(np.abs(dep.relative_magnitude_change) < 0.005)
    # a gain falling with amplitude, e.g. saturation: |G(1 A)| / |G(0.5 A)| - 1 = -0.1 (closed form), phase +3 deg
    bent = [run(a, lambda a: (1.1 - 0.2 * a) * np.exp(1j * np.radians(6.0 * (a - 0.5)))) for a in (0.5, 1.0)]
    dep = amplitude_dependence(bent)
    assert dep.significant and dep.significant_points.all()
    assert np.allclose(dep.relative_magnitude_change, -0.1, atol=0.005)
    assert np.allclose(dep.phase_change_deg, 3.0, atol=0.3)
    assert np.all(dep.z > 20)
    with pytest.raises(DataError, match="two or more amplitudes"):
        amplitude_dependence(linear[:1])


# --- errors ---------------------------------------------------------------------------------

def test_bad_estimation_input():
    r = rec(make_block(10.0))
    with pytest.raises(DataError, match="method must be 'lock-in' or 'rms', got 'fft'"):
        estimate_response(r, method="fft")
    with pytest.raises(DataError, match=r"<memory>: no usable block: block 10 Hz: 0\.50 periods left after settling "
                                        r"\(2\.95 s\); at least 1 period is needed"):
        estimate_response(r, settle_s=2.95)
    with pytest.raises(DataError, match=r"block 10 Hz: .* periods left after settling"):
        estimate_response(r, settle_s=2.95, method="rms")
    with pytest.raises(DataError, match="settle_s must be"):
        estimate_response(r, settle_s=-1.0)
    with pytest.raises(DataError, match="settle_s must be"):
        estimate_response(r, settle_s=float("nan"))
    b = make_block(10.0, gains=(G1, G2))
    for value in (0.0, 0.25):            # a dead channel: no warning (0 / 0), no G = 0 with zero variance
        for method in ("lock-in", "rms"):
            with pytest.raises(DataError, match=rf"block 10 Hz, output 'velocity_y2_m_per_s': every sample is "
                                                rf"{value:g}; a dead channel"):
                estimate_response(rec(Block(10.0, b.time_s, b.current_a, np.vstack(
                    [b.velocity_m_per_s[0], np.full(b.time_s.size, value)])), outputs=2), method=method)
    with pytest.raises(DataError, match=r"block 10 Hz.*current has no component at 10 Hz"):
        estimate_response(rec(Block(10.0, b.time_s, 0.1 * np.cos(2 * np.pi * 30.0 * b.time_s),
                                    b.velocity_m_per_s)))


# --- end to end -----------------------------------------------------------------------------

def test_simulated_recording_through_csv_matches_the_model(tmp_path):
    """plant.experiment.simulate -> CSV -> read_recording -> estimate_response agrees with Plant.frd within the reported
    variance: sum 2|G - frd|^2 / var is chi-square with 2 n_freq dof (the sub-block variances have 18 dof
    each, which widens the tails a little: the 1e-3 quantiles are used)."""
    from plant.data.read_stepped_sine import read_recording
    from plant.data.writers import write_recording_csv
    from plant.experiment.simulate import simulate_stepped_sine
    from plant.physics.effects import Delay
    from plant.physics.models import stage_x

    plant = stage_x() * Delay(0.001)
    f = np.array([1.0, 2.0, 3.5, 7.0, 15.0, 30.0, 75.0])
    sim = simulate_stepped_sine(plant, f_hz=f, current_amplitude_a=0.5, duration_s=5.0, sample_rate_hz=2000.0,
                                noise_fraction=0.02, seed=3)
    write_recording_csv(sim, tmp_path / "sim.csv")
    m = estimate_response(read_recording(tmp_path / "sim.csv"))
    truth = plant.frd(2 * np.pi * f)
    stat = np.sum(2 * np.abs(m.response[0] - truth) ** 2 / m.variance[0])
    dof = 2 * f.size
    assert scipy.stats.chi2.ppf(1e-3, dof) < stat < scipy.stats.chi2.ppf(1 - 1e-3, dof)
    # the delay's phase lag of 27 deg at 75 Hz is measured (closed form: 360 f tau)
    lag = np.degrees(np.angle(m.response[0, -1] / stage_x().frd(2 * np.pi * f[-1:])[0]))
    assert lag == pytest.approx(-27.0, abs=1.0)
