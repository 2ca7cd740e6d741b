"""plant.estimate.frf_estimation against the independent simulator ``tests/reference/independent_timesim.py``.

The truth is the simulator's own response: continuous-time C (jwI - A)^-1 B for multisines
simulated exactly in continuous time, the zero-order-hold discrete response at e^{jwT} for
held inputs and the closed loop. Statistical checks run many seeded draws:

* unbiased: per point z^2 = |mean error|^2 / (MSE / draws) has mean about 1 when the estimate is
  unbiased (each z^2 is about exponential with mean 1); its mean over the points must stay
  below ``BIAS_Z2`` and no point beyond ``MAX_Z``;
* calibrated: the mean over points of (mean reported variance / mean squared error) lies in
  0.8 .. 1.25.
"""

from __future__ import annotations

import independent_timesim as sim
import numpy as np
import pytest
from in_process import gantry

from plant.data.recordings import TimeRecording
from plant.errors import DataError
from plant.estimate.frf_estimation import (
    closed_loop_response,
    detect_period,
    estimate_frf,
    lpm_response,
    periodic_response,
)
from plant.identify.fitting import fit_plant
from plant.physics.models import Plant

FS = 1000.0
PERIOD = 1000
LINES = sim.odd_multisine_lines(200)
AXIS = sim.Axis()
CONTROLLER = sim.PI(kp=330.0, ki=330.0 * 2 * np.pi * 5, fs_hz=FS)
DRAWS = 60
BIAS_Z2 = 1.5
MAX_Z = 4.0


def _rec(r: sim.Record, kind: str = "velocity", *, reference: bool = False, source: str = "sim") -> TimeRecording:
    return TimeRecording(r.time_s, r.current_a, r.output[None], kind, ("velocity",),
                         reference=r.reference if reference else None, source=source)


def _multisine(rng, *, periods=6, noise=2e-3, output="velocity", **kw) -> sim.Record:
    return sim.multisine_record(AXIS, rng, fs_hz=FS, period_samples=PERIOD, periods=periods, lines=LINES,
                                rms_a=1.0, noise_std=noise, output=output, **kw)


def _draws(estimate, draws=DRAWS):
    """(estimates, reported variances, truth) over seeded draws; ``estimate(rng)`` -> (result, truth)."""
    g, v = [], []
    for seed in range(draws):
        result, truth = estimate(np.random.default_rng(seed))
        g.append(result.response[0])
        v.append(result.variance[0])
    return np.array(g), np.array(v), truth


def _bias_z2(g, truth):
    err = g - truth
    mse = np.mean(np.abs(err) ** 2, axis=0)
    return np.abs(err.mean(axis=0)) ** 2 / (mse / g.shape[0])


def _variance_ratio(g, v, truth):
    return float(np.mean(v.mean(axis=0) / np.mean(np.abs(g - truth) ** 2, axis=0)))


def _check_unbiased_and_calibrated(g, v, truth):
    z2 = _bias_z2(g, truth)
    assert z2.mean() < BIAS_Z2 and z2.max() < MAX_Z ** 2, (z2.mean(), z2.max())
    ratio = _variance_ratio(g, v, truth)
    assert 0.8 <= ratio <= 1.25, ratio
    return ratio


# --- the simulator itself ---------------------------------------------------------------------
def test_simulator_noise_free_estimates_match_its_truth():
    rng = np.random.default_rng(0)
    for output in ("velocity", "position"):
        m = periodic_response(_rec(_multisine(rng, noise=0.0, output=output), output), transient_periods=3)
        assert np.max(np.abs(m.response[0] / AXIS.response(m.f_hz) - 1)) < 1e-8
    t = np.arange(6 * PERIOD) / FS
    u = sim.multisine(t, FS / PERIOD, LINES, 1.0)
    m = periodic_response(_rec(sim.zoh_record(AXIS, rng, u, fs_hz=FS, noise_std=0.0)), transient_periods=3)
    assert np.max(np.abs(m.response[0] / AXIS.zoh_response(m.f_hz, FS) - 1)) < 1e-8
    assert m.f_hz.size == LINES.size and np.allclose(m.f_hz, LINES)
    flexible = sim.Axis(mode_mass_kg=10.0, mode_stiffness_n_per_m=10.0 * (2 * np.pi * 60) ** 2,
                        mode_damping_n_s_per_m=2 * 0.03 * 10.0 * 2 * np.pi * 60)
    r = sim.multisine_record(flexible, rng, fs_hz=FS, period_samples=PERIOD, periods=6, lines=LINES, rms_a=1.0,
                             noise_std=0.0)
    m = periodic_response(_rec(r), transient_periods=3)
    assert np.max(np.abs(m.response[0] / flexible.response(m.f_hz) - 1)) < 1e-8
    r = sim.zoh_record(flexible, rng, u, fs_hz=FS, noise_std=0.0)
    m = periodic_response(_rec(r), transient_periods=3)
    assert np.max(np.abs(m.response[0] / flexible.zoh_response(m.f_hz, FS) - 1)) < 1e-8


# --- periodic ---------------------------------------------------------------------------------
def test_periodic_unbiased_and_calibrated_with_coloured_and_current_noise():
    def estimate(rng):
        m = periodic_response(_rec(_multisine(rng, noise_pole=0.5, current_noise_std=0.02)))
        return m, AXIS.response(m.f_hz)

    g, v, truth = _draws(estimate)
    _check_unbiased_and_calibrated(g, v, truth)


def test_periodic_position_output_gives_velocity_response():
    def estimate(rng):
        m = periodic_response(_rec(_multisine(rng, noise=2e-6, output="position"), "position"))
        return m, AXIS.response(m.f_hz)

    g, v, truth = _draws(estimate)
    _check_unbiased_and_calibrated(g, v, truth)


def test_periodic_metadata():
    m = periodic_response(_rec(_multisine(np.random.default_rng(1), periods=5)), transient_periods=2)
    assert m.method == "periodic"
    assert m.metadata["period_s"] == pytest.approx(1.0) and m.metadata["periods"] == 3
    assert m.metadata["sample_rate_hz"] == pytest.approx(FS)
    assert np.all(m.metadata["variance_dof"] == 4.0)
    assert np.allclose(m.current_amplitude_a, np.sqrt(2.0 / LINES.size))
    assert m.response.shape == m.variance.shape == m.snr_db.shape == (1, LINES.size)
    assert m.harmonic_distortion.shape == (1, LINES.size, 2)


def test_fit_recovers_mass_and_damping_with_honest_standard_errors():
    within1 = within2 = n = 0
    start = Plant("x", mass_kg=30.0, damping_n_s_per_m=500.0)
    for seed in range(50):
        m = periodic_response(_rec(_multisine(np.random.default_rng(seed), periods=9, noise_pole=0.5)))
        fit = fit_plant(start, m, free=("mass_kg", "damping_n_s_per_m"))
        for name, true in (("mass_kg", sim.MASS_KG), ("damping_n_s_per_m", sim.DAMPING_N_S_PER_M)):
            z = abs(fit.values[name] - true) / fit.stderr[name]
            within1 += z <= 1
            within2 += z <= 2
            n += 1
    assert within1 / n >= 0.6 and within2 / n >= 0.9, (within1 / n, within2 / n)


# --- nonlinear distortion ---------------------------------------------------------------------
def _distortion_flags(draws, seed0, **kw):
    flags = []
    for seed in range(seed0, seed0 + draws):
        m = periodic_response(_rec(_multisine(np.random.default_rng(seed), **kw)))
        found = m.metadata["distortion_significant"]["velocity"]
        flags.append((found["odd"], found["even"]))
        if any(flags[-1]):
            assert any("nonlinear distortion" in note for note in m.notes)
    return np.array(flags)


def test_cubic_output_nonlinearity_shows_at_odd_lines_only():
    flags = _distortion_flags(10, 200, cubic=5000.0)
    assert flags[:, 0].all() and not flags[:, 1].any()


def test_quadratic_output_nonlinearity_shows_at_even_lines():
    flags = _distortion_flags(10, 300, quadratic=50.0)
    assert flags[:, 1].all()


def test_linear_plant_rarely_raises_a_distortion_alarm():
    flags = _distortion_flags(40, 400)
    assert flags.sum() <= 1


def test_distortion_levels_per_band():
    m = periodic_response(_rec(_multisine(np.random.default_rng(5), cubic=5000.0)))
    bands = m.metadata["distortion"]["velocity"]["odd"]
    assert bands and all(b["f_lo_hz"] <= b["f_hi_hz"] and b["lines"] >= 1 for b in bands)
    assert max(b["level_db"] for b in bands) > 20


# --- local polynomial method ------------------------------------------------------------------
def test_lpm_noise_input_unbiased_and_calibrated():
    def estimate(rng):
        u = rng.standard_normal(10_000)
        m = lpm_response(_rec(sim.zoh_record(AXIS, rng, u, fs_hz=FS, noise_std=2e-3)), f_range_hz=(0.5, 200))
        return m, AXIS.zoh_response(m.f_hz, FS)

    g, v, truth = _draws(estimate)
    _check_unbiased_and_calibrated(g, v, truth)


def test_lpm_single_chirp_unbiased_and_calibrated():
    t = np.arange(10_000) / FS
    u = sim.chirp(t, 0.2, 300.0, 1.0)

    def estimate(rng):
        m = lpm_response(_rec(sim.zoh_record(AXIS, rng, u, fs_hz=FS, noise_std=1e-3)), f_range_hz=(2, 200))
        return m, AXIS.zoh_response(m.f_hz, FS)

    g, v, truth = _draws(estimate)
    _check_unbiased_and_calibrated(g, v, truth)


def test_lpm_position_output_gives_velocity_response():
    def estimate(rng):
        u = rng.standard_normal(10_000)
        r = sim.zoh_record(AXIS, rng, u, fs_hz=FS, noise_std=1e-6, output="position")
        m = lpm_response(_rec(r, "position"), f_range_hz=(0.5, 200))
        return m, 2j * np.pi * m.f_hz * AXIS.zoh_response(m.f_hz, FS, "position")

    g, v, truth = _draws(estimate, draws=40)
    _check_unbiased_and_calibrated(g, v, truth)


def test_lpm_points_have_independent_windows_and_metadata():
    rng = np.random.default_rng(3)
    rec = _rec(sim.zoh_record(AXIS, rng, rng.standard_normal(10_000), fs_hz=FS, noise_std=2e-3))
    m = lpm_response(rec, order=2, bandwidth_lines=5, n_freq=50)
    lines = np.round(m.f_hz * rec.duration_s).astype(int)
    assert np.all(np.diff(lines) >= 11)
    assert np.all(m.metadata["variance_dof"] == 2 * (11 - 6))
    coherence = m.metadata["coherence"]
    assert coherence.shape == m.response.shape and np.all((coherence > 0) & (coherence < 1))
    assert np.all(coherence[0, :10] > 0.9) and coherence[0, -5:].mean() < coherence[0, :5].mean()


# --- closed loop ------------------------------------------------------------------------------
def _closed_loop(rng, reference, noise=2e-3):
    return sim.closed_loop_record(AXIS, CONTROLLER, rng, reference, noise_std=noise)


def test_closed_loop_periodic_reference_unbiased_and_calibrated():
    reference = 0.01 * sim.multisine(np.arange(6 * PERIOD) / FS, FS / PERIOD, LINES, 1.0)

    def estimate(rng):
        m = closed_loop_response(_rec(_closed_loop(rng, reference), reference=True))
        assert m.metadata["estimator"] == "periodic"
        return m, AXIS.zoh_response(m.f_hz, FS)

    g, v, truth = _draws(estimate)
    _check_unbiased_and_calibrated(g, v, truth)


def test_closed_loop_noise_reference_unbiased_where_naive_estimate_is_biased():
    naive = []

    def estimate(rng):
        r = _closed_loop(rng, 0.01 * rng.standard_normal(10_000))
        m = closed_loop_response(_rec(r, reference=True), f_range_hz=(0.5, 200))
        assert m.metadata["estimator"] == "lpm"
        naive.append(lpm_response(_rec(r), f_range_hz=(0.5, 200)))
        return m, AXIS.zoh_response(m.f_hz, FS)

    g, v, truth = _draws(estimate)
    _check_unbiased_and_calibrated(g, v, truth)
    g_naive = np.array([m.response[0] for m in naive])
    f = naive[0].f_hz
    truth_naive = AXIS.zoh_response(f, FS)
    assert _bias_z2(g_naive, truth_naive).mean() > 4
    # the naive (H1 / LPM on the current) limit (G S_rr - S_nn / C) / (S_rr + S_nn), S_nn / S_rr = 0.04
    rho = (2e-3 / 0.01) ** 2
    limit = (truth_naive - rho / CONTROLLER.response(f)) / (1 + rho)
    mean_naive = g_naive.mean(axis=0)
    assert np.mean(np.abs(mean_naive - limit) ** 2) < 0.25 * np.mean(np.abs(mean_naive - truth_naive) ** 2)


def test_periodic_closed_loop_ratio_of_means_equals_indirect_estimate():
    """With a periodic reference the indirect G_yr / G_ur is exactly Y_bar / U_bar of the period
    means, so the periodic estimate on the current is not biased beyond O(1 / (P SNR_u))."""
    reference = 0.01 * sim.multisine(np.arange(6 * PERIOD) / FS, FS / PERIOD, LINES, 1.0)
    r = _closed_loop(np.random.default_rng(7), reference)
    direct = periodic_response(_rec(r), period_s=1.0)
    indirect = closed_loop_response(_rec(r, reference=True))
    common, i, j = np.intersect1d(direct.f_hz, indirect.f_hz, return_indices=True)
    assert common.size >= 0.9 * LINES.size
    assert np.allclose(direct.response[:, i], indirect.response[:, j], rtol=1e-9)
    assert np.allclose(direct.variance[:, i], indirect.variance[:, j], rtol=1e-6)


def test_closed_loop_flags_a_poorly_known_reference_to_current_response():
    r = _closed_loop(np.random.default_rng(8), 0.01 * np.random.default_rng(9).standard_normal(10_000), noise=2e-2)
    m = closed_loop_response(_rec(r, reference=True))
    assert any("first-order variance of the ratio is unreliable" in note for note in m.notes)


# --- dispatch and period detection ------------------------------------------------------------
def test_estimate_frf_chooses_and_names_the_method():
    rng = np.random.default_rng(11)
    m = estimate_frf(_rec(_multisine(rng)))
    assert m.method == "periodic" and m.notes[0].startswith("method periodic: the current repeats every 1 s")
    twice = np.tile(rng.standard_normal(2500), 2)
    m = estimate_frf(_rec(sim.zoh_record(AXIS, rng, twice, fs_hz=FS, noise_std=2e-3)))
    assert m.method == "lpm" and "repeats only 2 times" in m.notes[0]
    r = sim.zoh_record(AXIS, rng, rng.standard_normal(5000), fs_hz=FS, noise_std=2e-3)
    m = estimate_frf(_rec(r), order=1)
    assert m.method == "lpm" and "not periodic" in m.notes[0] and m.metadata["order"] == 1
    reference = 0.01 * sim.multisine(np.arange(4 * PERIOD) / FS, FS / PERIOD, LINES, 1.0)
    m = estimate_frf(_rec(_closed_loop(rng, reference), reference=True))
    assert m.method == "closed-loop" and "reference" in m.notes[0]
    m = estimate_frf(_rec(r), method="lpm")
    assert m.method == "lpm" and m.notes[0] == "method lpm: requested"


def test_detect_period_of_a_repeated_chirp():
    t = np.arange(800) / FS
    one = sim.chirp(t, 2.0, 150.0, 1.0)
    noisy = np.tile(one, 5) + 0.05 * np.random.default_rng(0).standard_normal(4000)
    assert detect_period(noisy) == 800


# --- bad input --------------------------------------------------------------------------------
def _bad(r: sim.Record, **changes) -> TimeRecording:
    fields = {"time_s": r.time_s, "current_a": r.current_a, "output": r.output[None], "output_kind": "velocity",
              "output_names": ("velocity",), "source": "bad.csv", **changes}
    return TimeRecording(**fields)


@pytest.fixture(scope="module")
def record():
    return _multisine(np.random.default_rng(0), periods=4)


def test_constant_input_refused(record):
    for fn in (periodic_response, lpm_response, estimate_frf):
        with pytest.raises(DataError, match=r"bad\.csv: the input current is constant"):
            fn(_bad(record, current_a=np.full(record.time_s.size, 0.3)))


def test_too_few_samples_refused(record):
    short = {"time_s": record.time_s[:20], "current_a": record.current_a[:20], "output": record.output[None, :20]}
    for fn in (periodic_response, lpm_response):
        with pytest.raises(DataError, match=r"bad\.csv: 20 samples"):
            fn(_bad(record, **short))


def test_no_energy_in_band_refused(record):
    with pytest.raises(DataError, match=r"bad\.csv: no excited line in 300\.\.400 Hz"):
        periodic_response(_bad(record), f_range_hz=(300, 400))
    t = np.arange(8000) / FS
    r = sim.zoh_record(AXIS, np.random.default_rng(0), sim.chirp(t, 1.0, 50.0, 1.0), fs_hz=FS, noise_std=1e-3)
    with pytest.raises(DataError, match=r"bad\.csv: no input energy in 300\.\.400 Hz"):
        lpm_response(_bad(r), f_range_hz=(300, 400))


def test_lpm_refuses_a_multisine_with_gaps_between_its_lines(record):
    with pytest.raises(DataError, match=r"bad\.csv: no LPM window of 13 lines has enough lines with input energy"):
        lpm_response(_bad(record))


def test_non_uniform_sampling_refused(record):
    t = record.time_s.copy()
    t[100:] += 0.5 / FS
    for fn in (periodic_response, lpm_response):
        with pytest.raises(DataError, match=r"bad\.csv: sampling is not uniform"):
            fn(_bad(record, time_s=t))


def test_period_longer_than_half_the_record_refused(record):
    with pytest.raises(DataError, match=r"bad\.csv: period 2\.5 s is longer than half the record"):
        periodic_response(_bad(record), period_s=2.5)


def test_non_periodic_input_refused_by_the_periodic_method():
    rng = np.random.default_rng(0)
    r = sim.zoh_record(AXIS, rng, rng.standard_normal(4000), fs_hz=FS, noise_std=1e-3)
    with pytest.raises(DataError, match=r"bad\.csv: the input current is not periodic"):
        periodic_response(_bad(r))


def test_too_few_periods_after_the_transient_refused(record):
    with pytest.raises(DataError, match=r"bad\.csv: 4 whole periods .* fewer than the 2"):
        periodic_response(_bad(record), transient_periods=3)


def test_closed_loop_without_reference_refused(record):
    with pytest.raises(DataError, match=r"bad\.csv: closed-loop estimation needs the loop's reference"):
        closed_loop_response(_bad(record))
    with pytest.raises(DataError, match=r"bad\.csv: closed-loop estimation"):
        estimate_frf(_bad(record), method="closed-loop")


def test_unknown_method_refused(record):
    with pytest.raises(DataError, match=r"bad\.csv: unknown method 'h1'"):
        estimate_frf(_bad(record), method="h1")


def test_cli_fits_and_diagnoses_a_multisine_csv_through_its_frequency_response(tmp_path):
    """A time-domain CSV (time_s, current_a, velocity_m_per_s) of a multisine: ``--frf periodic``
    estimates the frequency response and the frequency-domain fit finds the simulator's mass and damping."""
    import json

    r = _multisine(np.random.default_rng(5), periods=8)
    path = tmp_path / "multisine.csv"
    np.savetxt(path, np.column_stack([r.time_s, r.current_a, r.output]), delimiter=",", fmt="%.10g",
               header="time_s,current_a,velocity_m_per_s", comments="")
    common = [str(path), "--stage", "x", "--frf", "periodic", "--set", f"force_constant_n_per_a={sim.KT_N_PER_A}",
              "--json"]
    out = gantry("fit", *common)
    assert out.returncode == 0, out.stderr
    params = json.loads(out.stdout)["parameters"]
    for name, truth in (("mass_kg", sim.MASS_KG), ("damping_n_s_per_m", sim.DAMPING_N_S_PER_M)):
        assert abs(params[name]["value"] - truth) < 4 * params[name]["stderr"], (name, params[name], truth)
    out = gantry("diagnose", *common)
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)["final_effects"] == []
    out = gantry("fit", *common, "--band-hz", "300:400")
    assert out.returncode == 2 and out.stderr.count("\n") == 1 and "no excited line in 300..400 Hz" in out.stderr


def test_data_driven_design_reads_time_domain_recordings(tmp_path):
    """``[[plant.measured]]`` entries may be multisine CSVs: their frequency responses come from the
    periodic estimator and match the simulator's truth."""
    import dataclasses

    from design.workflows import load_problem, measured_plants

    rows = []
    for m in (20.0, 40.0):
        r = sim.multisine_record(dataclasses.replace(AXIS, mass_kg=m), np.random.default_rng(int(m)), fs_hz=FS,
                                 period_samples=PERIOD, periods=6, lines=LINES, rms_a=1.0, noise_std=1e-4)
        np.savetxt(tmp_path / f"m{m:g}.csv", np.column_stack([r.time_s, r.current_a, r.output]), delimiter=",",
                   fmt="%.10g", header="time_s,current_a,velocity_m_per_s", comments="")
        rows.append(f'  {{ payload_kg = {m}, file = "m{m:g}.csv" }},')
    spec = tmp_path / "dd.toml"
    spec.write_text('[plant]\nstage = "x"\npayload_kg = { min = 20.0, max = 40.0, points = 2 }\nmeasured = [\n'
                    + "\n".join(rows) + '\n]\n[controller]\nkp = { min = 0.0, max = 10000.0 }\n'
                    'ki = { min = 0.0, max = 1.0e7 }\n')
    data = measured_plants(load_problem(spec))
    payload, w, G = data.payload_kg, data.w_rad_s, data.response
    assert list(payload) == [20.0, 40.0] and w.size == LINES.size
    for m, g in zip(payload, G):
        truth = dataclasses.replace(AXIS, mass_kg=m).response(w / (2 * np.pi))
        # noise 1e-4 m/s over 5 periods of 1000 samples, 67 lines of 0.17 A: sigma_G about 1.6e-5 m/s per A
        np.testing.assert_allclose(g, truth, rtol=0.01, atol=1e-4)
