"""Thesis plants, Appendix A state space, Xie-Wang and Qin gantry models, PMLSM motor.

Reference values are closed forms written out here from the thesis equations (numbers in the
comments) or python-control 0.10.2 evaluations of independent realisations.
"""

import math

import control
import numpy as np
import pytest

from plant import (
    CurrentLoop,
    Delay,
    Plant,
    Resonance,
    Sampling,
    TiltCoupling,
    stage_x,
    stage_y,
)
from plant.errors import ParameterError
from plant.physics.gantry_models import (
    qin_linearised_ss,
    thesis_state_space,
    xie_wang_frd,
    xie_wang_ss,
)
from plant.physics.models import corner_frequency_hz
from plant.physics.motor import (
    back_emf_constant_v_s_per_m,
    current_loop_bandwidth_hz,
    current_loop_tf,
    thrust_constant_n_per_a,
    winding_tf,
)

W = np.geomspace(0.05, 5000.0, 500)
S = 1j * W
# thesis section 3.1 and Appendix A: K_t = 20 N/A, b = 440 N s/m, M = 35 kg, L = 0.8 m, l = y = 0.4 m
KT, B, M, L_M, L_POS = 20.0, 440.0, 35.0, 0.8, 0.4
RNG_PARAMS = [  # (M, b, K_t, L, l): the thesis set and two others, so no coincidence (L = 2 l) hides an error
    (M, B, KT, L_M, L_POS),
    (12.0, 330.0, 17.0, 1.1, 0.3),
    (48.0, 550.0, 31.0, 0.6, 0.45),
]


# --- thesis Eq. 3.15 / 3.16 and Appendix A -------------------------------------------------------

@pytest.mark.parametrize("m, b, kt, length, pos", RNG_PARAMS)
def test_stage_x_and_y_are_eq_3_15_and_3_16(m, b, kt, length, pos):
    kw = dict(mass_kg=m, damping_n_s_per_m=b, force_constant_n_per_a=kt, motor_length_m=length,
              load_position_m=pos)
    # thesis Eq. 3.15: P_x = K_t / (b + M s)
    assert np.allclose(stage_x(**kw).frd(W), kt / (b + m * S), rtol=1e-13, atol=0)
    # thesis Eq. 3.16: P_y = K_t L / (2 M l s + 2 b L)
    eq_3_16 = kt * length / (2 * m * pos * S + 2 * b * length)
    assert np.allclose(stage_y(**kw).frd(W), eq_3_16, rtol=1e-13, atol=0)
    assert np.allclose(stage_y(**kw).frd_outputs(W), eq_3_16, rtol=1e-13, atol=0)   # both rails
    # corner b_e / (2 pi m_e): X b / (2 pi M) and Y b L / (2 pi M l) (poles of Eq. 3.15 / 3.16)
    assert corner_frequency_hz(stage_x(**kw)) == pytest.approx(b / (2 * math.pi * m), rel=1e-14)
    assert corner_frequency_hz(stage_y(**kw)) == pytest.approx(b * length / (2 * math.pi * m * pos), rel=1e-14)


def test_thesis_defaults_are_the_thesis_values():
    # section 3.1: K_t 20 N/A, b 440 (range 330-550), L 0.8 m, M 35 kg; Appendix A: y = 0.4 m
    p = stage_y()
    assert (p.force_constant_n_per_a, p.damping_n_s_per_m, p.mass_kg, p.motor_length_m, p.load_position_m) == \
        (KT, B, M, L_M, L_POS)


@pytest.mark.parametrize("m, b, kt, length, pos", RNG_PARAMS)
def test_appendix_a_state_space_transfer_matrix_is_figure_a1(m, b, kt, length, pos):
    ss = thesis_state_space(mass_kg=m, damping_n_s_per_m=b, force_constant_n_per_a=kt, motor_length_m=length,
                            load_position_m=pos)
    # thesis Figure A.1 (Mathematica output), with y the load position:
    #   [[K/(b+ms), 0, 0], [0, KL/(2bL+2msy), KL/(2bL+2msy)], [0, KL/(2bL+2msy), KL/(2bL+2msy)]]
    px = (kt / m, [1.0, b / m])                                          # monic form of K/(b+ms)
    py = (kt * length / (2 * m * pos), [1.0, b * length / (m * pos)])    # monic form of KL/(2bL+2msy)
    figure_a1 = [[px, None, None], [None, py, py], [None, py, py]]
    tf = control.ss2tf(ss)                                               # python-control 0.10.2
    for i in range(3):
        for j in range(3):
            entry = control.minreal(tf[i, j], tol=1e-8, verbose=False)   # cancel the s = 0 pole-zero pairs
            num, den = entry.num[0][0], entry.den[0][0]
            if figure_a1[i][j] is None:
                assert np.allclose(num, 0.0, atol=1e-12), (i, j)
            else:
                gain, monic = figure_a1[i][j]
                assert den[0] != 0 and np.allclose(den / den[0], monic, rtol=1e-10), (i, j)
                assert np.allclose(num / den[0], [gain], rtol=1e-10), (i, j)
    # and evaluated at s = jw (no cancellation involved)
    h = ss(S)
    gx, gy = kt / (b + m * S), kt * length / (2 * b * length + 2 * m * S * pos)
    zero = np.zeros_like(gx)
    assert np.allclose(h, np.array([[gx, zero, zero], [zero, gy, gy], [zero, gy, gy]]), rtol=1e-10, atol=1e-15)


def test_stage_y_is_the_figure_a1_response_to_the_total_current():
    # Figure A.1: v_y1 = P_y (i1 + i2); the plant's input is i = i1 + i2 (split equally)
    ss = thesis_state_space(mass_kg=M, damping_n_s_per_m=B, force_constant_n_per_a=KT, motor_length_m=L_M,
                            load_position_m=L_POS)
    h = ss(S)
    both = 0.5 * (h[1, 1] + h[1, 2])      # v_y1 for i1 = i2 = i/2
    assert np.allclose(stage_y().frd(W), both, rtol=1e-12)


# --- batches and python-control interoperability ----------------------------------------------------

def test_payload_batch_shapes_and_rows():
    payloads = np.linspace(5.0, 40.0, 200)
    plant = stage_x() * Delay(0.0005) * CurrentLoop(300.0)
    batch = plant.with_payload(payloads)
    g = batch.frd(W)
    assert g.shape == (200, W.size)
    for k in (0, 77, 199):   # each row is the plant at that payload
        assert np.array_equal(g[k], plant.with_payload(payloads[k]).frd(W))
    y = (stage_y(load_position_m=0.25) * TiltCoupling(40.0, 2e4)).with_payload(payloads)
    assert y.frd_outputs(W).shape == (200, 2, W.size) and y.frd(W).shape == (200, W.size)
    assert plant.with_payload(20.0).frd(W).shape == (W.size,)


@pytest.mark.parametrize("plant", [
    stage_x(),
    stage_y(mass_kg=20.0, load_position_m=0.3),
    stage_x() * CurrentLoop(300.0) * Resonance(80.0, 50.0, 0.05),
    stage_y(load_position_m=0.25) * TiltCoupling(40.0, 2e4) * CurrentLoop(500.0),
], ids=["x", "y-off-centre", "x-lag-resonance", "y-tilt"])
def test_to_control_equals_frd_for_rational_plants(plant):
    # no delay: the rational model is exact at every frequency (python-control 0.10.2 evaluation)
    tf = plant.to_control()
    assert isinstance(tf, control.TransferFunction)
    assert np.allclose(tf(S), plant.frd(W), rtol=1e-9, atol=0)


def test_to_control_pade_matches_frd_below_the_pade_range():
    tau, rate = 0.0005, 5000.0
    plant = stage_x() * Delay(tau) * Sampling(rate) * CurrentLoop(300.0)
    low = W * (tau + 1.5 / rate) < 1.0
    # Pade(6) of exp(-s tau) and Pade(3) of exp(-s T) (in the hold and the sample delay) are exact to ~1e-9
    # for w (tau + 1.5 T) < 1, so the rational model equals the exact response there, ZOH droop included
    tf = plant.to_control(pade_order=6)
    assert np.allclose(tf(S[low]), plant.frd(W[low]), rtol=1e-8)
    assert isinstance(plant.to_frd_data(W), control.FrequencyResponseData)
    with pytest.raises(ParameterError, match="mass_kg is a batch"):
        plant.with_payload([10.0, 20.0]).to_control()


# --- Xie & Wang heavy-load gantry (thesis Eq. 2.14-2.15) --------------------------------------------

XW = dict(mass_kg=30.0, inertia_kg_m2=2.0, damping1_n_s_per_m=400.0, damping2_n_s_per_m=500.0, l1_m=0.3,
          l2_m=0.5, joint_stiffness_n_m_per_rad=3e4)


def test_xie_wang_frd_equals_its_state_space():
    # python-control 0.10.2 evaluation of xie_wang_ss at s = jw, (2, 2, n) outputs x inputs
    assert np.allclose(xie_wang_frd(W, **XW), xie_wang_ss(**XW)(S), rtol=1e-9, atol=1e-15)


def test_xie_wang_undamped_closed_form():
    # b1 = b2 = 0: translation 1/(M s^2) and tilt 1/(J s^2 + K_a) decouple; with y1 = y_c - l1 a,
    # y2 = y_c + l2 a and the torque -f1 l1 + f2 l2 (Eq. 2.15), velocity per force is
    # s [1/(M s^2) + l_i l_j sigma_i sigma_j / (J s^2 + K_a)]  (sigma = -1 for rail 1, +1 for rail 2)
    m, J, l1, l2, ka = 30.0, 2.0, 0.3, 0.5, 3e4
    h = xie_wang_frd(W, mass_kg=m, inertia_kg_m2=J, damping1_n_s_per_m=0.0, damping2_n_s_per_m=0.0, l1_m=l1,
                     l2_m=l2, joint_stiffness_n_m_per_rad=ka)
    trans, tilt = 1 / (m * S**2), 1 / (J * S**2 + ka)
    closed = S * np.array([[trans + l1 * l1 * tilt, trans - l1 * l2 * tilt],
                           [trans - l1 * l2 * tilt, trans + l2 * l2 * tilt]])
    assert np.allclose(h, closed, rtol=1e-9)


def test_xie_wang_low_frequency_limit():
    # at DC the spring holds alpha = 0: both rails move at (f1 + f2) / (b1 + b2) (Eq. 2.14 with alpha = 0)
    h = xie_wang_frd(np.array([1e-6]), **XW)[..., 0]
    assert np.allclose(h, 1 / (400.0 + 500.0), rtol=1e-6)


@pytest.mark.parametrize("ka", [np.inf, 1e13])
def test_xie_wang_reduces_to_thesis_stage_y(ka):
    # l1 = l2 = L/2, b1 = b2 = b, K_a -> infinity, f1 = f2 = K_t i / 2:
    # y1 = y2 = K_t i / (M s + 2 b), which is thesis Eq. 3.16 with l = L/2
    h = xie_wang_frd(W, mass_kg=M, inertia_kg_m2=1.5, damping1_n_s_per_m=B, damping2_n_s_per_m=B,
                     l1_m=L_M / 2, l2_m=L_M / 2, joint_stiffness_n_m_per_rad=ka)
    rails = (h[:, 0] + h[:, 1]) * KT / 2
    eq_3_16 = KT * L_M / (2 * M * (L_M / 2) * S + 2 * B * L_M)
    assert np.allclose(rails, eq_3_16, rtol=1e-7, atol=0)


def test_xie_wang_rigid_limit_with_an_off_centre_load():
    # K_a -> infinity holds alpha = 0 wherever the load sits: y1 = y2 = (f1 + f2) / (M s + b1 + b2)
    kw = dict(XW, joint_stiffness_n_m_per_rad=np.inf)
    h = xie_wang_frd(W, **kw)
    assert np.allclose(h, 1 / (30.0 * S + 900.0), rtol=1e-12)
    big = xie_wang_frd(W, **dict(XW, joint_stiffness_n_m_per_rad=1e14))
    assert np.allclose(big, h, rtol=1e-6)


def test_centred_symmetric_load_does_not_tilt():
    # symmetry: l1 = l2 and b1 = b2, equal thrusts -> no torque, no tilt, y1 = y2 exactly for any K_a
    # (the coupling term printed by Xie & Wang, +(b1 l1 + b2 l2), would tilt it; the derived one is
    # b2 l2 - b1 l1 = 0, see plant.physics.gantry_models)
    h = xie_wang_frd(W, mass_kg=M, inertia_kg_m2=1.5, damping1_n_s_per_m=B, damping2_n_s_per_m=B,
                     l1_m=0.4, l2_m=0.4, joint_stiffness_n_m_per_rad=2e4)
    v = h[:, 0] + h[:, 1]
    assert np.allclose(v[0], v[1], rtol=1e-12)
    assert np.allclose(v[0], 2 / (M * S + 2 * B), rtol=1e-9)        # f1 + f2 = 2 N on M s + 2 b
    centred = stage_y() * TiltCoupling(40.0, 2e4)
    assert np.allclose(centred.frd(W), stage_y().frd(W), rtol=1e-9)


def test_off_centre_load_with_finite_stiffness_splits_the_rails_near_the_tilt_mode():
    f_tilt = 40.0
    p = stage_y(load_position_m=0.25) * TiltCoupling(f_tilt, 2e4)
    y1, y2 = p.frd_outputs(W)
    rel = np.abs(y1 - y2) / np.abs(0.5 * (y1 + y2))
    near = (W > 2 * math.pi * 0.7 * f_tilt) & (W < 2 * math.pi * 1.3 * f_tilt)
    low = W < 2 * math.pi * 0.5
    assert rel[near].max() > 0.3        # the tilt mode shows up as a Y1/Y2 difference ...
    assert rel[low].max() < 0.01        # ... that vanishes at low frequency, where the spring holds
    # and the rigid limit (no tilt effect) keeps the rails together at every frequency
    rigid = stage_y(load_position_m=0.25).frd_outputs(W)
    assert np.array_equal(rigid[0], rigid[1])


# --- Qin et al. (thesis Eq. 2.11-2.13) linearised about delta = 0 ------------------------------------

def test_qin_linearised_closed_forms():
    m, J, l = 20.0, 1.5, 0.8
    h = qin_linearised_ss(mass_kg=m, inertia_kg_m2=J, beam_length_m=l)(S)
    # Eq. 2.11-2.13 at delta = 0, inputs (f_y1, f_y2, f_x), velocity outputs (x', y', delta'):
    # m x'' = f_y1 + f_y2, m y'' = f_x, J delta'' = (f_y2 - f_y1) l / 2
    one, zero = 1 / (m * S), np.zeros_like(S)
    expected = np.array([[one, one, zero],
                         [zero, zero, one],
                         [-l / (2 * J * S), l / (2 * J * S), zero]])
    assert np.allclose(h, expected, rtol=1e-12, atol=1e-15)


# --- PMLSM (thesis section 2.2) -------------------------------------------------------------------

def test_thrust_constant_is_eq_2_27():
    tau, poles, flux = 0.032, 6.0, 0.041
    # Eq. 2.27: F = 3/2 pi/tau P lambda_f i_q
    assert thrust_constant_n_per_a(pole_pitch_m=tau, pole_number=poles, magnet_flux_wb=flux) == \
        pytest.approx(1.5 * math.pi / tau * poles * flux, rel=1e-15)
    # Eq. 2.23 speed term: back-EMF constant P pi / tau lambda_f = 2/3 K_t
    assert back_emf_constant_v_s_per_m(pole_pitch_m=tau, pole_number=poles, magnet_flux_wb=flux) == \
        pytest.approx(math.pi / tau * poles * flux, rel=1e-15)
    with pytest.raises(ParameterError, match="pole_pitch_m"):
        thrust_constant_n_per_a(pole_pitch_m=0.0, pole_number=poles, magnet_flux_wb=flux)


def test_winding_and_current_loop_closed_forms():
    R, Lh, kp, ki = 2.0, 5e-3, 30.0, 4e3
    # Eq. 2.23-2.24 with i_d = 0, back-EMF excluded: I / V = 1 / (L s + R)
    assert np.allclose(winding_tf(resistance_ohm=R, inductance_h=Lh)(S), 1 / (Lh * S + R), rtol=1e-12)
    # PI around the winding: (kp s + ki) / (L s^2 + (R + kp) s + ki)
    loop = current_loop_tf(resistance_ohm=R, inductance_h=Lh, kp_v_per_a=kp, ki_v_per_a_s=ki)
    assert np.allclose(loop(S), (kp * S + ki) / (Lh * S**2 + (R + kp) * S + ki), rtol=1e-10)
    # its -3 dB point: |T|^2 = 1/2 is a quadratic in x = w^2 with one positive root
    # L^2 x^2 + ((R + kp)^2 - 2 L ki - 2 kp^2) x - ki^2 = 0
    x = max(np.roots([Lh**2, (R + kp) ** 2 - 2 * Lh * ki - 2 * kp**2, -ki**2]).real)
    bw = current_loop_bandwidth_hz(resistance_ohm=R, inductance_h=Lh, kp_v_per_a=kp, ki_v_per_a_s=ki)
    assert bw == pytest.approx(math.sqrt(x) / (2 * math.pi), rel=1e-6)


def test_current_loop_bandwidth_with_pole_zero_cancellation():
    # ki / kp = R / L cancels the winding pole: closed loop kp / (L s + kp), bandwidth kp / (2 pi L)
    R, Lh, kp = 2.0, 5e-3, 30.0
    kw = dict(resistance_ohm=R, inductance_h=Lh, kp_v_per_a=kp, ki_v_per_a_s=kp * R / Lh)
    assert current_loop_bandwidth_hz(**kw) == pytest.approx(kp / (2 * math.pi * Lh), rel=1e-6)
    assert CurrentLoop.from_motor(**kw).bandwidth_hz == pytest.approx(kp / (2 * math.pi * Lh), rel=1e-6)
    with pytest.raises(ParameterError, match="inductance_h must be positive"):
        current_loop_bandwidth_hz(**dict(kw, inductance_h=-1e-3))


def test_plant_rejects_a_load_outside_the_beam():
    with pytest.raises(ParameterError, match="load_position_m"):
        Plant("y", load_position_m=0.8)
    with pytest.raises(ParameterError, match="stage must be 'x' or 'y'"):
        Plant("z")
