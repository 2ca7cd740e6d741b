"""Admittance synthesis (issue 5): closed forms, a verified design, an explained infeasible spec."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from design.admittance import _Loops, mouse_impedance, synthesise_admittance
from design.loops import rendered_admittance_frd, virtual_admittance_frd
from design.spec import load_spec, parse_spec
from plant import stage_x

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "specs" / "stage_x_admittance.toml"
W = np.geomspace(0.5, 500, 200)


def test_ideal_velocity_loop_renders_the_virtual_admittance():
    # with a very stiff velocity loop (huge PI gains) v/F -> 1/(m_v s + b_v) (thesis Eq. 3.23, k_v = 0)
    H = rendered_admittance_frd(stage_x(), W, kp=1e7, ki=1e9, m_v=2.0, b_v=5.0)
    assert np.allclose(H, 1 / (2.0 * 1j * W + 5.0), rtol=1e-3)
    assert np.allclose(virtual_admittance_frd(W, 2.0, 5.0), 1 / (2.0 * 1j * W + 5.0))


def test_mouse_impedance_closed_form():
    # rigid neck (k_n -> inf): the clamp sees both masses, Z = (m_h + m_b) s
    z = mouse_impedance(W, np.array([[0.003, 0.03, 1e12, 0.1]]))[0]
    assert np.allclose(z, 0.033 * 1j * W, rtol=1e-6)
    # no neck (k_n, c_n -> 0): only the head, Z = m_h s
    z = mouse_impedance(W, np.array([[0.003, 0.03, 1e-12, 1e-12]]))[0]
    assert np.allclose(z, 0.003 * 1j * W, rtol=1e-6)


def test_library_rendered_admittance_matches_design_loops():
    spec = load_spec(SPEC)
    loops = _Loops(spec, 236.0, 47.0, [35.0], W)
    _, H = loops.responses(1.5, 3.0)
    ref = rendered_admittance_frd(spec.plant.plant(), W, kp=236.0, ki=47.0, m_v=1.5, b_v=3.0)
    assert np.allclose(H[0], ref, rtol=1e-12)


@pytest.fixture(scope="module")
def synth_out():
    out = subprocess.run([sys.executable, "-m", "design", "synth", str(SPEC), "--json"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def test_admittance_design_is_verified_and_meets_its_constraints(synth_out):
    adm = synth_out["admittance"]
    spec = load_spec(SPEC)
    a = spec.admittance
    assert adm["status"] == "optimal" and adm["verified"] and synth_out["verified"]
    assert synth_out["gains"]["m_v"] == adm["m_v"] and synth_out["gains"]["b_v"] == adm["b_v"]
    assert adm["peak_resistance_n"] == pytest.approx(adm["m_v"] * a.locomotion.peak_acceleration_m_per_s2
                                                     + adm["b_v"] * a.locomotion.peak_speed_m_per_s)
    # independent re-check here on 30 payloads and every mouse corner
    loops = _Loops(spec, adm["kp"], adm["ki"], np.linspace(5, 40, 30), np.geomspace(0.01, 5000, 6000))
    chk = loops.check(spec, adm["m_v"], adm["b_v"])
    assert chk.worst_phase_margin_deg >= a.phase_margin_deg - 0.2
    assert chk.peak_motor_force_n <= a.motor_peak_force_n
    assert chk.current_per_sensor_step_a <= a.current_per_sensor_step_max_a * 1.005
    # less virtual mass than found breaks a constraint (it is the least feasible)
    assert not loops.check(spec, 0.8 * adm["m_v"], adm["b_v"]).ok


def test_infeasible_admittance_names_the_binding_constraint():
    data = __import__("tomllib").loads(SPEC.read_text())
    data["admittance"]["m_v"] = {"min": 0.01, "max": 0.05}        # far too light a virtual mass
    data["admittance"]["b_v"] = {"min": 0.01, "max": 1.0}         # and too little virtual damping
    res = synthesise_admittance(parse_spec(data), kp=236.0, ki=47.0)
    assert res.status == "infeasible" and not res.verified
    assert " at " in res.message and "kg" in res.message


def test_bad_admittance_key_is_named(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(SPEC.read_text().replace("peak_speed_m_per_s = 0.5", "peak_speed = 0.5"))
    out = subprocess.run([sys.executable, "-m", "design", "synth", str(bad)], capture_output=True, text=True)
    assert out.returncode == 2 and "admittance.locomotion.peak_speed" in out.stderr
