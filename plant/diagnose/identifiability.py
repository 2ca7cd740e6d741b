"""Whether the data identify an effect a model adds: a reported model names only effects whose parameters the data
set apart.

An effect added to the base model is *not identified* when one of its fitted parameters

* sits at a bound of its plausible range (the optimum lies on the edge: the data asked for more of it than the
  physics allows, or for none of it);
* is not determined: its standard error is infinite (a singular Jacobian), or, for the parameter that says how
  much of the effect there is (``Effect.main_parameter``: a delay's seconds, a lag's corner, a mode's frequency),
  wider than ``RELATIVE_ERROR`` times its value (the ±1σ interval reaches zero); a mode's damping or a load's
  offset from its declared position may be loosely set while the mode itself is plain;
* is a mode's frequency (``Effect.in_band``) outside the excited band widened by ``BAND_FACTOR`` on either side (a
  resonance at 327 kHz fitted to 1-75 Hz is a phase lag, not a resonance);
* is its main parameter and cancels another parameter of the model: their correlation exceeds
  ``CANCEL_CORRELATION`` in magnitude (a resonance whose notch sits 0.2 % below its peak, a filter traded against
  a delay): only their combination is identified (the covariance is numerically of lower rank). Two secondary
  parameters may trade off (a payload-sensed mode shows no notch, so its mass split and damping move together)
  while the mode they shape is plain.

A diagnosis reports only models whose added effects are all identified; the better-fitting models left out for
this are named with the reason (``plant.diagnose.diagnosis``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from plant.identify.fit_result import PlantFit
from plant.physics.effects import EFFECTS

#: a standard error wider than this times the value leaves the parameter undetermined
RELATIVE_ERROR = 1.0
#: a mode identified by a band of data lies within it, widened by this factor (an octave) at either end
BAND_FACTOR = 2.0
#: two parameters correlated beyond this cancel each other: only their combination is identified
CANCEL_CORRELATION = 0.9999
#: a value within this relative distance (of its bound, or of the range for a bound at zero) sits on the bound
AT_BOUND = 1e-4


@dataclass(frozen=True)
class Unidentified:
    """An effect of a model that the data do not identify, and why (one sentence, with the figures)."""

    effect: str
    reason: str

    def text(self) -> str:
        return f"{self.effect} ({self.reason})"


def unidentified(fit: PlantFit, base: tuple[str, ...], band_hz: tuple[float, float]) -> tuple[Unidentified, ...]:
    """The effects ``fit`` adds to ``base`` that its data (excited over ``band_hz``, lowest and highest frequency)
    do not identify, each with its first reason (module doc); () when every added effect is identified."""
    params = fit.plant.parameters()
    free = list(fit.free)
    out = []
    for effect in fit.plant.effect_names:
        if effect in base:
            continue
        names = [n for n in free if n.partition(".")[0] == effect]
        main = f"{effect}.{EFFECTS[effect].main_parameter}"
        reason = next((r for r in (_parameter_reason(fit, params[n], n, EFFECTS[effect], band_hz) for n in names)
                       if r), "") or (_cancelled(fit, free, main) if main in names else "")
        if reason:
            out.append(Unidentified(effect, reason))
    return tuple(out)


def _parameter_reason(fit: PlantFit, p, name: str, cls, band_hz: tuple[float, float]) -> str:
    value, err = fit.values[name], fit.stderr.get(name, math.nan)
    unit = f" {p.unit}" if p.unit else ""
    for side, bound in (("lower", p.lower), ("upper", p.upper)):
        if math.isfinite(bound) and _on(value, bound, p.lower, p.upper):
            return f"{name} = {value:.4g}{unit} sits at its {side} bound"
    field = name.partition(".")[2]
    lo, hi = band_hz[0] / BAND_FACTOR, band_hz[1] * BAND_FACTOR
    if field in cls.in_band and not lo <= value <= hi:
        return f"{name} = {value:.4g}{unit} lies outside the excited band {band_hz[0]:.3g}-{band_hz[1]:.3g} Hz"
    if not math.isfinite(err):
        return f"{name} is not determined by the data (singular Jacobian)"
    if field == cls.main_parameter and err > RELATIVE_ERROR * abs(value):
        return f"{name} = {value:.4g} ± {err:.2g}{unit}: its ±1σ exceeds its value"
    return ""


def _on(value: float, bound: float, lower: float, upper: float) -> bool:
    if bound != 0.0:
        return abs(value - bound) <= AT_BOUND * abs(bound)
    span = upper - lower if math.isfinite(upper - lower) else 1.0
    return abs(value - bound) <= AT_BOUND * span


def _cancelled(fit: PlantFit, free: list[str], main: str) -> str:
    """The first free parameter correlated with ``main`` beyond ``CANCEL_CORRELATION``, in words ("" if none)."""
    corr = np.asarray(fit.correlation, float)
    i = free.index(main)
    for j, b in enumerate(free):
        c = corr[i, j]
        if j != i and np.isfinite(c) and abs(c) > CANCEL_CORRELATION:
            return f"{main} and {b} cancel each other (correlation {c:+.4f}): only their combination is identified"
    return ""
