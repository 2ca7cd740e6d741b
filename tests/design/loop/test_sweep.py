"""Robustness sweeps (``design.loop.sweep``), their fast loop analysis (``design.loop.fast``) and
``gantry sweep`` (``design.cli.sweep``)."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import control
import numpy as np
import pytest
from in_process import gantry

from design.cli import main
from design.loop.analysis import analyse_loop
from design.loop.controller import PI
from design.loop.fast import fast_analyse_loop
from design.loop.loops import closed_loop_tf, open_loop_tf
from design.loop.sweep import batch_plant, monte_carlo_sweep, percentiles_inf
from design.spec.schema import load_spec
from design.views.json import sweep_rows, sweep_to_dict
from plant import CurrentLoop, Delay, Resonance, stage_x, stage_y
from plant.errors import ParameterError, SpecError
from plant.grid import log_grid_rad_s
from plant.physics.effects import Sampling, TiltCoupling

ROOT = Path(__file__).resolve().parents[3]
THESIS_X = ROOT / "specs" / "thesis_stage_x.toml"
KP, KI = 236.0, 47.0  # thesis PI gains (Appendix A plotting code)
#: reference grid: the default analysis on 20 000 points (linear-interpolation error ~1e-7)
FINE_GRID = log_grid_rad_s(1e-3, 1e4, 20000)

# Stage X with a delay and a current loop, uncertainty as the bundled specs declare it (damping 330-550 N*s/m from
# thesis section 3.1; the other ranges are plausible choices for this benchmark-like spec)
MC_SPEC = """
name = "Stage X with delay and current loop"
[plant]
stage = "x"
force_constant_n_per_a = 20.0
damping_n_s_per_m = 440.0
payload_kg = { min = 5.0, max = 40.0, points = 8, nominal = 35.0 }
[plant.effects]
delay = { seconds = 0.0005 }
current_loop = { bandwidth_hz = 1000.0 }
[plant.uncertainty]
damping_n_s_per_m = { min = 330.0, max = 550.0 }
force_constant_n_per_a = { min = 18.0, max = 22.0 }
"delay.seconds" = { min = 0.00025, max = 0.001 }
"current_loop.bandwidth_hz" = { min = 500.0, max = 2000.0 }
[controller]
kp = 236.0
ki = 47.0
"""


def damping_spec(tmp_path: Path, lo: float, hi: float, name: str = "damping.toml") -> Path:
    """The thesis Stage X spec with damping uncertainty [lo, hi] only."""
    path = tmp_path / name
    path.write_text(THESIS_X.read_text().replace("{ min = 330.0, max = 550.0 }", f"{{ min = {lo}, max = {hi} }}"))
    return path


@pytest.fixture
def mc_spec(tmp_path):
    path = tmp_path / "mc.toml"
    path.write_text(MC_SPEC)
    return path


# --- fast loop analysis ------------------------------------------------------------------

@pytest.mark.parametrize("mass_kg", [5.0, 20.0, 40.0])
def test_fast_analysis_matches_python_control(mass_kg):
    # python-control 0.10.2 stability_margins / bandwidth (at -10 log10 2 dB = 1/sqrt 2) on the
    # rational model (Pade(6) delay: its phase error at the 400 Hz phase crossover is < 1e-9 rad)
    plant = stage_x(mass_kg=mass_kg) * CurrentLoop(1000.0) * Delay(5e-4)
    gm, pm, _, wpc, wgc, _ = control.stability_margins(open_loop_tf(plant, PI(KP, KI)))
    bw_hz = control.bandwidth(closed_loop_tf(plant, PI(KP, KI)), dbdrop=-10 * np.log10(2)) / (2 * np.pi)
    f = fast_analyse_loop(plant, PI(KP, KI))
    assert f.gain_margin_db == pytest.approx(20 * np.log10(gm), abs=1e-4)
    assert f.phase_margin_deg == pytest.approx(pm, abs=1e-4)
    assert f.phase_crossover_hz == pytest.approx(wpc / (2 * np.pi), rel=1e-5)
    assert f.gain_crossover_hz == pytest.approx(wgc / (2 * np.pi), rel=1e-5)
    assert f.closed_loop_bandwidth_hz == pytest.approx(bw_hz, rel=1e-5)


def _batches():
    rng = np.random.default_rng(11)
    n = 60
    m = rng.uniform(5, 40, (n, 1))
    return {
        "x_delay_current_loop": (stage_x() * Delay(5e-4) * CurrentLoop(1000.0)).with_values(
            {"mass_kg": m, "delay.seconds": rng.uniform(2e-4, 2e-3, (n, 1)),
             "current_loop.bandwidth_hz": rng.uniform(300, 2000, (n, 1))}),
        # lightly damped notch and peak: several gain crossovers and a narrow |T| dip
        "x_resonance": (stage_x() * Resonance(50.0, 35.0, 0.05) * Delay(5e-4)).with_values(
            {"mass_kg": m, "resonance.frequency_hz": (fr := rng.uniform(40, 80, (n, 1))),
             # notch damping 0.02-0.2; a viscous coupling damps the peak fr / fa times more
             "resonance.damping_ratio": rng.uniform(0.02, 0.2, (n, 1)) * fr / 35.0}),
        "y_tilt": (stage_y() * TiltCoupling(40.0, 2e5) * CurrentLoop(1000.0)).with_values(
            {"mass_kg": m, "tilt_coupling.frequency_hz": rng.uniform(20, 80, (n, 1))}),
        "x_sampling": (stage_x() * Sampling(2000.0)).with_values(
            {"mass_kg": m, "sampling.rate_hz": rng.uniform(500, 5000, (n, 1))}),
    }


@pytest.mark.parametrize("name", list(_batches()))
@pytest.mark.parametrize("gains", [(KP, KI), (2000.0, 20000.0)])
def test_fast_analysis_matches_fine_grid(name, gains):
    plants = _batches()[name]
    ref = analyse_loop(plants, PI(*gains), w_rad_s=FINE_GRID)
    f = fast_analyse_loop(plants, PI(*gains))
    np.testing.assert_allclose(f.closed_loop_bandwidth_hz, ref.closed_loop_bandwidth_hz, rtol=1e-4)
    np.testing.assert_allclose(f.phase_margin_deg, ref.margins.phase_margin_deg, atol=5e-3)
    np.testing.assert_allclose(f.gain_margin_db, ref.margins.gain_margin_db, atol=5e-3)


# --- sweep library -----------------------------------------------------------------------

def test_nominal_sweep_is_python_controls_margins_and_its_own_worst_case():
    """Without samples the sweep's nominal margins are python-control 0.10.2's on the thesis plant (no
    delay: a rational loop), and every distribution collapses onto the nominal value."""
    spec = load_spec(THESIS_X).problem()
    masses = np.linspace(5, 40, 6)
    r = monte_carlo_sweep(spec, payload_kg=masses)
    for k, m in enumerate(masses):
        gm, pm, *_ = control.stability_margins(open_loop_tf(spec.plant.plant().with_payload(m), PI(KP, KI)))
        assert r.nominal.phase_margin_deg[k] == pytest.approx(pm, abs=1e-3)
        assert r.nominal.gain_margin_db[k] == pytest.approx(20 * np.log10(gm) if np.isfinite(gm) else np.inf,
                                                            abs=1e-3)
    for d in r.distributions:
        assert d.samples.shape == (6, 1)
        np.testing.assert_array_equal(d.worst, getattr(r.nominal, d.name))
        for values in d.percentiles:
            np.testing.assert_array_equal(values, getattr(r.nominal, d.name))
    assert r.samples == 0 and "closed_loop_bandwidth_p5_hz" not in sweep_rows(r)[0]


def test_percentiles_bracket_nominal_and_worst_is_minimum(mc_spec):
    r = monte_carlo_sweep(load_spec(mc_spec).problem(), payload_kg=np.linspace(5, 40, 8), samples=300, seed=4)
    for d in r.distributions:
        p5, p50, p95 = d.percentiles
        nominal = getattr(r.nominal, d.name)
        assert np.all(p5 <= nominal) and np.all(nominal <= p95)
        assert np.all(p5 <= p50) and np.all(p50 <= p95)
        np.testing.assert_array_equal(d.worst, d.samples.min(axis=1))
        assert np.all(d.worst <= p5)
    # the overall worst sample, recomputed independently on the default grid
    spec = load_spec(mc_spec).problem()
    for name, w in r.worst_case().items():
        assert w.value == getattr(r, name).samples.min()
        plant = spec.plant.plant(w.payload_kg).with_values(w.parameters)
        a = analyse_loop(plant, PI(KP, KI))
        recomputed = {"closed_loop_bandwidth_hz": a.closed_loop_bandwidth_hz,
                      "phase_margin_deg": a.margins.phase_margin_deg, "gain_margin_db": a.margins.gain_margin_db}
        assert w.value == pytest.approx(float(recomputed[name]), rel=1e-4, abs=1e-3)


def test_samples_are_uniform_over_the_ranges(mc_spec):
    r = monte_carlo_sweep(load_spec(mc_spec).problem(), payload_kg=[20.0], samples=4000, seed=2)
    for name, (lo, hi) in r.uncertainty.items():
        x = r.parameter_samples[name]
        u = (x - lo) / (hi - lo)
        assert u.min() >= 0 and u.max() <= 1
        # uniform on [0, 1]: mean 1/2 (sd 0.0046 for 4000 samples), variance 1/12
        assert u.mean() == pytest.approx(0.5, abs=0.02)
        assert u.var() == pytest.approx(1 / 12, rel=0.05)


def test_more_damping_uncertainty_widens_the_spread(tmp_path):
    masses = np.linspace(5, 40, 8)
    narrow = monte_carlo_sweep(load_spec(damping_spec(tmp_path, 420.0, 460.0)).problem(), payload_kg=masses,
                               samples=200)
    wide = monte_carlo_sweep(load_spec(damping_spec(tmp_path, 330.0, 550.0, "wide.toml")).problem(), payload_kg=masses,
                             samples=200)
    for q in ("closed_loop_bandwidth_hz", "phase_margin_deg"):
        spread_narrow = np.diff(getattr(narrow, q).percentiles[[0, -1]], axis=0)[0]
        spread_wide = np.diff(getattr(wide, q).percentiles[[0, -1]], axis=0)[0]
        assert np.all(spread_wide > 2 * spread_narrow)


def test_bandwidth_falls_with_payload():
    # thesis Figure 4.31: the bandwidth decreases with payload (5-40 kg), for every sample
    r = monte_carlo_sweep(load_spec(THESIS_X).problem(), payload_kg=np.linspace(5, 40, 36), samples=200)
    bw = r.closed_loop_bandwidth_hz
    assert np.all(np.diff(bw.samples, axis=0) < 0)
    assert np.all(np.diff(bw.percentiles, axis=1) < 0) and np.all(np.diff(bw.worst) < 0)


def test_seed_reproducible_and_recorded(mc_spec):
    spec = load_spec(mc_spec).problem()
    a = monte_carlo_sweep(spec, payload_kg=[5.0, 40.0], samples=50, seed=7)
    b = monte_carlo_sweep(spec, payload_kg=[5.0, 40.0], samples=50, seed=7)
    c = monte_carlo_sweep(spec, payload_kg=[5.0, 40.0], samples=50, seed=8)
    for name in a.parameter_samples:
        np.testing.assert_array_equal(a.parameter_samples[name], b.parameter_samples[name])
        assert not np.array_equal(a.parameter_samples[name], c.parameter_samples[name])
    np.testing.assert_array_equal(a.phase_margin_deg.samples, b.phase_margin_deg.samples)
    assert sweep_to_dict(a)["seed"] == 7 and a.seed == 7


def test_chunks_and_progress_do_not_change_the_result(mc_spec, monkeypatch, capsys):
    import design.loop.sweep as sweep_module

    spec = load_spec(mc_spec).problem()
    calls = []
    whole = monte_carlo_sweep(spec, payload_kg=[5.0, 20.0, 40.0], samples=100, seed=1)
    monkeypatch.setattr(sweep_module, "CHUNK_PLANTS", 64)
    chunked = monte_carlo_sweep(spec, payload_kg=[5.0, 20.0, 40.0], samples=100, seed=1,
                                progress=lambda done, total: calls.append((done, total)))
    # the refined grid of a chunk depends on its plants, so values agree to the fast path's accuracy
    np.testing.assert_allclose(chunked.gain_margin_db.samples, whole.gain_margin_db.samples, rtol=1e-5)
    np.testing.assert_allclose(chunked.closed_loop_bandwidth_hz.samples, whole.closed_loop_bandwidth_hz.samples,
                               rtol=1e-5)
    assert calls[-1] == (300, 300) and len(calls) == 5
    assert [d for d, _ in calls] == sorted(d for d, _ in calls)
    assert capsys.readouterr() == ("", "")  # the library never prints


def test_batch_plant_order():
    plant = stage_x() * Delay(1e-3)
    b = batch_plant(plant, [5.0, 10.0], {"delay.seconds": np.array([1e-3, 2e-3, 3e-3])}, rows=[1, 3, 5])
    # payload-major: row r is payload r // 3 with sample r % 3
    np.testing.assert_array_equal(b.mass_kg[:, 0], [5.0, 10.0, 10.0])
    np.testing.assert_array_equal(b.effect("delay").seconds[:, 0], [2e-3, 1e-3, 3e-3])


@pytest.mark.parametrize("uncertainty, message", [
    ({"delay.second": (1e-4, 1e-3)}, "plant.uncertainty.delay.second"),
    ({"resonance.frequency_hz": (10, 20)}, "plant.uncertainty.resonance.frequency_hz"),
    ({"mass_kg": (5, 10)}, "plant.uncertainty.mass_kg"),
    ({"damping_n_s_per_m": (-5, 10)}, "plant.uncertainty.damping_n_s_per_m"),
])
def test_bad_uncertainty_names_the_key(uncertainty, message):
    with pytest.raises(SpecError, match=message):
        monte_carlo_sweep(stage_x() * Delay(5e-4), payload_kg=[10.0], controller=PI(KP, KI), samples=10,
                          uncertainty=uncertainty)


def test_bad_arguments():
    plant = stage_x()
    with pytest.raises(ParameterError):
        monte_carlo_sweep(plant, payload_kg=[10.0], controller=PI(KP, KI), samples=-1)
    with pytest.raises(ParameterError):
        monte_carlo_sweep(plant, payload_kg=[0.0], controller=PI(KP, KI))
    with pytest.raises(ParameterError):
        monte_carlo_sweep(plant, payload_kg=[10.0])  # no gains for a bare Plant
    with pytest.raises(SpecError, match="plant.uncertainty"):
        monte_carlo_sweep(plant, payload_kg=[10.0], controller=PI(KP, KI), samples=10)  # nothing to sample


def test_percentiles_inf():
    x = np.array([[3.0, 1.0, 2.0, 4.0, 10.0], [1.0, 2.0, np.inf, np.inf, 5.0]])
    q = [0, 5, 50, 95, 100]
    # finite rows: numpy's default (linear) percentiles
    np.testing.assert_allclose(percentiles_inf(x[:1], q)[:, 0], np.percentile(x[0], q))
    # with +inf (no phase crossover: infinite gain margin), sorted [1, 2, 5, inf, inf]
    np.testing.assert_array_equal(percentiles_inf(x[1:], q)[:, 0], [1.0, 1.2, 5.0, np.inf, np.inf])


# --- command line -----------------------------------------------------------------------

def run_main(monkeypatch, capsys, *args):
    monkeypatch.setattr(sys, "argv", ["gantry", *map(str, args)])
    with pytest.raises(SystemExit) as exc:
        main()
    out, err = capsys.readouterr()
    return exc.value.code, out, err


def test_cli_csv_round_trip(mc_spec, tmp_path, monkeypatch, capsys):
    out_csv = tmp_path / "sweep.csv"
    code, out, _ = run_main(monkeypatch, capsys, "sweep", mc_spec, "--payload", "5:40:6", "--samples", "40",
                            "--seed", "3", "--csv", out_csv, "--json")
    assert code in (0, None)
    doc = json.loads(out, parse_constant=lambda c: pytest.fail(f"non-strict JSON constant {c}"))
    assert doc["seed"] == 3 and doc["samples"] == 40 and doc["percentiles"] == [5.0, 50.0, 95.0]
    with out_csv.open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 6 == len(doc["payloads"])
    lib = monte_carlo_sweep(load_spec(mc_spec).problem(), payload_kg=np.linspace(5, 40, 6), samples=40, seed=3)
    for i, (row, entry) in enumerate(zip(rows, doc["payloads"])):
        assert float(row["payload_kg"]) == entry["payload_kg"]
        assert row["seed"] == "3" and row["samples"] == "40"
        for key, stat in (("closed_loop_bandwidth", "p5"), ("phase_margin", "p95"), ("gain_margin", "worst")):
            unit = {"closed_loop_bandwidth": "hz", "phase_margin": "deg", "gain_margin": "db"}[key]
            name = f"{key}_{unit}"
            value = float(row[f"{key}_{stat}_{unit}"])
            assert value == entry[name][stat]
            dist = getattr(lib, name)
            expected = dist.worst[i] if stat == "worst" else dist.percentile(float(stat[1:]))[i]
            assert value == expected
    assert not list(tmp_path.glob(".sweep.csv.*"))  # no temporary file left behind


def test_cli_json_is_strict_with_infinite_gain_margin(monkeypatch, capsys):
    # the thesis plant without effects never reaches -180 deg: infinite gain margin -> null
    code, out, _ = run_main(monkeypatch, capsys, "sweep", THESIS_X, "--payload", "5:40:3", "--samples", "5", "--json")
    assert code in (0, None)
    doc = json.loads(out, parse_constant=lambda c: pytest.fail(f"non-strict JSON constant {c}"))
    assert doc["payloads"][0]["gain_margin_db"]["worst"] is None
    assert doc["worst_case"]["closed_loop_bandwidth_hz"]["payload_kg"] == 40.0


def test_cli_table_is_thinned(mc_spec, monkeypatch, capsys):
    code, out, _ = run_main(monkeypatch, capsys, "sweep", mc_spec, "--samples", "20")
    assert code in (0, None)
    assert "15 of 71 payloads shown" in out and "Worst case" in out
    code, out, _ = run_main(monkeypatch, capsys, "sweep", THESIS_X, "--payload", "5:40:8")
    assert "nominal payload sweep" in out and "shown" not in out


@pytest.mark.parametrize("payload", ["5:40", "40:5:10", "a:b:3", "5:40:1", "0:40:5", "5:40:0", "5:40:2.5", "nan"])
def test_cli_bad_payload(payload, monkeypatch, capsys):
    code, out, err = run_main(monkeypatch, capsys, "sweep", THESIS_X, "--payload", payload)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("gantry: error: --payload")


def test_cli_bad_uncertainty_key_exits_2_with_one_line(tmp_path):
    spec = tmp_path / "bad.toml"
    spec.write_text(MC_SPEC.replace('"delay.seconds"', '"delay.second"'))
    proc = subprocess.run([str(Path(sys.executable).with_name("gantry")), "sweep", str(spec), "--samples", "10"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1
    assert "plant.uncertainty.delay.second" in proc.stderr and str(spec) in proc.stderr


def _gantry_json(*args):
    out = gantry(*map(str, args))
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def test_sweep_flags_the_requirements_the_swept_gains_violate_and_sweeps_a_synthesised_design(tmp_path):
    spec = ROOT / "specs" / "stage_x_synth.toml"
    thesis = _gantry_json("sweep", spec, "--samples", "200", "--payload", "5:40:8", "--json")
    assert (thesis["kp"], thesis["ki"]) == (236.0, 47.0) and thesis["gains_source"] == "the spec's controller values"
    worst_gm = min(p["gain_margin_db"]["worst"] for p in thesis["payloads"])
    assert worst_gm < 6.0 and not thesis["meets_requirements"]
    assert any(v.startswith(f"gain margin {worst_gm:.1f} dB < 6 at ") for v in thesis["violations"])
    design = tmp_path / "design.json"
    design.write_text(json.dumps(_gantry_json("synth", spec, "--json")))
    gains = json.loads(design.read_text())["gains"]
    swept = _gantry_json("sweep", spec, "--samples", "200", "--payload", "5:40:8", "--design", design, "--json")
    assert (swept["kp"], swept["ki"]) == (gains["kp"], gains["ki"]) and str(design) in swept["gains_source"]
    assert swept["meets_requirements"] and swept["violations"] == []
    assert min(p["phase_margin_deg"]["worst"] for p in swept["payloads"]) >= 45.0 - 0.05
