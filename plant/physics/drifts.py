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

#: why a frequency response does not search a drift
NOT_SEARCHED = ("a frequency response is a steady state; a stepped sine's drift over its blocks is fitted by the "
                "diagnosis's drift model, a time recording's by this effect")
SPAN_BOUNDS = {"mid_s": (-1e9, 1e9, "s"), "half_s": (1e-6, 1e9, "s")}


def _u(effect, signals: ForceSignals) -> np.ndarray:
    """(t - mid_s) / half_s at the signals' times."""
    if signals.time_s is None:
        raise EffectError(f"{effect.name} depends on the time: the signals carry none")
    return (np.asarray(signals.time_s, float) - effect.mid_s) / effect.half_s


def _spanned(effect, samples: FitSamples):
    """``effect`` with mid_s and half_s over the samples' times."""
    if samples.time_s is None:
        return effect
    lo, hi = float(np.min(samples.time_s)), float(np.max(samples.time_s))
    return replace(effect, mid_s=(lo + hi) / 2, half_s=(hi - lo) / 2) if hi > lo else effect


def _check(effect, field: str) -> None:
    check_positive(f"{effect.name}.half_s", effect.half_s)
    for name in ("mid_s", field):
        check_finite(f"{effect.name}.{name}", getattr(effect, name))


@dataclass(frozen=True)
class ForceConstantDrift(MechanicalEffect):
    """A force constant drifting over the recording (module doc): K(t) = K (1 + change u), u = (t - mid_s) /
    half_s."""

    mid_s: float = 0.0
    half_s: float = 1.0
    change: float = 0.0
    name: ClassVar[str] = "force_constant_drift"
    realised_as: ClassVar[str] = "force"
    bounds: ClassVar = {**SPAN_BOUNDS, "change": (-0.5, 0.5, "1")}
    signature: ClassVar[str] = "a residual proportional to the current times the time (a coil warming)"
    main_parameter: ClassVar[str] = "change"
    neutral: ClassVar = {"change": 0.0}
    search_fixed: ClassVar = ("mid_s", "half_s")
    residual_signature: ClassVar = "current x time"
    searched: ClassVar[bool] = False
    not_searched: ClassVar[str] = NOT_SEARCHED
    in_synthesis: ClassVar[bool] = False
    time_domain: ClassVar[bool] = True
    simulated: ClassVar[bool] = False

    def __post_init__(self) -> None:
        _check(self, "change")

    def force_regressors(self, signals: ForceSignals) -> dict[str, np.ndarray]:
        # K u_drive (1 + d u) = m a + b v + ...: with K u_drive on the left, exactly
        return {"change": -signals.force_n * _u(self, signals)}

    def configured(self, samples: FitSamples, residual_n) -> ForceConstantDrift:
        return _spanned(self, samples)


@dataclass(frozen=True)
class DampingDrift(MechanicalEffect):
    """A damping drifting over the recording (module doc): b(t) = b + change_n_s_per_m u, u = (t - mid_s) / half_s."""

    mid_s: float = 0.0
    half_s: float = 1.0
    change_n_s_per_m: float = 0.0
    name: ClassVar[str] = "damping_drift"
    realised_as: ClassVar[str] = "force"
    bounds: ClassVar = {**SPAN_BOUNDS, "change_n_s_per_m": (-1e5, 1e5, "N*s/m")}
    signature: ClassVar[str] = "a residual proportional to the velocity times the time (a lubricant warming)"
    main_parameter: ClassVar[str] = "change_n_s_per_m"
    neutral: ClassVar = {"change_n_s_per_m": 0.0}
    search_fixed: ClassVar = ("mid_s", "half_s")
    residual_signature: ClassVar = "velocity x time"
    searched: ClassVar[bool] = False
    not_searched: ClassVar[str] = NOT_SEARCHED
    in_synthesis: ClassVar[bool] = False
    time_domain: ClassVar[bool] = True
    simulated: ClassVar[bool] = False

    def __post_init__(self) -> None:
        _check(self, "change_n_s_per_m")

    def force_regressors(self, signals: ForceSignals) -> dict[str, np.ndarray]:
        return {"change_n_s_per_m": np.asarray(signals.velocity_m_per_s, float) * _u(self, signals)}

    def configured(self, samples: FitSamples, residual_n) -> DampingDrift:
        return _spanned(self, samples)
