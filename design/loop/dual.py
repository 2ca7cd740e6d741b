"""Velocity loops of the two-motor Stage Y (``plant.physics.dual_drive``): the controller structures a
drive offers for a gantry, and what the closed loop does, from 2 x 2 frequency responses.

Signals: rail velocities y = (v1, v2) (m/s), motor currents u = (i1, i2) (A), u = C (r [1, 1] - y) with
the translation command r on both rails. Structures (gains as python-control's PI, kp + ki / s):

* ``PerMotor``: the same PI on each motor from its own rail, C = c I; the yaw is left to the mechanics'
  and the two loops' agreement.
* ``CommonDifferential``: translation on the mean v_c = (v1 + v2) / 2 with the total current
  i_c = i1 + i2, yaw on the half difference v_d = (v2 - v1) / 2 with i_d = i2 - i1:
  C = T_in diag(c_c, c_d) T_out, T_out = [[1/2, 1/2], [-1/2, 1/2]], T_in = [[1/2, -1/2], [1/2, 1/2]].
  Its common loop is the one-loop Stage Y of the thesis (Eq. 3.16 on the total current); equal gains
  c_c = c_d = 2 c are ``PerMotor`` with c.
* ``MasterSlave``: one PI on the master rail's velocity v1 commands the total current, shared equally
  (the slave drive copies the master's current): C = [[c/2, 0], [c/2, 0]].

Each structure is C = T_in diag(PI_1, .., PI_n) T_out. It is judged by the loop-at-a-time margins of
each of its n channels with the other closed (l_j = L_jj - L_jk L_kj / (1 + L_kk) of
L = diag(PI) T_out P T_in: the loops a drive engineer tunes); at the plant inputs, where the motors are,
by the simultaneous (balanced, skew 0) disk margin alpha = 1 / max_w mu(S - I / 2), S = (I + C P)^-1, mu
for a diagonal complex perturbation (Seiler, Packard & Gahinet 2020; ``mu_diagonal``); and by MIMO
Nyquist stability from the winding of det(I + P C) (``mimo_unstable_poles``). Translation bandwidth:
the -3 dB frequency of r -> v_c; yaw coupling: the peak of |r -> v_d|.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from design.loop.controller import PI
from design.loop.margins import closed_loop_bandwidth_hz, crossover_margins, delay_margin_s
from plant.physics.effect_base import balanced

#: T_out: rail velocities -> (mean, half difference); T_in: (total, differential current) -> motor currents
T_OUT = np.array([[0.5, 0.5], [-0.5, 0.5]])
T_IN = np.array([[0.5, -0.5], [0.5, 0.5]])


@dataclass(frozen=True)
class _Structure:
    """C = T_in diag(PI_1, ..., PI_n) T_out: n PI channels between the rails and the motors."""

    t_in: ClassVar[np.ndarray]
    t_out: ClassVar[np.ndarray]

    def channels(self) -> tuple[PI, ...]:
        """Each channel's PI (A/(m/s), A/m)."""
        raise NotImplementedError

    def gains(self) -> dict[str, float]:
        """The gains by name (A/(m/s), A/m)."""
        return {f.name: float(getattr(self, f.name)) for f in dataclasses.fields(self)}

    @property
    def parameters(self) -> np.ndarray:
        """The gains in field order, what a synthesis searches over."""
        return np.array(list(self.gains().values()))

    def tf(self, period_s: float | None = None):
        """C as a python-control state-space model, motor currents (2) per rail velocity error (2): T_in, each
        channel's PI (``PI.tf``, or with ``period_s`` the drive's discrete ``PI.discrete``), T_out."""
        import control

        parts = [control.ss(c.tf() if period_s is None else c.discrete(period_s)) for c in self.channels()]
        core = parts[0] if len(parts) == 1 else control.append(*parts)
        dt = 0 if period_s is None else period_s
        return control.ss([], [], [], self.t_in, dt) * core * control.ss([], [], [], self.t_out, dt)

    def channel_frd(self, w_rad_s) -> np.ndarray:
        """diag(PI_j(jw)) as (..., n, n, n_freq); gains given as arrays give a batch of controllers."""
        return self.channel_at(1j * np.asarray(w_rad_s, float))

    def channel_at(self, s) -> np.ndarray:
        """diag(PI_j(s)) at complex ``s`` (``channel_frd``)."""
        s = np.asarray(s, complex)
        k = [c.at(s) for c in self.channels()]
        shape = np.broadcast_shapes(*(c.shape for c in k))
        out = np.zeros(shape[:-1] + (len(k), len(k), shape[-1]), dtype=complex)
        for j, c in enumerate(k):
            out[..., j, j, :] = c
        return out

    def frd(self, w_rad_s) -> np.ndarray:
        """C(jw), shape (..., 2, 2, n_freq): motor currents per rail velocity error."""
        return self.at(1j * np.asarray(w_rad_s, float))

    def at(self, s) -> np.ndarray:
        """C(s) at complex ``s`` (``frd``)."""
        return matmul(matmul(self.t_in, self.channel_at(s)), self.t_out)


@dataclass(frozen=True)
class PerMotor(_Structure):
    """The same PI on each motor from its own rail: kp in A/(m/s), ki in A/m."""

    kp: float
    ki: float
    name: ClassVar[str] = "per_motor"
    t_in: ClassVar[np.ndarray] = np.eye(2)
    t_out: ClassVar[np.ndarray] = np.eye(2)

    def channels(self):
        return (PI(self.kp, self.ki),) * 2


@dataclass(frozen=True)
class CommonDifferential(_Structure):
    """A PI on the translation (total current per mean velocity) and one on the yaw (differential current per
    half difference of the rail velocities); A/(m/s) and A/m."""

    kp_common: float
    ki_common: float
    kp_differential: float
    ki_differential: float
    name: ClassVar[str] = "common_differential"
    t_in: ClassVar[np.ndarray] = T_IN
    t_out: ClassVar[np.ndarray] = T_OUT

    def channels(self):
        return PI(self.kp_common, self.ki_common), PI(self.kp_differential, self.ki_differential)


@dataclass(frozen=True)
class MasterSlave(_Structure):
    """One PI on the master rail Y1's velocity; the total current shared equally by both motors."""

    kp: float
    ki: float
    name: ClassVar[str] = "master_slave"
    t_in: ClassVar[np.ndarray] = np.array([[0.5], [0.5]])
    t_out: ClassVar[np.ndarray] = np.array([[1.0, 0.0]])

    def channels(self):
        return (PI(self.kp, self.ki),)


Controller = PerMotor | CommonDifferential | MasterSlave
#: each structure's class by its name
BY_NAME = {c.name: c for c in (PerMotor, CommonDifferential, MasterSlave)}


@dataclass(frozen=True)
class DualLoopFigures:
    """What a structure's loop does on a batch of plants (arrays of the batch shape)."""

    #: closed-loop poles in the right half-plane (0: stable), from the winding of det(I + P C)
    unstable_poles: np.ndarray
    #: loop-at-a-time margins at the motor inputs, the other loop closed: the worse of the two inputs
    gain_margin_db: np.ndarray
    phase_margin_deg: np.ndarray
    #: simultaneous balanced disk margin at both motor inputs, and its gain/phase forms
    disk_margin: np.ndarray
    disk_gain_margin_db: np.ndarray
    disk_phase_margin_deg: np.ndarray
    #: -3 dB bandwidth of the translation command to the mean rail velocity (Hz)
    bandwidth_hz: np.ndarray
    #: peak over frequency of |v_d / r|: rail disagreement per unit translation command
    yaw_coupling: np.ndarray
    #: margins against the same gain or phase change on both motor inputs at once (both force constants, both
    #: drives' lag): those of the characteristic loci of L = C P (``common_loci``), the worse locus
    common_gain_margin_db: np.ndarray
    common_phase_margin_deg: np.ndarray
    #: the least extra delay (s) common to both drives that brings the loop to the stability boundary
    common_delay_margin_s: np.ndarray


def matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Products of small matrices stored as (..., m, k, n_freq) and (..., k, n, n_freq), a constant matrix
    given as (m, k) (element by element over the frequencies: faster than einsum for 2 x 2; a constant's
    zeros skipped, its ones not multiplied, an identity returns the other factor)."""
    if a.ndim == 2 or b.ndim == 2:
        return _constant_matmul(a, b)
    m, k, n = a.shape[-3], a.shape[-2], b.shape[-2]
    batch = np.broadcast_shapes(a.shape[:-3], b.shape[:-3])
    out = np.empty(batch + (m, n, max(a.shape[-1], b.shape[-1])), dtype=np.result_type(a, b))
    for i in range(m):
        for j in range(n):
            s = a[..., i, 0, :] * b[..., 0, j, :]
            for q in range(1, k):
                s = s + a[..., i, q, :] * b[..., q, j, :]
            out[..., i, j, :] = s
    return out


def _constant_matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``matmul`` with one factor a constant (m, k) matrix."""
    left = a.ndim == 2
    const, x = (a, b) if left else (b, a)
    if const.shape[0] == const.shape[1] and np.array_equal(const, np.eye(const.shape[0])):
        return x
    m, n = (const.shape[0], x.shape[-2]) if left else (x.shape[-3], const.shape[1])
    out = np.zeros(x.shape[:-3] + (m, n, x.shape[-1]), dtype=np.result_type(x, const))
    for i in range(m):
        for j in range(n):
            for q in range(const.shape[1] if left else const.shape[0]):
                c = const[i, q] if left else const[q, j]
                if c == 0:
                    continue
                term = x[..., q, j, :] if left else x[..., i, q, :]
                out[..., i, j, :] += term if c == 1 else c * term
    return out


def mu_diagonal(m11: np.ndarray, m22: np.ndarray, off_product: np.ndarray, det: np.ndarray) -> np.ndarray:
    """Structured singular value of 2 x 2 matrices M for a diagonal complex perturbation, from |m11|, |m22|,
    |m12 m21| and |det M| (arrays of one shape), exactly: for two complex blocks the D-scaled bound
    min_d sigma_max(D M D^-1) is mu (Doyle 1982), and with D = diag(d, 1) the Frobenius norm is least at
    d^2 = |m21| / |m12| while det M does not change, so mu^2 = (F + sqrt(F^2 - 4 |det M|^2)) / 2 with
    F = |m11|^2 + |m22|^2 + 2 |m12 m21|."""
    f = m11**2 + m22**2 + 2 * off_product
    return np.sqrt((f + np.sqrt(np.maximum(f**2 - 4 * det**2, 0.0))) / 2)


def mimo_unstable_poles(w_rad_s: np.ndarray, det: np.ndarray) -> np.ndarray:
    """Closed-loop poles in the right half-plane from det(I + L(jw)) (``(..., n_freq)``) on a rising grid
    that starts where the open loop's integrators dominate and ends where |det - 1| < 1, for open
    loops whose poles are in the left half-plane or at the origin.

    On the D-contour indented to the right of the origin, det ~ K s^-n near 0 (n: the integrators it
    shows, from the slope of |det| at the bottom of the grid) adds -180 n deg, positive and negative
    frequencies each the phase change D over the grid, and the large arc nothing; the argument
    principle gives Z = n / 2 - D / 180 deg. A count that is not close to an integer (a grid too coarse
    for the winding) or a grid that ends with |det - 1| >= 1 counts as one unstable pole."""
    w = np.asarray(w_rad_s, float)
    d = np.asarray(det)
    turn = np.angle(d[..., 1:] / d[..., :-1]).sum(axis=-1)
    slope = -np.log(np.abs(d[..., 1] / d[..., 0])) / np.log(w[1] / w[0])
    n = np.round(np.clip(slope, 0, None))
    z = n / 2 - turn / math.pi
    poles = np.round(z)
    bad = (np.abs(z - poles) > 0.25) | ~(np.abs(d[..., -1] - 1) < 1) | ~np.isfinite(z)
    return np.where(bad, np.maximum(poles, 1), np.maximum(poles, 0)).astype(int)


def common_loci(l11: np.ndarray, l12: np.ndarray, l21: np.ndarray, l22: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The characteristic loci of 2 x 2 loops L(jw) (entries (..., n_freq)): the eigenvalues at each frequency,
    continued from one frequency to the next (a pair swaps where the crossed pairing is the nearer). The same
    complex factor k on both loop inputs gives det(I + k L) = (1 + k lambda_1)(1 + k lambda_2), so the margins
    of each locus as a single loop are the margins against a change common to both inputs (MacFarlane &
    Postlethwaite 1977)."""
    half = (l11 + l22) / 2
    root = np.sqrt(half * half - (l11 * l22 - l12 * l21))
    r1, r2 = half + root, half - root
    same = np.abs(r1[..., 1:] - r1[..., :-1]) + np.abs(r2[..., 1:] - r2[..., :-1])
    crossed = np.abs(r1[..., 1:] - r2[..., :-1]) + np.abs(r2[..., 1:] - r1[..., :-1])
    flip = np.concatenate([np.zeros(r1.shape[:-1] + (1,), bool), crossed < same], axis=-1)
    odd = (np.cumsum(flip, axis=-1) % 2).astype(bool)
    return np.where(odd, r2, r1), np.where(odd, r1, r2)


#: a characteristic locus below this fraction of the other everywhere is a loop that is not there (the rounding of
#: a rank-one structure's zero eigenvalue: master-slave drives both motors from one channel)
NO_LOOP = 1e-9


@dataclass(frozen=True)
class ChannelForm:
    """Plants (..., 2, 2, n_freq) seen through a loop structure's fixed transforms (``t_in``, ``t_out``): what
    ``loop_figures`` needs of them whatever the gains, computed once for a scan over gains on the same plants
    (``take`` selects plants without recomputing)."""

    t_in: np.ndarray
    t_out: np.ndarray
    #: T_out P, T_out P T_in (the channels' plant) and T_OUT P T_in (channel efforts -> mean, half difference)
    B: np.ndarray
    Q: np.ndarray
    move: np.ndarray

    @staticmethod
    def of(plant_frd: np.ndarray, structure: type[Controller] | Controller) -> ChannelForm:
        P = np.asarray(plant_frd)
        t_in, t_out = structure.t_in, structure.t_out
        B = matmul(t_out, P)
        return ChannelForm(t_in, t_out, B, matmul(B, t_in), matmul(matmul(T_OUT, P), t_in))

    def take(self, rows) -> ChannelForm:
        return dataclasses.replace(self, B=self.B[rows], Q=self.Q[rows], move=self.move[rows])


def loop_figures(w_rad_s, plant_frd: np.ndarray | ChannelForm, controller: Controller, *, disk: bool = True,
                 common: bool = True) -> DualLoopFigures:
    """``DualLoopFigures`` of ``controller`` on plants ``plant_frd`` (..., 2, 2, n_freq), both on ``w_rad_s``; a
    controller with gains shaped (k, 1) and plants (s, 2, 2, n_freq) give figures shaped (k, s). ``disk``
    False leaves the disk margin out (NaN), the dearest figure.

    In channel form: with Q = T_out P T_in (per plant) and D = diag(PI_j), L = D Q is the channels' loop,
    det(I + C P) = det(I + D Q) (Sylvester), the channel efforts for a translation command are
    u = (I + D Q)^-1 D T_out [1, 1]^T and the rails move T_OUT P T_in u; the disk margin's sensitivity at the
    motor inputs is S = I - T_in (I + D Q)^-1 D T_out P (push-through identity)."""
    w = np.asarray(w_rad_s, float)
    form = plant_frd if isinstance(plant_frd, ChannelForm) else ChannelForm.of(plant_frd, controller)
    if form.t_in is not controller.t_in or form.t_out is not controller.t_out:
        raise ValueError(f"plants in another structure's channel form than {type(controller).__name__}'s")
    t_in, t_out, B, Q, move = controller.t_in, controller.t_out, form.B, form.Q, form.move
    d = [c.frd(w) for c in controller.channels()]
    r = t_out.sum(axis=1)                                       # T_out [1, 1]^T: the command per channel
    if len(d) == 1:
        a = d[0] * Q[..., 0, 0, :]
        det = 1 + a
        channels = [a]
        u = [d[0] * r[0] / det]
    else:
        a, b = d[0] * Q[..., 0, 0, :], d[0] * Q[..., 0, 1, :]
        c, e = d[1] * Q[..., 1, 0, :], d[1] * Q[..., 1, 1, :]
        bc = b * c
        det = (1 + a) * (1 + e) - bc
        channels = [a - bc / (1 + e), e - bc / (1 + a)]     # each channel broken, the other closed
        v = [d[0] * r[0], d[1] * r[1]]
        u = [((1 + e) * v[0] - b * v[1]) / det, ((1 + a) * v[1] - c * v[0]) / det]
    unstable = mimo_unstable_poles(w, det)
    margins = [crossover_margins(w, lj) for lj in channels]
    mean_motion = sum(move[..., 0, j, :] * u[j] for j in range(len(u)))
    half_difference = sum(move[..., 1, j, :] * u[j] for j in range(len(u)))
    bandwidth = closed_loop_bandwidth_hz(w, mean_motion, dc_gain=1.0)
    nan = np.full(np.shape(bandwidth), np.nan)
    alpha, disk_gm, disk_pm, common_gm, common_pm, common_dm = nan, nan, nan, nan, nan, nan
    if disk:
        # L = C P = T_in D T_out P at the motor inputs
        L = matmul(t_in, np.stack(np.broadcast_arrays(*(dj[..., None, :] * row for dj, row in
                                                        zip(d, np.moveaxis(B, -3, 0)))), axis=-3))
        l11, l22, off = L[..., 0, 0, :], L[..., 1, 1, :], L[..., 0, 1, :] * L[..., 1, 0, :]
        # S - I / 2 = adj(I + L) / det(I + L) - I / 2 and det(S - I / 2) = det(I - L) / (4 det(I + L)), with
        # det(I + L) = det(I + D Q) above
        inv_det = 1 / det
        minus = 1 - l11 - l22 + l11 * l22 - off
        mu = mu_diagonal(np.abs((1 + l22) * inv_det - 0.5), np.abs((1 + l11) * inv_det - 0.5),
                         np.abs(off * inv_det**2), np.abs(minus * inv_det) / 4)
        alpha = 1.0 / mu.max(axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            disk_gm = np.where(alpha < 2, 20 * np.log10((2 + alpha) / (2 - alpha)), np.inf)
            disk_pm = np.degrees(2 * np.arctan(alpha / 2))
    if common:
        # the eigenvalues of L = T_in (D T_out P) are those of the channels' loop D Q = (D T_out P) T_in with
        # zeros added (the nonzero eigenvalues of a product do not depend on its order): the loci of D Q, and
        # with one channel its loop and the zero locus
        zero = np.zeros_like(a)
        loci = common_loci(a, b, c, e) if len(d) == 2 else common_loci(a, zero, zero, zero)
        each = []
        for locus, other in (loci, loci[::-1]):
            # a locus at rounding level of the other everywhere is the zero eigenvalue of a rank-one loop
            absent = np.all(np.abs(locus) <= NO_LOOP * np.abs(other), axis=-1)
            safe = np.where(np.abs(locus) == 0, 1e-300, locus)
            figures = (*crossover_margins(w, safe), delay_margin_s(w, safe))
            each.append(tuple(np.where(absent, np.inf, m) for m in figures))
        common_gm, common_pm, common_dm = (np.minimum(each[0][k], each[1][k]) for k in range(3))
    return DualLoopFigures(unstable, np.minimum.reduce([m[0] for m in margins]),
                           np.minimum.reduce([m[1] for m in margins]), alpha, disk_gm, disk_pm,
                           bandwidth, np.abs(half_difference).max(axis=-1), common_gm, common_pm, common_dm)


def translation_step(plant, controller: Controller, t_s: np.ndarray, *, pade_order: int = 6):
    """Rail velocities (2, n) after a unit step of the translation command (m/s per m/s), by python-control on
    one plant (``plant.physics.dual_drive.DualDriveStageY``; its delays as Pade approximants of
    ``pade_order``); the yaw error is their difference."""
    import control


    chain = control.tf([1.0], [1.0])
    for e in plant.effects:
        chain = chain * e.to_tf(pade_order=pade_order)
    drive = control.ss(chain)
    P = plant.state_space() * control.append(drive, drive)
    C = controller.tf()
    loop = balanced(control.feedback(P * C, np.eye(2)) * control.ss([], [], [], np.ones((2, 1))))
    return control.forced_response(loop, t_s, np.ones_like(t_s)).outputs


def offset_ramp_a_per_s(plant, controller: Controller, *, rail: int = 0) -> float:
    """How fast the motors' half-difference current (i2 - i1) / 2 ramps (A/s) per m/s of a constant offset on rail
    ``rail``'s velocity sensor, on one plant (``plant.physics.dual_drive.DualDriveStageY``): the residue at s = 0 of
    the closed loop's response to the offset, -(I + C P)^-1 C e_rail, read at s = 1e-7 rad/s on the real axis
    (twice that, to tell a pole at 0 from a finite response: 0 when there is none). Integral action on both rails'
    velocities against the yaw spring leaves the loop such a pole: the offset makes the rails disagree, the
    beam yaws at a constant rate, and the integrators wind the motors against the spring without end."""
    def response(s: float) -> np.ndarray:
        z = np.array([complex(s)])
        k = plant.force_constants()[..., None, :, None]
        P = plant.point_mobility(z, carriage=False) * k * plant.chain(z, "drive") * plant.chain(z, "sensor")
        C = controller.at(z)
        M = np.eye(2) + matmul(C, P)[..., 0]
        u = -np.linalg.solve(M, C[..., rail, 0])
        return (u[1] - u[0]).real / 2

    s1 = 1e-7
    a, b = s1 * response(s1), 2 * s1 * response(2 * s1)
    return float(a) if abs(a - b) < 1e-3 * max(abs(a), 1e-300) else 0.0
