"""The force of a cable carrier (energy chain) on the carriage: a spring towards the chain's rest position and
a drag that grows along the travel.

The chain's bent loop pulls the carriage back towards where it lies unbent, about linearly for the small
travel of a gantry stage (a few tens of N/m for the chain of a linear-motor axis); the part of the chain that
moves, and slides on its guide, lengthens as the carriage moves away from the chain's fixed end, so its drag
(a friction, opposing the motion) grows along the travel. The force the motor must supply on top of the rigid
body where the carriage is, x (m), moving at v (m/s):

    F_c(x, v) = pull_n + stiffness_n_per_m (x - centre_m) + drag_n_per_m (x - centre_m) sign(v),

with ``centre_m`` the middle of the recorded travel (set from the recording by ``configured``, held by the
fit) and ``pull_n`` the chain's force there; its rest position is centre_m - pull_n / stiffness_n_per_m. The
drag's value at centre_m is a Coulomb friction (``coulomb_friction`` holds it, with the guides' own): the cable
adds its growth along the travel, ``drag_n_per_m``, of either sign (which end of the travel the chain is fixed at).
The data cannot tell the pull from a constant force of another origin (an amplifier offset), so the effect
excludes ``offset``: its pull is the constant force, and with no stiffness it is an offset (``contains``: a
diagnosis names a cable only where the data set its stiffness apart from 0). The three parameters enter the
time-domain inverse model linearly (``force_regressors``).

One home in both domains: the spring is a stiffness between the rails and the ground that the mechanics
carries (``rail_stiffness``: the impedance k / s beside the rail damping in every frequency response, a
position state in the realisation every simulation and sampled-data check is built from, as
``plant.physics.mechanics.BodyChain``), so the frequency response and the time simulations share it; the
rest of the force, constant, is the rail force a time simulation applies (``rail_force_n``), and the drag adds to
the Coulomb friction's magnitude where the carriage is (``rail_friction_n``: it sticks as that friction does). A
frequency response holds no drag: about a stepped sine's centre x_0 the drag is a Coulomb friction of
drag_n_per_m (x_0 - centre_m), which ``coulomb_friction`` describes there. The realisation's
spring is relaxed at x = 0, where the continuous run starts; a run that starts elsewhere (the mouse run) sets
its state there (``Realisation.ground``). A stepped sine from rest cannot show the pull and is refused (a
continuous run simulates it). The rigid Stage X or Y model only: on the tilting
beam of ``tilt_coupling`` the chain would pull one rail, which this model does not say.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from plant.errors import EffectError
from plant.physics.effect_base import FitSamples, ForceSignals, MechanicalEffect
from plant.physics.parameters import check_finite, check_positive


@dataclass(frozen=True)
class CableForce(MechanicalEffect):
    """A cable carrier's spring towards its rest position (module doc): F_c(x) = pull_n + k (x - centre_m)."""

    stiffness_n_per_m: float = 30.0
    pull_n: float = 0.0
    centre_m: float = 0.0
    drag_n_per_m: float = 0.0
    name: ClassVar[str] = "cable_force"
    realised_as: ClassVar[str] = "state_space"
    bounds: ClassVar = {"stiffness_n_per_m": (0.0, 1.0e5, "N/m"), "pull_n": (-1000.0, 1000.0, "N"),
                        "centre_m": (-10.0, 10.0, "m"), "drag_n_per_m": (-1.0e5, 1.0e5, "N/m")}
    signature: ClassVar[str] = ("a residual force that grows along the travel, one sign on each side of a rest "
                                "position (and a friction that grows along it)")
    main_parameter: ClassVar[str] = "stiffness_n_per_m"
    neutral: ClassVar = {"stiffness_n_per_m": 0.0, "pull_n": 0.0, "drag_n_per_m": 0.0}
    search_fixed: ClassVar = ("centre_m",)
    excludes: ClassVar = ("offset", "tilt_coupling")
    contains: ClassVar = {"offset": "stiffness_n_per_m"}
    searched: ClassVar[bool] = False
    not_searched: ClassVar[str] = ("its spring acts below a stage's recorded band and its pull leaves no trace in a "
                                   "frequency response; fitted from time-domain recordings with the position")
    time_domain: ClassVar[bool] = True
    needs_position: ClassVar[bool] = True
    simulated: ClassVar[bool] = False
    rail_force: ClassVar[bool] = True
    rail_friction: ClassVar[bool] = True
    complexity: ClassVar[int] = 1

    def __post_init__(self) -> None:
        check_positive("cable_force.stiffness_n_per_m", self.stiffness_n_per_m, allow_zero=True)
        for field in ("pull_n", "centre_m", "drag_n_per_m"):
            check_finite(f"cable_force.{field}", getattr(self, field))

    @property
    def rest_m(self) -> float:
        """Where the chain lies unbent (m): centre_m - pull_n / k (nan without a spring)."""
        k = float(np.mean(self.stiffness_n_per_m))
        return float(np.mean(self.centre_m) - np.mean(self.pull_n) / k) if k > 0 else float("nan")

    def rail_stiffness(self):
        return self.stiffness_n_per_m

    def force(self, position_m) -> np.ndarray:
        """F_c (N) at ``position_m``: the force the motor must supply there (module doc)."""
        return self.pull_n + self.stiffness_n_per_m * (np.asarray(position_m, float) - self.centre_m)

    def rail_force_n(self, position_m: float, velocity_m_per_s: float, motor_force_n: float) -> float:
        """The part of -F_c the mechanics' spring (relaxed at x = 0) does not carry, the drag aside: -(pull_n -
        k centre_m)."""
        return -float(self.pull_n - self.stiffness_n_per_m * self.centre_m)

    def rail_friction_n(self, position_m: float) -> float:
        """The drag's part of the Coulomb friction at ``position_m`` (N): drag_n_per_m (x - centre_m)."""
        return float(self.drag_n_per_m * (position_m - self.centre_m))

    def force_regressors(self, signals: ForceSignals) -> dict[str, np.ndarray]:
        if signals.position_m is None:
            raise EffectError("cable_force depends on the position: the recording has velocity only")
        x = np.asarray(signals.position_m, float)
        return {"stiffness_n_per_m": x - self.centre_m, "pull_n": np.ones_like(x),
                "drag_n_per_m": (x - self.centre_m) * np.sign(signals.velocity_m_per_s)}

    def configured(self, samples: FitSamples, residual_n) -> CableForce:
        if samples.position_m is None:
            return self
        lo, hi = float(np.min(samples.position_m)), float(np.max(samples.position_m))
        return replace(self, centre_m=(lo + hi) / 2)
