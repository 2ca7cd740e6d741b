"""A design's gains on a plant fitted from a measurement (``gantry report --data``): each fitted parameter against
the range the spec declares for it, and the loop's margins and bandwidth on the fitted plant.

Ranges: ``mass_kg`` against the payload range, every other parameter against its ``plant.uncertainty`` range; a
parameter the spec gives no range is compared with nothing ("no range"). A parameter whose standard error is not
finite or exceeds its value is "not identified" (the data do not set it: a current loop's corner far above the
recorded band reads 1e10 Hz ± inf) and is held at the spec's nominal value in the fitted plant the loop is judged
on, so that an unmeasured lag is not taken as absent. The fitted stage is judged at its fitted mass and at
``PAYLOAD_POINTS`` payloads across the spec's range: the stage keeps its measured delay, damping and force constant
whatever it carries. "Outside" means the fitted value lies outside the range by
more than two of its standard errors; then the design's verification over the spec's box does not cover the
measured stage, and the margins on the fitted plant are what the measurement says.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from design.loop.controller import PI
from design.loop.fast import fast_analyse_loop
from design.problem import LoopProblem
from plant.identify.fit_result import PlantFit

#: payloads across the spec's range the fitted stage is judged at (its fitted mass besides)
PAYLOAD_POINTS = 36
#: standard errors beyond the range's end at which a fitted value counts as outside it
OUTSIDE_SIGMAS = 2.0


@dataclass(frozen=True)
class FittedParameter:
    """One fitted parameter (SI): value, standard error, the spec's range (None, None: none declared) and
    ``status``: "inside", "outside", "no range" or "not identified"."""

    name: str
    value: float
    stderr: float
    low: float | None
    high: float | None
    status: str


@dataclass(frozen=True)
class FittedCheck:
    """The fitted parameters against the spec and the gains' loop on the fitted stage (unidentified parameters at
    the spec's nominal values) at its fitted mass and across the spec's payload range: the least phase margin (deg),
    gain margin (dB) and bandwidth (Hz), closed-loop stability at every payload and whether the spec's phase- and
    gain-margin requirements hold at every one."""

    parameters: tuple[FittedParameter, ...]
    phase_margin_deg: float
    gain_margin_db: float
    bandwidth_hz: float
    stable: bool
    meets: bool
    #: the fitted mass (kg) and the payload range (kg) the fitted stage was swept over
    fitted_mass_kg: float
    payload_kg: tuple[float, float]

    @property
    def outside(self) -> tuple[FittedParameter, ...]:
        return tuple(p for p in self.parameters if p.status == "outside")

    @property
    def unidentified(self) -> tuple[FittedParameter, ...]:
        return tuple(p for p in self.parameters if p.status == "not identified")


def _status(value: float, stderr: float, low: float | None, high: float | None) -> str:
    if not (math.isfinite(stderr) and stderr <= abs(value)):
        return "not identified"
    if low is None:
        return "no range"
    return "outside" if value < low - OUTSIDE_SIGMAS * stderr or value > high + OUTSIDE_SIGMAS * stderr else "inside"


def check_fitted(loop: LoopProblem, controller: PI, fit: PlantFit) -> FittedCheck:
    """``fit``'s free parameters against ``loop``'s spec and ``controller`` on the fitted plant (module doc)."""
    family = loop.plant
    ranges = {name: (u.min, u.max) for name, u in family.uncertainty.items()}
    ranges["mass_kg"] = (family.payload_kg.min, family.payload_kg.max)
    nominal = family.plant().parameters()
    params, held = [], {}
    for name in fit.free:
        value, stderr = float(fit.values[name]), float(fit.stderr.get(name, math.inf))
        low, high = ranges.get(name, (None, None))
        status = _status(value, stderr, low, high)
        params.append(FittedParameter(name, value, stderr, low, high, status))
        if status == "not identified" and name in nominal:
            held[name] = nominal[name].value
    plant = fit.plant.with_values(held) if held else fit.plant
    req = loop.requirements
    masses = np.unique(np.r_[np.linspace(family.payload_kg.min, family.payload_kg.max, PAYLOAD_POINTS),
                             float(fit.values["mass_kg"])])
    n = fast_analyse_loop(plant.with_payload(masses), controller, level2=req.level2)
    pm, gm, bw = (np.ravel(x) for x in (n.phase_margin_deg, n.gain_margin_db, n.closed_loop_bandwidth_hz))
    stable = bool(np.all(n.stable))
    return FittedCheck(tuple(params), float(np.min(pm)), float(np.min(gm)), float(np.nanmin(bw)), stable,
                       stable and float(np.min(pm)) >= req.phase_margin_deg and float(np.min(gm)) >= req.gain_margin_db,
                       float(fit.values["mass_kg"]), (family.payload_kg.min, family.payload_kg.max))
