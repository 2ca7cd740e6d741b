"""Thesis plants, gantry models, motor and effects against closed forms and the thesis."""

import math

import control
import numpy as np
import pytest

from plant import (CoulombFriction, CurrentLoop, Delay, Plant, Resonance, Sampling, TiltCoupling, make_effect,
                   stage_x, stage_y)
from plant.errors import EffectError, GridError, ParameterError
from plant.gantry_models import qin_linearised_ss, thesis_state_space, xie_wang_frd, xie_wang_ss
from plant.motor import current_loop_bandwidth_hz, thrust_constant_n_per_a

W = np.geomspace(0.1, 5000.0, 300)
S = 1j * W
# thesis section 3.1 / Appendix A values
KT, B, M, L_M, L_POS = 20.0, 440.0, 35.0, 0.8, 0.4


def test_stage_x_is_eq_3_15():
    assert np.allclose(stage_x().frd(W), KT / (B + M * S), rtol=1e-13)


def test_stage_y_is_eq_3_16():
    assert np.allclose(stage_y().frd(W), KT * L_M / (2 * M * L_POS * S + 2 * B * L_M), rtol=1e-13)
    off = stage_y(load_position_m=0.3)   # Eq. 3.16 keeps l as a parameter
    assert np.allclose(off.frd(W), KT * L_M / (2 * M * 0.3 * S + 2 * B * L_M), rtol=1e-13)


def test_appendix_a_state_space_gives_figure_a1():
    ss = thesis_state_space(mass_kg=M, damping_n_s_per_m=B, force_constant_n_per_a=KT, motor_length_m=L_M,
                            load_position_m=L_POS)
    h = ss(S)                                 # (3, 3, n)
    px = KT / (B + M * S)
    py = KT * L_M / (2 * B * L_M + 2 * M * S * L_POS)
    fig_a1 = np.array([[px, 0 * px, 0 * px], [0 * px, py, py], [0 * px, py, py]])
    assert np.allclose(h, fig_a1, rtol=1e-10, atol=1e-14)


def test_plant_batches_and_python_control():
    batch = stage_x().with_payload(np.linspace(5, 40, 200))
    assert batch.frd(W).shape == (200, W.size)
    p = stage_x() * Delay(0.0005) * CurrentLoop(300.0) * Resonance(80.0, 50.0, 0.05)
    tf = p.to_control(pade_order=8)
    low = W < 300
    assert np.allclose(tf(S[low]), p.frd(W[low]), rtol=1e-6)
    frd = p.to_frd_data(W)
    assert isinstance(frd, control.FrequencyResponseData)


def test_xie_wang_state_space_and_frd_agree():
    kw = dict(mass_kg=30.0, inertia_kg_m2=2.0, damping1_n_s_per_m=400.0, damping2_n_s_per_m=500.0, l1_m=0.3, l2_m=0.5,
              joint_stiffness_n_m_per_rad=3e4)
    h = xie_wang_frd(W, **kw)
    assert np.allclose(xie_wang_ss(**kw)(S), h, rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("ka", [np.inf, 1e12])
def test_xie_wang_reduces_to_thesis_stage_y(ka):
    # l1 = l2 = L/2 and K_a -> infinity: y1 = y2 = (f1 + f2)/(M s + 2b); with f = K_t i/2 each
    # this is thesis Eq. 3.16 (l = L/2)
    h = xie_wang_frd(W, mass_kg=M, inertia_kg_m2=1.0, damping1_n_s_per_m=B, damping2_n_s_per_m=B, l1_m=0.4, l2_m=0.4,
                     joint_stiffness_n_m_per_rad=ka)
    v = (h[:, 0] + h[:, 1]) * KT / 2
    eq_3_16 = KT * L_M / (2 * M * L_POS * S + 2 * B * L_M)
    assert np.allclose(v[0], eq_3_16, rtol=1e-6) and np.allclose(v[1], eq_3_16, rtol=1e-6)


def test_off_centre_load_makes_the_rails_disagree_near_the_tilt_mode():
    p = stage_y(load_position_m=0.25) * TiltCoupling(40.0, 2e4)
    g = p.frd_outputs(W)
    near = (W > 2 * np.pi * 30) & (W < 2 * np.pi * 50)
    low = W < 2 * np.pi * 0.5
    rel = np.abs(g[0] - g[1]) / np.abs(g.mean(axis=0))
    assert rel[near].max() > 0.3 and rel[low].max() < 0.01
    centred = stage_y() * TiltCoupling(40.0, 2e4)
    assert np.allclose(centred.frd_outputs(W)[0], centred.frd_outputs(W)[1], rtol=1e-9)


def test_qin_linearised_closed_forms():
    m, J, l = 20.0, 1.5, 0.8
    h = qin_linearised_ss(mass_kg=m, inertia_kg_m2=J, beam_length_m=l)(S)
    # thesis Eq. 2.11-2.13 at delta = 0: x'' = (f1 + f2)/m, y'' = f_x/m, delta'' = (f2 - f1) l/(2J)
    assert np.allclose(h[0, 0], 1 / (m * S)) and np.allclose(h[0, 1], 1 / (m * S))
    assert np.allclose(h[1, 2], 1 / (m * S))
    assert np.allclose(h[2, 0], -l / (2 * J * S)) and np.allclose(h[2, 1], l / (2 * J * S))


def test_thrust_constant_eq_2_27():
    assert thrust_constant_n_per_a(pole_pitch_m=0.03, pole_number=4, magnet_flux_wb=0.05) == pytest.approx(
        1.5 * math.pi / 0.03 * 4 * 0.05)


def test_current_loop_from_motor_pole_zero_cancellation():
    # ki/kp = R/L cancels the winding pole: closed loop kp/(L s + kp), bandwidth kp/(2 pi L)
    R, Lh, kp = 2.0, 5e-3, 30.0
    bw = current_loop_bandwidth_hz(resistance_ohm=R, inductance_h=Lh, kp_v_per_a=kp, ki_v_per_a_s=kp * R / Lh)
    assert bw == pytest.approx(kp / (2 * math.pi * Lh), rel=1e-6)
    assert CurrentLoop.from_motor(resistance_ohm=R, inductance_h=Lh, kp_v_per_a=kp,
                                  ki_v_per_a_s=kp * R / Lh).bandwidth_hz == pytest.approx(bw)


def test_series_effects_closed_forms():
    assert np.allclose(Delay(0.002).frd(W), np.exp(-S * 0.002))
    assert np.allclose(CurrentLoop(150.0).frd(W), 1 / (1 + S / (2 * np.pi * 150.0)))
    T = 1 / 4000.0
    assert np.allclose(Sampling(4000.0).frd(W), (1 - np.exp(-S * T)) / (S * T) * np.exp(-S * T))
    m1, m2, k = 10.0, 25.0, 2e6
    r = Resonance.from_two_mass(motor_mass_kg=m1, load_mass_kg=m2, stiffness_n_per_m=k, damping_ratio=0.01)
    assert r.antiresonance_hz == pytest.approx(math.sqrt(k / m2) / (2 * math.pi))
    assert r.frequency_hz == pytest.approx(math.sqrt(k * (m1 + m2) / (m1 * m2)) / (2 * math.pi))
    # undamped two-mass motor-side velocity / force = (m2 s^2 + k) / (s (m1 m2 s^2 + (m1 + m2) k)): the factor
    # times the rigid-body 1/((m1 + m2) s) must equal it (damping 0 limit)
    r0 = Resonance(r.frequency_hz, r.antiresonance_hz, 1e-9)
    exact = (m2 * S**2 + k) / (S * (m1 * m2 * S**2 + (m1 + m2) * k))
    assert np.allclose(r0.frd(W) / ((m1 + m2) * S), exact, rtol=1e-6)


def test_pade_models_match_at_low_frequency():
    for e in (Delay(0.001), Sampling(2000.0)):
        low = W < 0.5 / (e.seconds if isinstance(e, Delay) else 1.5 / e.rate_hz)
        assert np.allclose(e.to_tf()(S[low]), np.exp(-S[low] * (e.seconds if isinstance(e, Delay)
                                                                 else 1.5 / e.rate_hz)), rtol=1e-6)


def test_coulomb_describing_function_solves_the_amplitude_balance():
    amp_a, fc = 0.5, 2.0
    p = stage_x(excitation_current_a=amp_a) * CoulombFriction(fc)
    g = p.frd(W)
    v = np.abs(g) * amp_a
    # closed form: |(b + j w M) V + 4 F_c / pi| = K_t I at every frequency
    assert np.allclose(np.abs((B + S * M) * v + 4 * fc / np.pi), KT * amp_a, rtol=1e-9)
    with pytest.raises(EffectError, match="no transfer function"):
        p.to_control()


@pytest.mark.parametrize("kwargs, words", [
    ({"mass_kg": -1.0}, "mass_kg must be positive"),
    ({"force_constant_n_per_a": 0.0}, "force_constant_n_per_a must be positive"),
    ({"damping_n_s_per_m": float("nan")}, "damping_n_s_per_m must be a finite number"),
])
def test_non_physical_parameters_are_named(kwargs, words):
    with pytest.raises(ParameterError, match=words):
        Plant("x", **kwargs)


def test_bad_effects_and_grids_are_named():
    with pytest.raises(EffectError, match="unknown effect 'dealy'"):
        make_effect("dealy")
    with pytest.raises(EffectError, match="delay added twice"):
        stage_x() * Delay() * Delay()
    with pytest.raises(ParameterError, match="delay.seconds must be non-negative"):
        Delay(-1e-3)
    with pytest.raises(GridError, match="non-empty"):
        stage_x().frd([])
    with pytest.raises(GridError, match="strictly increasing"):
        stage_x().frd([1.0, 3.0, 2.0])
    with pytest.raises(EffectError, match="Stage Y only"):
        stage_x() * TiltCoupling()
