"""Diagnosis on data with a hidden effect, using the project's own seeded simulator (the independent
one is in test_diagnosis_independent.py and benchmarks/bench_diagnosis.py).

Hidden-effect parameters: delay 0.3-3 ms, current-loop
bandwidth 30-150 Hz, resonance 30-70 Hz with damping ratio 0.02-0.1, Coulomb friction 10-40 %
of the excitation force, mass 25-50 kg, noise 1-5 %. The truth comes from the draw, never
from the code under test.
"""

import json
from dataclasses import replace

import numpy as np
import pytest
from in_process import gantry

from plant import (
    CoulombFriction,
    CurrentLoop,
    Delay,
    Resonance,
    TiltCoupling,
    stage_x,
    stage_y,
)
from plant.data.frequency_response import MeasuredResponse
from plant.data.writers import write_recording_csv
from plant.diagnose.diagnosis import _ranked, detect_nonlinearity, diagnose
from plant.errors import DataError
from plant.estimate.lockin import amplitude_dependence, estimate_response
from plant.experiment.simulate import simulate_stepped_sine
from plant.physics.effects import EFFECTS

F_HZ = np.geomspace(1, 75, 30)       # thesis section 4.1: 1-75 Hz
AMPLITUDE_A = 0.5                    # thesis section 4.1: 0.5 A on Stage X
FORCE_N = 20.0 * AMPLITUDE_A         # K_t = 20 N/A (thesis section 3.1)


def draw(kind: str, rng):
    mass = rng.uniform(25, 50)
    noise = rng.uniform(0.01, 0.05)
    plant = stage_x(mass_kg=mass, excitation_current_a=AMPLITUDE_A)
    hidden = {
        "delay": lambda: Delay(rng.uniform(0.3e-3, 3e-3)),
        "current_loop": lambda: CurrentLoop(rng.uniform(30, 150)),
        "resonance": lambda: (lambda fr: Resonance(fr, fr * rng.uniform(0.5, 0.85), rng.uniform(0.02, 0.1)))(
            rng.uniform(30, 70)),
        "coulomb_friction": lambda: CoulombFriction(rng.uniform(0.1, 0.4) * FORCE_N),
        "none": lambda: None,
    }[kind]()
    return (plant * hidden if hidden else plant), hidden, noise


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["delay", "current_loop", "resonance", "coulomb_friction", "none"])
def test_hidden_effect_hit_rate(kind):
    rng = np.random.default_rng({"delay": 11, "current_loop": 12, "resonance": 13, "coulomb_friction": 14,
                                 "none": 15}[kind])
    good = 0
    failures = []
    for i in range(10):
        truth, hidden, noise = draw(kind, rng)
        rec = simulate_stepped_sine(truth, f_hz=F_HZ, current_amplitude_a=AMPLITUDE_A, noise_fraction=noise, seed=i)
        diag = diagnose(stage_x(), estimate_response(rec))
        named = diag.added == (() if hidden is None else (kind,))
        param_ok = True
        if hidden is not None and named:
            key = f"{kind}.{EFFECTS[kind].main_parameter}"
            true = getattr(hidden, key.split(".")[1])
            param_ok = abs(diag.final.values[key] / true - 1) < 0.15
        ok = named and param_ok and diag.final.reduced_chi2 < 2
        good += ok
        if not ok:
            failures.append((i, diag.added, diag.final.reduced_chi2))
    assert good >= 9, f"{kind}: {good}/10 correct; failures {failures}"


def test_parsimony_only_mass_wrong():
    # true mass 43 kg instead of the thesis's 35 (parsimony): refit explains it, no effect added
    rec = simulate_stepped_sine(stage_x(mass_kg=43.0), f_hz=F_HZ, current_amplitude_a=AMPLITUDE_A,
                                noise_fraction=0.02, seed=3)
    diag = diagnose(stage_x(), estimate_response(rec))
    assert diag.added == ()
    assert diag.final.values["mass_kg"] == pytest.approx(43.0, rel=0.01)
    assert diag.verdict == "explained" and len(diag.steps) == 1
    assert all(c.delta_bic < 10 for c in diag.steps[0].ranking if not c.skipped)


def test_stage_y_off_centre_load_shows_tilt_coupling():
    # Xie & Wang (thesis Eq. 2.14-2.15): off-centre load (l1 = 0.25 m of L = 0.8 m) and finite K_a
    truth = stage_y(mass_kg=40.0, load_position_m=0.25) * TiltCoupling(45.0, 2.0e4)
    rec = simulate_stepped_sine(truth, f_hz=F_HZ, current_amplitude_a=1.75, noise_fraction=0.02, seed=5)
    diag = diagnose(stage_y(load_position_m=0.25), estimate_response(rec))
    assert diag.added == ("tilt_coupling",)
    assert diag.final.values["tilt_coupling.frequency_hz"] == pytest.approx(45.0, rel=0.05)
    assert diag.final.reduced_chi2 < 2


def test_friction_shows_as_nonlinearity_and_amplitude_dependence():
    truth = stage_x(mass_kg=35.0, excitation_current_a=AMPLITUDE_A) * CoulombFriction(2.5)
    low = estimate_response(simulate_stepped_sine(truth, f_hz=F_HZ[::3], current_amplitude_a=0.5,
                                                  noise_fraction=0.02, seed=1))
    high = estimate_response(simulate_stepped_sine(truth, f_hz=F_HZ[::3], current_amplitude_a=1.0,
                                                   noise_fraction=0.02, seed=2))
    dep = amplitude_dependence([low, high])
    assert dep.significant
    # friction matters less at the larger amplitude: |G| rises with amplitude at low frequency
    assert dep.relative_magnitude_change[0, 0, 0] > 0.05
    diag = diagnose(stage_x(), low, amplitude_dependent=dep.significant)
    assert diag.nonlinearity.detected
    assert "coulomb_friction" in diag.added


def test_linear_data_is_not_called_nonlinear():
    rec = simulate_stepped_sine(stage_x() * Delay(0.001), f_hz=F_HZ[::3], current_amplitude_a=AMPLITUDE_A,
                                noise_fraction=0.05, seed=4)
    diag = diagnose(stage_x(), estimate_response(rec))
    assert not diag.nonlinearity.detected
    assert next(c for c in diag.steps[0].ranking if c.effect == "coulomb_friction").skipped


def test_one_frequency_is_explained_not_guessed():
    rec = simulate_stepped_sine(stage_x() * Delay(0.001), f_hz=[10.0], current_amplitude_a=AMPLITUDE_A,
                                noise_fraction=0.02, seed=0)
    with pytest.raises(DataError, match="1 frequency give 2 real values.*exactly determine"):
        diagnose(stage_x(), estimate_response(rec))


def test_too_few_frequencies_for_a_candidate_are_reported():
    # 2 frequencies = 4 real values: mass + damping + delay fit (1 dof), the 3-parameter
    # resonance cannot be identified and must be reported as such
    rec = simulate_stepped_sine(stage_x() * Delay(0.002), f_hz=[5.0, 40.0], current_amplitude_a=AMPLITUDE_A,
                                noise_fraction=0.02, seed=0)
    diag = diagnose(stage_x(), estimate_response(rec))
    resonance = next(c for c in diag.steps[0].ranking if c.effect == "resonance")
    assert "not identifiable" in resonance.skipped


def test_cli_names_a_hidden_delay_and_shows_the_error_falling(tmp_path):
    truth = stage_x(mass_kg=40.0) * Delay(0.0012)
    rec = simulate_stepped_sine(truth, f_hz=F_HZ, current_amplitude_a=AMPLITUDE_A, noise_fraction=0.02, seed=8)
    write_recording_csv(rec, tmp_path / "rec.csv")
    out = gantry("diagnose", str(tmp_path / "rec.csv"), "--stage", "x", "--json", "--report", str(tmp_path / "d.html"))
    assert out.returncode == 0, out.stderr
    res = json.loads(out.stdout)
    assert res["final_effects"] == ["delay"]
    assert res["ranking"][0]["effect"] == "delay"
    assert res["parameters"]["delay.seconds"]["value"] == pytest.approx(0.0012, rel=0.15)
    chi = [s["reduced_chi2"] for s in res["steps"]]
    assert chi[0] > 100 * chi[-1] and chi[-1] < 2
    assert res["failing_bands"] and not res["nonlinearity"]["detected"]
    html = (tmp_path / "d.html").read_text()
    assert html.count("<svg") >= 3 and "http" not in html.split("<svg")[0]


def test_cli_bad_input_exits_2_with_one_line(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("frequency_hz,time_s,current_a,velocity_m_per_s\n1,0,0.1,0.2\n1,0.001,abc,0.1\n")
    out = gantry("diagnose", str(bad), "--stage", "x")
    assert out.returncode == 2
    assert out.stderr.strip().count("\n") == 0 and "row 3" in out.stderr and "current_a" in out.stderr


def test_nan_harmonics_never_switch_off_nonlinearity_detection():
    # a harmonic at or above 0.45 x the sample rate is NaN (not measurable); a clear 3rd harmonic
    # elsewhere must still be detected, and a recording with no measurable harmonic is not called nonlinear
    f = np.geomspace(1, 75, 10)
    g = (stage_x().frd(2 * np.pi * f))[None]
    hd = np.zeros((1, f.size, 2))
    hd[0, 2, 1] = 0.05                     # 5 % third harmonic at the third frequency
    hd[0, -3:, :] = np.nan                 # the top harmonics not measurable
    data = MeasuredResponse(f, g, (1e-3 * np.abs(g)) ** 2, ("velocity",), np.full(f.size, 0.5), np.zeros((1, f.size)),
                            hd)
    nl = detect_nonlinearity(data)
    assert nl.detected and nl.max_third_harmonic_f_hz == pytest.approx(f[2])
    none = detect_nonlinearity(replace(data, harmonic_distortion=np.full_like(hd, np.nan)))
    assert not none.detected and "no harmonic was measurable" in none.description


def test_a_model_that_holds_the_stage_still_is_compared_without_a_ratio():
    # a friction model the drive cannot overcome at the top frequencies predicts no motion there: G / M has no
    # value, the band means leave those points out, and the chi^2 still counts them (no warning: they are errors)
    from plant.identify.residuals import residual_summary

    g = stage_x().frd(2 * np.pi * F_HZ)[None]
    model = g.copy()
    model[0, -4:] = 0.0
    res = residual_summary(F_HZ, g, (0.01 * np.abs(g)) ** 2, model)
    assert np.isnan(res.magnitude_error_db[0, -4:]).all() and np.isnan(res.phase_error_deg[0, -4:]).all()
    assert np.allclose(res.magnitude_error_db[0, :-4], 0.0) and np.allclose(res.phase_error_deg[0, :-4], 0.0)
    assert all(np.isfinite(b.magnitude_error_db) and np.isfinite(b.phase_error_deg) for b in res.bands)
    assert res.bands[-1].reduced_chi2 > 1e3 and res.failing == (res.bands[-1],)


def test_models_whose_bic_agree_to_the_last_bits_are_listed_in_name_order():
    # delay + one vanishing lag: three fits of the same model, apart only in the optimiser's last bits
    bic = {("delay", "sensor_filter"): 3.1780538283, ("delay", "sampling"): 3.1780538286,
           ("delay", "current_loop"): 3.1780538296, ("delay",): 0.0, ("delay", "resonance"): 3.1790}
    assert _ranked(bic) == [("delay",), ("delay", "current_loop"), ("delay", "sampling"), ("delay", "sensor_filter"),
                            ("delay", "resonance")]
