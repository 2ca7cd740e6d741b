"""The two-motor Stage Y and its velocity loops built from Lagrange's equations in rail coordinates, with
python-control only (nothing from ``plant`` or ``design``): a reference for ``plant.physics.dual_drive``
and ``design.loop.dual``.

Generalised coordinates q = (y1, y2), the beam's positions at the rails (L apart); a point at s from
Y1 moves with y(s) = (1 - s/L) y1 + (s/L) y2 and the yaw is (y2 - y1) / L. Kinetic energy of the beam
(mass m_b at L/2, yaw inertia J_b) and the carriage (m_c at p, J_c), the joints' yaw spring K_a and
the rails' dampers b1, b2 give

    M_q q'' + diag(b1, b2) q' + K_a / L^2 [[1, -1], [-1, 1]] q = diag(k1, k2) (i1, i2)
    M_q = m_b a(L/2) a(L/2)^T + m_c a(p) a(p)^T + (J_b + J_c) / L^2 [[1, -1], [-1, 1]],  a(s) = (1 - s/L, s/L)

Outputs: the rail velocities q'. Each motor's current passes its own delay (Pade) and first-order
current loop; the controllers are python-control transfer functions, joined by its products and
``feedback``. For thousands of draws, ``closed_loop_matrices`` assembles the same closed loop with NumPy
(its poles are python-control's: ``test_independent_dual_drive.py``).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import control
import numpy as np


@dataclass(frozen=True)
class Rig:
    beam_mass_kg: float = 16.0
    beam_inertia_kg_m2: float = 16.0 * 0.8**2 / 12
    carriage_mass_kg: float = 35.0
    carriage_inertia_kg_m2: float = 0.0
    rail_separation_m: float = 0.8
    carriage_position_m: float = 0.4
    b1: float = 440.0
    b2: float = 440.0
    k1: float = 20.0
    k2: float = 20.0
    yaw_stiffness: float = 2.0e5
    delay_s: float = 0.0
    current_loop_hz: float | None = None
    #: a Butterworth low-pass after each channel's PI (the same on every channel: in series with each motor)
    low_pass_hz: float | None = None


def mechanics(rig: Rig) -> control.StateSpace:
    """Currents (i1, i2) -> rail velocities (v1, v2): states (y1, y2, v1, v2)."""
    return control.ss(*_mechanics_matrices(rig), np.zeros((2, 2)))


def _mechanics_matrices(rig: Rig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, C) of ``mechanics``."""
    L, p = rig.rail_separation_m, rig.carriage_position_m

    def a(s):
        return np.array([1 - s / L, s / L])

    twist = np.array([[1.0, -1.0], [-1.0, 1.0]]) / L**2
    M = (rig.beam_mass_kg * np.outer(a(L / 2), a(L / 2)) + rig.carriage_mass_kg * np.outer(a(p), a(p))
         + (rig.beam_inertia_kg_m2 + rig.carriage_inertia_kg_m2) * twist)
    D = np.diag([rig.b1, rig.b2])
    K = rig.yaw_stiffness * twist
    Mi = np.linalg.inv(M)
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Mi @ K, -Mi @ D]])
    B = np.vstack([np.zeros((2, 2)), Mi @ np.diag([rig.k1, rig.k2])])
    C = np.hstack([np.zeros((2, 2)), np.eye(2)])
    return A, B, C


def _drive_factors(rig: Rig, pade_order: int) -> list[tuple]:
    """(numerator, denominator) of each factor of ``drive``: the delay (Pade), the current loop, the filter."""
    factors = []
    if rig.delay_s > 0:
        factors.append(control.pade(rig.delay_s, pade_order))
    if rig.current_loop_hz is not None:
        wc = 2 * np.pi * rig.current_loop_hz
        factors.append(([wc], [1.0, wc]))
    if rig.low_pass_hz is not None:
        wf = 2 * np.pi * rig.low_pass_hz
        factors.append(([wf**2], [1.0, np.sqrt(2) * wf, wf**2]))
    return factors


def drive(rig: Rig, pade_order: int = 8) -> control.TransferFunction:
    """One motor's current command -> current: the delay (Pade), the current loop and the drive's filter."""
    g = control.tf([1.0], [1.0])
    for num, den in _drive_factors(rig, pade_order):
        g = g * control.tf(num, den)
    return g


def plant(rig: Rig, pade_order: int = 8) -> control.StateSpace:
    """Commanded currents -> rail velocities, drives included."""
    d = control.ss(drive(rig, pade_order))
    return mechanics(rig) * control.append(d, d)


def pi(kp: float, ki: float) -> control.TransferFunction:
    return control.tf([kp, ki], [1.0, 0.0])


@functools.lru_cache(maxsize=16)
def controller(structure: str, gains: tuple[float, ...]) -> control.StateSpace:
    """Rail velocity errors (e1, e2) -> motor current commands (i1, i2); built once per structure and gains (a
    Monte Carlo check closes it around thousands of plants; python-control's products leave it unchanged)."""
    if structure == "per_motor":
        kp, ki = gains
        return control.append(control.ss(pi(kp, ki)), control.ss(pi(kp, ki)))
    if structure == "common_differential":
        kpc, kic, kpd, kid = gains
        t_out = np.array([[0.5, 0.5], [-0.5, 0.5]])       # errors -> (mean, half difference)
        t_in = np.array([[0.5, -0.5], [0.5, 0.5]])        # (total, differential) current -> motors
        core = control.append(control.ss(pi(kpc, kic)), control.ss(pi(kpd, kid)))
        return control.ss([], [], [], t_in) * core * control.ss([], [], [], t_out)
    if structure == "master_slave":
        kp, ki = gains
        core = control.ss(pi(kp, ki))
        return control.ss([], [], [], np.array([[0.5], [0.5]])) * core * control.ss([], [], [], np.array([[1.0, 0.0]]))
    raise ValueError(structure)


def closed_loop(rig: Rig, structure: str, gains, pade_order: int = 8) -> control.StateSpace:
    """Translation command r (on both rails) -> rail velocities (v1, v2), by negative feedback."""
    P = plant(rig, pade_order)
    K = controller(structure, gains)
    T = control.feedback(P * K, np.eye(2))
    return T * control.ss([], [], [], np.array([[1.0], [1.0]]))


def unstable_poles(rig: Rig, structure: str, gains, pade_order: int = 8) -> int:
    return int(np.sum(closed_loop(rig, structure, gains, pade_order).poles().real > 1e-9))


#: each structure's channels: errors -> channels (T_out) and channel outputs -> motor currents (T_in)
_CHANNELS = {
    "per_motor": (np.eye(2), np.eye(2)),
    "common_differential": (np.array([[0.5, 0.5], [-0.5, 0.5]]), np.array([[0.5, -0.5], [0.5, 0.5]])),
    "master_slave": (np.array([[1.0, 0.0]]), np.array([[0.5], [0.5]])),
}


def _drive_ss(rig: Rig, pade_order: int):
    """One motor's drive (``drive``: the delay's Pade approximant times the current loop's lag) in controllable
    canonical form from its polynomials: (A, B, C, D)."""
    num, den = np.array([1.0]), np.array([1.0])
    for n, d in _drive_factors(rig, pade_order):
        num, den = np.polymul(num, n), np.polymul(den, d)
    num, den = num / den[0], den / den[0]
    k = den.size - 1
    num = np.r_[np.zeros(k + 1 - num.size), num]
    A = np.zeros((k, k))
    A[0] = -den[1:]
    A[1:, :-1] = np.eye(k - 1)
    B = np.zeros((k, 1))
    B[0, 0] = 1.0
    C = (num[1:] - num[0] * den[1:])[None]
    return A, B, C, np.array([[num[0]]])


def closed_loop_matrices(rigs, structure: str, gains, pade_order: int = 8) -> np.ndarray:
    """State matrices (n_rigs, n, n) of ``closed_loop`` for many rigs, assembled with NumPy from the same equations
    (states: the twist d = y2 - y1 and the rail velocities, each motor's drive, one integrator per channel). The
    common position (y1 + y2) / 2, which nothing feeds back, is left out: ``closed_loop`` has that pole at 0 as
    well. Agrees with python-control's ``closed_loop`` poles (tests/reference/test_independent_dual_drive.py)."""
    t_out, t_in = _CHANNELS[structure]
    nc = t_out.shape[0]
    g = np.tile(np.asarray(gains, dtype=float), 2 if structure == "per_motor" else 1)   # (kp, ki) per channel
    kp, ki = np.diag(g[0::2]), np.diag(g[1::2])
    out = []
    for rig in rigs:
        # mechanics on (d, v1, v2), d = y2 - y1: K q = K_a / L^2 (-d, d) is the y2 column with y1 = 0
        A, B, C = _mechanics_matrices(rig)
        Am, Bm, Cm = A[1:, 1:].copy(), B[1:], C[:, 1:]
        Am[0] = [0.0, -1.0, 1.0]
        Ad, bd, cd, dd = _drive_ss(rig, pade_order)
        Ad2, Bd2, Cd2, Dd2 = (np.kron(np.eye(2), x) for x in (Ad, bd, cd, dd))
        # u = T_in (Ki z + Kp e_c), e_c = T_out e, e = -y
        Gx, Gz = -t_in @ kp @ t_out @ Cm, t_in @ ki
        out.append(np.block([
            [Am + Bm @ Dd2 @ Gx, Bm @ Cd2, Bm @ Dd2 @ Gz],
            [Bd2 @ Gx, Ad2, Bd2 @ Gz],
            [-t_out @ Cm, np.zeros((nc, Ad2.shape[0])), np.zeros((nc, nc))]]))
    return np.array(out)


def unstable_pole_counts(rigs, structure: str, gains, pade_order: int = 8) -> np.ndarray:
    """``unstable_poles`` of each rig: eigenvalues of ``closed_loop_matrices`` (one batched LAPACK call) with a
    real part above 1e-9."""
    return np.sum(np.linalg.eigvals(closed_loop_matrices(rigs, structure, gains, pade_order)).real > 1e-9, axis=-1)


def input_loop(rig: Rig, structure: str, gains, pade_order: int = 8) -> control.StateSpace:
    """The loop broken at the motor inputs, K P (currents in, currents out)."""
    return controller(structure, gains) * plant(rig, pade_order)


def channel_loop(rig: Rig, structure: str, gains, j: int, pade_order: int = 8) -> control.StateSpace:
    """The loop of the structure's channel j (its PI channels around T_out P T_in) with the other channel
    closed by ``control.feedback`` on that channel only; master-slave has one channel."""
    P = plant(rig, pade_order)
    if structure == "master_slave":
        kp, ki = gains
        return control.ss(pi(kp, ki)) * control.ss([], [], [], np.array([[1.0, 0.0]])) * P * \
            control.ss([], [], [], np.array([[0.5], [0.5]]))
    if structure == "per_motor":
        kp, ki = gains
        core = control.append(control.ss(pi(kp, ki)), control.ss(pi(kp, ki)))
        t_in, t_out = np.eye(2), np.eye(2)
    else:
        kpc, kic, kpd, kid = gains
        core = control.append(control.ss(pi(kpc, kic)), control.ss(pi(kpd, kid)))
        t_in, t_out = np.array([[0.5, -0.5], [0.5, 0.5]]), np.array([[0.5, 0.5], [-0.5, 0.5]])
    L = core * control.ss([], [], [], t_out) * P * control.ss([], [], [], t_in)
    closed_other = np.diag([1.0 if i != j else 0.0 for i in range(2)])
    return control.feedback(L, closed_other)[j, j]


def clamp_path(rig: Rig, structure: str, gains, *, head_kg: float, body_kg: float, neck_k: float, neck_c: float,
               leg_k: float = 0.0, leg_c: float = 0.0, pade_order: int = 10):
    """(A, B, C, D) from the translation command r (on both rails' loops) to -F_s, the force the head clamp on the
    carriage reads, negated, with the mouse attached there: K = -F_s / r of the admittance loop.

    Bodies: the beam and carriage in rail coordinates (``mechanics``) plus the head m_h on the clamp at p, where a
    point moves with a(p) . q'; the mouse's body m_b tied to the head by the neck (k_n, c_n) and to the ground by
    the legs (k_l, c_l). States: the twist d = y2 - y1, the neck's stretch e = x_b - a . q, the body's position x_b
    (only with legs), v = q', v_b; then each motor's drive (``drive``), then the controller's states. The neck
    pulls the clamp with f_n = k_n e + c_n (v_b - a . v); the clamp reads F_s = f_n - m_h a . v'."""
    L, p = rig.rail_separation_m, rig.carriage_position_m
    a = np.array([1 - p / L, p / L])

    def ap(s):
        return np.array([1 - s / L, s / L])

    twist = np.array([[1.0, -1.0], [-1.0, 1.0]]) / L**2
    Mg = (rig.beam_mass_kg * np.outer(ap(L / 2), ap(L / 2)) + rig.carriage_mass_kg * np.outer(a, a)
          + (rig.beam_inertia_kg_m2 + rig.carriage_inertia_kg_m2) * twist + head_kg * np.outer(a, a))
    Mi = np.linalg.inv(Mg)
    legs = leg_k > 0
    # states: d, e, [x_b], v1, v2, v_b
    names = ["d", "e"] + (["xb"] if legs else []) + ["v1", "v2", "vb"]
    n = len(names)
    ix = {k: i for i, k in enumerate(names)}
    V = [ix["v1"], ix["v2"]]
    A = np.zeros((n, n))
    B = np.zeros((n, 2))
    A[ix["d"], V] = [-1.0, 1.0]
    A[ix["e"], ix["vb"]] = 1.0
    A[ix["e"], V] = -a
    if legs:
        A[ix["xb"], ix["vb"]] = 1.0
    # generalised forces on the gantry: -D v - K_a twist q + diag(k) i + a f_n
    fn = np.zeros(n)                          # f_n as a row over the states
    fn[ix["e"]], fn[ix["vb"]] = neck_k, neck_c
    fn[V] = -neck_c * a
    force = np.zeros((2, n))
    force[:, V] = -np.diag([rig.b1, rig.b2])
    force[:, ix["d"]] = -rig.yaw_stiffness / L**2 * np.array([-1.0, 1.0])
    force += np.outer(a, fn)
    A[V, :] = Mi @ force
    B[V, :] = Mi @ np.diag([rig.k1, rig.k2])
    A[ix["vb"], :] = -fn / body_kg
    A[ix["vb"], ix["vb"]] -= leg_c / body_kg
    if legs:
        A[ix["vb"], ix["xb"]] -= leg_k / body_kg
    # outputs: v1, v2 and F_s = f_n - m_h a . v'
    C = np.zeros((3, n))
    D = np.zeros((3, 2))
    C[0, V[0]], C[1, V[1]] = 1.0, 1.0
    C[2] = fn - head_kg * a @ A[V, :]
    D[2] = -head_kg * a @ B[V, :]
    d = control.ss(drive(rig, pade_order))
    G = control.ss(A, B, C, D) * control.append(d, d)
    K = controller(structure, gains)
    AG, BG, CG, DG = (np.asarray(m) for m in (G.A, G.B, G.C, G.D))
    AK, BK, CK, DK = (np.asarray(m) for m in (K.A, K.B, K.C, K.D))
    if np.any(DG[:2] != 0):
        raise ValueError("the rail velocities must not feed through from the current commands")
    C12, C3, D3 = CG[:2], CG[2:], DG[2:]
    one = np.ones((2, 1))
    Acl = np.block([[AG - BG @ DK @ C12, BG @ CK], [-BK @ C12, AK]])
    Bcl = np.vstack([BG @ DK @ one, BK @ one])
    Ccl = -np.hstack([C3 - D3 @ DK @ C12, D3 @ CK])
    Dcl = -D3 @ DK @ one
    # two integrators on the rails repeat the twist (their difference is -d plus a constant): a mode at s = 0 that
    # neither r nor F_s sees, which python-control's minimal realisation removes
    m = control.ss(Acl, Bcl, Ccl, Dcl).minreal(tol=1e-9)
    return tuple(np.asarray(x) for x in (m.A, m.B, m.C, m.D))
