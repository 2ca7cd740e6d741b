"""Multi-body gantry models the thesis builds on or cites.

* ``thesis_state_space``: the 6-state model of thesis Appendix A (A, B, C matrices).
* ``xie_wang_frd`` / ``xie_wang_ss``: the heavy-load gantry of Xie & Wang (thesis
  Eq. 2.14-2.15): thrusts f1, f2 in, rail velocities y1, y2 out, per-rail damping,
  off-centre load and joint stiffness K_a.
* ``qin_linearised_ss``: the H-gantry of Qin et al. (thesis Eq. 2.11-2.13) about delta = 0.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from plant.physics.parameters import check_positive

if TYPE_CHECKING:
    import control


def thesis_state_space(*, mass_kg: float, damping_n_s_per_m: float, force_constant_n_per_a: float,
                       motor_length_m: float, load_position_m: float) -> control.StateSpace:
    """Thesis Appendix A: states (x, v_x, y1, v_y1, y2, v_y2), inputs (i1, i2, i3) as printed,
    outputs (v_x, v_y1, v_y2). Its transfer matrix is thesis Figure A.1."""
    import control

    m, b, k, L, l = mass_kg, damping_n_s_per_m, force_constant_n_per_a, motor_length_m, load_position_m
    for name, v in [("mass_kg", m), ("damping_n_s_per_m", b), ("force_constant_n_per_a", k),
                    ("motor_length_m", L), ("load_position_m", l)]:
        check_positive(name, v)
    a = -b * L / (2 * m * l)
    A = np.array([[0, 1, 0, 0, 0, 0], [0, -b / m, 0, 0, 0, 0], [0, 0, 0, 1, 0, 0],
                  [0, 0, 0, a, 0, a], [0, 0, 0, 0, 0, 1], [0, 0, 0, a, 0, a]], dtype=float)
    g = k * L / (2 * m * l)
    B = np.array([[0, 0, 0], [k / m, 0, 0], [0, 0, 0], [0, g, g], [0, 0, 0], [0, g, g]], dtype=float)
    C = np.array([[0, 1, 0, 0, 0, 0], [0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 0, 1]], dtype=float)
    return control.ss(A, B, C, np.zeros((3, 3)))


def _xie_wang_damping(b1, b2, l1, l2):
    """Damping matrix entries of coordinates (y_c, alpha).

    y1 = y_c - l1*alpha, y2 = y_c + l2*alpha; rail damping enters as C^T diag(b1, b2) C.
    Xie & Wang print the coupling term as +(b1 l1 + b2 l2); the derivation from the rail
    forces gives (b2 l2 - b1 l1), which vanishes for a centred load as it must.
    """
    d11 = b1 + b2
    d12 = b2 * l2 - b1 * l1
    d22 = b1 * l1**2 + b2 * l2**2
    return d11, d12, d22


def xie_wang_frd(w_rad_s, *, mass_kg, inertia_kg_m2, damping1_n_s_per_m, damping2_n_s_per_m,
                 l1_m, l2_m, joint_stiffness_n_m_per_rad) -> np.ndarray:
    """Velocity response of the Xie-Wang gantry, shape (..., 2, 2, n_freq): [y1,y2] per [f1,f2] (m/s per N).

    Parameters broadcast against the frequency axis; ``joint_stiffness_n_m_per_rad=np.inf`` gives
    the rigid limit y1 = y2 = (f1 + f2) / (M s + b1 + b2).
    """
    s = 1j * np.asarray(w_rad_s)
    m, J = np.asarray(mass_kg, float), np.asarray(inertia_kg_m2, float)
    b1, b2 = np.asarray(damping1_n_s_per_m, float), np.asarray(damping2_n_s_per_m, float)
    l1, l2, ka = np.asarray(l1_m, float), np.asarray(l2_m, float), np.asarray(joint_stiffness_n_m_per_rad, float)
    d11, d12, d22 = _xie_wang_damping(b1, b2, l1, l2)
    a = m * s**2 + d11 * s
    c = d12 * s
    rigid = np.isinf(ka)
    ka_f = np.where(rigid, 1.0, ka)
    d = np.where(rigid, np.inf, J * s**2 + d22 * s + ka_f)
    # inverse of [[a, c], [c, d]] times s; the rigid limit (d -> inf) handled explicitly
    with np.errstate(invalid="ignore", divide="ignore"):
        det = a * d - c**2
        i11 = np.where(rigid, 1 / a, d / det)
        i12 = np.where(rigid, 0, -c / det)
        i22 = np.where(rigid, 0, a / det)
    # H = C s inv(K(s)) C^T with C = [[1, -l1], [1, l2]]
    C = [[1.0, -l1], [1.0, l2]]
    inv = [[i11, i12], [i12, i22]]
    out = []
    for r in range(2):
        row = []
        for col in range(2):
            h = sum(C[r][p] * inv[p][q] * C[col][q] for p in range(2) for q in range(2))
            row.append(s * h)
        out.append(np.stack(np.broadcast_arrays(*row), axis=-2))
    return np.stack(out, axis=-3)


def xie_wang_ss(*, mass_kg: float, inertia_kg_m2: float, damping1_n_s_per_m: float, damping2_n_s_per_m: float,
                l1_m: float, l2_m: float, joint_stiffness_n_m_per_rad: float) -> control.StateSpace:
    """State-space form of ``xie_wang_frd``: states (y_c, alpha, v_c, omega), inputs (f1, f2),
    outputs (v_y1, v_y2)."""
    import control

    for name, v in [("mass_kg", mass_kg), ("inertia_kg_m2", inertia_kg_m2), ("l1_m", l1_m), ("l2_m", l2_m)]:
        check_positive(name, v)
    check_positive("joint_stiffness_n_m_per_rad", joint_stiffness_n_m_per_rad)
    d11, d12, d22 = _xie_wang_damping(damping1_n_s_per_m, damping2_n_s_per_m, l1_m, l2_m)
    Mi = np.diag([1 / mass_kg, 1 / inertia_kg_m2])
    D = np.array([[d11, d12], [d12, d22]])
    K = np.diag([0.0, joint_stiffness_n_m_per_rad])
    Ct = np.array([[1.0, -l1_m], [1.0, l2_m]])
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Mi @ K, -Mi @ D]])
    B = np.vstack([np.zeros((2, 2)), Mi @ Ct.T])
    C = np.hstack([np.zeros((2, 2)), Ct])
    return control.ss(A, B, C, np.zeros((2, 2)))


def qin_linearised_ss(*, mass_kg: float, inertia_kg_m2: float, beam_length_m: float) -> control.StateSpace:
    """Qin et al. (thesis Eq. 2.11-2.13) linearised about delta = 0.

    At delta = 0: m x'' = f_y1 + f_y2, m y'' = f_x, J delta'' = (f_y2 - f_y1) l/2.
    States (x, y, delta, x', y', delta'); inputs (f_y1, f_y2, f_x); outputs the three velocities.
    (The delta-dependent terms are second order about delta = 0 with the forces at zero.)
    """
    import control

    check_positive("mass_kg", mass_kg)
    check_positive("inertia_kg_m2", inertia_kg_m2)
    check_positive("beam_length_m", beam_length_m)
    m, J, l = mass_kg, inertia_kg_m2, beam_length_m
    A = np.block([[np.zeros((3, 3)), np.eye(3)], [np.zeros((3, 3)), np.zeros((3, 3))]])
    G = np.array([[1 / m, 1 / m, 0.0], [0.0, 0.0, 1 / m], [-l / (2 * J), l / (2 * J), 0.0]])
    B = np.vstack([np.zeros((3, 3)), G])
    C = np.hstack([np.zeros((3, 3)), np.eye(3)])
    return control.ss(A, B, C, np.zeros((3, 3)))
