"""Admittance synthesis: closed forms of the coupled model, the two formulations, a
verified and tight design, an explained infeasible spec, bad keys named."""

import json
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from design.admittance.model import (
    AdmittanceEvaluator,
    MouseModel,
    gantry_loop,
    interaction_gain,
    motor_force_per_newton,
    mouse_corners,
    rendered_admittance,
    sensor_current_per_newton,
    virtual_impedance_frd,
)
from design.admittance.synthesis import (
    build_rows,
    ccp_design,
    ipopt_design,
    synthesise_admittance,
)
from design.admittance.verify import coupled_polynomials, verify_admittance
from design.loop.loops import rendered_admittance_frd, virtual_admittance_frd
from design.spec.schema import load_spec, parse_spec
from design.synth.scenarios import grid, parameter_sets, uncertainty_ranges
from design.views.json import admittance_to_dict
from plant import stage_x

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "specs" / "stage_x_admittance.toml"
W = np.geomspace(0.5, 500, 200)


def _spec_with(**admittance):
    data = tomllib.loads(SPEC.read_text())
    for key, value in admittance.items():
        data["admittance"][key] = value
    return parse_spec(data).problem()


def test_ideal_velocity_loop_renders_the_virtual_admittance():
    # closed form: with a very stiff velocity loop v/F -> 1/(m_v s + b_v) (thesis Eq. 3.23, k_v = 0)
    H = rendered_admittance_frd(stage_x(), W, kp=1e7, ki=1e9, m_v=2.0, b_v=5.0)
    assert np.allclose(H, 1 / (2.0 * 1j * W + 5.0), rtol=1e-3)
    assert np.allclose(virtual_admittance_frd(W, 2.0, 5.0), 1 / (2.0 * 1j * W + 5.0))


def test_mouse_impedance_closed_forms():
    # rigid neck: the clamp sees both masses, Z = (m_h + m_b) s; no neck: the head alone, Z = m_h s
    assert np.allclose(MouseModel(0.003, 0.03, 1e12, 0.1).impedance_frd(W), 0.033 * 1j * W, rtol=1e-6)
    assert np.allclose(MouseModel(0.003, 0.03, 1e-12, 1e-12).impedance_frd(W), 0.003 * 1j * W, rtol=1e-6)
    # the polynomial form used by the verification is the same function
    mouse = MouseModel(0.003, 0.03, 100.0, 0.4)
    num, den = mouse.impedance_polys()
    s = 1j * W
    assert np.allclose(np.polyval(num, s) / np.polyval(den, s), mouse.impedance_frd(W), rtol=1e-12)


def test_rendered_admittance_matches_design_loops():
    spec = load_spec(SPEC).problem()
    loop = gantry_loop(spec, W, [35.0], kp=236.0, ki=47.0)
    ref = rendered_admittance_frd(spec.plant.plant(), W, kp=236.0, ki=47.0, m_v=1.5, b_v=3.0)
    assert np.allclose(rendered_admittance(loop, 1.5, 3.0)[0], ref, rtol=1e-12)


def test_hardware_responses_have_their_closed_forms():
    # thesis plant without electrical lags: P = K_t/(M s + b), G = 1/(M s + b)
    data = tomllib.loads(SPEC.read_text())
    data["plant"]["effects"] = {}
    data["plant"].pop("uncertainty")          # nominal parameters; its ranges name the removed effects
    bare = parse_spec(data).problem()
    kt, b, M, kp, ki = 20.0, 440.0, 35.0, 236.0, 47.0
    loop = gantry_loop(bare, W, [M], kp=kp, ki=ki)
    s = 1j * W
    P, C, G = kt / (M * s + b), kp + ki / s, 1 / (M * s + b)
    S, T, z = 1 / (1 + P * C), P * C / (1 + P * C), 1.2 * s + 3.0
    assert np.allclose(sensor_current_per_newton(loop, 1.2, 3.0)[0], C * S / z, rtol=1e-10)
    assert np.allclose(motor_force_per_newton(loop, 1.2, 3.0)[0], T * (1 / (G * z) - 1), rtol=1e-10)
    # the docstring's limits: DC current per newton b / (K_t b_v); in band (T ~ 1, M w >> b, m_v w >> b_v)
    # the motor supplies M / m_v - 1 of the sensed force and the current per newton is M / (K_t m_v)
    w0 = np.array([1e-6, 2e-6])
    dc = sensor_current_per_newton(gantry_loop(bare, w0, [M], kp=kp, ki=ki), 1.2, 3.0)[0, 0]
    assert abs(dc) == pytest.approx(b / (kt * 3.0), rel=1e-4)
    stiff = gantry_loop(bare, np.array([1000.0, 1001.0]), [M], kp=1e6, ki=0.0)
    assert abs(motor_force_per_newton(stiff, 1.2, 3.0)[0, 0]) == pytest.approx(M / 1.2 - 1, rel=0.02)
    assert abs(sensor_current_per_newton(stiff, 1.2, 3.0)[0, 0]) == pytest.approx(M / (kt * 1.2), rel=0.02)


def test_rational_interaction_loop_equals_the_grid_loop():
    # two independent paths: grid responses (K / z) and python-control polynomials (no delay: exact)
    data = tomllib.loads(SPEC.read_text())
    data["plant"]["effects"] = {"current_loop": {"bandwidth_hz": 1000.0}}
    data["plant"].pop("uncertainty")
    spec = parse_spec(data).problem()
    mouse = MouseModel(0.003, 0.025, 120.0, 0.3)
    loop = gantry_loop(spec, W, [20.0], kp=300.0, ki=3e4)
    L_grid = interaction_gain(loop, mouse)[0] / virtual_impedance_frd(W, 0.8, 2.0)
    num, den, _ = coupled_polynomials(spec.plant.plant().with_payload(20.0), mouse, kp=300.0, ki=3e4, m_v=0.8,
                                      b_v=2.0)
    s = 1j * W
    assert np.allclose(np.polyval(num, s) / np.polyval(den, s), L_grid, rtol=1e-7)


def test_ccp_and_ipopt_agree_and_keep_every_row():
    spec = load_spec(SPEC).problem()
    a = spec.admittance
    lo, hi = np.array([a.m_v.min, a.b_v.min]), np.array([a.m_v.max, a.b_v.max])
    weights = np.array([a.locomotion.peak_acceleration_m_per_s2, a.locomotion.peak_speed_m_per_s])
    rows = build_rows(spec, np.array([5.0, 40.0]), mouse_corners(spec), kp=275.0, ki=4.46e4)
    x_ccp, info = ccp_design(rows, hi, lo, hi, weights)
    x_ip = ipopt_design(rows, x_ccp, lo, hi, weights)
    assert rows.slack(*x_ccp).min() >= -1e-9 and rows.slack(*x_ip).min() >= -1e-7
    assert weights @ x_ccp < 0.05 * weights @ hi        # it moved far from the start
    assert weights @ x_ccp == pytest.approx(weights @ x_ip, rel=1e-3)
    assert info["socp_solves"] >= 2


@pytest.fixture(scope="module")
def synth_out():
    out = subprocess.run([sys.executable, "-m", "design", "synth", str(SPEC), "--json"], capture_output=True,
                         text=True)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def _check_scenarios(spec, payload_kg):
    """Payloads x the corners of the spec's uncertainty box."""
    return grid(payload_kg, parameter_sets(uncertainty_ranges(spec), draws=0))


def test_admittance_design_is_verified_and_meets_its_constraints(synth_out):
    adm = synth_out["admittance"]
    spec = load_spec(SPEC).problem()
    a = spec.admittance
    assert spec.plant.uncertainty            # the bundled spec is robust to its declared uncertainty
    assert adm["status"] == "optimal" and adm["verified"] and synth_out["verified"]
    assert synth_out["gains"]["m_v"] == adm["m_v"] and synth_out["gains"]["b_v"] == adm["b_v"]
    assert adm["kp"] == synth_out["gains"]["kp"]                  # PI gains from the PI stage
    assert adm["peak_resistance_n"] == pytest.approx(adm["m_v"] * a.locomotion.peak_acceleration_m_per_s2
                                                     + adm["b_v"] * a.locomotion.peak_speed_m_per_s)
    v = adm["verification"]
    # poles at the 8 payload points x 8 uncertainty corners designed for (and the tightest check scenarios)
    assert v["cases"] >= 64 * 16 and v["cases"] % 16 == 0
    assert v["max_closed_loop_pole_real_part"] < 0 and not v["failures"]
    assert v["python_control_min_phase_margin_deg"] >= a.phase_margin_deg - 0.1
    assert v["python_control_min_gain_margin_db"] >= a.gain_margin_db - 0.05
    assert 0 < adm["rendered_bandwidth_hz"] < 1000
    mc = adm["monte_carlo"]
    assert mc["samples"] == 10_000 and mc["violations"] == 0 and mc["rate_upper_bound_95"] < 3.1e-4
    # re-check on other payloads x the uncertainty corners and a denser grid
    ev = AdmittanceEvaluator(spec, _check_scenarios(spec, np.linspace(5, 40, 23)), np.geomspace(0.01, 5000, 6000),
                             kp=adm["kp"], ki=adm["ki"])
    chk = ev.evaluate(adm["m_v"], adm["b_v"])
    assert chk.phase_margin_deg.min() >= a.phase_margin_deg - 0.05
    assert chk.gain_margin_db.min() >= a.gain_margin_db - 0.05
    assert chk.motor_force_n.max() <= a.hardware.motor_peak_force_n
    assert chk.sensor_current_a.max() <= a.hardware.max_current_per_sensor_step_a * 1.001
    # tight: 2 % less of either virtual parameter breaks a requirement
    assert not ev.evaluate(0.98 * adm["m_v"], adm["b_v"]).meets
    assert not ev.evaluate(adm["m_v"], 0.98 * adm["b_v"]).meets


@pytest.mark.slow
def test_no_point_of_a_grid_beats_the_design(synth_out):
    # brute force (coarse): every (m_v, b_v) of a log grid that meets the requirements on the design
    # scenarios costs at least as much
    adm = synth_out["admittance"]
    spec = load_spec(SPEC).problem()
    a = spec.admittance
    ev = AdmittanceEvaluator(spec, _check_scenarios(spec, np.linspace(5, 40, 8)), np.geomspace(0.01, 5000, 1000),
                             kp=adm["kp"], ki=adm["ki"])
    best = np.inf
    for m in np.geomspace(0.1, 3.0, 14):
        for b in np.geomspace(0.5, 10.0, 14):
            if ev.evaluate(m, b, bandwidth=False).meets:
                best = min(best, m * a.locomotion.peak_acceleration_m_per_s2 + b * a.locomotion.peak_speed_m_per_s)
    assert np.isfinite(best)
    assert adm["peak_resistance_n"] <= best * 1.001


def _independent_margins(m_v, b_v, kp, ki, draw, w):
    """Interaction-loop margins (python-control FRD) and hardware peaks from closed forms written here:
    P = Kt e^{-s tau} w_c / (s + w_c) / (M s + b), G = 1 / (M s + b) (thesis Eq. 3.15 with the drive's
    delay and first-order current loop), the mouse of the model docstring."""
    import control

    M, b, tau, fc, mh, mb, k, c = draw
    s = 1j * w
    G = 1.0 / (M * s + b)
    P = 20.0 * np.exp(-s * tau) * (2 * np.pi * fc) / (s + 2 * np.pi * fc) * G
    C = kp + ki / s
    S = 1 / (1 + P * C)
    zn = c + k / s
    zm = mh * s + mb * s * zn / (mb * s + zn)
    z = m_v * s + b_v
    L = zm * P * C / (1 + P * C + G * zm) / z
    gm, pm, *_ = control.stability_margins(control.frd(L, w))
    gm_db = 20 * np.log10(gm) if np.isfinite(gm) and gm > 0 else np.inf
    return (pm if np.isfinite(pm) else np.inf, gm_db, np.max(np.abs(C * S / z)) * 0.00625,
            np.max(np.abs((1 - S) * (1 / (G * z) - 1))) * 0.3)


@pytest.mark.slow
def test_robust_admittance_holds_where_the_nominal_design_fails(synth_out):
    # independent Monte Carlo over payload x the spec's uncertainty x the mouse ranges, with the plant
    # written in closed form here; the design for the nominal parameters must fail on it (else the
    # check could not tell)
    adm = synth_out["admittance"]
    spec = load_spec(SPEC).problem()
    a = spec.admittance
    nominal = synthesise_admittance(spec, kp=adm["kp"], ki=adm["ki"], nominal=True)
    assert nominal.status == "optimal" and nominal.peak_resistance_n < adm["peak_resistance_n"]
    rng = np.random.default_rng(11)
    w = np.geomspace(0.01, 20000, 1500)
    lo = [5.0, 330.0, 3e-4, 700.0, 0.002, 0.020, 20.0, 0.2]
    hi = [40.0, 550.0, 8e-4, 1300.0, 0.004, 0.035, 200.0, 1.0]
    draws = [rng.uniform(lo, hi) for _ in range(60)]
    draws += [np.where(rng.random(8) < 0.5, lo, hi) for _ in range(30)]      # corners of the whole box
    robust_bad = nominal_bad = 0
    for d in draws:
        for x, count in ((adm, "robust"), ({"m_v": nominal.m_v, "b_v": nominal.b_v}, "nominal")):
            pm, gm, cur, force = _independent_margins(x["m_v"], x["b_v"], adm["kp"], adm["ki"], d, w)
            bad = (pm < a.phase_margin_deg - 0.2 or gm < a.gain_margin_db - 0.1
                   or cur > a.hardware.max_current_per_sensor_step_a * 1.002 or force > a.hardware.motor_peak_force_n)
            if count == "robust":
                robust_bad += bad
            else:
                nominal_bad += bad
    assert robust_bad == 0
    assert nominal_bad >= 10


def test_verification_rejects_an_unstable_design():
    spec = load_spec(SPEC).problem()
    ev = AdmittanceEvaluator(spec, np.array([5.0, 40.0]), np.geomspace(0.01, 5000, 2000), kp=275.0, ki=4.46e4)
    check = ev.evaluate(0.005, 0.01)
    assert not check.meets
    v = verify_admittance(spec, check, kp=275.0, ki=4.46e4)
    assert not v.verified and v.max_closed_loop_pole_real_part > 0
    assert any("unstable coupled loop" in f for f in v.failures)


def test_infeasible_admittance_names_the_binding_constraint_and_key():
    spec = _spec_with(m_v={"min": 0.005, "max": 0.02}, b_v={"min": 0.01, "max": 0.05})
    res = synthesise_admittance(spec, kp=275.0, ki=4.46e4)
    assert res.status == "infeasible" and not res.verified
    assert "admittance.m_v.max" in res.message and " kg" in res.message
    assert res.binding["payload_kg"] is not None and res.binding["constraint"] in (
        "phase_margin", "gain_margin", "sensor_current", "motor_force", "stability")


def test_infeasible_admittance_exits_1_with_its_reason(tmp_path):
    data = SPEC.read_text().replace("m_v = { min = 0.005, max = 100.0 }", "m_v = { min = 0.005, max = 0.02 }")
    data = data.replace("b_v = { min = 0.01, max = 500.0 }", "b_v = { min = 0.01, max = 0.05 }")
    spec = tmp_path / "tight.toml"
    spec.write_text(data)
    out = subprocess.run([sys.executable, "-m", "design", "synth", str(spec), "--json"], capture_output=True,
                         text=True)
    assert out.returncode == 1
    doc = json.loads(out.stdout)
    assert doc["status"] == "infeasible" and doc["admittance"]["status"] == "infeasible"
    assert doc["gains"]["m_v"] is None and not doc["verified"]


def test_single_numbers_give_one_mouse_corner_each():
    spec = _spec_with(mouse={"head_mass_kg": 0.003, "body_mass_kg": 0.03, "neck_stiffness_n_per_m": 100.0,
                             "neck_damping_n_s_per_m": {"min": 0.2, "max": 1.0}})
    assert len(mouse_corners(spec)) == 2


@pytest.mark.parametrize("old, new, key", [
    ("peak_speed_m_per_s = 0.5", "peak_speed = 0.5", "admittance.locomotion.peak_speed"),
    ("motor_peak_force_n = 300.0", "motor_peak_force_n = -1.0", "admittance.hardware.motor_peak_force_n"),
    ("body_mass_kg = { min = 0.020, max = 0.035 }", "body_mass_kg = { min = 0.035, max = 0.020 }",
     "admittance.mouse.body_mass_kg"),
])
def test_bad_admittance_key_is_named(tmp_path, old, new, key):
    bad = tmp_path / "bad.toml"
    text = SPEC.read_text()
    assert old in text
    bad.write_text(text.replace(old, new))
    out = subprocess.run([sys.executable, "-m", "design", "synth", str(bad)], capture_output=True, text=True)
    assert out.returncode == 2 and key in out.stderr
    assert "Traceback" not in out.stderr and len(out.stderr.strip().splitlines()) == 1


def test_admittance_with_measured_plant_is_refused_with_a_reason():
    from plant.errors import SpecError

    data = tomllib.loads(SPEC.read_text())
    data["plant"]["measured"] = [{"payload_kg": 5.0, "file": "x5.csv"}]
    with pytest.raises(SpecError, match="admittance: needs the plant model"):
        parse_spec(data, source="dd.toml")


def test_stiffest_dynamics_off_the_circle_still_get_an_exact_design():
    # bounds so tight that (m_v.max, b_v.max) passes the exact check but not the conservative margin
    # circle: neither formulation moves, the exact polish starts from the upper bounds (on the nominal
    # plant: with the spec's damping up to 550 N*s/m the sensor-step current alone needs b_v > 1.45)
    res = synthesise_admittance(_spec_with(m_v={"min": 0.005, "max": 0.43}, b_v={"min": 0.01, "max": 1.45}),
                                kp=275.0, ki=4.46e4, nominal=True)
    assert res.status == "optimal" and res.verified
    assert res.solver["best_formulation"].startswith("upper bounds")
    assert res.m_v <= 0.43 and res.b_v <= 1.45


@pytest.mark.slow
def test_admittance_report_section_with_infinite_margins():
    # a tight sensor-current limit needs a virtual mass so large that the interaction loop never
    # crosses 0 dB: the margins are infinite (None in JSON) and the report says so
    from design.admittance.curves import admittance_curves
    from design.results import DesignOutcome
    from design.views.admittance import add_admittance_section
    from design.views.html import Report

    data = tomllib.loads(SPEC.read_text())
    data["admittance"]["hardware"]["max_current_per_sensor_step_a"] = 0.01
    spec = parse_spec(data).problem()
    result = synthesise_admittance(spec, kp=275.0, ki=4.46e4)
    adm = admittance_to_dict(result, spec)
    assert adm["verified"] and adm["worst_phase_margin_deg"] is None
    assert adm["binding"]["constraint"] == "sensor_current"
    report = Report("t")
    outcome = DesignOutcome(None, admittance=result)
    add_admittance_section(report, spec, outcome,
                           admittance_curves(spec, kp=result.kp, ki=result.ki, m_v=result.m_v, b_v=result.b_v))
    html = report.render()
    assert "worst PM ∞°" in html and html.count("<svg") == 3
