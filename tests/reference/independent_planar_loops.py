"""An independent model of the coupled Stage Y and rotation stage under their loops, for checking the planar
synthesis (imports nothing from ``plant`` or ``design``).

Newton-Euler, written out: the beam with Stage X's carriage fixed on it at p from rail Y1 is one rigid body (mass
M = m_b + m_c, its centre of mass s_g = (m_b L / 2 + m_c p) / M from Y1, yaw inertia about it
J = J_b + J_c + m_b (L/2 - s_g)^2 + m_c (p - s_g)^2); the rotation stage (inertia J_r about its axis, its mass in
m_c) turns on it with the absolute angle psi. With f_i = k_i i_i at rail i, the rails' damping b_i, the guides' yaw
stiffness K_a, the rotation motor's torque tau on the stage (its reaction -tau on the beam) and the bearing's
damping b_r on the relative rate phi' = psi' - theta'::

    M v_g'          = f1 + f2 - b1 v1 - b2 v2
    J theta''       = -s_g (f1 - b1 v1) + (L - s_g) (f2 - b2 v2) - K_a theta - tau + b_r phi'
    J_r psi''       = tau - b_r phi'
    v1 = v_g - s_g theta',  v2 = v_g + (L - s_g) theta',  phi' = psi' - theta'

Each motor's current passes a first-order current loop and a pure delay. Loops: Stage Y's common/differential
pair (the mean rail velocity to the total current, the half difference to the differential current, i1 =
(i_c - i_d) / 2, i2 = (i_c + i_d) / 2) and the rotation PI on phi'. Margins of a channel are those of its loop with
the other channels closed, found on a dense logarithmic grid (crossings interpolated linearly); stability from the
closed loop's eigenvalues with each delay a Pade approximant (python-control's ``pade``).
"""

from __future__ import annotations

from dataclasses import dataclass

import control
import numpy as np


@dataclass(frozen=True)
class Machine:
    beam_mass_kg: float = 16.0
    beam_inertia_kg_m2: float = 16.0 * 0.8**2 / 12
    carriage_mass_kg: float = 56.0
    carriage_inertia_kg_m2: float = 0.0
    rail_separation_m: float = 0.8
    carriage_position_m: float = 0.4
    damping1_n_s_per_m: float = 440.0
    damping2_n_s_per_m: float = 440.0
    force_constant_n_per_a: float = 20.0
    yaw_stiffness_n_m_per_rad: float = 2.0e5
    y_delay_s: float = 0.0005
    y_current_loop_hz: float = 1000.0
    rotation_inertia_kg_m2: float = 0.05
    rotation_damping_n_m_s_per_rad: float = 0.05
    torque_constant_n_m_per_a: float = 2.0
    rotation_delay_s: float = 0.0005
    rotation_current_loop_hz: float = 1000.0


def mechanics(m: Machine):
    """(A, B, C): states (v_g, theta, theta', psi'), inputs (f1, f2, tau), outputs (v1, v2, phi')."""
    L, p = m.rail_separation_m, m.carriage_position_m
    M = m.beam_mass_kg + m.carriage_mass_kg
    sg = (m.beam_mass_kg * L / 2 + m.carriage_mass_kg * p) / M
    J = (m.beam_inertia_kg_m2 + m.carriage_inertia_kg_m2 + m.beam_mass_kg * (L / 2 - sg) ** 2
         + m.carriage_mass_kg * (p - sg) ** 2)
    b1, b2, br = m.damping1_n_s_per_m, m.damping2_n_s_per_m, m.rotation_damping_n_m_s_per_rad
    C = np.array([[1.0, 0, -sg, 0], [1.0, 0, L - sg, 0], [0, 0, -1.0, 1.0]])
    v1, v2, phi = C                                  # each output as a row over the states
    A = np.zeros((4, 4))
    B = np.zeros((4, 3))
    A[0] = (-b1 * v1 - b2 * v2) / M
    B[0] = [1 / M, 1 / M, 0]
    A[1, 2] = 1.0
    A[2] = (sg * b1 * v1 - (L - sg) * b2 * v2 + br * phi) / J
    A[2, 1] -= m.yaw_stiffness_n_m_per_rad / J
    B[2] = [-sg / J, (L - sg) / J, -1 / J]
    A[3] = -br * phi / m.rotation_inertia_kg_m2
    B[3] = [0, 0, 1 / m.rotation_inertia_kg_m2]
    return A, B, C


def plant_frd(w_rad_s, m: Machine) -> np.ndarray:
    """Velocities (v1, v2, phi') per current (i1, i2, i_r), (3, 3, n_freq), the delays exact."""
    A, B, C = mechanics(m)
    s = 1j * np.asarray(w_rad_s, float)
    H = np.einsum("ij,fjk,kl->fil", C, np.linalg.inv(s[:, None, None] * np.eye(4) - A), B)
    wy, wr = 2 * np.pi * m.y_current_loop_hz, 2 * np.pi * m.rotation_current_loop_hz
    drive_y = m.force_constant_n_per_a * wy / (s + wy) * np.exp(-s * m.y_delay_s)
    drive_r = m.torque_constant_n_m_per_a * wr / (s + wr) * np.exp(-s * m.rotation_delay_s)
    H = H * np.stack([drive_y, drive_y, drive_r], axis=1)[:, None, :]
    return np.moveaxis(H, 0, -1)


@dataclass(frozen=True)
class Gains:
    kp_common: float
    ki_common: float
    kp_differential: float
    ki_differential: float
    kp_rotation: float
    ki_rotation: float


#: channel efforts (common, differential, rotation) -> currents (i1, i2, i_r); velocities -> channel measurements
T_IN = np.array([[0.5, -0.5, 0], [0.5, 0.5, 0], [0, 0, 1.0]])
T_OUT = np.array([[0.5, 0.5, 0], [-0.5, 0.5, 0], [0, 0, 1.0]])


def channel_loops(w_rad_s, m: Machine, g: Gains) -> np.ndarray:
    """Each channel's loop with the other two closed, (3, n_freq): common, differential, rotation."""
    s = 1j * np.asarray(w_rad_s, float)
    P = plant_frd(w_rad_s, m)
    pis = np.stack([g.kp_common + g.ki_common / s, g.kp_differential + g.ki_differential / s,
                    g.kp_rotation + g.ki_rotation / s])
    L = np.einsum("jf,jk,klf,lm->fjm", pis, T_OUT, P, T_IN)
    out = np.empty((3, s.size), complex)
    for j in range(3):
        o = [k for k in range(3) if k != j]
        rest = np.eye(2) + L[:, o][:, :, o]
        out[j] = L[:, j, j] - np.einsum("fk,fk->f", L[:, j, o], np.linalg.solve(rest, L[:, o, j][..., None])[..., 0])
    return out


def margins(loop: np.ndarray) -> tuple[float, float]:
    """(GM dB, PM deg) of a loop sampled on a dense grid: the least over every crossing, log|L| and the phase
    interpolated linearly between samples; the phase margin the rotation of the crossing's phase to -180 deg
    either way; inf where there is none."""
    mag = np.log(np.abs(loop))
    phase = np.unwrap(np.angle(loop))
    pm, gm = np.inf, np.inf
    for i in np.flatnonzero(np.sign(mag[:-1]) != np.sign(mag[1:])):
        t = mag[i] / (mag[i] - mag[i + 1])
        ph = np.degrees(phase[i] + t * (phase[i + 1] - phase[i]))
        wrapped = (ph + 180) % 360 - 180                    # the phase in [-180, 180)
        pm = min(pm, 180 - abs(wrapped))                    # the rotation that takes it to -180 deg
    shifted = phase + np.pi                                  # zero where the phase passes -180 deg (mod 360)
    k = np.round(shifted / (2 * np.pi))
    r = shifted - 2 * np.pi * k
    for i in np.flatnonzero((np.sign(r[:-1]) != np.sign(r[1:])) & (k[:-1] == k[1:])):
        t = r[i] / (r[i] - r[i + 1])
        gm = min(gm, -20 * np.log10(np.exp(mag[i] + t * (mag[i + 1] - mag[i]))))
    return gm, pm


def closed_loop_poles(m: Machine, g: Gains, *, pade_order: int = 8) -> np.ndarray:
    """Eigenvalues of the whole loop (python-control state space, each delay a Pade approximant)."""
    A, B, C = mechanics(m)
    mech = control.ss(A, B, C, np.zeros((3, 3)))
    wy, wr = 2 * np.pi * m.y_current_loop_hz, 2 * np.pi * m.rotation_current_loop_hz

    def drive(k, wc, tau):
        num, den = control.pade(tau, pade_order)
        return control.ss(control.tf([k * wc], [1, wc]) * control.tf(num, den))

    chain = control.append(drive(m.force_constant_n_per_a, wy, m.y_delay_s),
                           drive(m.force_constant_n_per_a, wy, m.y_delay_s),
                           drive(m.torque_constant_n_m_per_a, wr, m.rotation_delay_s))
    plant = mech * chain
    pis = control.append(*(control.ss(control.tf([kp, ki], [1, 0])) for kp, ki in
                           ((g.kp_common, g.ki_common), (g.kp_differential, g.ki_differential),
                            (g.kp_rotation, g.ki_rotation))))
    K = control.ss([], [], [], T_IN) * pis * control.ss([], [], [], T_OUT)
    return control.poles(control.feedback(plant * K, np.eye(3)))
