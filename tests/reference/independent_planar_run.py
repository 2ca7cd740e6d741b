"""An independent reference simulator of a mouse walking in two dimensions through both axes' admittance on the
planar gantry. Nothing here imports the tool (``plant``, ``design``): only numpy and scipy. The tests hold
``design.admittance.planar_run.simulate_planar_run`` against it.

Mechanics by Newton's law on each body, small yaw (the tool derives Lagrange's equations with casadi):

* the carriage (mass m_c with the head on its clamp) at x_c = p along the beam, y_c = y1 + p theta,
  theta = (y2 - y1) / L; pushed along the beam (1, theta) by F_xr = f_x - b_x p' and across it (-theta, 1) by
  the beam's normal force N, and by the neck F_n at the clamp:
      m_c p''   = F_xr + F_nx - theta N
      m_c y_c'' = N + F_ny + theta F_xr,        y_c'' = y1'' + theta p'' + 2 p' theta' + p theta''
* the beam (mass m_b at its middle, yaw inertia J = J_b + J_c with the carriage's), on the rails' motors f1, f2
  and dampers, the carriage's reaction -(N + theta F_xr) across it at p from Y1, the guides' K_a:
      m_b (y1'' + y2'') / 2 = f1 + f2 - b1 y1' - b2 y2' - N - theta F_xr
      J theta''             = L/2 (f2 - b2 y2' - f1 + b1 y1') - (p - L/2)(N + theta F_xr) - K_a theta + b_r phi'
* the rotation stage (J_r, on a bearing b_r, no torque): J_r (theta'' + phi'') = -b_r phi'.

Five equations, linear in (y1'', y2'', p'', phi'', N), solved at each instant. Drives: first-order current
loops (bandwidth f_c) from the held commands, forces K i. The mouse: head on the clamp, body m_b on an isotropic
neck (k_n, c_n), legs G = m_b a_d + (m_v a_d + b_v v_d per axis) + k_l (x_d - b) + c_l (v_d - b') limited to
F_max in magnitude. Sensed force F_s = F_n - m_h (p'', y_c'').

Discrete part at the drive ticks (rate f_d): X: a trapezoidal PI on p' with the integrator held while the
command is beyond its limit in the error's direction; Y: u = T_in (PI_j on T_out (r - (y1', y2'))), each channel's
integrator held when a motor it drives is beyond its limit in the direction it pushes; commands ``delay`` ticks
late and clipped to the limits. Laws at every ``n_a``-th tick: reading res round((F + bias) / res), zero within
the deadband, forward Euler v[j] = v[j-1] + T_a (r[j] - b_v v[j-1]) / m_v, the reference ``computation_delay``
updates late. The continuous part is integrated by ``scipy.integrate.solve_ivp`` (DOP853) tick to tick.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp


def _accelerations(q, dq, forces, neck, m):
    """(y1'', y2'', p'', phi'') and N from Newton's equations (module docstring)."""
    y1, y2, p, _ = q
    v1, v2, vp, vphi = dq
    f1, f2, fx = forces
    L = m["L"]
    th, dth = (y2 - y1) / L, (v2 - v1) / L
    fxr = fx - m["b_x"] * vp
    mc, mb, J, Jr = m["m_c"], m["m_b"], m["J"], m["J_r"]
    A = np.zeros((5, 5))
    r = np.zeros(5)
    # unknowns: y1'', y2'', p'', phi'', N
    A[0, 2], A[0, 4] = mc, th
    r[0] = fxr + neck[0]
    A[1, 0], A[1, 1], A[1, 2], A[1, 4] = mc * (1 - p / L), mc * p / L, mc * th, -1.0
    r[1] = neck[1] + th * fxr - mc * 2 * vp * dth
    A[2, 0] = A[2, 1] = mb / 2
    A[2, 4] = 1.0
    r[2] = f1 + f2 - m["b1"] * v1 - m["b2"] * v2 - th * fxr
    A[3, 0], A[3, 1], A[3, 4] = -J / L, J / L, p - L / 2
    r[3] = L / 2 * (f2 - m["b2"] * v2 - f1 + m["b1"] * v1) - (p - L / 2) * th * fxr - m["K_a"] * th + m["b_r"] * vphi
    A[4, 0], A[4, 1], A[4, 3] = -Jr / L, Jr / L, Jr
    r[4] = -m["b_r"] * vphi
    sol = np.linalg.solve(A, r)
    return sol[:4], th, dth


def simulate(machine: dict, drives: dict, x_pi: tuple, y_structure: dict, laws: dict, sensor: dict, mouse: dict,
             time_s, xd, vd, ad, *, start_p: float, drive_rate_hz: float, law_ticks: int, computation_delay: int,
             rtol: float = 1e-9):
    """The run over the ticks ``time_s``; ``xd, vd, ad`` (n, 2) relative to the start. machine: L, m_b, J, m_c
    (with the head), J_r, b1, b2, b_x, b_r, K_a; drives: K (3: Y1, Y2, X), f_c (3, Hz), limit (3, A), delay (ticks,
    the same for all); x_pi: (kp, ki); y_structure: t_in (2, n), t_out (n, 2), kp (n), ki (n); laws: m_v (2), b_v
    (2), T_a; sensor: res, bias, deadband; mouse: m_h, m_b, k_n, c_n, k_l, c_l, f_max, feedforward. Returns
    (clamp position (n, 2) relative to the start, sensed force (n, 2), currents (n, 3))."""
    m, mo = machine, mouse
    T = 1.0 / drive_rate_hz
    K, wc, lim = (np.asarray(drives[k], float) for k in ("K", "f_c", "limit"))
    wc = 2 * np.pi * wc
    mv, bv = np.asarray(laws["m_v"], float), np.asarray(laws["b_v"], float)
    start = np.array([start_p, 0.0])

    def clamp(z):
        y1, y2, p = z[0], z[1], z[2]
        v1, v2, vp = z[4], z[5], z[6]
        th, dth = (y2 - y1) / m["L"], (v2 - v1) / m["L"]
        return np.array([p, y1 + p * th]), np.array([vp, v1 + vp * th + p * dth])

    def evaluate(z, drive):
        c, vc = clamp(z)
        b, vb = z[11:13], z[13:15]
        neck = mo["k_n"] * (b - c) + mo["c_n"] * (vb - vc)
        acc, th, dth = _accelerations(z[0:4], z[4:8], K * z[8:11], neck, m)
        p, vp = z[2], z[6]
        ac = np.array([acc[2], acc[0] + th * acc[2] + 2 * vp * dth + p * (acc[1] - acc[0]) / m["L"]])
        g = drive - mo["k_l"] * b - mo["c_l"] * vb
        size = np.hypot(*g)
        leg = g if size <= mo["f_max"] else g * (mo["f_max"] / size)
        return acc, neck, leg, neck - mo["m_h"] * ac

    def rhs(_, z, ic, drive):
        acc, neck, leg, _ = evaluate(z, drive)
        return np.concatenate([z[4:8], acc, wc * (ic - z[8:11]), z[13:15], (leg - neck) / mo["m_b"]])

    t = np.asarray(time_s, float)
    n = t.size
    z = np.zeros(15)
    z[2] = start_p
    z[11:13] = start
    tin, tout = np.asarray(y_structure["t_in"], float), np.asarray(y_structure["t_out"], float)
    ykp, yki = np.asarray(y_structure["kp"], float), np.asarray(y_structure["ki"], float)
    y_int, y_prev = np.zeros(ykp.size), np.zeros(ykp.size)
    x_int = x_prev = 0.0
    va, ref = np.zeros(2), np.zeros(2)
    refs = [np.zeros(2)] * (computation_delay + 1)
    cmds = [np.zeros(3)] * (drives["delay"] + 1)
    ic = np.zeros(3)
    pos, fs_out, cur = np.empty((n, 2)), np.empty((n, 2)), np.empty((n, 3))
    for k in range(n):
        ff = (mv * ad[k] + bv * vd[k]) if mo["feedforward"] else 0.0
        drive = mo["m_b"] * ad[k] + ff + mo["k_l"] * (start + xd[k]) + mo["c_l"] * vd[k]
        _, _, _, fs = evaluate(z, drive)
        if k % law_ticks == 0:
            for a in range(2):
                r = sensor["res"] * np.round((fs[a] + sensor["bias"]) / sensor["res"])
                r = 0.0 if abs(r) <= sensor["deadband"] else r
                va[a] = va[a] + laws["T_a"] * (r - bv[a] * va[a]) / mv[a]
            refs = refs[1:] + [va.copy()]
            ref = refs[0]
        e = ref[0] - z[6]
        trial = x_int + x_pi[1] * T * (e + x_prev) / 2
        u = x_pi[0] * e + trial
        if (u > lim[2] and e > 0) or (u < -lim[2] and e < 0):
            trial = x_int
            u = x_pi[0] * e + trial
        x_int, x_prev = trial, e
        ey = tout @ (ref[1] - z[4:6])
        ytrial = y_int + yki * T * (ey + y_prev) / 2
        uy = tin @ (ykp * ey + ytrial)
        for j in range(ey.size):
            for mtr in range(2):
                push = np.sign(tin[mtr, j] * ey[j])
                if abs(uy[mtr]) > lim[mtr] and push != 0 and np.sign(uy[mtr]) == push:
                    ytrial[j] = y_int[j]
        y_int, y_prev = ytrial, ey
        uy = np.clip(tin @ (ykp * ey + ytrial), -lim[:2], lim[:2])
        cmds = cmds[1:] + [np.array([uy[0], uy[1], min(max(u, -lim[2]), lim[2])])]
        c, _ = clamp(z)
        pos[k], fs_out[k], cur[k] = c - start, fs, z[8:11]
        ic = cmds[0]
        if k + 1 < n:
            sol = solve_ivp(rhs, (t[k], t[k + 1]), z, method="DOP853", rtol=rtol, atol=rtol * 1e-6, args=(ic, drive))
            z = sol.y[:, -1]
    return pos, fs_out, cur
