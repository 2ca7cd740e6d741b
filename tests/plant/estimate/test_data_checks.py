"""Checking stepped-sine data before estimating from it: short blocks used from partial periods,
currents that are not sinusoids at their block frequency (broadband data read as a stepped sine),
outputs lost in noise, aliased harmonics, encoder-differenced velocity, strict JSON.

The data are made here in closed form: a current through the first-order plant
G(s) = 20 / (35 s + 440) = K / (tau s + 1), K = 20/440 m/s per A, tau = 35/440 s. A sine
A sin(w t) from rest gives v = K A / (1 + (w tau)^2) (sin w t - w tau cos w t + w tau e^{-t/tau});
a broadband current goes through the plant's exact zero-order-hold discretisation.
"""

import json

import numpy as np
import pytest
import scipy.signal
from in_process import gantry

from design.views.json import print_json
from plant.data.read_stepped_sine import read_recording
from plant.data.recordings import Block, Recording
from plant.data.writers import write_recording_csv
from plant.errors import DataError
from plant.estimate.lockin import estimate_response

FS = 2000.0
K, TAU = 20.0 / 440.0, 35.0 / 440.0
AMP_I = 0.5
F_HZ = np.round(np.geomspace(1.0, 100.0, 40), 1)


def g_true(f_hz):
    return 20.0 / (35j * 2 * np.pi * np.asarray(f_hz) + 440.0)


def sine_block(f_hz, seconds, *, rng, noise=0.02, current_noise=0.0, gain=1.0, start=True):
    """Sine current (white noise ``current_noise`` x its amplitude) and the plant's velocity times
    ``gain`` (white noise ``noise`` x the velocity amplitude K A / sqrt(1 + (w tau)^2)); ``start``:
    from rest (with the plant's transient) or in steady state."""
    t = np.arange(int(round(seconds * FS))) / FS
    w = 2 * np.pi * f_hz
    wt = w * TAU
    v = K * AMP_I / (1 + wt**2) * (np.sin(w * t) - wt * np.cos(w * t) + (wt * np.exp(-t / TAU) if start else 0.0))
    sigma_v = noise * K * AMP_I / np.sqrt(1 + wt**2)
    i = AMP_I * np.sin(w * t) + rng.normal(0.0, current_noise * AMP_I, t.size)
    return Block(float(f_hz), t, i, (gain * v + rng.normal(0.0, sigma_v, t.size))[None, :])


def broadband_block(f_hz, current, *, rng, noise=1e-4):
    """A block labelled ``f_hz`` whose current is ``current`` (any excitation) through the plant."""
    a = np.exp(-1.0 / (FS * TAU))
    v = scipy.signal.lfilter([0.0, K * (1 - a)], [1.0, -a], current)         # exact ZOH discretisation
    t = np.arange(current.size) / FS
    return Block(float(f_hz), t, current, (v + rng.normal(0.0, noise, v.size))[None, :])


def rec(blocks):
    return Recording(tuple(blocks), ("velocity_m_per_s",))


def thesis_like(rng, seconds=2.0, **kw):
    return [sine_block(f, seconds, rng=rng, **kw) for f in F_HZ]


# --- short blocks -----------------------------------------------------------------------------

def test_a_short_block_is_used_from_its_partial_periods_and_a_too_short_one_left_out():
    """The 1 Hz block holds 2.3 periods (refused whole before: 'at least 2 whole periods'): its settled
    1.8 periods are used with 3 half-period sub-blocks; a 0.8 s block at 1.2 Hz (0.96 periods) is left out
    with a note, the other blocks are estimated."""
    rng = np.random.default_rng(1)
    blocks = thesis_like(rng)
    blocks[0] = sine_block(1.0, 2.3, rng=rng)
    blocks.insert(1, sine_block(1.2, 0.8, rng=rng))
    m = estimate_response(rec(blocks))
    assert m.f_hz.tolist() == F_HZ.tolist()
    assert m.metadata["excluded_f_hz"] == [1.2]
    assert m.metadata["periods_used"][0] == pytest.approx(1.8)          # 2.3 periods less half a period settling
    assert m.metadata["subblocks"][0] == 3                               # 3 half periods
    assert len(m.metadata["subblocks"]) == m.f_hz.size == len(m.metadata["settle_s"])
    assert any(n.startswith("block 1 Hz: only 1.80 periods after settling") for n in m.notes)
    assert any(n.startswith("block 1.2 Hz: 0.") and "at least 1 period is needed" in n and n.endswith("excluded")
               for n in m.notes)
    z2 = 2 * np.abs(m.response[0] - g_true(m.f_hz)) ** 2 / m.variance[0]  # chi-square, 2 dof (fewer for 1 Hz)
    assert np.all(z2 < 60)
    assert abs(m.response[0, 0] - g_true(1.0)) < 0.02 * abs(g_true(1.0))


@pytest.mark.parametrize("seconds, k", [(1.3, 2), (1.7, 3)])
def test_variance_of_a_short_window_is_unbiased(seconds, k):
    """Steady-state 1 Hz sine, all 1.3 (1.7) periods fitted (partial period included): 2 (3) sub-blocks.
    400 realisations: the scatter (relative sd 5 %) against the reported variance (2 (k - 1) dof each:
    mean over 400 has relative sd <= 5 %); [0.75, 1.33] is about +-4 sd of their ratio. The Cramer-Rao
    bound 4 sigma^2 / (N A^2) is reached within the offset's and harmonics' cost over a partial window."""
    rng = np.random.default_rng(5)
    g, var = np.empty(400, complex), np.empty(400)
    for n in range(400):
        m = estimate_response(rec([sine_block(1.0, seconds, rng=rng, noise=0.05, start=False)]), settle_s=0.0)
        g[n], var[n] = m.response[0, 0], m.variance[0, 0]
    assert m.metadata["subblocks"] == [k]
    assert m.metadata["periods_used"] == [pytest.approx(seconds)]
    scatter = np.mean(np.abs(g - g_true(1.0)) ** 2)
    assert 0.75 < np.mean(var) / scatter < 1.33
    sigma_v = 0.05 * K * AMP_I / np.sqrt(1 + (2 * np.pi * TAU) ** 2)
    assert 0.8 < scatter / (4 * sigma_v**2 / (seconds * FS) / AMP_I**2) < 2.0


# --- is the data a stepped sine? --------------------------------------------------------------

def _random_current(n, rng):
    """Gaussian noise low-passed to about 50 Hz (a second-order Butterworth), 0.5 A RMS."""
    b, a = scipy.signal.butter(2, 50.0, fs=FS)
    x = scipy.signal.lfilter(b, a, rng.normal(size=n))
    return AMP_I * x / np.std(x)


def _prbs_current(n, rng):
    """+-0.5 A, a new random level every 8 samples (250 Hz clock)."""
    return AMP_I * np.repeat(rng.choice([-1.0, 1.0], size=n // 8 + 1), 8)[:n]


def _multisine_current(n, rng):
    """20 sines at odd multiples of 0.7 Hz with random phases (none at a block label), 0.5 A RMS."""
    t = np.arange(n) / FS
    x = sum(np.cos(2 * np.pi * 0.7 * (2 * k + 1) * t + rng.uniform(0, 2 * np.pi)) for k in range(20))
    return AMP_I * x / np.std(x)


@pytest.mark.parametrize("excitation", [_random_current, _prbs_current, _multisine_current])
def test_broadband_data_read_as_a_stepped_sine_is_refused(excitation):
    """A broadband recording cut into blocks the frequency column only labels: no block's current is a
    sinusoid at its label, so no response that any model would fit is returned."""
    rng = np.random.default_rng(2)
    blocks = [broadband_block(f, excitation(int(2.0 * FS), rng), rng=rng) for f in F_HZ]
    with pytest.raises(DataError, match=r"<memory>: the recording does not look like a stepped sine: in (3\d|40) of "
                                        r"40 blocks the current is not a sinusoid at the block frequency .*use a "
                                        r"method for broadband data"):
        estimate_response(rec(blocks))


def test_one_broadband_block_is_left_out_with_a_note():
    rng = np.random.default_rng(3)
    blocks = thesis_like(rng)
    j = int(np.flatnonzero(F_HZ == 17.3)[0]) if 17.3 in F_HZ else 25
    f_bad = F_HZ[j]
    blocks[j] = broadband_block(f_bad, _random_current(int(2.0 * FS), rng), rng=rng)
    m = estimate_response(rec(blocks))
    assert f_bad not in m.f_hz and m.f_hz.size == 39
    assert m.metadata["excluded_f_hz"] == [f_bad]
    note = [n for n in m.notes if n.startswith(f"block {f_bad:g} Hz")]
    assert len(note) == 1
    assert "the current is not a sinusoid at the block frequency: only " in note[0]
    assert "% of the output power: excluded" in note[0]


def test_sinusoids_in_heavy_white_noise_are_all_kept():
    """A sine current with white noise at 0 dB per sample (sigma = amplitude / sqrt(2)) and outputs at
    20 % noise: every block passes (false alarm 1e-4 per test); the only notes are about the 2 s blocks
    at 1 to 1.3 Hz, which keep fewer than 2 periods after settling."""
    rng = np.random.default_rng(4)
    m = estimate_response(rec(thesis_like(rng, current_noise=1 / np.sqrt(2), noise=0.2)))
    assert m.f_hz.size == 40
    assert all("periods after settling" in n and n.endswith("degrees of freedom)") for n in m.notes)
    assert np.all((m.current_fundamental_fraction > 0.3) & (m.current_fundamental_fraction < 0.7))   # 1/2
    assert np.all(np.abs(m.current_snr_db) < 1.0)                                                      # 0 dB


def test_a_sinusoid_riding_on_other_content_is_kept():
    """A sine current under a 900 Hz square ripple of twice its amplitude (11 % of the current's power at
    the block frequency): the sinusoid is detected, the fit separates it, the block is kept and exact to
    its noise."""
    rng = np.random.default_rng(10)
    blocks = thesis_like(rng)
    b = blocks[25]
    ripple = 2 * AMP_I * np.sign(np.sin(2 * np.pi * 900.0 * b.time_s + 0.3))
    blocks[25] = Block(b.f_hz, b.time_s, b.current_a + ripple, b.velocity_m_per_s)
    m = estimate_response(rec(blocks))
    assert m.f_hz.size == 40 and not any("current" in n for n in m.notes)
    assert m.current_fundamental_fraction[25] == pytest.approx(0.125 / 1.125, rel=0.05)   # closed form
    assert abs(m.response[0, 25] - g_true(b.f_hz)) < 5 * np.sqrt(m.variance[0, 25])


def test_an_output_lost_in_noise_is_kept_and_weighted_down():
    """A lightly damped plant at its antiresonance: the velocity at one block is 1/1000 of the others'
    (below its noise); the current is a clean sinusoid, so the block stays, with a large variance."""
    rng = np.random.default_rng(6)
    blocks = thesis_like(rng)
    blocks[20] = sine_block(F_HZ[20], 2.0, rng=rng, gain=1e-3, noise=0.05 * 1e3)   # same noise, tiny signal
    m = estimate_response(rec(blocks))
    assert m.f_hz.size == 40
    assert m.snr_db[0, 20] < 0 and m.fundamental_fraction[0, 20] < 0.01
    assert m.variance[0, 20] > 1e4 * np.median(m.variance[0] / np.abs(m.response[0]) ** 2) * abs(m.response[0, 20]) ** 2
    assert [n for n in m.notes if "not detected" in n] == [
        f"block {F_HZ[20]:g} Hz, output 'velocity_m_per_s': the fundamental is not detected above the noise "
        f"(SNR {m.snr_db[0, 20]:.0f} dB, {100 * m.fundamental_fraction[0, 20]:.2g} % of the output power): kept, "
        "weighted by its variance"]


# --- harmonics that cannot be measured, strict JSON -------------------------------------------

def test_unmeasurable_harmonics_are_nan_and_everything_else_copes(capsys):
    """At 2 kHz sampling, 400 Hz has its 3rd harmonic (1200 Hz) above 0.45 fs: NaN; 480 Hz both. Data
    checks, notes and JSON output are unaffected."""
    rng = np.random.default_rng(7)
    m = estimate_response(rec([sine_block(f, 1.0, rng=rng) for f in (10.0, 400.0, 480.0)]))
    assert np.isnan(m.harmonic_distortion[0, 1, 1]) and np.all(np.isnan(m.harmonic_distortion[0, 2]))
    assert np.isfinite(m.harmonic_distortion[0, 0]).all()
    assert np.isfinite(m.fundamental_fraction).all() and np.isfinite(m.current_fundamental_fraction).all()
    assert int(np.nanargmax(m.harmonic_distortion[0, :, 0])) in (0, 1)
    print_json({"harmonic_distortion": m.harmonic_distortion, "notes": m.notes, "metadata": m.metadata})
    out = json.loads(capsys.readouterr().out)
    assert out["harmonic_distortion"][0][2] == [None, None]


def test_print_json_is_strict_everywhere(capsys):
    obj = {"a": float("nan"), "b": [1.0, float("inf"), (np.float64(-np.inf), np.float32(2.5))],
           "c": {"d": np.array([[1.0, np.nan], [np.inf, 3.0]]), "e": np.int64(4), "f": np.bool_(True)},
           "g": (np.nan,), "h": "text", "i": None}
    print_json(obj)
    text = capsys.readouterr().out
    assert "NaN" not in text and "Infinity" not in text
    assert json.loads(text) == {"a": None, "b": [1.0, None, [None, 2.5]], "c": {"d": [[1.0, None], [None, 3.0]],
                                "e": 4, "f": True}, "g": [None], "h": "text", "i": None}


# --- encoder-differenced velocity -------------------------------------------------------------

def encoder_blocks(rng, quantum_m=1e-7):
    """The plant's position (closed-form velocity integrated per sample) quantised to ``quantum_m`` and
    differenced at the logging rate: velocity on the lattice n q fs."""
    out = []
    for b in thesis_like(rng, noise=0.0):
        x = np.round(np.cumsum(b.velocity_m_per_s[0]) / FS / quantum_m) * quantum_m
        out.append(Block(b.f_hz, b.time_s, b.current_a, (np.diff(x, prepend=0.0) * FS)[None, :]))
    return out


def test_encoder_differenced_velocity_is_recognised_through_csv(tmp_path):
    rng = np.random.default_rng(8)
    write_recording_csv(rec(encoder_blocks(rng)), tmp_path / "enc.csv")     # velocity written with 9 digits
    m = estimate_response(read_recording(tmp_path / "enc.csv"))
    assert m.metadata["encoder_velocity_quantum_m_per_s"] == pytest.approx(1e-7 * FS, rel=1e-9)
    assert m.metadata["sample_rate_hz"] == pytest.approx(FS)
    assert ("velocity is an encoder position quantum 1e-7 m differenced at 2000 Hz: its half-sample delay and "
            "sinc droop are part of the sensor") in m.notes


def test_a_continuous_or_coarse_velocity_is_not_taken_for_an_encoder():
    rng = np.random.default_rng(9)
    m = estimate_response(rec(thesis_like(rng)))                       # continuous values with noise
    assert "encoder_velocity_quantum_m_per_s" not in m.metadata
    assert m.metadata["sample_rate_hz"] == pytest.approx(FS)
    blocks = encoder_blocks(rng)
    blocks[3] = Block(blocks[3].f_hz, blocks[3].time_s, blocks[3].current_a,
                      blocks[3].velocity_m_per_s + rng.normal(0.0, 1e-6, blocks[3].time_s.size))   # 5 % off-lattice
    assert "encoder_velocity_quantum_m_per_s" not in estimate_response(rec(blocks)).metadata


def test_an_output_flat_in_one_block_leaves_that_block_out():
    """A velocity that does not move in one block (below the resolution) costs that block, not the
    recording; flat in every block it is a dead channel and refused."""
    rng = np.random.default_rng(11)
    blocks = [sine_block(f, 2.0, rng=rng) for f in (5.0, 10.0, 20.0)]
    b = blocks[1]
    blocks[1] = Block(b.f_hz, b.time_s, b.current_a, np.zeros_like(b.velocity_m_per_s))
    m = estimate_response(rec(blocks))
    assert m.f_hz.tolist() == [5.0, 20.0]
    assert m.notes == ("block 10 Hz, output 'velocity_m_per_s': every sample is 0 (no motion above the velocity "
                       "resolution): excluded",)
    flat = [Block(b.f_hz, b.time_s, b.current_a, np.zeros_like(b.velocity_m_per_s)) for b in blocks]
    with pytest.raises(DataError, match="every sample is 0; a dead channel"):
        estimate_response(rec(flat))


def test_diagnose_refuses_broadband_data_in_one_line(tmp_path):
    """The command line: exit status 2, one line naming the file, no diagnosis of broadband data."""
    rng = np.random.default_rng(3)
    path = tmp_path / "broadband.csv"
    write_recording_csv(rec([broadband_block(f, _random_current(int(2.0 * FS), rng), rng=rng) for f in F_HZ]), path)
    out = gantry("diagnose", str(path), "--stage", "x", "--json")
    assert out.returncode == 2 and out.stdout == ""
    assert out.stderr.count("\n") == 1 and "broadband.csv" in out.stderr
    assert "not look like a stepped sine" in out.stderr
