"""An independent model of the admittance-controlled gantry with a mouse at its clamp, from Newton's law.

Nothing here imports the tool (``plant``, ``design``): the state-space matrices are written out by hand
from the forces on each body, the drive's delay is python-control's Pade approximant, the sampled law is
discretised by scipy's ``cont2discrete``, and margins come from python-control's ``stability_margins`` on a
dense frequency response. It is the reference the tests hold the tool's grid evaluation, ray bounds and
verification against.

Bodies (SI units): the gantry with the head on its clamp, mass M + m_h, rail damping b; the mouse's body m_b,
tied to the head by the neck (k_n, c_n) and to the ground by the legs (k_l, c_l). Drive: PI on the velocity
error e = u - v (integrator state xi), the current command delayed (Pade, order ``pade``), a first-order current
loop at w_c, motor force K_t i. States: [xi, i, v, v_b, q = x_b - x, x_b, delay...]. (x_b is left out for a mouse
with no legs on the ground: nothing sees it.) Output: the force the head
exerts on the gantry, F_s = F_n - m_h dv/dt, with F_n = k_n q + c_n (v_b - v); the path K = -F_s / u.
"""

from __future__ import annotations

import math

import numpy as np


def _pade_ss(delay_s: float, order: int):
    """A balanced state-space realisation of python-control's Pade approximant of e^(-s delay)."""
    import control
    from scipy.linalg import matrix_balance
    from scipy.signal import tf2ss

    num, den = control.pade(delay_s, order)
    A, B, C, D = tf2ss(num, den)
    _, (scale, _) = matrix_balance(A, permute=False, separate=True)
    return A * (1 / scale)[:, None] * scale[None, :], B / scale[:, None], C * scale[None, :], D


def coupled_path(*, mass_kg, damping, kt, kp, ki, delay_s, current_hz, head_kg, body_kg, neck_k, neck_c, leg_k,
                 leg_c, pade: int = 6):
    """(A, B, C, D) of the path from the velocity reference u to -F_s (continuous)."""
    Ad, Bd, Cd, Dd = _pade_ss(delay_s, pade) if delay_s > 0 else (np.zeros((0, 0)), np.zeros((0, 1)),
                                                                 np.zeros((1, 0)), np.ones((1, 1)))
    nd = Ad.shape[0]
    n = 6 + nd
    A = np.zeros((n, n))
    B = np.zeros((n, 1))
    m_tot = mass_kg + head_kg
    wc = 2 * math.pi * current_hz
    XI, I, V, VB, Q, XB = range(6)
    D0 = 6
    # i_cmd = kp (u - v) + ki xi ;  delayed i_d = Cd d + Dd i_cmd ;  d' = Ad d + Bd i_cmd
    icmd_x = np.zeros(n)
    icmd_x[V], icmd_x[XI] = -kp, ki
    icmd_u = kp
    A[XI, V], B[XI, 0] = -1.0, 1.0
    if nd:
        A[D0:, D0:] = Ad
        A[D0:, :] += Bd @ icmd_x[None, :]
        B[D0:, 0] += Bd[:, 0] * icmd_u
    id_x = Dd[0, 0] * icmd_x
    id_x[D0:] += Cd[0]
    id_u = Dd[0, 0] * icmd_u
    A[I, :] += wc * id_x
    A[I, I] -= wc
    B[I, 0] += wc * id_u
    # forces: F_n = k_n q + c_n (v_b - v)
    fn = np.zeros(n)
    fn[Q], fn[VB], fn[V] = neck_k, neck_c, -neck_c
    dv = (kt * np.eye(n)[I] + fn - damping * np.eye(n)[V]) / m_tot       # (M + m_h) v' = K_t i + F_n - b v
    A[V] = dv
    A[VB] = (-fn - leg_k * np.eye(n)[XB] - leg_c * np.eye(n)[VB]) / body_kg
    A[Q, VB], A[Q, V] = 1.0, -1.0
    A[XB, VB] = 1.0
    C = -(fn - head_kg * dv)[None, :]        # -F_s = -(F_n - m_h v')
    if leg_k == 0 and leg_c == 0:            # a floating body's position is a pure integrator nothing sees
        keep = np.arange(n) != XB
        return A[np.ix_(keep, keep)], B[keep], C[:, keep], np.zeros((1, 1))
    return A, B, C, np.zeros((1, 1))


def response(ss, x) -> np.ndarray:
    """C (x I - A)^-1 B + D at the points ``x``, one LU solve per point (LAPACK's, batched)."""
    A, B, C, D = ss
    x = np.asarray(x).ravel()
    n = A.shape[0]
    return (C @ np.linalg.solve(x[:, None, None] * np.eye(n) - A, np.broadcast_to(B, (x.size, n, 1))))[:, 0, 0] \
        + D[0, 0]


def sampled_loop(path, *, m_v, b_v, period_s, forward_euler=False, zoh=False):
    """(Ad, Bd, Cd, Dd) of the discrete interaction loop: the path sampled with a zero-order hold (scipy
    ``cont2discrete``) after the law: backward Euler y[k] = (m_v y[k-1] + T F[k]) / (m_v + b_v T), forward
    Euler y[k] = y[k-1] + T (F[k] - b_v y[k-1]) / m_v, or (``zoh``) scipy's zero-order-hold discretisation of
    1/(m_v s + b_v) advanced by its one sample of delay."""
    from scipy.signal import cont2discrete

    Ad, Bd, Cd, Dd, _ = cont2discrete(path, period_s, method="zoh")
    # law: y[k] = a y[k-1] + c F[k]; as a state space in series before Kd
    if forward_euler:
        a, c = 1.0 - b_v * period_s / m_v, period_s / m_v
    elif zoh:
        num, den, _ = cont2discrete(([1.0], [m_v, b_v]), period_s, method="zoh")   # c z^-1 / (1 - a z^-1)
        a, c = -den[1] / den[0], num[0][-1] / den[0]
    else:
        a, c = m_v / (m_v + b_v * period_s), period_s / (m_v + b_v * period_s)
    n = Ad.shape[0]
    A = np.zeros((n + 1, n + 1))
    A[0, 0] = a                  # law state s[k+1] = y[k] = a s[k] + c F[k]  (s = y[k-1])
    A[1:, 1:] = Ad
    A[1:, :1] = Bd * a           # Kd's input is y[k] = a s[k] + c F[k]
    B = np.zeros((n + 1, 1))
    B[0, 0] = c
    B[1:, 0] = Bd[:, 0] * c
    C = np.hstack([Dd * a, Cd])
    D = Dd * c
    return A, B, C, D


def margins_from_response(w_rad_s, L) -> tuple[float, float]:
    """python-control's (phase margin deg, gain margin dB) of the frequency response L on ``w_rad_s``."""
    import control

    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        gm, pm, *_ = control.stability_margins(control.frd(L, w_rad_s))
    return (float(pm) if np.isfinite(pm) else math.inf,
            20 * math.log10(gm) if np.isfinite(gm) and gm > 0 else math.inf)


def closed_loop_stable(loop, *, discrete: bool) -> bool:
    """Eigenvalues of the unity negative feedback around the single-input single-output ``loop``."""
    A, B, C, D = loop
    k = 1.0 / (1.0 + D[0, 0])
    Acl = A - k * B @ C
    lam = np.linalg.eigvals(Acl)
    return bool(np.all(np.abs(lam) < 1.0)) if discrete else bool(np.all(lam.real < 0))


def felt_model(*, mass_kg, damping, kt, kp, ki, delay_s, current_hz, head_kg, neck_k, neck_c, m_v, b_v,
               pade: int = 6):
    """(A, B, C, D) from the mouse's body velocity v_b to the neck force F_n, the continuous admittance law
    closed: m_v y' = F_s - b_v y is the velocity reference, F_s = F_n - m_h v' the sensed force, and the
    gantry with the head (M + m_h) v' = K_t i + F_n - b v. States [xi, i, v, q = x_b - x, y, delay...]."""
    Ad, Bd, Cd, Dd = _pade_ss(delay_s, pade) if delay_s > 0 else (np.zeros((0, 0)), np.zeros((0, 1)),
                                                                 np.zeros((1, 0)), np.ones((1, 1)))
    nd = Ad.shape[0]
    n = 5 + nd
    XI, I, V, Q, Y = range(5)
    D0 = 5
    e = np.eye(n)
    m_tot = mass_kg + head_kg
    wc = 2 * math.pi * current_hz
    A = np.zeros((n, n))
    B = np.zeros((n, 1))
    # F_n = k_n q + c_n (v_b - v): state part and input part
    fn_x, fn_u = neck_k * e[Q] - neck_c * e[V], neck_c
    dv_x, dv_u = (kt * e[I] + fn_x - damping * e[V]) / m_tot, fn_u / m_tot
    fs_x, fs_u = fn_x - head_kg * dv_x, fn_u - head_kg * dv_u
    A[XI], A[XI, Y], A[XI, V] = 0.0, 1.0, -1.0                  # xi' = y - v
    icmd_x = kp * (e[Y] - e[V]) + ki * e[XI]
    if nd:
        A[D0:, D0:] = Ad
        A[D0:, :] += Bd @ icmd_x[None, :]
    id_x = Dd[0, 0] * icmd_x
    id_x[D0:] += Cd[0]
    A[I] = wc * id_x - wc * e[I]
    A[V], B[V, 0] = dv_x, dv_u
    A[Q, V], B[Q, 0] = -1.0, 1.0
    A[Y], B[Y, 0] = (fs_x - b_v * e[Y]) / m_v, fs_u / m_v
    return A, B, fn_x[None, :], np.array([[fn_u]])
