"""The mouse lab's bandwidth model of their admittance-controlled delta robot, reproduced in numpy.

Source: bsbrl/exoskeleton (Hope et al., Nature Methods 2024, MIT licence), live script
``1. Exoskeleton Design Optimization/Exoskeleton - 5. Bandwidth/Admittance3DoF_1axis_oursystemwithZps2Hzoh.mlx``.
For one Cartesian axis ``n`` of the robot (``Jinv_col = Jinv(:, n)``, ``J_col = J(:, n)``, s = jw)::

    Y_v   = (k_a s^2 + s) / (m_v s^2 + b_v s + k_v)          virtual admittance (m/s per N)
    Y_r   = 1 / (m_r s + b_r),  m_r = TSIM(n, n), b_r = 100 m_r  robot admittance
    C_pos = k_p_p + k_p_p/s + k_d_p s/(tc_p s + 1)              position loop (k_d_p = 0)
    C_vel = k_p_v + k_p_v/s + k_d_v s/(tc_v s + 1)              velocity loop (k_d_v = 0)
    H     = (1 - e^{-sT}) / (sT),  T = 0.01 s                    zero-order hold on output and on input
    A_i   = Y_r Jinv_col(i) k_g C_vel,  B_i = Jinv_col(i) H C_pos,  k_g = 1.4 N*m/A
    C = Y_v S_cal / s,  D = S_p / s,  E = sum_i J_col(i) A_i,  F = sum_i B_i A_i
    Y_a   = F C H_in S_f / (F C Z_ps + F D + E + 1),  Z_ps = m_ps s, m_ps = 0.01 kg

``Y_a`` is the apparent admittance, velocity of the robot per external force. This module evaluates every
term above on a frequency grid, with the delays kept exact (``e^{-sT}``, no Padé approximant), and gives the
"bandwidth" at which ``Y_a`` departs from ``Y_v`` (:func:`admittance_bandwidth_hz`).

Reproduced as written, quirks included:

* ``k_a = 1``, labelled "1 = no gain", puts a zero at s = -1 rad/s into ``Y_v``: MATLAB prints
  ``Y_v = (s^2 + s)/(0.04 s^2 + 0.4 s)``, i.e. ``(s + 1)/(0.04 s + 0.4)``, not ``1/(0.04 s + 0.4)``.
* The controllers use the proportional gain for the integral term too (``k_p + k_p/s``); the integral gains
  the script defines (``k_i_p = 0``, ``k_i_v = 30``) are never used. ``pos_ki`` / ``vel_ki`` = ``None``
  reproduces this; give a number to use a real integral gain.
* ``E`` sums ``J(i, n) Jinv(i, n)`` over i, the (n, n) entry of ``J' Jinv``, not of ``J Jinv`` = I.
* The printed outputs (``Jinv``, ``J``, ``JSIM``, ``TSIM`` at the pose (-0.4, -0.4, -0.6) m) come from the
  inverse kinematics of the folder ``Exoskeleton - 4. Dynamics``, whose ``IKinemDelta2.m`` mirrors Y
  (``Y = -Y``); the copy in the Bandwidth folder does not, and gives other matrices.
  :func:`delta_robot_matrices` mirrors by default so that it reproduces the printed numbers.

The sensor (``S_f``, ``S_p``: first-order lags with time constant 0), the output scaling ``S_cal = 1`` and the
derivative terms (gain 0) are kept as parameters with the script's values. The model takes the Jacobian
column, the robot mass and damping as parameters, so it can be fed another plant; it imports nothing from the
rest of the project.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Cartesian pose of the published analysis (m)
PUBLISHED_POSITION_M = (-0.4, -0.4, -0.6)


@dataclass(frozen=True)
class DeltaRobotMatrices:
    """The script's kinematic and mass matrices at one pose (rows: motors 1..3, columns: x, y, z)."""

    theta_rad: np.ndarray  # motor angles
    jinv: np.ndarray  # Jinv = inv(Jq) Jx, joint rate per Cartesian velocity (rad/m)
    j: np.ndarray  # J = inv(Jinv) (m/rad)
    jsim: np.ndarray  # JSIM = I_A (m_C/I_A J' + inv(J))
    tsim: np.ndarray  # TSIM = Jinv' JSIM = m_C I + I_A Jinv' Jinv, the Cartesian "mass" (kg)


def delta_robot_matrices(
    position_m: tuple[float, float, float] = PUBLISHED_POSITION_M,
    *,
    proximal_length_m: float = 0.34,
    distal_length_m: float = 0.656,
    base_radius_m: float = 0.19,
    platform_radius_m: float = 0.1,
    motor_angles_rad: tuple[float, float, float] = (6 * math.pi / 4, math.pi / 6, 5 * math.pi / 6),
    proximal_mass_per_length_kg_per_m: float = 0.5,
    distal_mass_per_length_kg_per_m: float = 0.5,
    elbow_mass_kg: float = 0.1,
    platform_mass_kg: float = 1.0,
    gearbox_inertia_kg_m2: float = 0.17,
    mirror_y_in_ik: bool = True,
) -> DeltaRobotMatrices:
    """Jinv, J, JSIM and TSIM of the script (IKinemDelta2, Zhangvectors, DeltaJacobian2; Zhang et al. 2012).

    Defaults are the published parameters; ``mirror_y_in_ik`` selects the ``Y = -Y`` variant of
    ``IKinemDelta2.m`` that produced the printed outputs. Raises ValueError if the pose is unreachable.
    """
    lp, ld, rf, rm = proximal_length_m, distal_length_m, base_radius_m, platform_radius_m
    x, y, z = (float(v) for v in position_m)
    y_ik = -y if mirror_y_in_ik else y

    def motor_angle(x0: float, y0: float, z0: float) -> float:
        y1 = -rf
        y0 = y0 - rm
        a = (x0**2 + y0**2 + z0**2 + lp**2 - ld**2 - y1**2) / (2 * z0)
        b = (y1 - y0) / z0
        disc = -((a + b * y1) ** 2) + lp**2 * (b**2 + 1)
        if disc < 0:
            raise ValueError(f"pose {position_m} is out of the workspace")
        yj = (y1 - a * b - math.sqrt(disc)) / (b**2 + 1)
        zj = a + b * yj
        theta = math.atan(-zj / (y1 - yj))
        return theta + math.pi if yj > y1 else theta

    c, s = math.cos(2 * math.pi / 3), math.sin(2 * math.pi / 3)
    theta = np.array(
        [
            motor_angle(x, y_ik, z),
            motor_angle(x * c + y_ik * s, y_ik * c - x * s, z),
            motor_angle(x * c - y_ik * s, y_ik * c + x * s, z),
        ]
    )
    kappa = np.asarray(motor_angles_rad, float)
    r = np.array([x, y, z])
    e = (rf - rm) * np.stack([np.cos(kappa), np.sin(kappa), np.zeros(3)], axis=1)
    u = np.stack([np.cos(kappa) * np.cos(theta), np.sin(kappa) * np.cos(theta), -np.sin(theta)], axis=1)
    w = (r - e - lp * u) / ld
    v = np.stack([-np.sin(kappa), np.cos(kappa), np.zeros(3)], axis=1)
    jq = np.diag(lp * np.einsum("ij,ij->i", w, np.cross(v, u)))
    jinv = np.linalg.solve(jq, w)
    j = np.linalg.inv(jinv)
    i_a = (
        gearbox_inertia_kg_m2
        + proximal_mass_per_length_kg_per_m * lp**3 / 3
        + elbow_mass_kg * lp**2
        + 4 * distal_mass_per_length_kg_per_m * ld * lp**2 / 3
    )
    jsim = i_a * (platform_mass_kg / i_a * j.T + np.linalg.inv(j))
    return DeltaRobotMatrices(theta_rad=theta, jinv=jinv, j=j, jsim=jsim, tsim=jinv.T @ jsim)


def _lag(tc_s: float, s: np.ndarray) -> np.ndarray:
    return 1.0 / (tc_s * s + 1.0)


def _pid(kp: float, ki: float | None, kd: float, tc_s: float, s: np.ndarray) -> np.ndarray:
    return kp + (kp if ki is None else ki) / s + kd * s / (tc_s * s + 1.0)


def _zoh(t_s: float, s: np.ndarray) -> np.ndarray:
    return -np.expm1(-s * t_s) / (s * t_s)  # (1 - e^{-sT})/(sT), exact delay, accurate at small sT


@dataclass(frozen=True)
class LabBandwidthModel:
    """One Cartesian axis of the lab's model. Defaults: the published parameters for axis n = 1 (x).

    All frequency methods take angular frequencies ``w_rad_s`` (> 0, any shape) and return complex
    responses at s = jw of the same shape (``a_frd``/``b_frd``: a leading axis of 3, one row per motor).
    """

    jinv_col_rad_per_m: tuple[float, float, float] = (3.09263279, -2.17778052, -0.139824195)  # Jinv(:, 1)
    j_col_m_per_rad: tuple[float, float, float] = (0.811632966, -1.9620539, 1.8809074)  # J(:, 1)
    robot_mass_kg: float = 4.41929149  # m_r = TSIM(1, 1)
    robot_damping_n_s_per_m: float | None = None  # b_r; None: 100 m_r as in the script
    virtual_mass_kg: float = 0.04  # m_v
    virtual_damping_n_s_per_m: float = 0.4  # b_v
    virtual_stiffness_n_per_m: float = 0.0  # k_v
    accel_gain_k_a_s: float = 1.0  # k_a (s): 1 is a zero at -1 rad/s, not "no gain"
    pos_kp: float = 1.0  # k_p_p
    pos_ki: float | None = None  # None: k_p_p, the script's quirk
    pos_kd: float = 0.0  # k_d_p
    pos_tc_s: float = 0.1  # tc_p
    vel_kp: float = 50.0  # k_p_v
    vel_ki: float | None = None  # None: k_p_v, the script's quirk
    vel_kd: float = 0.0  # k_d_v
    vel_tc_s: float = 0.1  # tc_v
    motor_constant_nm_per_a: float = 1.4  # k_g, the current loop is perfect: C_fb_i = k_g
    hold_time_s: float = 0.01  # T of H_zoh (output)
    hold_in_time_s: float | None = None  # T of H_zohin; None: = hold_time_s
    force_sensor_tc_s: float = 0.0  # S_f = 1/(tc s + 1)
    position_sensor_tc_s: float = 0.0  # S_p = 1/(tc s + 1)
    output_scale: float = 1.0  # S_cal
    post_sensor_mass_kg: float = 0.01  # m_ps, Z_ps = m_ps s

    @classmethod
    def published(cls, axis: int = 1, matrices: DeltaRobotMatrices | None = None) -> LabBandwidthModel:
        """The script's model for Cartesian axis ``axis`` (1, 2, 3 = x, y, z) at the published pose."""
        if axis not in (1, 2, 3):
            raise ValueError(f"axis must be 1, 2 or 3, not {axis!r}")
        mats = delta_robot_matrices() if matrices is None else matrices
        k = axis - 1
        return cls(
            jinv_col_rad_per_m=tuple(float(v) for v in mats.jinv[:, k]),
            j_col_m_per_rad=tuple(float(v) for v in mats.j[:, k]),
            robot_mass_kg=float(mats.tsim[k, k]),
        )

    @property
    def b_r(self) -> float:
        """Robot damping b_r (N*s/m)."""
        if self.robot_damping_n_s_per_m is None:
            return 100.0 * self.robot_mass_kg
        return self.robot_damping_n_s_per_m

    @staticmethod
    def _s(w_rad_s) -> np.ndarray:
        w = np.asarray(w_rad_s, float)
        if not np.all(np.isfinite(w)) or np.any(w <= 0):
            raise ValueError("frequencies must be finite and > 0 rad/s (the loops have poles at s = 0)")
        return 1j * w

    def virtual_admittance_frd(self, w_rad_s) -> np.ndarray:
        """Y_v(jw) (m/s per N)."""
        s = self._s(w_rad_s)
        num = self.accel_gain_k_a_s * s**2 + s
        return num / (self.virtual_mass_kg * s**2 + self.virtual_damping_n_s_per_m * s + self.virtual_stiffness_n_per_m)

    def robot_admittance_frd(self, w_rad_s) -> np.ndarray:
        """Y_r(jw) = 1/(m_r s + b_r)."""
        s = self._s(w_rad_s)
        return 1.0 / (self.robot_mass_kg * s + self.b_r)

    def pos_controller_frd(self, w_rad_s) -> np.ndarray:
        """C_fb_pos(jw)."""
        return _pid(self.pos_kp, self.pos_ki, self.pos_kd, self.pos_tc_s, self._s(w_rad_s))

    def vel_controller_frd(self, w_rad_s) -> np.ndarray:
        """C_fb_vel(jw) (one diagonal entry)."""
        return _pid(self.vel_kp, self.vel_ki, self.vel_kd, self.vel_tc_s, self._s(w_rad_s))

    def zoh_frd(self, w_rad_s) -> np.ndarray:
        """H_zoh(jw) = (1 - e^{-jwT})/(jwT) on the output (exact delay)."""
        return _zoh(self.hold_time_s, self._s(w_rad_s))

    def zoh_in_frd(self, w_rad_s) -> np.ndarray:
        """H_zohin(jw), the hold on the input."""
        t = self.hold_time_s if self.hold_in_time_s is None else self.hold_in_time_s
        return _zoh(t, self._s(w_rad_s))

    def a_frd(self, w_rad_s) -> np.ndarray:
        """A(i)(jw) = Y_r Jinv_col(i) k_g C_fb_vel, shape (3, *w.shape)."""
        common = self.robot_admittance_frd(w_rad_s) * self.motor_constant_nm_per_a * self.vel_controller_frd(w_rad_s)
        return np.multiply.outer(np.asarray(self.jinv_col_rad_per_m, float), common)

    def b_frd(self, w_rad_s) -> np.ndarray:
        """B{i}(jw) = Jinv_col(i) H_zoh C_fb_pos, shape (3, *w.shape)."""
        common = self.zoh_frd(w_rad_s) * self.pos_controller_frd(w_rad_s)
        return np.multiply.outer(np.asarray(self.jinv_col_rad_per_m, float), common)

    def c_frd(self, w_rad_s) -> np.ndarray:
        """C(jw) = Y_v S_cal / s."""
        s = self._s(w_rad_s)
        return self.virtual_admittance_frd(w_rad_s) * self.output_scale / s

    def d_frd(self, w_rad_s) -> np.ndarray:
        """D(jw) = S_p / s."""
        s = self._s(w_rad_s)
        return _lag(self.position_sensor_tc_s, s) / s

    def e_frd(self, w_rad_s) -> np.ndarray:
        """E(jw) = sum_i J_col(i) A(i)."""
        return np.tensordot(np.asarray(self.j_col_m_per_rad, float), self.a_frd(w_rad_s), axes=1)

    def f_frd(self, w_rad_s) -> np.ndarray:
        """F(jw) = sum_i B{i} A(i)."""
        return np.sum(self.b_frd(w_rad_s) * self.a_frd(w_rad_s), axis=0)

    def apparent_admittance_frd(self, w_rad_s) -> np.ndarray:
        """Y_a(jw) = F C H_zohin S_f / (F C Z_ps + F D + E + 1) (m/s per N), exact delays."""
        s = self._s(w_rad_s)
        f, c = self.f_frd(w_rad_s), self.c_frd(w_rad_s)
        num = f * c * self.zoh_in_frd(w_rad_s) * _lag(self.force_sensor_tc_s, s)
        den = f * c * (self.post_sensor_mass_kg * s) + f * self.d_frd(w_rad_s) + self.e_frd(w_rad_s) + 1.0
        return num / den


def _departure(model: LabBandwidthModel, w: np.ndarray, mag_db: float, phase_deg: float) -> np.ndarray:
    """max(|gain error| / mag_db, |phase error| / phase_deg) of Y_a/Y_v: >= 1 where Y_a has departed."""
    ratio = model.apparent_admittance_frd(w) / model.virtual_admittance_frd(w)
    return np.maximum(np.abs(20 * np.log10(np.abs(ratio))) / mag_db, np.abs(np.angle(ratio, deg=True)) / phase_deg)


def admittance_bandwidth_hz(
    model: LabBandwidthModel,
    *,
    f_min_hz: float = 1e-3,
    f_max_hz: float = 1e3,
    points: int = 4000,
    mag_db: float = 3.0,
    phase_deg: float = 30.0,
) -> float:
    """First frequency (Hz) where |20 log10|Y_a/Y_v|| >= ``mag_db`` or |angle(Y_a/Y_v)| >= ``phase_deg``.

    Scans a log grid of ``points`` from ``f_min_hz`` to ``f_max_hz`` and refines the first crossing by
    bisection (to 1e-9 relative). Returns ``math.inf`` if Y_a stays within both bounds up to ``f_max_hz``;
    raises ValueError if it has already departed at ``f_min_hz``.
    """
    if not 0 < f_min_hz < f_max_hz or points < 2 or mag_db <= 0 or phase_deg <= 0:
        raise ValueError("need 0 < f_min_hz < f_max_hz, points >= 2 and positive bounds")
    f = np.geomspace(f_min_hz, f_max_hz, points)
    out = _departure(model, 2 * np.pi * f, mag_db, phase_deg) >= 1.0
    if out[0]:
        raise ValueError(f"Y_a already departs from Y_v at f_min_hz = {f_min_hz} Hz")
    if not out.any():
        return math.inf
    k = int(np.argmax(out))
    lo, hi = float(f[k - 1]), float(f[k])
    while hi - lo > 1e-9 * hi:
        mid = math.sqrt(lo * hi)
        if _departure(model, np.array([2 * np.pi * mid]), mag_db, phase_deg)[0] >= 1.0:
            hi = mid
        else:
            lo = mid
    return hi
