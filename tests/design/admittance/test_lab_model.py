"""design.admittance.lab_model against what MATLAB printed for the mouse lab's bandwidth live script.

Reference: bsbrl/exoskeleton (MIT), ``1. Exoskeleton Design Optimization/Exoskeleton - 5. Bandwidth/
Admittance3DoF_1axis_oursystemwithZps2Hzoh.mlx``. Every ``PRINTED_*`` literal below is copied from the
``matlab/output.xml`` of that .mlx (the outputs MATLAB stored with the script, one set per loop index n);
the ``A3_*`` literals from the ``output.xml`` of the sibling ``Admittance3DoF_oursystemwithZps.mlx``.

What the printout allows: the kinematic matrices and every transfer function printed as polynomials
(Y_v, C_fb_pos, C_fb_vel, Y_r, A, C, D, E) are matched to the printed 4 significant digits. F and Y_a are
printed as state-space models with internal delays, but MATLAB shows only the matrices "computed with all
internal delays set to zero" (C = 0 and D = 0 there, since every path to the output passes through a
1 - e^{-sT}) and the delay values (0.01 s), not the delay channels, so their frequency response cannot be
rebuilt from the printout. From them we check what is printed: the rational (delay-free) dynamics of the
three F branches and the modes of the zero-delay Y_a pencil. The delayed Y_a itself is checked against the
one figure stored in output.xml (MATLAB's own Bode plot of Y_a, digitised).
"""

import dataclasses
import math

import control as ct
import numpy as np
import pytest
import scipy.linalg

from design.admittance.lab_model import (
    PUBLISHED_POSITION_M,
    LabBandwidthModel,
    admittance_bandwidth_hz,
    delta_robot_matrices,
)

# ---------------------------------------------------------------------------------------------------------
# Printed in output.xml of Admittance3DoF_1axis_oursystemwithZps2Hzoh.mlx
# ---------------------------------------------------------------------------------------------------------

# variables Jinv, J, JSIM, TSIM (script lines 54, 55, 93, 95)
PRINTED_JINV = [[3.0926, 2.7153, 2.0296], [-2.1778, -2.0053, -1.1521], [-0.1398, -2.9987, -3.0677]]
PRINTED_J = [[0.8116, 0.6752, 0.2834], [-1.9621, -2.7697, -0.2579], [1.8809, 2.6766, -0.0868]]
PRINTED_JSIM = [[1.5497, -1.3140, 2.3653], [0.1554, -3.2483, 2.4017], [0.2500, -0.9736, -0.8190]]
PRINTED_TSIM = [[4.4193, 3.1465, 2.1992], [3.1465, 5.8655, 4.0622], [2.1992, 4.0622, 4.5460]]

# transfer functions, (numerator, denominator), highest power first, as printed; the same for n = 1, 2, 3
PRINTED_Y_V = ([1, 1, 0], [0.04, 0.4, 0])  # Y_v = (s^2 + s)/(0.04 s^2 + 0.4 s)
PRINTED_C_FB_POS = ([1, 1], [1, 0])  # (s + 1)/s
PRINTED_C_FB_VEL = ([50, 50], [1, 0])  # (50 s + 50)/s
PRINTED_C = ([1, 1, 0], [0.04, 0.4, 0, 0])  # C = (s^2 + s)/(0.04 s^3 + 0.4 s^2)
PRINTED_D = ([1], [1, 0])  # D = 1/s

# per axis n: Y_r, A (From input 1..3 to output), E
PRINTED_Y_R = {
    1: ([1], [4.419, 441.9]),
    2: ([1], [5.865, 586.5]),
    3: ([1], [4.546, 454.6]),
}
PRINTED_A = {
    1: ([[216.5, 216.5], [-152.4, -152.4], [-9.788, -9.788]], [4.419, 441.9, 0]),
    2: ([[190.1, 190.1], [-140.4, -140.4], [-209.9, -209.9]], [5.865, 586.5, 0]),
    3: ([[142.1, 142.1], [-80.65, -80.65], [-214.7, -214.7]], [4.546, 454.6, 0]),
}
PRINTED_E = {
    1: ([8914, 1.792e06, 9.092e07, 8.914e07, 0, 0], [86.31, 2.589e04, 2.589e06, 8.631e07, 0, 0, 0]),
    2: ([-1538, -3.092e05, -1.569e07, -1.538e07, 0, 0], [201.8, 6.054e04, 6.054e06, 2.018e08, 0, 0, 0]),
    3: ([1647, 3.311e05, 1.68e07, 1.647e07, 0, 0], [93.95, 2.818e04, 2.818e06, 9.395e07, 0, 0, 0]),
}

# F for n = 1: 12 states, "values computed with all internal delays set to zero", C = 0, D = 0,
# "Internal delays (seconds): 0.01 0.01 0.01". Nonzero entries (row, column, value), 1-based.
PRINTED_F1_A = [
    (1, 2, 8), (1, 3, 48.99), (1, 4, 48.99), (2, 3, 6.123), (2, 4, 6.123), (3, 3, -100), (4, 3, 1),
    (5, 6, 8), (5, 7, -34.5), (5, 8, -34.5), (6, 7, -4.312), (6, 8, -4.312), (7, 7, -100), (8, 7, 1),
    (9, 10, 8), (9, 11, -8.859), (9, 12, -8.859), (10, 11, -1.107), (10, 12, -1.107), (11, 11, -100), (12, 11, 1),
]  # fmt: skip
PRINTED_F1_B = [(3, 1, 8), (7, 1, 8), (11, 1, 2)]

# Y_a for n = 1: descriptor model with 53 states, C = 0, D = 0 at zero delays, ten internal delays of 0.01 s.
PRINTED_YA1_A = [
    (1, 2, 8), (1, 3, 48.99), (1, 4, 48.99), (2, 3, 6.123), (2, 4, 6.123), (3, 3, -100), (3, 13, 25),
    (3, 14, 25), (4, 3, 1), (5, 6, 8), (5, 7, -34.5), (5, 8, -34.5), (6, 7, -4.312), (6, 8, -4.312),
    (7, 7, -100), (7, 13, 25), (7, 14, 25), (8, 7, 1), (9, 10, 8), (9, 11, -8.859), (9, 12, -8.859),
    (10, 11, -1.107), (10, 12, -1.107), (11, 11, -100), (11, 13, 6.25), (11, 14, 6.25), (12, 11, 1),
    (13, 13, -10), (14, 13, 1), (15, 14, 1), (16, 53, 8), (17, 18, 8), (17, 19, 48.99), (17, 20, 48.99),
    (18, 19, 6.123), (18, 20, 6.123), (19, 19, -100), (19, 29, 25), (19, 30, 25), (20, 19, 1), (21, 22, 8),
    (21, 23, -34.5), (21, 24, -34.5), (22, 23, -4.312), (22, 24, -4.312), (23, 23, -100), (23, 29, 25),
    (23, 30, 25), (24, 23, 1), (25, 26, 8), (25, 27, -8.859), (25, 28, -8.859), (26, 27, -1.107),
    (26, 28, -1.107), (27, 27, -100), (27, 29, 6.25), (27, 30, 6.25), (28, 27, 1), (29, 29, -10),
    (29, 32, 0.64), (30, 29, 1), (31, 30, 1), (32, 32, 1), (33, 33, 1), (33, 53, -0.125), (34, 35, 8),
    (34, 36, 48.99), (34, 37, 48.99), (35, 36, 6.123), (35, 37, 6.123), (36, 36, -100), (36, 46, 8),
    (37, 36, 1), (38, 39, 8), (38, 40, -34.5), (38, 41, -34.5), (39, 40, -4.312), (39, 41, -4.312),
    (40, 40, -100), (40, 46, 8), (41, 40, 1), (42, 43, 8), (42, 44, -8.859), (42, 45, -8.859),
    (43, 44, -1.107), (43, 45, -1.107), (44, 44, -100), (44, 46, 2), (45, 44, 1), (46, 53, 1),
    (47, 47, -300), (47, 48, -234.4), (47, 49, -122.1), (47, 53, 32), (48, 47, 128), (49, 48, 64),
    (50, 49, 0.125), (51, 50, 0.25), (52, 51, 0.25), (53, 47, 3.227), (53, 48, 5.068), (53, 49, 4.018),
    (53, 50, 31.52), (53, 53, 1),
]  # fmt: skip
# its E matrix is the identity except E(32, 32) = E(33, 33) = E(53, 53) = 0 and E(32, 33) = 1
PRINTED_YA1_E_CHANGES = [(32, 32, 0), (33, 33, 0), (53, 53, 0), (32, 33, 1)]

# The one figure in output.xml: bode(Y_rp, Y_vp, Y_ap, {1e-2, 1e2}), one magnitude/phase pair per axis n.
# Digitised here: centroid of the yellow "Y apparent" pixels in a column, axes 1e-2..1e2 rad/s over pixel
# columns 85..506; one pixel is about 1.9 dB and 6.9 deg. Points where another curve, a tick or the legend
# touches the yellow one are left out. (w rad/s, value)
FIGURE_YA_DB = {
    1: [(0.0107, 8.3), (0.297, 9.1), (1.8655, 14.8), (4.1004, 9.2), (9.8373, 5.0), (19.8113, 0.5),
        (30.6857, -3.0), (56.6199, -8.1), (87.6986, -12.3)],
    2: [(0.0107, 8.4), (0.297, 8.9), (3.1536, 18.7), (6.9319, 14.2), (9.8373, 11.5), (19.8113, 6.5),
        (30.6857, 2.6), (56.6199, -3.2), (87.6986, -7.1)],
    3: [(0.0107, 8.8), (0.297, 8.8), (7.5659, 11.1), (9.8373, 9.5), (19.8113, 4.3), (30.6857, 0.8),
        (56.6199, -4.4), (80.3504, -8.1)],
}  # fmt: skip
FIGURE_YA_DEG = {
    1: [(0.0107, 0.0), (1.8655, -38.1), (2.8894, -45.0), (4.1004, -48.5), (6.9319, -57.1), (9.8373, -65.8),
        (19.8113, -86.5), (36.5549, -106.5), (51.8757, -121.2), (67.4495, -133.9), (87.6986, -149.5)],
    2: [(0.0107, 0.0), (0.7776, 34.6), (1.011, 39.3), (3.7568, -38.1), (6.9319, -58.8), (9.8373, -69.2),
        (19.8113, -90.0), (36.5549, -110.8), (51.8757, -127.2), (67.4495, -141.9), (87.6986, -159.2)],
    3: [(0.0107, 0.0), (0.8487, 34.6)],
}  # fmt: skip
FIGURE_TOL_DB, FIGURE_TOL_DEG = 1.5, 3.0

# Printed in output.xml of Admittance3DoF_oursystemwithZps.mlx (pose (0, 0, -0.6) m, mu_1 = 1 kg/m,
# m_B = 0.25 kg, m_C = 2 kg): variables Jinv and TSIM
A3_JINV = [[0.0000, 2.0381, -2.4762], [-1.7650, -1.0190, -2.4762], [1.7650, -1.0190, -2.4762]]
A3_TSIM = [[3.6359, 0.0, 0.0], [0.0, 3.6359, 0.0], [0.0, 0.0, 6.8295]]

# I_A of the script: gearbox + proximal link + elbow mass + distal links (kg m^2)
I_A = 0.17 + 0.5 * 0.34**3 / 3 + 0.1 * 0.34**2 + 4 * 0.5 * 0.656 * 0.34**2 / 3

# ---------------------------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------------------------


def _sig4(x: float) -> float:
    return float(f"{x:.4g}")


def _poly_mismatches(ours, printed, name: str) -> list[str]:
    """Mismatches between our (num, den) and MATLAB's printed ones: rounded to 4 significant digits they must be
    equal, and normalised by the leading denominator coefficient they must agree to 1e-3 relative."""
    out = []
    (on, od), (pn, pd) = ours, printed
    on, od = np.trim_zeros(np.asarray(on, float), "f"), np.trim_zeros(np.asarray(od, float), "f")
    pn, pd = np.asarray(pn, float), np.asarray(pd, float)
    if on.shape != pn.shape or od.shape != pd.shape:
        return [f"{name}: degrees {len(on) - 1}/{len(od) - 1}, printed {len(pn) - 1}/{len(pd) - 1}"]
    for part, o, p in (("num", on, pn), ("den", od, pd)):
        if [_sig4(v) for v in o] != [float(v) for v in p]:
            out.append(f"{name} {part}: {[_sig4(v) for v in o]} printed {list(p)}")
    o_all, p_all = np.concatenate([on, od]) / od[0], np.concatenate([pn, pd]) / pd[0]
    if not np.allclose(o_all, p_all, rtol=1e-3, atol=0):
        out.append(f"{name} normalised: {o_all} printed {p_all}")
    return out


def _tf_polys(sys: ct.TransferFunction) -> tuple[np.ndarray, np.ndarray]:
    return np.asarray(sys.num[0][0], float), np.asarray(sys.den[0][0], float)


def _matlab_tfs(m: LabBandwidthModel) -> dict:
    """The script's rational transfer functions from the model's parameters, multiplied out by python-control
    the way MATLAB's tf arithmetic does it (products and sums of numerators and denominators, no cancelling)."""
    assert m.pos_kd == 0 and m.vel_kd == 0  # the printed controllers have no derivative term
    s = ct.tf("s")
    y_v = (m.accel_gain_k_a_s * s**2 + s) / (m.virtual_mass_kg * s**2 + m.virtual_damping_n_s_per_m * s)
    y_r = 1 / (m.robot_mass_kg * s + m.b_r)
    c_pos = m.pos_kp + (m.pos_kp if m.pos_ki is None else m.pos_ki) / s
    c_vel = m.vel_kp + (m.vel_kp if m.vel_ki is None else m.vel_ki) / s
    a = [y_r * (ji * m.motor_constant_nm_per_a * c_vel) for ji in m.jinv_col_rad_per_m]
    e = m.j_col_m_per_rad[0] * a[0] + m.j_col_m_per_rad[1] * a[1] + m.j_col_m_per_rad[2] * a[2]
    return {"Y_v": y_v, "Y_r": y_r, "C_fb_pos": c_pos, "C_fb_vel": c_vel, "A": a, "E": e,
            "C": y_v * m.output_scale / s, "D": 1 / s}  # fmt: skip


def _printed_mismatches(m: LabBandwidthModel, n: int) -> list[str]:
    tfs = _matlab_tfs(m)
    out = []
    printed = {"Y_v": PRINTED_Y_V, "C_fb_pos": PRINTED_C_FB_POS, "C_fb_vel": PRINTED_C_FB_VEL, "C": PRINTED_C,
               "D": PRINTED_D, "Y_r": PRINTED_Y_R[n], "E": PRINTED_E[n]}  # fmt: skip
    for name, polys in printed.items():
        out += _poly_mismatches(_tf_polys(tfs[name]), polys, f"{name} (n={n})")
    nums, den = PRINTED_A[n]
    for i in range(3):
        out += _poly_mismatches(_tf_polys(tfs["A"][i]), (nums[i], den), f"A({i + 1}) (n={n})")
    return out


def _figure_errors(m: LabBandwidthModel, n: int) -> tuple[float, float]:
    """Largest |dB| and |deg| differences between the model's Y_a and MATLAB's plotted one."""
    w = np.array([p[0] for p in FIGURE_YA_DB[n]])
    db = 20 * np.log10(np.abs(m.apparent_admittance_frd(w)))
    err_db = np.max(np.abs(db - [p[1] for p in FIGURE_YA_DB[n]]))
    w = np.array([p[0] for p in FIGURE_YA_DEG[n]])
    deg = np.angle(m.apparent_admittance_frd(w), deg=True)
    err_deg = np.max(np.abs(deg - [p[1] for p in FIGURE_YA_DEG[n]]))
    return float(err_db), float(err_deg)


def _dense(entries, n: int, base=None) -> np.ndarray:
    out = np.zeros((n, n)) if base is None else base.copy()
    for r, c, v in entries:
        out[r - 1, c - 1] = v
    return out


W = np.geomspace(0.05, 300.0, 60)  # rad/s

# ---------------------------------------------------------------------------------------------------------
# kinematics: Jinv, J, JSIM, TSIM
# ---------------------------------------------------------------------------------------------------------


def test_kinematics_reproduce_printed_matrices():
    mats = delta_robot_matrices()
    for ours, printed in ((mats.jinv, PRINTED_JINV), (mats.j, PRINTED_J), (mats.jsim, PRINTED_JSIM),
                          (mats.tsim, PRINTED_TSIM)):  # fmt: skip
        np.testing.assert_allclose(ours, printed, rtol=0, atol=5.01e-5)
    assert PUBLISHED_POSITION_M == (-0.4, -0.4, -0.6)


def test_printed_matrices_need_the_mirrored_inverse_kinematics():
    """The Bandwidth folder's own IKinemDelta2.m (no Y = -Y) gives other matrices than the printed ones."""
    mats = delta_robot_matrices(mirror_y_in_ik=False)
    assert np.max(np.abs(mats.jinv - PRINTED_JINV)) > 1.0
    assert abs(mats.tsim[0, 0] - PRINTED_TSIM[0][0]) > 0.1


def test_tsim_is_platform_mass_plus_link_inertia_from_printed_jinv():
    """TSIM = Jinv' JSIM = m_C I + I_A Jinv' Jinv: the printed TSIM(1,1) = 4.4193 from the printed Jinv."""
    jinv = np.array(PRINTED_JINV)
    tsim = 1.0 * np.eye(3) + I_A * jinv.T @ jinv
    np.testing.assert_allclose(tsim, PRINTED_TSIM, rtol=0, atol=6e-4)  # Jinv printed to 5 digits
    assert _sig4(tsim[0, 0]) == 4.419
    np.testing.assert_allclose(np.linalg.inv(jinv), PRINTED_J, rtol=0, atol=5e-4)


def test_second_script_matrices():
    """The sibling script, another pose and heavier links, is reproduced too (its pose has X = Y = 0)."""
    mats = delta_robot_matrices((0.0, 0.0, -0.6), proximal_mass_per_length_kg_per_m=1.0, elbow_mass_kg=0.25,
                                platform_mass_kg=2.0)  # fmt: skip
    np.testing.assert_allclose(mats.jinv, A3_JINV, rtol=0, atol=5.01e-5)
    np.testing.assert_allclose(mats.tsim, A3_TSIM, rtol=0, atol=5.01e-5)


def test_default_model_is_published_axis_1():
    default, published = LabBandwidthModel(), LabBandwidthModel.published(1)
    np.testing.assert_allclose(default.jinv_col_rad_per_m, published.jinv_col_rad_per_m, rtol=1e-8)
    np.testing.assert_allclose(default.j_col_m_per_rad, published.j_col_m_per_rad, rtol=1e-8)
    assert default.robot_mass_kg == pytest.approx(published.robot_mass_kg, rel=1e-8)
    assert _sig4(default.robot_mass_kg) == 4.419 and default.b_r == pytest.approx(441.929149)
    with pytest.raises(ValueError):
        LabBandwidthModel.published(4)


# ---------------------------------------------------------------------------------------------------------
# printed transfer functions
# ---------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("n", [1, 2, 3])
def test_printed_transfer_functions(n):
    """Y_v, C_fb_pos, C_fb_vel, C, D, Y_r, A(1..3) and E: coefficients to the printed 4 significant digits."""
    assert _printed_mismatches(LabBandwidthModel.published(n), n) == []


@pytest.mark.parametrize("n", [1, 2, 3])
def test_frequency_responses_equal_printed_polynomials(n):
    """The module's vectorised responses against MATLAB's printed polynomials evaluated at jw."""
    m = LabBandwidthModel.published(n)
    jw = 1j * W

    def printed(p):
        return np.polyval(p[0], jw) / np.polyval(p[1], jw)

    rtol = 2e-3  # both polynomials printed to 4 significant digits
    np.testing.assert_allclose(m.virtual_admittance_frd(W), printed(PRINTED_Y_V), rtol=1e-12)
    np.testing.assert_allclose(m.pos_controller_frd(W), printed(PRINTED_C_FB_POS), rtol=1e-12)
    np.testing.assert_allclose(m.vel_controller_frd(W), printed(PRINTED_C_FB_VEL), rtol=1e-12)
    np.testing.assert_allclose(m.c_frd(W), printed(PRINTED_C), rtol=1e-12)
    np.testing.assert_allclose(m.d_frd(W), printed(PRINTED_D), rtol=1e-12)
    np.testing.assert_allclose(m.robot_admittance_frd(W), printed(PRINTED_Y_R[n]), rtol=rtol)
    np.testing.assert_allclose(m.e_frd(W), printed(PRINTED_E[n]), rtol=rtol)
    nums, den = PRINTED_A[n]
    a = m.a_frd(W)
    assert a.shape == (3, W.size)
    for i in range(3):
        np.testing.assert_allclose(a[i], printed((nums[i], den)), rtol=rtol)


def test_k_a_is_a_zero_at_minus_one():
    """k_a = 1 ("no gain") makes Y_v = (s + 1)/(0.04 s + 0.4): it rises from 1/b_v to 1/m_v."""
    m = LabBandwidthModel()
    y = m.virtual_admittance_frd(np.array([1e-4, 1.0, 1e4]))
    assert abs(y[0]) == pytest.approx(1 / 0.4, rel=1e-6)
    assert abs(y[1]) == pytest.approx(abs((1j + 1) / (0.04j + 0.4)), rel=1e-12)
    assert abs(y[2]) == pytest.approx(1 / 0.04, rel=1e-3)


# ---------------------------------------------------------------------------------------------------------
# F and Y_a: the delayed models
# ---------------------------------------------------------------------------------------------------------


def test_f_and_ya_equal_the_formula_from_independent_pieces():
    """F and Y_a with exact delays against the script's formulas built from python-control pieces."""
    for n in (1, 2, 3):
        m = LabBandwidthModel.published(n)
        tfs = _matlab_tfs(m)
        jw, t = 1j * W, m.hold_time_s

        def ev(sys):
            return np.asarray(sys(jw), complex).reshape(-1)

        hold = (1 - np.exp(-jw * t)) / (jw * t)
        f = sum(ji * hold * ev(tfs["C_fb_pos"]) * ev(a) for ji, a in zip(m.jinv_col_rad_per_m, tfs["A"]))
        c, d, e = ev(tfs["C"]), ev(tfs["D"]), ev(tfs["E"])
        y_a = f * c * hold / (f * c * m.post_sensor_mass_kg * jw + f * d + e + 1)
        np.testing.assert_allclose(m.f_frd(W), f, rtol=1e-9)
        np.testing.assert_allclose(m.apparent_admittance_frd(W), y_a, rtol=1e-9)
        np.testing.assert_allclose(m.b_frd(W)[0] / m.jinv_col_rad_per_m[0], hold * ev(tfs["C_fb_pos"]), rtol=1e-12)


def test_printed_f_branches_are_our_delay_free_dynamics():
    """The printed F (n = 1, delays zeroed) has three 4-state branches, one per motor i. From its input to the
    first state of branch i it is 8 C_fb_pos A(i) / s, A(i) taken from the module: the rational part of
    B{i} A(i) = Jinv(i) (1 - e^{-sT})/(sT) C_fb_pos A(i) (8 is the printed realisation's state scaling). The
    output row and the delay channels that make F from these states are not printed."""
    a_mat, b_vec = _dense(PRINTED_F1_A, 12), _dense(PRINTED_F1_B, 12)[:, :1]
    m = LabBandwidthModel.published(1)
    x = np.linalg.solve(1j * W[:, None, None] * np.eye(12) - a_mat, np.broadcast_to(b_vec, (W.size, 12, 1)))[..., 0]
    ours = m.pos_controller_frd(W) * m.a_frd(W) / (1j * W)
    for i in range(3):
        np.testing.assert_allclose(x[:, 4 * i] / ours[i], 8.0, rtol=2e-3)
    assert sorted(np.round(np.linalg.eigvals(a_mat).real, 6)) == [-100.0] * 3 + [0.0] * 9


def test_printed_ya_modes_at_zero_delay():
    """With the delays zeroed, F vanishes and Y_a's denominator becomes E + 1: the printed 53-state pencil
    (n = 1) has the roots of m_r s^2 + (b_r + k_g k_p_v c) s + k_g k_p_v c, c = sum_i J(i,1) Jinv(i,1), the
    virtual admittance's pole -b_v/m_v (twice, C in numerator and denominator) and the robot's -b_r/m_r."""
    a_mat = _dense(PRINTED_YA1_A, 53)
    e_mat = _dense(PRINTED_YA1_E_CHANGES, 53, base=np.eye(53))
    alpha, beta = scipy.linalg.eigvals(a_mat, e_mat, homogeneous_eigvals=True)
    finite = np.abs(beta) > 1e-9 * np.abs(alpha)
    lam = alpha[finite] / beta[finite]
    lam = np.sort(lam[np.abs(lam) > 1e-6].real)  # drop the integrators
    m = LabBandwidthModel.published(1)
    k = m.motor_constant_nm_per_a * m.vel_kp * float(np.dot(m.j_col_m_per_rad, m.jinv_col_rad_per_m))
    closed = np.sort(np.roots([m.robot_mass_kg, m.b_r + k, k]).real)
    assert closed[0] == pytest.approx(lam[0], rel=1e-3)  # -202.7: printed matrices have 4 digits
    assert closed[1] == pytest.approx(lam[-1], rel=1e-3)  # -0.5093
    robot = -m.b_r / m.robot_mass_kg
    virtual = -m.virtual_damping_n_s_per_m / m.virtual_mass_kg
    middle = lam[1:-1]
    assert np.sum(np.isclose(middle, virtual, rtol=1e-9)) == 2
    # the robot pole: 9 times in the F branches, twice more (perturbed by the 4-digit print) in E's realisation
    assert np.sum(np.isclose(middle, robot, rtol=1e-9)) == 9
    assert np.all(np.isclose(middle, virtual, rtol=1e-9) | np.isclose(middle, robot, rtol=0.03))


@pytest.mark.parametrize("n", [1, 2, 3])
def test_ya_matches_matlabs_bode_plot(n):
    """The delayed Y_a against MATLAB's Bode plot of Y_ap (digitised), to about a pixel."""
    err_db, err_deg = _figure_errors(LabBandwidthModel.published(n), n)
    assert err_db < FIGURE_TOL_DB and err_deg < FIGURE_TOL_DEG


# ---------------------------------------------------------------------------------------------------------
# the checks can fail
# ---------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "change",
    [
        {"virtual_mass_kg": 0.042},
        {"virtual_damping_n_s_per_m": 0.42},
        {"accel_gain_k_a_s": 0.0},
        {"robot_damping_n_s_per_m": 10 * 4.41929149},
        {"robot_mass_kg": 4.5},
        {"motor_constant_nm_per_a": 1.45},
        {"vel_kp": 52.0},
        {"vel_ki": 30.0},
        {"pos_ki": 0.0},
        {"jinv_col_rad_per_m": (3.0926, -2.1778, 0.1398)},
        {"j_col_m_per_rad": (0.8116, -1.9621, -1.8809)},
    ],
)
def test_wrong_parameter_breaks_printed_match(change):
    m = dataclasses.replace(LabBandwidthModel(), **change)
    assert _printed_mismatches(LabBandwidthModel(), 1) == []
    assert _printed_mismatches(m, 1) != []


@pytest.mark.parametrize(
    "change",
    [
        {"hold_time_s": 0.02},
        {"hold_in_time_s": 0.03},
        {"post_sensor_mass_kg": 0.05},
        {"pos_kp": 1.5},
        {"force_sensor_tc_s": 0.005},
    ],
)
def test_wrong_parameter_breaks_figure_match(change):
    """Parameters that only Y_a sees (hold, m_ps, position gain, sensor) are pinned by the plotted Y_a."""
    m = dataclasses.replace(LabBandwidthModel(), **change)
    err_db, err_deg = _figure_errors(m, 1)
    assert err_db > FIGURE_TOL_DB or err_deg > FIGURE_TOL_DEG


# ---------------------------------------------------------------------------------------------------------
# bandwidth and input checks
# ---------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("n, expected_hz", [(1, 0.12175), (2, 0.18867), (3, 0.16415)])
def test_bandwidth_of_published_axes(n, expected_hz):
    m = LabBandwidthModel.published(n)
    f_bw = admittance_bandwidth_hz(m)
    assert f_bw == pytest.approx(expected_hz, rel=1e-4)
    # the definition: inside both bounds just below, out of one of them at f_bw
    for f, inside in ((0.999 * f_bw, True), (f_bw, False)):
        ratio = m.apparent_admittance_frd(2 * np.pi * f) / m.virtual_admittance_frd(2 * np.pi * f)
        departed = abs(20 * np.log10(abs(ratio))) >= 3 - 1e-6 or abs(np.angle(ratio, deg=True)) >= 30 - 1e-6
        assert departed is not inside
    # the 3 dB gain bound is the one hit first on every axis (Y_a peaks above Y_v before its phase falls)
    ratio = m.apparent_admittance_frd(2 * np.pi * f_bw) / m.virtual_admittance_frd(2 * np.pi * f_bw)
    assert 20 * np.log10(abs(ratio)) == pytest.approx(3.0, abs=1e-6)


def test_bandwidth_edges_and_bad_input():
    m = LabBandwidthModel()
    assert admittance_bandwidth_hz(m, f_max_hz=0.05) == math.inf
    assert admittance_bandwidth_hz(m, phase_deg=5.0) < admittance_bandwidth_hz(m)
    with pytest.raises(ValueError):
        admittance_bandwidth_hz(m, f_min_hz=0.2)
    with pytest.raises(ValueError):
        admittance_bandwidth_hz(m, f_min_hz=1.0, f_max_hz=0.5)
    for bad in ([0.0, 1.0], [-1.0], [np.nan]):
        with pytest.raises(ValueError):
            m.apparent_admittance_frd(np.array(bad))
    assert m.apparent_admittance_frd(np.ones((2, 3))).shape == (2, 3)
    assert m.b_frd(np.ones((2, 3))).shape == (3, 2, 3)
