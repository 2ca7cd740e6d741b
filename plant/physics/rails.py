"""What makes Stage Y's two rails differ besides the beam's tilt: a sensor that reads one rail to a different scale,
and two motors whose force constants differ (each motor has its own batch of magnets and coils).

``rail_scale``: rail Y2's recorded velocity over its true velocity, relative to rail Y1's (``y2_scale``; an encoder's
scale error or a wrong resolution setting, 3 % makes the rails disagree by 0.26 dB at every frequency). It changes
no motion, only what is recorded, so it multiplies the Y2 output of the response and of the realisation.

``motor_imbalance``: the motors' force constants K_t (1 + d) and K_t (1 - d) around their mean (``fraction``, d): the
beam then takes a torque d K_t i (l1 + l2) / 2 besides the push, which moves the rails apart only through the
tilt mode (a rigid beam keeps them together and shows only the mean), so it requires ``tilt_coupling``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from plant.errors import ParameterError
from plant.physics.effect_base import Effect


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
