"""The mouse at the head clamp, as the gantry feels it: a mechanical impedance (force per velocity).

Head mass m_h beyond the force sensor (it moves with the clamp), body mass m_b on the neck
(stiffness k_n, damping c_n) and on the legs (stiffness k_l, damping c_l) to the ground: a walking or
bracing mouse stands on the floor, and its body is tied to the ground through its legs. With
Z_n = c_n + k_n/s and Z_b = m_b s + c_l + k_l/s (SI units, s = jw)::

    Z_m = m_h s + Z_n Z_b / (Z_n + Z_b)        (N*s/m; passive for any non-negative parameters)

Legs 0 (k_l = c_l = 0) is the floating mouse, Z_b = m_b s. With legs the gantry feels, at low
frequency, the neck and legs in series as a spring to the ground, k_n k_l / (k_n + k_l).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

#: log-spaced leg stiffnesses between the ends of the spec's range in the design and check sets
LEG_POINTS = 2


@dataclass(frozen=True)
class MouseModel:
    """One mouse (SI units); fields may be (n, 1) arrays for a batch of mice."""

    head_mass_kg: float
    body_mass_kg: float
    neck_stiffness_n_per_m: float
    neck_damping_n_s_per_m: float
    leg_stiffness_n_per_m: float = 0.0
    leg_damping_n_s_per_m: float = 0.0

    def impedance(self, s) -> np.ndarray:
        """Z_m at complex frequencies ``s`` (rad/s), force per velocity (N*s/m)."""
        s = np.asarray(s, complex)
        inv_s = 1.0 / s                  # on the grid once, not per mouse
        zn = self.neck_damping_n_s_per_m + self.neck_stiffness_n_per_m * inv_s
        zb = self.body_mass_kg * s + self.leg_damping_n_s_per_m + self.leg_stiffness_n_per_m * inv_s
        return self.head_mass_kg * s + zn * zb / (zn + zb)

    def impedance_frd(self, w_rad_s) -> np.ndarray:
        """Z_m(jw) on a grid of angular frequencies (rad/s)."""
        return self.impedance(1j * np.asarray(w_rad_s, float))

    def impedance_polys(self) -> tuple[np.ndarray, np.ndarray]:
        """Z_m as numerator / denominator polynomials in s (highest power first), with the factor s that
        numerator and denominator share when the legs have no stiffness cancelled."""
        mh, mb = self.head_mass_kg, self.body_mass_kg
        kn, cn = self.neck_stiffness_n_per_m, self.neck_damping_n_s_per_m
        kl, cl = self.leg_stiffness_n_per_m, self.leg_damping_n_s_per_m
        q = np.array([mb, cn + cl, kn + kl])
        num = np.polyadd(np.polymul([mh, 0.0, 0.0], q), np.polymul([cn, kn], [mb, cl, kl]))
        den = np.polymul([1.0, 0.0], q)
        if kl == 0:
            return num[:-1], q          # the constant term of num is k_n k_l = 0
        return num, den

    @property
    def grounded(self) -> bool:
        return bool(np.any(np.asarray(self.leg_stiffness_n_per_m) > 0)
                    or np.any(np.asarray(self.leg_damping_n_s_per_m) > 0))

    def mode_rad_s(self) -> float:
        """Natural frequency of the body between neck and legs, sqrt((k_n + k_l) / m_b) (rad/s)."""
        return math.sqrt((self.neck_stiffness_n_per_m + self.leg_stiffness_n_per_m) / self.body_mass_kg)

    def as_dict(self) -> dict:
        return {"head_mass_kg": self.head_mass_kg, "body_mass_kg": self.body_mass_kg,
                "neck_stiffness_n_per_m": self.neck_stiffness_n_per_m,
                "neck_damping_n_s_per_m": self.neck_damping_n_s_per_m,
                "leg_stiffness_n_per_m": self.leg_stiffness_n_per_m,
                "leg_damping_n_s_per_m": self.leg_damping_n_s_per_m}

    def label(self) -> str:
        legs = ("floating (feet off the ground)" if not self.grounded else
                f"legs {self.leg_stiffness_n_per_m:g} N/m, {self.leg_damping_n_s_per_m:g} N*s/m")
        return (f"head {self.head_mass_kg * 1e3:g} g, body {self.body_mass_kg * 1e3:g} g, neck "
                f"{self.neck_stiffness_n_per_m:g} N/m, {self.neck_damping_n_s_per_m:g} N*s/m, {legs}")


def mouse_set(mouse, *, leg_points: int = LEG_POINTS) -> tuple[MouseModel, ...]:
    """The mice a design holds for: every corner of the spec's ranges (``design.problem.Mouse``), the
    leg stiffness also at ``leg_points`` log-spaced points inside its range, and with ``floating`` the
    same mice with their feet off the ground."""
    legs = tuple(itertools.product(mouse.leg_stiffness_n_per_m.points(leg_points),
                                   mouse.leg_damping_n_s_per_m.corners()))
    if mouse.floating:
        legs = ((0.0, 0.0),) + tuple(leg for leg in legs if leg != (0.0, 0.0))
    return tuple(MouseModel(mh, mb, kn, cn, kl, cl) for (mh, mb, kn, cn), (kl, cl) in itertools.product(
        itertools.product(mouse.head_mass_kg.corners(), mouse.body_mass_kg.corners(),
                          mouse.neck_stiffness_n_per_m.corners(), mouse.neck_damping_n_s_per_m.corners()), legs))


def stack(mice) -> MouseModel:
    """A sequence of mice as one batch (fields of shape (n, 1))."""
    return MouseModel(*(np.array([getattr(m, f) for m in mice], float)[:, None] for f in FIELDS))


def random_mice(mouse, samples: int, *, seed: int) -> MouseModel:
    """``samples`` independent draws over the spec's mouse ranges, as one batch of (n, 1) arrays: uniform
    masses and neck parameters, the leg stiffness log-uniform over its range when it spans more than a
    decade, and a quarter of the draws floating when ``floating``."""
    rng = np.random.default_rng((seed, 1))
    draw = [rng.uniform(r.min, r.max, (samples, 1)) for r in (
        mouse.head_mass_kg, mouse.body_mass_kg, mouse.neck_stiffness_n_per_m, mouse.neck_damping_n_s_per_m)]
    k = mouse.leg_stiffness_n_per_m
    if k.min > 0 and k.max > 10 * k.min:
        kl = np.exp(rng.uniform(math.log(k.min), math.log(k.max), (samples, 1)))
    else:
        kl = rng.uniform(k.min, k.max, (samples, 1))
    cl = rng.uniform(mouse.leg_damping_n_s_per_m.min, mouse.leg_damping_n_s_per_m.max, (samples, 1))
    if mouse.floating:
        off = rng.uniform(size=(samples, 1)) < 0.25
        kl, cl = np.where(off, 0.0, kl), np.where(off, 0.0, cl)
    return MouseModel(*draw, kl, cl)


FIELDS = tuple(MouseModel.__dataclass_fields__)
