"""Multisine design (plant.experiment.excitation) and ``gantry excite``: checked against independent numpy."""

import json
import math

import numpy as np
import pytest
from in_process import gantry

from plant.errors import ParameterError
from plant.experiment.excitation import (
    design_multisine,
    design_stepped_sine,
    multisine_variance,
    predicted_variance,
    stepped_sine_variance,
    write_excitation_csv,
    write_stepped_sine_csv,
)


def crest(x):
    return np.max(np.abs(x)) / np.sqrt(np.mean(x**2))


@pytest.mark.parametrize("kw", [dict(period_s=5.0, lines_per_decade=25.0), dict(period_s=1.0, lines_per_decade=None),
                                dict(period_s=2.0, lines_per_decade=8.0)])
def test_only_odd_harmonics_in_the_band_and_whole_periods(kw):
    ms = design_multisine(f_min_hz=1.0, f_max_hz=75.0, peak_a=0.5, sample_rate_hz=2000.0, periods=3, **kw)
    n = round(kw["period_s"] * 2000.0)
    assert ms.samples_per_period == n and ms.current_a.size == 3 * n == ms.time_s.size
    periods = ms.current_a.reshape(3, n)
    assert np.allclose(periods, periods[0], atol=1e-12)              # the periods repeat exactly
    spectrum = np.abs(np.fft.rfft(periods[0])) / n
    excited = np.flatnonzero(spectrum > 1e-9 * spectrum.max())
    assert np.all(excited % 2 == 1)                                    # odd lines only
    f = excited / kw["period_s"]
    assert f.min() >= 1.0 - 1e-9 and f.max() <= 75.0 + 1e-9
    assert np.allclose(f, ms.f_hz)
    assert np.isclose(np.max(np.abs(ms.current_a)), 0.5)               # the requested peak is played
    assert np.isclose(ms.crest_factor, crest(periods[0]))


def test_log_spacing_thins_the_lines_and_keeps_the_band_edges():
    dense = design_multisine(f_min_hz=1.0, f_max_hz=75.0, peak_a=1.0, period_s=5.0)
    sparse = design_multisine(f_min_hz=1.0, f_max_hz=75.0, peak_a=1.0, period_s=5.0, lines_per_decade=10.0)
    assert dense.f_hz.size == 186 and 12 <= sparse.f_hz.size <= 20
    assert sparse.f_hz[0] == 1.0 and sparse.f_hz[-1] == 75.0
    ratios = sparse.f_hz[1:] / sparse.f_hz[:-1]
    assert np.all(ratios[-5:] < 10 ** (1.5 / 10))                      # log-spaced at the top


def test_the_period_must_be_a_whole_number_of_samples():
    with pytest.raises(ParameterError, match="period_s"):
        design_multisine(f_min_hz=1.0, f_max_hz=75.0, peak_a=1.0, period_s=1.00025, sample_rate_hz=2000.0)


@pytest.mark.parametrize("kw, name", [
    (dict(f_max_hz=1000.0), "f_max_hz"),
    (dict(f_min_hz=80.0), "f_min_hz"),
    (dict(f_min_hz=10.2, f_max_hz=10.8, period_s=1.0), "period_s"),
    (dict(peak_a=math.nan), "peak_a"),
    (dict(f_min_hz=math.inf), "f_min_hz"),
    (dict(sample_rate_hz=-1.0), "sample_rate_hz"),
    (dict(periods=0), "periods"),
    (dict(phases="chirp"), "phases"),
    (dict(periods=100_000), "periods"),
])
def test_bad_arguments_are_named(kw, name):
    args = dict(f_min_hz=1.0, f_max_hz=75.0, peak_a=0.5, period_s=5.0, sample_rate_hz=2000.0) | kw
    with pytest.raises(ParameterError, match=name):
        design_multisine(**args)


def test_crest_factors_schroeder_below_random_and_optimised_at_most_schroeder():
    # 74 equal odd lines 1.5-74.5 Hz: Schroeder's crest factor for many equal lines is about 1.7
    kw = dict(f_min_hz=1.0, f_max_hz=75.0, peak_a=1.0, period_s=2.0, sample_rate_hz=2000.0)
    schroeder = design_multisine(phases="schroeder", **kw).crest_factor
    optimised = design_multisine(phases="optimised", **kw).crest_factor
    h = np.arange(3, 150, 2)
    rng = np.random.default_rng(1)
    t = np.arange(4000) / 2000.0
    random = [crest(np.cos(2 * np.pi * np.outer(t, h / 2.0) + rng.uniform(0, 2 * np.pi, h.size)).sum(axis=1))
              for _ in range(20)]
    assert 1.55 < schroeder < 1.85
    assert schroeder < np.min(random)
    assert optimised <= schroeder + 1e-12 and optimised < 1.6
    log = dict(kw, period_s=5.0, lines_per_decade=25.0)
    assert design_multisine(phases="optimised", **log).crest_factor <= design_multisine(phases="schroeder",
                                                                                         **log).crest_factor


def test_csv_round_trip(tmp_path):
    ms = design_multisine(f_min_hz=2.0, f_max_hz=40.0, peak_a=0.7, period_s=0.5, sample_rate_hz=1000.0, periods=2)
    path = tmp_path / "ms.csv"
    write_excitation_csv(ms, path)
    assert path.read_text().splitlines()[0] == "time_s,current_a"
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    assert data.shape == (1000, 2)
    assert np.allclose(data[:, 0], np.arange(1000) / 1000.0, atol=1e-9)
    assert np.allclose(data[:, 1], ms.current_a, rtol=1e-8, atol=1e-9)
    assert [p.name for p in tmp_path.iterdir()] == ["ms.csv"]          # no temporary file left


def test_predicted_multisine_variance_matches_a_monte_carlo():
    ms = design_multisine(f_min_hz=5.0, f_max_hz=200.0, peak_a=0.5, period_s=0.2, sample_rate_hz=1000.0,
                          periods=6, lines_per_decade=6.0, phases="random", seed=2)
    sigma, n, rng = 2e-3, 200, np.random.default_rng(7)
    U = np.fft.fft(ms.current_a[:n])
    k = np.flatnonzero(np.abs(U[: n // 2]) > 1e-9 * np.abs(U).max())
    g = 0.03 * np.exp(-0.5j)                      # any response: the error is linear in the noise alone
    errors = []
    for _ in range(2000):
        noise = sigma * rng.standard_normal((5, n))                    # 5 periods after the dropped one
        V = g * U[k] + np.fft.fft(noise, axis=1)[:, k]
        errors.append(np.abs(np.mean(V / U[k], axis=0) - g) ** 2)
    measured = np.mean(errors, axis=0)
    predicted = multisine_variance(ms, sigma)
    assert np.allclose(k, ms.harmonics)
    assert np.all(np.abs(measured / predicted - 1) < 0.15)            # 2000 repeats: about 2 % scatter each
    assert abs(measured.mean() / predicted.mean() - 1) < 0.05


def test_predicted_stepped_sine_variance_matches_a_monte_carlo():
    fs, f, amp, sigma, block, settle = 2000.0, 7.0, 0.5, 1e-3, 2.0, 0.5
    t = np.arange(round((block - settle) * fs)) / fs
    e = np.exp(-2j * np.pi * f * t)
    rng = np.random.default_rng(3)
    noise = sigma * rng.standard_normal((4000, t.size))
    errors = np.abs(2 / t.size * noise @ e / amp) ** 2                # lock-in phasor of the noise, over A
    predicted = stepped_sine_variance(amplitude_a=amp, block_s=block, settle_s=settle, sample_rate_hz=fs,
                                      noise_m_per_s=sigma)
    assert abs(errors.mean() / predicted - 1) < 0.06


def test_ratio_follows_energy_per_line():
    ms = design_multisine(f_min_hz=1.0, f_max_hz=75.0, peak_a=0.5, period_s=1.0, periods=250, phases="optimised")
    pred = predicted_variance(ms, noise_m_per_s=1e-3, settle_s=0.0)
    k, f, cf = pred.stepped_f_hz.size, ms.f_hz.size, ms.crest_factor
    # one period dropped of 250: the multisine's variance is 250/249 of the full-record value
    assert np.isclose(pred.ratio, 2 * k / (f * cf**2) * 249 / 250)
    assert pred.stepped_time_s == 250.0 and pred.multisine_time_s == 250.0


def test_cli_writes_the_excitation(tmp_path):
    out = tmp_path / "ms.csv"
    res = gantry("excite", "--out", out, "--form", "multisine", "--duration-s", "20", "--period-s", "2",
                 "--f-min-hz", "1.5", "--json")
    assert res.returncode == 0, res.stderr
    doc = json.loads(res.stdout)
    assert doc["form"] == "multisine"
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape == (40000, 2) and doc["samples"] == 40000 and doc["periods"] == 10
    assert np.isclose(np.max(np.abs(data[:, 1])), 0.5, rtol=1e-6)
    assert doc["ratio"] > 0 and doc["crest_factor"] >= math.sqrt(2)
    text = gantry("excite", "--out", out, "--form", "multisine", "--periods", "3", "--phases", "schroeder")
    assert text.returncode == 0, text.stderr
    assert "crest factor" in text.stdout and "ratio stepped / multisine" in text.stdout


@pytest.mark.parametrize("args, name", [
    (["--f-max-hz", "1500"], "--f-max-hz"),
    (["--duration-s", "1e9"], "--duration-s"),
    (["--periods", "100000"], "--periods"),
    (["--duration-s", "12"], "--duration-s"),
    (["--period-s", "0.00025"], "--period-s"),
    (["--amplitude-a", "nan"], "--amplitude-a"),
    (["--periods", "1"], "--periods"),
    (["--phases", "chirp"], "phases"),
    (["--form", "chirp"], "--form"),
    (["--frequencies", "0"], "--frequencies"),
    (["--block-s", "0.0001"], "--block-s"),
    (["--block-s", "0.01"], "--block-s"),
])
def test_cli_bad_arguments_exit_2_with_one_line(tmp_path, args, name):
    out = tmp_path / "ms.csv"
    res = gantry("excite", "--out", out, *args)
    assert res.returncode == 2
    assert name in res.stderr and res.stderr.count("\n") == 1 and res.stderr.startswith("gantry: error:")
    assert list(tmp_path.iterdir()) == []                              # nothing written


def test_periodic_response_on_the_played_multisine_meets_the_prediction():
    from scipy.signal import lfilter

    from plant.data.recordings import TimeRecording
    from plant.estimate.frf_estimation import periodic_response

    ms = design_multisine(f_min_hz=1.0, f_max_hz=75.0, peak_a=0.5, period_s=1.0, sample_rate_hz=2000.0,
                          periods=12, phases="optimised")
    a = np.exp(-400.0 / 20.0 / 2000.0)                # Stage X mass-damper, zero-order hold, k_t = 20 N/A
    b = 20.0 * (1 - a) / 400.0
    clean = lfilter([0.0, b], [1.0, -a], ms.current_a)
    z = np.exp(-2j * np.pi * ms.f_hz / 2000.0)
    truth = b * z / (1 - a * z)
    sigma, rng = 1e-3, np.random.default_rng(5)
    errors, reported = [], []
    for _ in range(10):
        rec = TimeRecording(ms.time_s, ms.current_a, (clean + sigma * rng.standard_normal(clean.size))[None, :],
                            "velocity", ("velocity_m_per_s",))
        m = periodic_response(rec, period_s=ms.period_s, transient_periods=1)
        assert np.allclose(m.f_hz, ms.f_hz)
        errors.append(np.abs(m.response[0] - truth) ** 2)
        reported.append(m.variance[0])
    predicted = multisine_variance(ms, sigma, transient_periods=1)
    assert abs(np.mean(errors) / predicted.mean() - 1) < 0.2           # 380 exponential errors: ~5 % scatter
    assert abs(np.mean(reported) / predicted.mean() - 1) < 0.1


@pytest.mark.parametrize(("lines_per_decade", "better"), [(25.0, "stepped_sine"), (8.0, "multisine")])
def test_the_verdict_follows_the_peak_power_each_line_gets(tmp_path, lines_per_decade, better):
    # at one peak current a multisine of N lines with crest factor c gives each line 2/(c^2 N) of the peak power
    # that each of the stepped sine's N_f frequencies gets for 1/N_f of the time: ratio ~ 2 N_f / (c^2 N)
    # (closed form; the first period dropped and the blocks' settling move it by a few per cent)
    res = gantry("excite", "--out", tmp_path / "x.csv", "--lines-per-decade", lines_per_decade, "--json")
    assert res.returncode == 0, res.stderr
    d = json.loads(res.stdout)
    n, nf, c = len(d["f_hz"]), len(d["stepped"]["f_hz"]), d["crest_factor"]
    assert d["ratio"] == pytest.approx(2 * nf / (c * c * n), rel=0.05)
    assert d["better"] == better and ("STEPPED SINE" in d["verdict"]) == (better == "stepped_sine")
    assert d["form"] == better                                         # the better one is written by default
    header = (tmp_path / "x.csv").read_text().partition("\n")[0]
    assert header == ("frequency_hz,time_s,current_a" if better == "stepped_sine" else "time_s,current_a")
    text = gantry("excite", "--out", tmp_path / "x.csv", "--lines-per-decade", lines_per_decade)
    assert d["verdict"][:60] in text.stdout


def test_the_stepped_sine_file_holds_the_thesis_blocks(tmp_path):
    # thesis section 4.1: one block per frequency, log-spaced over the band, each starting at t = 0
    stepped = design_stepped_sine(f_min_hz=1.0, f_max_hz=75.0, amplitude_a=0.5, frequencies=6, block_s=0.5,
                                  sample_rate_hz=1000.0)
    path = tmp_path / "ss.csv"
    write_stepped_sine_csv(stepped, path)
    assert path.read_text().partition("\n")[0] == "frequency_hz,time_s,current_a"
    data = np.loadtxt(path, delimiter=",", skiprows=1).reshape(6, 500, 3)
    f = np.exp(np.linspace(0.0, math.log(75.0), 6))
    t = np.arange(500) / 1000.0
    assert np.allclose(data[:, :, 0], f[:, None], rtol=1e-8)
    assert np.allclose(data[:, :, 1], t[None, :], atol=1e-9)
    assert np.allclose(data[:, :, 2], 0.5 * np.sin(2 * np.pi * f[:, None] * t[None, :]), atol=1e-8)
    assert stepped.duration_s == 3.0


def test_the_played_stepped_sine_read_back_with_a_velocity_gives_the_plant(tmp_path):
    # the written file plus a velocity column is a stepped-sine recording (docs/formats.md): the lock-in on it
    # recovers an independent zero-order-hold mass-damper (Stage X, thesis Table 4.1 scale) to the noise
    from scipy.signal import lfilter

    from design.workflows import measure

    fs, m, b, kt = 2000.0, 20.0, 400.0, 20.0
    stepped = design_stepped_sine(f_min_hz=2.0, f_max_hz=60.0, amplitude_a=0.5, frequencies=5, block_s=2.0,
                                  sample_rate_hz=fs)
    write_stepped_sine_csv(stepped, tmp_path / "ss.csv")
    data = np.loadtxt(tmp_path / "ss.csv", delimiter=",", skiprows=1).reshape(5, 4000, 3)
    a = math.exp(-b / m / fs)
    velocity = lfilter([0.0, kt * (1 - a) / b], [1.0, -a], data[:, :, 2], axis=1)      # each block from rest
    rows = np.column_stack([data.reshape(-1, 3), velocity.ravel()])
    np.savetxt(tmp_path / "rec.csv", rows, delimiter=",", fmt="%.12g",
               header="frequency_hz,time_s,current_a,velocity_m_per_s", comments="")
    measured = measure(tmp_path / "rec.csv")
    z = np.exp(-2j * np.pi * stepped.f_hz / fs)
    truth = kt * (1 - a) / b * z / (1 - a * z)
    assert np.allclose(measured.f_hz, stepped.f_hz)
    assert np.allclose(measured.response[0], truth, rtol=0.02)


@pytest.mark.parametrize(("kw", "name"), [({"amplitude_a": "0.5"}, "amplitude_a"), ({"block_s": True}, "block_s"),
                                          ({"frequencies": 2.5}, "frequencies"), ({"f_max_hz": 1500.0}, "f_max_hz"),
                                          ({"f_min_hz": float("nan")}, "f_min_hz")])
def test_stepped_sine_arguments_are_checked(kw, name):
    args = {"f_min_hz": 1.0, "f_max_hz": 75.0, "amplitude_a": 0.5, **kw}
    with pytest.raises(ParameterError, match=name):
        design_stepped_sine(**args)
