"""An independent stepped-sine recording of the X motor on a planar gantry whose beam may be skewed and whose
carriage's centre of mass may sit off the X motor's line (imports nothing from ``plant`` or ``design``).

The linear equations at rest from the momentum principles, written out in (y1, y2, p, psi) with theta = (y2 - y1) / L,
the beam's middle y_m = (y1 + y2) / 2 and the carriage's centre of mass x_c = p - e theta, y_c = y1 + eps p + p theta
(eps the skew, e the offset); psi the rotation stage's absolute angle:

    y momentum:                   m_b y_m'' + m_c y_c'' = f1 + f2 - b1 y1' - b2 y2'
    angular momentum about Y1:    (J_b + J_c) theta'' + J_r psi'' + m_b (L / 2) y_m'' + m_c (p y_c'' - e x_c'')
                                    = L (f2 - b2 y2') - K_a theta
    the carriage along the beam:  m_c (x_c'' + eps y_c'') = f_x - b_x p'
    the rotation stage:           J_r psi'' = -b_r (psi' - theta')

The X motor's force is k_x E i with E a first-order current loop and a delay; the record is the exact response of
this state space to the held current (scipy's zero-order hold at the sample rate, from rest), each block a sine of
``amplitude_a``, white noise added to every velocity and to the current.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import cont2discrete


@dataclass(frozen=True)
class Machine:
    beam_mass_kg: float = 16.0
    beam_inertia_kg_m2: float = 16.0 * 0.8**2 / 12
    carriage_mass_kg: float = 35.0
    carriage_inertia_kg_m2: float = 0.0
    rail_separation_m: float = 0.8
    damping1_n_s_per_m: float = 440.0
    damping2_n_s_per_m: float = 440.0
    damping_x_n_s_per_m: float = 330.0
    yaw_stiffness_n_m_per_rad: float = 2.0e5
    rotation_inertia_kg_m2: float = 2.0e-3
    rotation_damping_n_m_s_per_rad: float = 0.01
    skew_rad: float = 0.0
    offset_m: float = 0.0
    force_constant_x_n_per_a: float = 20.0
    current_loop_hz: float = 1000.0


def matrices(m: Machine, p: float):
    """(M, D, K, B): M q'' + D q' + K q = B f_x in q = (y1, y2, p, psi), each row one equation of the module doc."""
    L, eps, e = m.rail_separation_m, m.skew_rad, m.offset_m
    th = np.array([-1.0, 1.0, 0.0, 0.0]) / L
    mid = np.array([0.5, 0.5, 0.0, 0.0])
    xc = np.array([0.0, 0.0, 1.0, 0.0]) - e * th
    yc = np.array([1.0, 0.0, eps, 0.0]) + p * th
    psi = np.array([0.0, 0.0, 0.0, 1.0])
    mb, mc = m.beam_mass_kg, m.carriage_mass_kg
    M = np.array([mb * mid + mc * yc,
                  (m.beam_inertia_kg_m2 + m.carriage_inertia_kg_m2) * th + m.rotation_inertia_kg_m2 * psi
                  + mb * (L / 2) * mid + mc * (p * yc - e * xc),
                  mc * (xc + eps * yc),
                  m.rotation_inertia_kg_m2 * psi])
    D = np.zeros((4, 4))
    D[0, 0], D[0, 1] = m.damping1_n_s_per_m, m.damping2_n_s_per_m
    D[1, 1] = L * m.damping2_n_s_per_m
    D[2, 2] = m.damping_x_n_s_per_m
    D[3] = m.rotation_damping_n_m_s_per_rad * (psi - th)
    K = np.zeros((4, 4))
    K[1] = m.yaw_stiffness_n_m_per_rad * th
    B = np.array([0.0, 0.0, 1.0, 0.0])
    return M, D, K, B


def state_space(m: Machine, p: float):
    """(A, B, C): states (q, q', the current loop's force), input the commanded current (A), outputs the velocities
    (y1', y2', p')."""
    M, D, K, B = matrices(m, p)
    Mi = np.linalg.inv(M)
    wc = 2 * np.pi * m.current_loop_hz
    A = np.zeros((9, 9))
    A[:4, 4:8] = np.eye(4)
    A[4:8, :4], A[4:8, 4:8], A[4:8, 8] = -Mi @ K, -Mi @ D, Mi @ B
    A[8, 8] = -wc
    Bi = np.zeros((9, 1))
    Bi[8, 0] = wc * m.force_constant_x_n_per_a
    C = np.zeros((3, 9))
    C[0, 4], C[1, 5], C[2, 6] = 1.0, 1.0, 1.0
    return A, Bi, C


def x_motor_recording(m: Machine, p: float, f_hz, *, amplitude_a: float = 1.0, sample_rate_hz: float = 4000.0,
                      periods: int = 30, min_block_s: float = 1.0, velocity_noise: float = 1e-5,
                      current_noise: float = 1e-3, seed: int = 0) -> str:
    """A stepped-sine CSV (``frequency_hz,time_s,current_a`` and the three velocities) of the X motor, from rest in
    every block."""
    A, B, C = state_space(m, p)
    h = 1.0 / sample_rate_hz
    Ad, Bd, *_ = cont2discrete((A, B, C, np.zeros((3, 1))), h, method="zoh")
    rng = np.random.default_rng(seed)
    rows = ["frequency_hz,time_s,current_a,velocity_y1_m_per_s,velocity_y2_m_per_s,velocity_x_m_per_s"]
    for f in np.asarray(f_hz, float):
        n = int(np.ceil(max(periods / f, min_block_s) * sample_rate_hz))
        t = np.arange(n) * h
        i = amplitude_a * np.sin(2 * np.pi * f * t)
        x = np.zeros(9)
        y = np.empty((n, 3))
        for k in range(n):
            y[k] = C @ x
            x = Ad @ x + Bd[:, 0] * i[k]
        y += velocity_noise * rng.standard_normal(y.shape)
        i_meas = i + current_noise * rng.standard_normal(n)
        rows += [f"{f:.6g},{tk:.6f},{ik:.6e},{a:.6e},{b:.6e},{c:.6e}" for tk, ik, (a, b, c) in zip(t, i_meas, y)]
    return "\n".join(rows) + "\n"
