"""The gantry as one planar machine, from Lagrange's equations: the beam on its two rails, the X carriage on the
beam with its position a coordinate, the rotation stage on the carriage.

Generalised coordinates q = (y1, y2, p, phi) (m, m, m, rad): the rails' positions Y1 and Y2, ``rail_separation_m``
= L apart; the carriage's position p along the beam from Y1; the rotation stage's angle phi relative to the
carriage. The beam yaws by theta = (y2 - y1) / L (small: the joints' stiffness K_a holds it to micro-radians,
Xie & Wang, thesis Eq. 2.14-2.15), so a point at s along the beam is at y1 + s theta. Energies (SI units)::

    T = m_b ((y1' + y2') / 2)^2 / 2 + (J_b + J_c) theta'^2 / 2          the beam (middle) and the carriage's yaw
      + m_c (x_c'^2 + y_c'^2) / 2                                      the carriage with all it carries:
        x_c = p - e theta,  y_c = y1 + (theta + epsilon) p             its centre of mass
      + J_r (theta' + phi')^2 / 2                                      the rotation stage
    V = K_a theta^2 / 2
    R = (b1 y1'^2 + b2 y2'^2 + b_x p'^2 + b_r phi'^2) / 2              Rayleigh: the guides' and bearing's damping

Two geometric errors make X and Y meet at rest, both zero by default: the beam's skew epsilon (``beam_skew_rad``:
the beam not square to the rails, so the carriage moving along it moves along the rails by epsilon p; accelerating
it along the beam pushes the rails together) and the carriage's centre of mass off the X motor's line of force by e
(``carriage_offset_m``, along the rails: accelerating the carriage along the beam yaws it). With both zero the
carriage's coordinate meets no other at rest. The X motor's force does work on p alone (it acts between the beam and
the carriage along the beam), so both couplings enter through the mass matrix, reciprocally.

Each actuator's generalised force: the Y motors' f1, f2 on y1, y2 (their reaction on the ground); the X motor's
f_x on p (its reaction along the beam, which the rails hold: no work); the rotation motor's torque tau_r on phi
(relative: its reaction on the carriage is inside the coordinate, Q_theta gets nothing). A push on the clamp
(f_x, f_y at the carriage, the torque tau_m on the rotation stage) does the virtual work
f_x dx_c + f_y dy_c + tau_m (dtheta + dphi). Lagrange's equations, d/dt dT/dq' - dT/dq + dR/dq' + dV/dq = Q, are
derived symbolically (casadi): M(q) q'' = Q - (dM/dt q' - dT/dq) - D q' - K q, with the mass matrix changing as
the carriage moves.

``linearised(p)`` gives the state-space model at a carriage position (q' = 0): for frequency-domain work. With the
rotation stage's inertia zero, it is ``plant.physics.dual_drive.DualDriveStageY`` in y1, y2 (the same energies,
the tests hold it to it) and thesis Stage X in p: m_c p'' + b_x p' = f_x (Eq. 3.15); with both Y motors alike and
the carriage in the middle, thesis Stage Y (Eq. 3.16). ``dynamics`` is the full nonlinear right-hand side with the
carriage moving, for time-domain work.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from functools import cached_property

import casadi as ca
import numpy as np

from plant.errors import ParameterError
from plant.physics.parameters import check_positive

#: the largest beam skew the small-angle model takes (rad)
MAX_SKEW_RAD = 0.05
#: coordinates, actuator inputs and clamp loads, in order
COORDINATES = ("y1_m", "y2_m", "carriage_position_m", "rotation_rad")
ACTUATORS = ("force1_n", "force2_n", "force_x_n", "torque_rotation_n_m")
CLAMP = ("clamp_force_x_n", "clamp_force_y_n", "clamp_torque_n_m")


@dataclass(frozen=True)
class PlanarGantry:
    """The planar gantry's mechanics (module doc); one machine (scalars), SI units. Defaults as
    ``DualDriveStageY``'s, the rotation stage's as assumptions: a small stage of 2e-3 kg m^2 on a bearing damped
    with 0.01 N*m*s/rad (no published value; edit for your rig)."""

    beam_mass_kg: float = 16.0
    beam_inertia_kg_m2: float = 16.0 * 0.8**2 / 12
    #: Stage X's carriage with everything it carries (payload and rotation stage included), its own yaw inertia
    carriage_mass_kg: float = 35.0
    carriage_inertia_kg_m2: float = 0.0
    rail_separation_m: float = 0.8
    damping1_n_s_per_m: float = 440.0
    damping2_n_s_per_m: float = 440.0
    #: the X guides' damping (thesis Stage X: b)
    damping_x_n_s_per_m: float = 330.0
    yaw_stiffness_n_m_per_rad: float = 2.0e5
    rotation_inertia_kg_m2: float = 2.0e-3
    rotation_damping_n_m_s_per_rad: float = 0.01
    #: the beam's angle from square to the rails (rad; small: the model is linear in it), and the carriage's centre of
    #: mass off the X motor's line of force, along the rails (m): the two ways X and Y meet at rest (module doc)
    beam_skew_rad: float = 0.0
    carriage_offset_m: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if np.ndim(value) != 0:
                raise ParameterError(f"{f.name}: the planar model takes one machine (a number), got {value!r}")
            if f.name in ("beam_skew_rad", "carriage_offset_m"):
                limit = MAX_SKEW_RAD if f.name == "beam_skew_rad" else self.rail_separation_m / 2
                if not (math.isfinite(value) and abs(value) <= limit):
                    raise ParameterError(f"{f.name} must be finite and at most {limit:g} in size, got {value!r}")
                continue
            check_positive(f.name, value, allow_zero=f.name in ("carriage_inertia_kg_m2",
                                                                  "rotation_damping_n_m_s_per_rad"))

    def with_values(self, **values) -> PlanarGantry:
        return replace(self, **values)

    @cached_property
    def _lagrange(self):
        """casadi functions of (q, q', u, w): the mass matrix M(q), and the rest of the equations h with
        M q'' = h (u the actuators, w the clamp's loads)."""
        q, dq = ca.SX.sym("q", 4), ca.SX.sym("dq", 4)
        u, w = ca.SX.sym("u", 4), ca.SX.sym("w", 3)
        y1, y2, p, phi = (q[i] for i in range(4))
        L = self.rail_separation_m
        eps, e = self.beam_skew_rad, self.carriage_offset_m
        theta = (y2 - y1) / L
        dtheta = (dq[1] - dq[0]) / L
        xc, yc = p - e * theta, y1 + (theta + eps) * p
        dxc, dyc = dq[2] - e * dtheta, dq[0] + dq[2] * (theta + eps) + p * dtheta
        T = (self.beam_mass_kg * ((dq[0] + dq[1]) / 2) ** 2
             + (self.beam_inertia_kg_m2 + self.carriage_inertia_kg_m2) * dtheta**2
             + self.carriage_mass_kg * (dxc**2 + dyc**2)
             + self.rotation_inertia_kg_m2 * (dtheta + dq[3]) ** 2) / 2
        V = self.yaw_stiffness_n_m_per_rad * theta**2 / 2
        R = (self.damping1_n_s_per_m * dq[0] ** 2 + self.damping2_n_s_per_m * dq[1] ** 2
             + self.damping_x_n_s_per_m * dq[2] ** 2 + self.rotation_damping_n_m_s_per_rad * dq[3] ** 2) / 2
        # the clamp's virtual work at the carriage: f_x dx_c + f_y dy_c + tau_m (dtheta + dphi)
        work = w[0] * xc + w[1] * yc + w[2] * (theta + phi)
        Q = u + ca.jacobian(work, q).T
        dT = ca.gradient(T, dq)
        M = ca.jacobian(dT, dq)
        # d/dt dT/dq' = M q'' + (d dT/dq' / dq) q'
        h = Q - ca.jacobian(dT, q) @ dq + ca.gradient(T, q) - ca.gradient(R, dq) - ca.gradient(V, q)
        return ca.Function("mass", [q], [M]), ca.Function("rest", [q, dq, u, w], [h])

    def dynamics(self, q, dq, u, w=(0.0, 0.0, 0.0)) -> np.ndarray:
        """q'' (the coordinates' accelerations) at the state (q, q'), the actuators ``u`` (f1, f2, f_x in N, tau_r
        in N*m) and the clamp's loads ``w`` (f_x, f_y in N, tau_m in N*m): the nonlinear equations, the carriage
        free to move."""
        mass, rest = self._lagrange
        return np.linalg.solve(np.asarray(mass(q)), np.asarray(rest(q, dq, u, w)).ravel())

    def simulate(self, time_s, actuators, clamp=None, state0=None, *, rtol: float = 1e-9) -> np.ndarray:
        """The states (q, q') at the instants ``time_s`` (s, increasing) from ``state0`` (default rest with the
        carriage mid-beam), the actuators ``actuators`` (n_t, 4) and the clamp's loads ``clamp`` (n_t, 3) held
        from each instant to the next (zero-order hold), the nonlinear equations integrated interval by interval
        (``scipy.integrate.solve_ivp``, DOP853): (n_t, 8)."""
        from scipy.integrate import solve_ivp

        t = np.asarray(time_s, float)
        u = np.asarray(actuators, float).reshape(t.size, 4)
        w = np.zeros((t.size, 3)) if clamp is None else np.asarray(clamp, float).reshape(t.size, 3)
        x = np.zeros(8)
        x[2] = self.rail_separation_m / 2
        if state0 is not None:
            x = np.asarray(state0, float).reshape(8)
        out = np.empty((t.size, 8))
        out[0] = x
        for k in range(t.size - 1):
            sol = solve_ivp(lambda _, z, k=k: np.concatenate([z[4:], self.dynamics(z[:4], z[4:], u[k], w[k])]),
                            (t[k], t[k + 1]), out[k], method="DOP853", rtol=rtol, atol=rtol * 1e-3)
            out[k + 1] = sol.y[:, -1]
        return out

    def mass_matrix(self, carriage_position_m: float) -> np.ndarray:
        return np.asarray(self._lagrange[0]([0.0, 0.0, carriage_position_m, 0.0]))

    def matrices(self, carriage_position_m):
        """(M, D, K) of the linear model about rest (``matrices``) at ``carriage_position_m`` (m; an array gives a
        batch)."""
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        return matrices(carriage_position_m=carriage_position_m, **values)

    def linearised(self, carriage_position_m: float):
        """(A, B, C) about rest with the carriage at ``carriage_position_m`` (m from Y1, between the rails): states
        (q, q'), inputs (actuators, clamp loads: ``ACTUATORS + CLAMP``), outputs the coordinates' velocities
        (y1', y2', p', phi') and the carriage's lateral velocity y_c' (the point the mouse pushes)."""
        p0 = float(carriage_position_m)
        if not 0 < p0 < self.rail_separation_m:
            raise ParameterError(f"carriage_position_m must lie between the rails (0, {self.rail_separation_m:g}) m, "
                                 f"got {carriage_position_m!r}")
        mass, rest = self._lagrange
        q, dq, u, w = ca.SX.sym("q", 4), ca.SX.sym("dq", 4), ca.SX.sym("u", 4), ca.SX.sym("w", 3)
        acc = ca.solve(mass(q), rest(q, dq, u, w))
        x, v = ca.vertcat(q, dq), ca.vertcat(u, w)
        f = ca.vertcat(dq, acc)
        at = ca.Function("linear", [x, v], [ca.jacobian(f, x), ca.jacobian(f, v)])
        x0 = np.array([0.0, 0.0, p0, 0.0, 0.0, 0.0, 0.0, 0.0])
        A, B = (np.asarray(m) for m in at(x0, np.zeros(7)))
        L = self.rail_separation_m
        C = np.zeros((5, 8))
        C[:4, 4:] = np.eye(4)
        C[4, 4:7] = 1 - p0 / L, p0 / L, self.beam_skew_rad      # y_c' = y1' + p theta' + epsilon p' at rest
        return A, B, C

    def frd(self, w_rad_s, carriage_position_m: float) -> np.ndarray:
        """Velocity (outputs of ``linearised``) per input, (5, 7, n_freq), at ``w_rad_s`` (rad/s)."""
        A, B, C = self.linearised(carriage_position_m)
        w = np.asarray(w_rad_s, float).ravel()
        x = np.linalg.solve(1j * w[:, None, None] * np.eye(A.shape[0]) - A, np.broadcast_to(B, (w.size, *B.shape)))
        return np.moveaxis(C @ x, 0, -1)


def matrices(*, carriage_position_m, beam_mass_kg, beam_inertia_kg_m2, carriage_mass_kg, carriage_inertia_kg_m2,
             rail_separation_m, damping1_n_s_per_m, damping2_n_s_per_m, damping_x_n_s_per_m,
             yaw_stiffness_n_m_per_rad, rotation_inertia_kg_m2, rotation_damping_n_m_s_per_rad, beam_skew_rad=0.0,
             carriage_offset_m=0.0):
    """Mass, damping and stiffness matrices (..., 4, 4) of the planar machine about rest, M q'' + D q' + K q = Q,
    in q = (y1, y2, p, phi), in closed form from the module's energies (the coordinates' velocities at rest:
    theta' = a . q', y_c' = c . q', the beam's middle g . q'; fields as ``PlanarGantry``'s, arrays broadcast to a
    batch)::

        M = m_b g g^T + (J_b + J_c) a a^T + m_c (x x^T + c c^T) + J_r (a + e_phi) (a + e_phi)^T
        D = diag(b1, b2, b_x, b_r),  K = K_a a a^T
        a = (-1, 1, 0, 0) / L,  x = (e / L, -e / L, 1, 0),  c = (1 - p / L, p / L, epsilon, 0),  g = (1/2, 1/2, 0, 0)

    With the skew epsilon and the offset e zero (the defaults), the carriage's coordinate p meets no other in M, D
    or K: at rest, X moves apart from Y and the rotation stage (its position only sets c); the rotation stage meets
    the beam's yaw through J_r."""
    arrays = np.broadcast_arrays(*(np.asarray(v, float) for v in (
        carriage_position_m, beam_mass_kg, beam_inertia_kg_m2, carriage_mass_kg, carriage_inertia_kg_m2,
        damping1_n_s_per_m, damping2_n_s_per_m, damping_x_n_s_per_m, yaw_stiffness_n_m_per_rad,
        rotation_inertia_kg_m2, rotation_damping_n_m_s_per_rad)))
    p, mb, jb, mc, jc, b1, b2, bx, ka, jr, br = (v[..., None, None] for v in arrays)
    L, eps, e = float(rail_separation_m), float(beam_skew_rad), float(carriage_offset_m)
    zero, one = np.zeros_like(p), np.ones_like(p)

    def vec(*entries):                                      # (..., 4, 1)
        return np.concatenate(np.broadcast_arrays(*entries), axis=-2)

    def outer(v):
        return v * np.swapaxes(v, -1, -2)

    a = vec(-one / L, one / L, zero, zero)
    c = vec(1 - p / L, p / L, eps * one, zero)
    x = vec(e * one / L, -e * one / L, one, zero)
    g = vec(one / 2, one / 2, zero, zero)
    e_phi = vec(zero, zero, zero, one)
    M = mb * outer(g) + (jb + jc) * outer(a) + mc * (outer(x) + outer(c)) + jr * outer(a + e_phi)
    D = np.zeros_like(M)
    for k, b in enumerate((b1, b2, bx, br)):
        D[..., k, k] = b[..., 0, 0]
    return M, D, ka * outer(a)


def mobility(s, M, D, K) -> np.ndarray:
    """Velocity per generalised force, s (M s^2 + D s + K)^-1, (..., n, n, n_freq) at complex ``s`` for matrices
    (..., n, n) (``matrices``, or a block of them). Three coordinates (the planar checks keep the rails and the
    rotation stage) are inverted by the adjugate, every plant and frequency in the same array operations: numpy's
    inverse takes a batch one LAPACK call per matrix, which was the planar check's largest cost."""
    s = np.asarray(s, complex).ravel()
    n = M.shape[-1]
    if n != 3:
        ss = s[:, None, None]
        Z = M[..., None, :, :] * ss**2 + D[..., None, :, :] * ss + K[..., None, :, :]
        return np.moveaxis(np.linalg.inv(Z) * ss, -3, -1)
    s2 = s * s
    (a, b, c), (d, e, f), (g, h, i) = ([M[..., r, k, None] * s2 + D[..., r, k, None] * s + K[..., r, k, None]
                                        for k in range(3)] for r in range(3))
    co = (e * i - f * h, f * g - d * i, d * h - e * g)          # the first row's cofactors
    scale = s / (a * co[0] + b * co[1] + c * co[2])             # s / det Z
    adjugate = ((co[0], c * h - b * i, b * f - c * e),
                (co[1], a * i - c * g, c * d - a * f),
                (co[2], b * g - a * h, a * e - b * d))
    return np.stack([np.stack([x * scale for x in row], axis=-2) for row in adjugate], axis=-3)
