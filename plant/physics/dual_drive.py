"""Stage Y as the two-motor gantry it is: currents i1, i2 in, rail velocities v1, v2 out.

A beam (mass m_b, yaw inertia J_b about its middle) spans the rails Y1 and Y2, ``rail_separation_m``
= L apart (thesis section 3.1: the motor length); the carriage of Stage X with its payload (mass
m_c, yaw inertia J_c) rides on it at ``carriage_position_m`` = p from Y1. Each rail's motor pushes
with f_i = k_i i_i at its rail and its guide damps with b_i; the joints resist the beam's yaw alpha
with the stiffness K_a (Xie & Wang, thesis Eq. 2.14-2.15). About the centre of mass, at
l1 = s_g from Y1 and l2 = L - s_g from Y2, Newton's law gives

    M y_g'' + (b1 + b2) y_g' + (b2 l2 - b1 l1) alpha' = f1 + f2
    J alpha'' + (b2 l2 - b1 l1) y_g' + (b1 l1^2 + b2 l2^2) alpha' + K_a alpha = l2 f2 - l1 f1

with M = m_b + m_c, s_g = (m_b L / 2 + m_c p) / M, J = J_b + J_c + m_b (L/2 - s_g)^2 + m_c (p - s_g)^2, and
v1 = y_g' - l1 alpha', v2 = y_g' + l2 alpha' (``plant.physics.gantry_models.xie_wang_frd``); the carriage moves
with y_g' + (p - l1) alpha' (``point_mobility``: the mouse pushes there). With k1 = k2 =
K_t, b1 = b2 = b, the centre of mass midway and i1 = i2 = I / 2, v1 = v2 = K_t I / (M s + 2 b): thesis
Eq. 3.16 at l = L / 2, the tool's one-loop Stage Y on the total current I.

The drive effects (delay, current loop, sampling, ...) act on each motor's current, the sensor effects
on each rail's velocity; mechanical effects of the one-loop model (modes, friction) are not part of
this model.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from plant.errors import EffectError
from plant.grid import check_grid
from plant.physics.effect_base import ChainEffect, Effect
from plant.physics.gantry_models import xie_wang_ss
from plant.physics.parameters import check_positive


@dataclass(frozen=True)
class DualDriveStageY:
    """Stage Y with its two motors (module doc). Masses, positions and stiffness may be arrays that
    broadcast (a batch of carriage positions x payloads in one call); SI units."""

    #: moving mass and yaw inertia of the beam (Stage Y without Stage X)
    beam_mass_kg: float | np.ndarray = 16.0
    beam_inertia_kg_m2: float | np.ndarray = 16.0 * 0.8**2 / 12
    #: Stage X's carriage with everything it carries (payload included), and its own yaw inertia
    carriage_mass_kg: float | np.ndarray = 35.0
    carriage_inertia_kg_m2: float | np.ndarray = 0.0
    rail_separation_m: float = 0.8
    #: the carriage's distance from rail Y1 (0 < p < L)
    carriage_position_m: float | np.ndarray = 0.4
    damping1_n_s_per_m: float | np.ndarray = 440.0
    damping2_n_s_per_m: float | np.ndarray = 440.0
    force_constant1_n_per_a: float | np.ndarray = 20.0
    force_constant2_n_per_a: float | np.ndarray = 20.0
    yaw_stiffness_n_m_per_rad: float | np.ndarray = 2.0e5
    #: drive effects on each motor's current and sensor effects on each rail's velocity
    effects: tuple[Effect, ...] = field(default=())

    def __post_init__(self) -> None:
        for name in ("beam_mass_kg", "beam_inertia_kg_m2", "carriage_mass_kg", "rail_separation_m",
                     "damping1_n_s_per_m", "damping2_n_s_per_m", "force_constant1_n_per_a",
                     "force_constant2_n_per_a", "yaw_stiffness_n_m_per_rad"):
            check_positive(name, getattr(self, name))
        if np.any(np.asarray(self.carriage_inertia_kg_m2) < 0):
            raise EffectError("carriage_inertia_kg_m2 must be >= 0")
        p = np.asarray(self.carriage_position_m, float)
        if not np.all((p > 0) & (p < self.rail_separation_m)):
            raise EffectError(f"carriage_position_m must lie between the rails (0, {self.rail_separation_m:g}) m, "
                              f"got {self.carriage_position_m!r}")
        for e in self.effects:
            if not isinstance(e, ChainEffect) or e.place not in ("drive", "sensor"):
                raise EffectError(f"{e.name}: the two-motor Stage Y takes drive and sensor effects (delay, "
                                  "current_loop, sampling, sensor_filter, ...), not mechanical ones")

    def with_values(self, **values) -> DualDriveStageY:
        """A copy with fields replaced (``carriage_position_m=np.linspace(...)`` for a batch)."""
        return replace(self, **values)

    def mass_geometry(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Total mass M (kg), yaw inertia J about the centre of mass (kg m^2), and the centre of mass's
        distances l1, l2 (m) from rails Y1 and Y2 (module doc)."""
        mb, mc = np.asarray(self.beam_mass_kg, float), np.asarray(self.carriage_mass_kg, float)
        L, p = self.rail_separation_m, np.asarray(self.carriage_position_m, float)
        M = mb + mc
        s_g = (mb * L / 2 + mc * p) / M
        J = (np.asarray(self.beam_inertia_kg_m2, float) + np.asarray(self.carriage_inertia_kg_m2, float)
             + mb * (L / 2 - s_g) ** 2 + mc * (p - s_g) ** 2)
        return M, J, s_g, L - s_g

    def yaw_mode_hz(self) -> np.ndarray:
        """Undamped yaw natural frequency sqrt(K_a / J) / (2 pi) (Hz)."""
        _, J, _, _ = self.mass_geometry()
        return np.sqrt(np.asarray(self.yaw_stiffness_n_m_per_rad, float) / J) / (2 * np.pi)

    def chain(self, s, place: str) -> np.ndarray | float:
        """The product of the effects at ``place`` ("drive" or "sensor") at complex ``s``, shaped to multiply
        (..., 2, 2, n_freq); effect parameters given as arrays shaped (..., 1) make a batch."""
        out: np.ndarray | float = 1.0
        for e in self.effects:
            if e.place == place:
                out = out * e.response(np.asarray(s, complex))
        return out[..., None, None, :] if np.ndim(out) > 1 else out

    def point_mobility(self, s, *, carriage: bool = True) -> np.ndarray:
        """Velocity per force between the points rail Y1, rail Y2 and the carriage, (..., 3, 3, n_freq) at complex
        ``s`` (m/s per N; the mechanics alone; ``carriage`` False: the rails alone, (..., 2, 2, n_freq)). A point
        at e from the centre of mass moves with y_g' + e alpha' and a force there adds e times itself to the
        torque: H = s B (K(s))^-1 B^T with K(s) the module doc's matrix polynomial and the rows of B (1, -l1),
        (1, l2), (1, p - l1)."""
        s = np.asarray(s, complex)
        M, J, l1, l2 = (np.asarray(v, float)[..., None] for v in self.mass_geometry())
        b1 = np.asarray(self.damping1_n_s_per_m, float)[..., None]
        b2 = np.asarray(self.damping2_n_s_per_m, float)[..., None]
        ka = np.asarray(self.yaw_stiffness_n_m_per_rad, float)[..., None]
        e = np.asarray(self.carriage_position_m, float)[..., None] - l1
        a = M * s**2 + (b1 + b2) * s
        c = (b2 * l2 - b1 * l1) * s
        d = J * s**2 + (b1 * l1**2 + b2 * l2**2) * s + ka
        scale = s / (a * d - c**2)
        d, c, a = d * scale, c * scale, a * scale                 # s K(s)^-1 = [[d, -c], [-c, a]] s / det
        arms = (-l1, l2, e) if carriage else (-l1, l2)
        n = len(arms)
        out = np.empty(np.broadcast_shapes(a.shape, e.shape)[:-1] + (n, n, s.size), complex)
        for i in range(n):
            for j in range(i, n):
                out[..., i, j, :] = out[..., j, i, :] = d - (arms[i] + arms[j]) * c + arms[i] * arms[j] * a
        return out

    def force_constants(self) -> np.ndarray:
        """(k1, k2) in N/A, shape (..., 2)."""
        return np.stack(np.broadcast_arrays(np.asarray(self.force_constant1_n_per_a, float),
                                            np.asarray(self.force_constant2_n_per_a, float)), axis=-1)

    def frd(self, w_rad_s) -> np.ndarray:
        """Rail velocity per motor current, shape (..., 2, 2, n_freq): [v1, v2] per [i1, i2] (m/s per A)."""
        s = 1j * check_grid(w_rad_s)
        k = self.force_constants()[..., None, :, None]
        return self.point_mobility(s, carriage=False) * k * self.chain(s, "drive") * self.chain(s, "sensor")

    def state_space(self):
        """python-control state space of the mechanics (no chain effects): states (y_g, alpha, v_g, omega),
        inputs (i1, i2), outputs (v1, v2). One plant (no batch)."""
        import control

        M, J, l1, l2 = (float(np.asarray(v).reshape(())) for v in self.mass_geometry())
        mech = xie_wang_ss(mass_kg=M, inertia_kg_m2=J, damping1_n_s_per_m=float(self.damping1_n_s_per_m),
                           damping2_n_s_per_m=float(self.damping2_n_s_per_m), l1_m=l1, l2_m=l2,
                           joint_stiffness_n_m_per_rad=float(self.yaw_stiffness_n_m_per_rad))
        k = np.diag([float(self.force_constant1_n_per_a), float(self.force_constant2_n_per_a)])
        return control.ss(mech.A, mech.B @ k, mech.C, mech.D)
