"""Parameters that drift over a time recording: a force constant as the coil warms, a damping as the guides'
lubricant warms. Each is linear in its change over the record, u = (t - mid) / half running from -1 to 1 over the
moving samples (``mid_s``, ``half_s``, set from the recording by ``configured`` and held by the fit), so the
inverse model fits it exactly (``plant.identify.time_fit``), and each is added only where the parent model's
residual shows its pattern (current x time, velocity x time).

* ``ForceConstantDrift``: K(t) = K (1 + change u): the motor force K(t) u_drive; with K u_drive on the left of the
  inverse model its column is minus the motor force times u (exact, as ``force_constant_profile``'s over position).
* ``DampingDrift``: b(t) = b + change_n_s_per_m u: the damping force b(t) v; its column is v u.

A frequency response is a steady state: it holds K and b at mid-record (a stepped sine's drift over its blocks is
``plant.diagnose.drift``'s). No simulation runs them: a drift is defined over a recording's own span.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from plant.errors import EffectError
from plant.physics.effect_base import FitSamples, ForceSignals, MechanicalEffect
from plant.physics.parameters import check_finite, check_positive


@dataclass(frozen=True)
class _Drift(MechanicalEffect):
    """What the drifts share: the record's span (mid_s, half_s: u = (t - mid_s) / half_s, set from the samples' times
    by ``configured``), their standing in the search and the checks of their fields."""

    mid_s: float = 0.0
    half_s: float = 1.0
    realised_as: ClassVar[str] = "force"
    search_fixed: ClassVar = ("mid_s", "half_s")
    searched: ClassVar[bool] = False
    not_searched: ClassVar[str] = ("a frequency response is a steady state; a stepped sine's drift over its blocks is "
                                   "fitted by the diagnosis's drift model, a time recording's by this effect")
    in_synthesis: ClassVar[bool] = False
    time_domain: ClassVar[bool] = True
    simulated: ClassVar[bool] = False

    def __post_init__(self) -> None:
        check_positive(f"{self.name}.half_s", self.half_s)
        for name in ("mid_s", self.main_parameter):
            check_finite(f"{self.name}.{name}", getattr(self, name))

    def u(self, signals: ForceSignals) -> np.ndarray:
        """(t - mid_s) / half_s at the signals' times."""
        if signals.time_s is None:
            raise EffectError(f"{self.name} depends on the time: the signals carry none")
        return (np.asarray(signals.time_s, float) - self.mid_s) / self.half_s

    def configured(self, samples: FitSamples, residual_n):
        if samples.time_s is None:
            return self
        lo, hi = float(np.min(samples.time_s)), float(np.max(samples.time_s))
        return replace(self, mid_s=(lo + hi) / 2, half_s=(hi - lo) / 2) if hi > lo else self


@dataclass(frozen=True)
class ForceConstantDrift(_Drift):
    """A force constant drifting over the recording (module doc): K(t) = K (1 + change u), u = (t - mid_s) /
    half_s."""

    change: float = 0.0
    name: ClassVar[str] = "force_constant_drift"
    bounds: ClassVar = {"mid_s": (-1e9, 1e9, "s"), "half_s": (1e-6, 1e9, "s"), "change": (-0.5, 0.5, "1")}
    signature: ClassVar[str] = "a residual proportional to the current times the time (a coil warming)"
    main_parameter: ClassVar[str] = "change"
    neutral: ClassVar = {"change": 0.0}
    residual_signature: ClassVar = "current x time"

    def force_regressors(self, signals: ForceSignals) -> dict[str, np.ndarray]:
        # K u_drive (1 + d u) = m a + b v + ...: with K u_drive on the left, exactly
        return {"change": -signals.force_n * self.u(signals)}


@dataclass(frozen=True)
class DampingDrift(_Drift):
    """A damping drifting over the recording (module doc): b(t) = b + change_n_s_per_m u, u = (t - mid_s) / half_s."""

    change_n_s_per_m: float = 0.0
    name: ClassVar[str] = "damping_drift"
    bounds: ClassVar = {"mid_s": (-1e9, 1e9, "s"), "half_s": (1e-6, 1e9, "s"),
                        "change_n_s_per_m": (-1e5, 1e5, "N*s/m")}
    signature: ClassVar[str] = "a residual proportional to the velocity times the time (a lubricant warming)"
    main_parameter: ClassVar[str] = "change_n_s_per_m"
    neutral: ClassVar = {"change_n_s_per_m": 0.0}
    residual_signature: ClassVar = "velocity x time"

    def force_regressors(self, signals: ForceSignals) -> dict[str, np.ndarray]:
        return {"change_n_s_per_m": np.asarray(signals.velocity_m_per_s, float) * self.u(signals)}
