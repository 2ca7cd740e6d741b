"""What makes Stage Y's two rails differ besides the beam's tilt: a sensor that reads one rail to a different scale,
and two motors whose force constants differ (each motor has its own batch of magnets and coils).

``rail_scale``: rail Y2's recorded velocity over its true velocity, relative to rail Y1's (``y2_scale``; an encoder's
scale error or a wrong resolution setting, 3 % makes the rails disagree by 0.26 dB at every frequency). It changes
no motion, only what is recorded, so it multiplies the Y2 output of the response and of the realisation.

``motor_imbalance``: the motors' force constants K_t (1 + d) and K_t (1 - d) around their mean (``fraction``, d): the
beam then takes a torque d K_t i (l1 + l2) / 2 besides the push, which moves the rails apart only through the
tilt mode (a rigid beam keeps them together and shows only the mean), so it requires ``tilt_coupling``.

``yaw_coupling``: in a time recording of both rails, the beam's yaw in the force on the rails' mean (a load off
the beam's centre, rails whose dampings differ), from the measured difference of the rails.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from plant.errors import EffectError, ParameterError
from plant.physics.effect_base import Effect, ForceSignals
from plant.physics.parameters import check_finite


@dataclass(frozen=True)
class RailScale(Effect):
    """Rail Y2's velocity reading relative to rail Y1's (module doc)."""

    y2_scale: float = 1.0
    name: ClassVar[str] = "rail_scale"
    place: ClassVar[str] = "sensor"
    #: held exactly by the realisation (its Y2 output row scaled)
    realised_as: ClassVar[str] = "state_space"
    bounds: ClassVar = {"y2_scale": (0.5, 2.0, "1")}
    main_parameter: ClassVar[str] = "y2_scale"
    neutral: ClassVar = {"y2_scale": 1.0}
    signature: ClassVar[str] = "Y1 and Y2 disagreeing by one constant factor at every frequency"
    stages: ClassVar = ("y",)
    min_outputs: ClassVar[int] = 2
    in_synthesis: ClassVar[bool] = False
    complexity: ClassVar[int] = 1

    def __post_init__(self) -> None:
        self._check_positive()

    def output_scales(self, n_outputs: int) -> np.ndarray:
        """Factor on each recorded output (Y1, Y2), shape (..., n_outputs, 1) for a value of shape (..., 1) (a
        fitter's batch, broadcast over frequency) or (n_outputs, 1) for a scalar."""
        y2 = np.asarray(self.y2_scale, float)
        y2 = y2 if y2.ndim else y2[None]
        return np.stack([np.ones_like(y2), y2], axis=-2)[..., :n_outputs, :]

    def guesses(self, w_rad_s, ratio) -> list[dict[str, float]]:
        r = np.atleast_2d(ratio)
        if r.shape[0] < 2:
            return []
        scale = float(np.median(np.abs(r[1]) / np.maximum(np.abs(r[0]), 1e-300)))
        return [{"y2_scale": float(np.clip(scale, 0.51, 1.99))}]


@dataclass(frozen=True)
class MotorImbalance(Effect):
    """The two motors' force constants K_t (1 + d), K_t (1 - d) around their mean (module doc)."""

    fraction: float = 0.0
    name: ClassVar[str] = "motor_imbalance"
    place: ClassVar[str] = "mechanics"
    #: the beam's motor shares (``plant.physics.realisation``)
    realised_as: ClassVar[str] = "beam"
    bounds: ClassVar = {"fraction": (-0.5, 0.5, "1")}
    main_parameter: ClassVar[str] = "fraction"
    neutral: ClassVar = {"fraction": 0.0}
    signature: ClassVar[str] = "Y1 and Y2 disagreeing around the tilt mode even with the load centred"
    stages: ClassVar = ("y",)
    min_outputs: ClassVar[int] = 2
    requires_any: ClassVar = ("tilt_coupling",)
    in_synthesis: ClassVar[bool] = False
    complexity: ClassVar[int] = 1

    def __post_init__(self) -> None:
        d = np.asarray(self.fraction, float)
        if not np.all(np.isfinite(d)) or np.any(np.abs(d) >= 1):
            raise ParameterError(f"motor_imbalance.fraction must lie in (-1, 1) (each motor keeps a force), got "
                                 f"{self.fraction!r}")

    def shares(self) -> tuple[np.ndarray, np.ndarray]:
        """Each motor's part of the total force K_t i (Y1, Y2), over a batch of values."""
        d = np.asarray(self.fraction, float)
        return 0.5 * (1 + d), 0.5 * (1 - d)

    def guesses(self, w_rad_s, ratio) -> list[dict[str, float]]:
        return [{"fraction": d} for d in (-0.1, -0.03, 0.03, 0.1)]


@dataclass(frozen=True)
class YawCoupling(Effect):
    """The beam's yaw in the force on the rails' mean, in a time recording of both rails (module doc).

    With the load off the beam's centre the mean's force balance carries the load's inertia times the yaw's
    acceleration, and rails whose dampings differ the yaw's velocity (Lagrange's equations of the beam on its
    rails, ``plant.diagnose.two_rails``): K_t i = m c'' + b c' + inertia_kg d'' + damping_n_s_per_m d', with d the
    measured difference y2 - y1. inertia_kg is m e, the load's mass times its offset towards Y2 over the rails'
    separation (``tilt_coupling.offset_m`` = inertia_kg L / m); damping_n_s_per_m is (b2 - b1) / 2. A frequency
    response holds the tilt through ``tilt_coupling``; this is its part in the time-domain force balance, a
    candidate only where the rails' difference shows the beam turning."""

    inertia_kg: float = 0.0
    damping_n_s_per_m: float = 0.0
    name: ClassVar[str] = "yaw_coupling"
    place: ClassVar[str] = "mechanics"
    realised_as: ClassVar[str] = "force"
    bounds: ClassVar = {"inertia_kg": (-1e4, 1e4, "kg"), "damping_n_s_per_m": (-1e5, 1e5, "N*s/m")}
    main_parameter: ClassVar[str] = "inertia_kg"
    neutral: ClassVar = {"inertia_kg": 0.0, "damping_n_s_per_m": 0.0}
    signature: ClassVar[str] = ("a residual that follows the rails' difference (the beam turning under an off-centre "
                                "load)")
    stages: ClassVar = ("y",)
    min_outputs: ClassVar[int] = 2
    searched: ClassVar[bool] = False
    not_searched: ClassVar[str] = ("a frequency response holds the beam's tilt as tilt_coupling; this is its part in a "
                                   "time recording's force balance")
    in_synthesis: ClassVar[bool] = False
    time_domain: ClassVar[bool] = True
    needs_rails: ClassVar[bool] = True
    simulated: ClassVar[bool] = False
    frequency_response: ClassVar[bool] = False
    complexity: ClassVar[int] = 1

    def __post_init__(self) -> None:
        for field in self.bounds:
            check_finite(f"{self.name}.{field}", getattr(self, field))

    def force_regressors(self, signals: ForceSignals) -> dict[str, np.ndarray]:
        if signals.rail_difference_acceleration_m_per_s2 is None:
            raise EffectError(f"{self.name} follows the rails' difference: the recording has one output")
        return {"inertia_kg": np.asarray(signals.rail_difference_acceleration_m_per_s2, float),
                "damping_n_s_per_m": np.asarray(signals.rail_difference_velocity_m_per_s, float)}
