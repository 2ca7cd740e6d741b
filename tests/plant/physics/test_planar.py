"""The planar gantry (``plant.physics.planar``, Lagrange's equations derived by casadi) against what it must
reduce to and against an independent derivation: today's two-motor Stage Y and thesis Stage X / Stage Y at rest,
Newton-Euler equations written out here with the rotation stage, and the energy its nonlinear equations conserve
with the carriage moving."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from plant.errors import ParameterError
from plant.physics.dual_drive import DualDriveStageY
from plant.physics.planar import PlanarGantry

W = np.geomspace(1.0, 3000.0, 80)
S = 1j * W


@pytest.mark.parametrize("p", [0.05, 0.3, 0.4, 0.71])
def test_at_rest_it_is_todays_two_motor_stage_y_and_thesis_stage_x(p):
    """A free rotation stage (no bearing damping, no torque) passes nothing to the beam: the rails' and the
    carriage's point mobilities are ``DualDriveStageY``'s, the carriage along the beam is m_c p'' + b_x p' = f_x
    (thesis Eq. 3.15), and nothing of X reaches Y at rest."""
    g = PlanarGantry(carriage_inertia_kg_m2=0.05, rotation_damping_n_m_s_per_rad=0.0)
    H = g.frd(W, p)
    ref = DualDriveStageY(carriage_position_m=p, carriage_inertia_kg_m2=0.05).point_mobility(S)
    got = H[[0, 1, 4]][:, [0, 1, 5]]          # (y1', y2', y_c') per (f1, f2, clamp f_y)
    assert np.max(np.abs(got - ref) / np.max(np.abs(ref), axis=(0, 1))) < 1e-10
    np.testing.assert_allclose(H[2, 2], 1 / (g.carriage_mass_kg * S + g.damping_x_n_s_per_m), rtol=1e-12)
    assert np.max(np.abs(H[[0, 1, 4], 2])) == 0.0 and np.max(np.abs(H[2, [0, 1, 5]])) == 0.0


def test_both_motors_alike_and_the_carriage_midway_is_thesis_stage_y():
    """f1 = f2 = F / 2 with the carriage in the middle: v1 = v2 = F / (M s + 2 b), M = m_b + m_c (Eq. 3.16 at
    l = L / 2)."""
    g = PlanarGantry()
    H = g.frd(W, g.rail_separation_m / 2)
    want = 1 / ((g.beam_mass_kg + g.carriage_mass_kg) * S + 2 * g.damping1_n_s_per_m)
    for rail in (0, 1):
        np.testing.assert_allclose((H[rail, 0] + H[rail, 1]) / 2, want, rtol=1e-10)


def newton_euler(g: PlanarGantry, p: float, s: np.ndarray) -> np.ndarray:
    """The linear model at rest written out body by body (coordinates y1, y2, p, psi = theta + phi the stage's
    absolute angle): the beam and the carriage as one body in y and yaw, their centre of mass, inertia and the
    rails' damping about it; the rotation stage's bearing passing tau_r - b_r (psi' - theta') to the stage and its
    reaction to the carriage. Response (y1', y2', p', phi', y_c') per (f1, f2, f_x, tau_r, w_x, w_y, tau_m)."""
    L, mb, mc = g.rail_separation_m, g.beam_mass_kg, g.carriage_mass_kg
    M = mb + mc
    sg = (mb * L / 2 + mc * p) / M
    J = g.beam_inertia_kg_m2 + g.carriage_inertia_kg_m2 + mb * (L / 2 - sg) ** 2 + mc * (p - sg) ** 2
    l1, l2 = sg, L - sg
    b1, b2, bx, br = g.damping1_n_s_per_m, g.damping2_n_s_per_m, g.damping_x_n_s_per_m, g.rotation_damping_n_m_s_per_rad
    Jr, Ka = g.rotation_inertia_kg_m2, g.yaw_stiffness_n_m_per_rad
    out = np.zeros((5, 7, s.size), complex)
    for k, sk in enumerate(s):
        # unknowns: Y_g, Theta, P, Psi (positions); forces in: f1, f2, fx, tau_r, wx, wy, tau_m
        K = np.zeros((4, 4), complex)
        F = np.zeros((4, 7), complex)
        # M y_g'' + (b1 + b2) y_g' + (b2 l2 - b1 l1) theta' = f1 + f2 + w_y
        K[0, 0], K[0, 1] = M * sk**2 + (b1 + b2) * sk, (b2 * l2 - b1 * l1) * sk
        F[0, 0] = F[0, 1] = F[0, 5] = 1.0
        # J theta'' + ... + K_a theta = l2 f2 - l1 f1 + (p - l1) w_y - tau_r + b_r (psi' - theta')
        K[1, 0] = (b2 * l2 - b1 * l1) * sk
        K[1, 1] = J * sk**2 + (b1 * l1**2 + b2 * l2**2) * sk + Ka + br * sk
        K[1, 3] = -br * sk
        F[1, 0], F[1, 1], F[1, 3], F[1, 5] = -l1, l2, -1.0, p - l1
        # m_c p'' + b_x p' = f_x + w_x
        K[2, 2] = mc * sk**2 + bx * sk
        F[2, 2] = F[2, 4] = 1.0
        # J_r psi'' = tau_r + tau_m - b_r (psi' - theta')
        K[3, 3], K[3, 1] = Jr * sk**2 + br * sk, -br * sk
        F[3, 3] = F[3, 6] = 1.0
        X = np.linalg.solve(K, F) * sk                            # velocities of (y_g, theta, p, psi)
        yg, th, pp, psi = X
        out[:, :, k] = [yg - l1 * th, yg + l2 * th, pp, psi - th, yg + (p - l1) * th]
    return out


@pytest.mark.parametrize("p", [0.1, 0.55])
def test_the_whole_linear_model_is_newton_eulers_with_the_rotation_stage(p):
    g = PlanarGantry(rotation_inertia_kg_m2=0.02, rotation_damping_n_m_s_per_rad=2.0, carriage_inertia_kg_m2=0.1,
                     damping2_n_s_per_m=380.0)
    got, want = g.frd(W, p), newton_euler(g, p, S)
    scale = np.max(np.abs(want), axis=-1, keepdims=True)
    assert np.max(np.abs(got - want) / np.where(scale > 0, scale, 1.0)) < 1e-9
    # the rotation motor's reaction yaws the beam (its torque lands on the carriage)
    assert np.max(np.abs(got[0, 3])) > 0


def test_the_nonlinear_equations_conserve_energy_with_the_carriage_moving():
    """No damping, no input: the carriage crosses the beam at 0.5 m/s while the beam yaws and the stage spins;
    T + V stays constant to the integrator's tolerance (the moving carriage's terms derived right)."""
    g = PlanarGantry(damping1_n_s_per_m=1e-12, damping2_n_s_per_m=1e-12, damping_x_n_s_per_m=1e-12,
                     rotation_damping_n_m_s_per_rad=0.0, yaw_stiffness_n_m_per_rad=2.0e3)
    L = g.rail_separation_m

    def energy(x):
        q, dq = x[:4], x[4:]
        theta, dtheta = (q[1] - q[0]) / L, (dq[1] - dq[0]) / L
        dyc = dq[0] + dq[2] * theta + q[2] * dtheta
        T = (g.beam_mass_kg * ((dq[0] + dq[1]) / 2) ** 2 + (g.beam_inertia_kg_m2 + g.carriage_inertia_kg_m2)
             * dtheta**2 + g.carriage_mass_kg * (dq[2] ** 2 + dyc**2) + g.rotation_inertia_kg_m2
             * (dtheta + dq[3]) ** 2) / 2
        return T + g.yaw_stiffness_n_m_per_rad * theta**2 / 2

    x0 = np.array([0.0, 1e-3, 0.2, 0.0, 0.01, -0.02, 0.5, 1.0])
    sol = solve_ivp(lambda t, x: np.concatenate([x[4:], g.dynamics(x[:4], x[4:], np.zeros(4))]), (0, 0.8), x0,
                    rtol=1e-11, atol=1e-13, dense_output=True)
    e = np.array([energy(sol.sol(t)) for t in np.linspace(0, 0.8, 50)])
    assert sol.sol(0.8)[2] > 0.55                                   # the carriage did travel
    assert np.max(np.abs(e / e[0] - 1)) < 1e-8
    # a moving carriage on a yawing beam is not what the rest linearisation sees: its y acceleration differs
    moving = g.dynamics(x0[:4], x0[4:], np.zeros(4))
    still = g.dynamics(x0[:4], np.r_[x0[4:6], 0.0, x0[7]], np.zeros(4))
    assert not np.allclose(moving[:2], still[:2])


def test_a_carriage_outside_the_rails_and_a_batch_are_refused():
    with pytest.raises(ParameterError, match="between the rails"):
        PlanarGantry().linearised(0.9)
    with pytest.raises(ParameterError, match="one machine"):
        PlanarGantry(carriage_mass_kg=np.array([20.0, 30.0]))
    with pytest.raises(ParameterError):
        PlanarGantry(rotation_inertia_kg_m2=0.0)
    assert math.isfinite(PlanarGantry().mass_matrix(0.4)[0, 0])


def test_a_small_push_with_the_carriage_held_follows_the_linear_model():
    """The nonlinear equations stepped in time (``simulate``) against the linear model at the same position: a
    0.1 N step on rail Y1 and a 1 mN*m step on the rotation stage, the carriage held by its motor at rest."""
    from scipy.signal import StateSpace, lsim

    g = PlanarGantry()
    p = 0.3
    t = np.linspace(0.0, 0.2, 201)
    u = np.zeros((t.size, 4))
    u[:, 0], u[:, 3] = 0.1, 1e-3
    x0 = np.zeros(8)
    x0[2] = p
    got = g.simulate(t, u, state0=x0)
    A, B, C = g.linearised(p)
    _, y, _ = lsim(StateSpace(A, B[:, :4], C, np.zeros((5, 4))), u, t)
    np.testing.assert_allclose(got[:, 4:8], y[:, :4], atol=1e-6 * np.max(np.abs(y[:, :4])))
    assert np.max(np.abs(got[:, 5])) > 0                             # the push yawed the beam: rail Y2 moved


def test_the_closed_form_matrices_are_lagranges_and_batch():
    """M, D, K in closed form equal casadi's symbolic linearisation (the mass matrix, and A = [[0, I], [-M^-1 K,
    -M^-1 D]], B = [0; M^-1] for the actuators) at three carriage positions, with every inertia non-zero; a batch
    of positions gives the same; the carriage's coordinate meets no other."""
    from plant.physics.planar import mobility

    g = PlanarGantry(carriage_inertia_kg_m2=0.3, rotation_inertia_kg_m2=0.05, rotation_damping_n_m_s_per_rad=0.2)
    positions = np.array([0.1, 0.37, 0.7])
    Mb, Db, Kb = g.matrices(positions)
    for k, p in enumerate(positions):
        M, D, K = g.matrices(p)
        A, B, _ = g.linearised(p)
        Mi = np.linalg.inv(M)
        assert np.allclose(M, g.mass_matrix(p), rtol=1e-12, atol=1e-12)
        assert np.allclose(A[4:, :4], -Mi @ K, rtol=1e-12, atol=1e-9 * np.abs(A[4:, :4]).max())
        assert np.allclose(A[4:, 4:], -Mi @ D, rtol=1e-12, atol=1e-12 * np.abs(A[4:, 4:]).max())
        assert np.allclose(B[4:, :4], Mi, rtol=1e-12, atol=1e-12)
        assert np.array_equal(Mb[k], M) and np.array_equal(Db[k], D) and np.array_equal(Kb[k], K)
        for m in (M, D, K):
            assert not np.any(np.delete(m[2], 2)) and not np.any(np.delete(m[:, 2], 2))
        w = np.array([0.5, 60.0, 900.0])
        ref = g.frd(w, p)[:4, :4]
        assert np.abs(mobility(1j * w, M, D, K) - ref).max() < 1e-10 * np.abs(ref).max()


def test_the_three_coordinate_mobility_equals_numpys_inverse_through_the_resonances():
    """The rails and the rotation stage (the planar checks' three coordinates), inverted by the adjugate over a batch
    of carriage positions, on a grid dense through the yaw and rotation modes: numpy's LU inverse to 1e-11 of each
    matrix's largest entry, the rotation stage's bearing nearly undamped."""
    from plant.physics.planar import mobility

    g = PlanarGantry(carriage_inertia_kg_m2=0.3, rotation_inertia_kg_m2=0.02, rotation_damping_n_m_s_per_rad=1e-4)
    keep = np.array([0, 1, 3])
    M, D, K = (m[:, keep][:, :, keep] for m in g.matrices(np.linspace(0.05, 0.75, 9)))
    s = 1j * np.geomspace(0.01, 2e4, 3001)
    ss = s[:, None, None]
    ref = np.moveaxis(np.linalg.inv(M[:, None] * ss**2 + D[:, None] * ss + K[:, None]) * ss, 1, -1)
    got = mobility(s, M, D, K)
    assert got.shape == ref.shape == (9, 3, 3, s.size)
    assert np.all(np.abs(got - ref) <= 1e-11 * np.abs(ref).max(axis=(1, 2), keepdims=True))


SKEWED = dict(beam_skew_rad=0.004, carriage_offset_m=0.03, carriage_inertia_kg_m2=0.2, rotation_inertia_kg_m2=0.02)


@pytest.mark.parametrize("p", [0.15, 0.5])
def test_with_skew_and_offset_the_closed_form_is_still_lagranges(p):
    g = PlanarGantry(**SKEWED)
    M, D, K = g.matrices(p)
    A, B, _ = g.linearised(p)
    Mi = np.linalg.inv(M)
    assert np.allclose(M, g.mass_matrix(p), rtol=1e-12, atol=1e-12)
    assert np.allclose(A[4:, :4], -Mi @ K, rtol=1e-10, atol=1e-9 * np.abs(A[4:, :4]).max())
    assert np.allclose(A[4:, 4:], -Mi @ D, rtol=1e-10, atol=1e-12 * np.abs(A[4:, 4:]).max())
    assert np.allclose(B[4:, :4], Mi, rtol=1e-10, atol=1e-12)
    assert M[2, 0] != 0 and M[2, 1] != 0                             # X now meets both rails


@pytest.mark.parametrize("p", [0.15, 0.5])
def test_an_x_push_from_rest_accelerates_the_rails_as_the_momentum_principles_say(p):
    """From rest, only the X motor's force (between beam and carriage, along the beam): no force along the rails
    acts from outside, so the y momentum stays 0; the rails' x reactions act on the beam's line, so the angular
    momentum about a point of it stays 0 (the rotation stage, free on its bearing, keeps its own); the carriage along
    the beam obeys f_x alone. Three equations for (y1'', y2'', p''), against M^-1 Q of the model."""
    g = PlanarGantry(**SKEWED)
    L, mb, mc, eps, e = g.rail_separation_m, g.beam_mass_kg, g.carriage_mass_kg, g.beam_skew_rad, g.carriage_offset_m
    J = g.beam_inertia_kg_m2 + g.carriage_inertia_kg_m2
    fx = 10.0
    # unknowns (y1'', y2'', p''): theta'' = (y2'' - y1'') / L, the beam's middle (y1'' + y2'') / 2,
    # the carriage's centre of mass: x_c'' = p'' - e theta'', y_c'' = y1'' + eps p'' + p theta''
    th, mid = np.array([-1.0, 1.0, 0.0]) / L, np.array([0.5, 0.5, 0.0])
    xc, yc = np.array([0, 0, 1.0]) - e * th, np.array([1.0, 0, eps]) + p * th
    rows = [mb * mid + mc * yc,                                                 # d/dt of the y momentum = 0
            J * th + mb * (L / 2) * mid + mc * (p * yc - e * xc),               # d/dt of the angular momentum = 0
            mc * (xc + eps * yc)]                                               # along the beam: f_x
    want = np.linalg.solve(np.array(rows), np.array([0.0, 0.0, fx]))
    got = np.linalg.solve(g.matrices(p)[0], np.array([0.0, 0.0, fx, 0.0]))[:3]
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())


def test_skew_moves_the_rails_together_and_offset_yaws_them_from_the_x_motor():
    w = np.array([3.0, 30.0, 300.0])
    p = 0.4
    base = PlanarGantry().frd(w, p)[:2, 2]                                       # (y1', y2') per f_x
    skew = PlanarGantry(beam_skew_rad=0.004).frd(w, p)[:2, 2]
    offset = PlanarGantry(carriage_offset_m=0.03).frd(w, p)[:2, 2]
    assert np.abs(base).max() < 1e-15
    # the carriage mid-beam: a skew pushes both rails alike (no yaw), an offset turns them apart (no translation)
    assert np.abs(skew[0] - skew[1]).max() < 1e-9 * np.abs(skew).max() and np.abs(skew).max() > 0
    assert np.abs(offset[0] + offset[1]).max() < 1e-9 * np.abs(offset).max() and np.abs(offset).max() > 0
    # reciprocity: the X carriage answers a rail's force as the rail answers the X motor's
    g = PlanarGantry(beam_skew_rad=0.004, carriage_offset_m=0.03)
    H = g.frd(w, 0.27)
    np.testing.assert_allclose(H[2, 0], H[0, 2], rtol=1e-9)


def test_the_nonlinear_equations_with_skew_and_offset_conserve_energy():
    g = PlanarGantry(damping1_n_s_per_m=1e-12, damping2_n_s_per_m=1e-12, damping_x_n_s_per_m=1e-12,
                     rotation_damping_n_m_s_per_rad=0.0, yaw_stiffness_n_m_per_rad=2.0e3, **SKEWED)
    L, eps, e = g.rail_separation_m, g.beam_skew_rad, g.carriage_offset_m

    def energy(x):
        q, dq = x[:4], x[4:]
        theta, dtheta = (q[1] - q[0]) / L, (dq[1] - dq[0]) / L
        dxc, dyc = dq[2] - e * dtheta, dq[0] + dq[2] * (theta + eps) + q[2] * dtheta
        T = (g.beam_mass_kg * ((dq[0] + dq[1]) / 2) ** 2 + (g.beam_inertia_kg_m2 + g.carriage_inertia_kg_m2)
             * dtheta**2 + g.carriage_mass_kg * (dxc**2 + dyc**2)
             + g.rotation_inertia_kg_m2 * (dtheta + dq[3]) ** 2) / 2
        return T + g.yaw_stiffness_n_m_per_rad * theta**2 / 2

    x0 = np.array([0.0, 1e-3, 0.2, 0.0, 0.01, -0.02, 0.5, 1.0])
    sol = solve_ivp(lambda t, x: np.concatenate([x[4:], g.dynamics(x[:4], x[4:], np.zeros(4))]), (0, 0.6), x0,
                    rtol=1e-11, atol=1e-13, dense_output=True)
    e_t = np.array([energy(sol.sol(t)) for t in np.linspace(0, 0.6, 40)])
    assert np.max(np.abs(e_t / e_t[0] - 1)) < 1e-8


@pytest.mark.parametrize("field, value", [("beam_skew_rad", 0.2), ("beam_skew_rad", float("nan")),
                                          ("carriage_offset_m", 0.5)])
def test_a_skew_or_offset_beyond_the_model_is_refused_naming_it(field, value):
    with pytest.raises(ParameterError, match=field):
        PlanarGantry(**{field: value})
