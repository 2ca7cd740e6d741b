"""What a design that is not optimal trades, and what would move it.

* **Fronts.** The least force the virtual dynamics ask on the locomotion profile (m_v a_pk + b_v v_pk),
  against the interaction phase margin required of every mouse (floating and braced), and against the
  frequency up to which the rendered admittance must stay passive (Re Y_r >= 0), every other requirement
  held: each point is the best ray of ``design.admittance.ray`` on the design's own responses.
* **Hardware changes.** The same least force after one change of the rig at a time, each a new best ray on
  the heaviest design payload x the uncertainty corners x every mouse (the loop sampled exactly), beside the
  design's own figure on the same set: a lighter payload (the payload range's top -25 %), half the drive's
  delay, a faster admittance update (x2, x10), one more sample of computation delay, a faster drive loop
  (x2), and with ``motor_force_criterion = "worst_sinusoid"`` a motor of twice the peak force. On the bundled
  spec a faster update lowers the force (tests), as a faster law approaching the continuous one should.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from design.admittance.model import (
    PiLoops,
    admittance_problem,
    check_grid_for,
    interaction_responses,
    with_mode_points,
)
from design.admittance.ray import ACTIVE_ADD, HAIR_PM_DEG, best_ray, ray_problem, top_curves
from design.admittance.rig import RULE_NAMES, RigTiming
from design.parallel import thread_map
from design.problem import LoopProblem, Passivity
from design.synth.scenarios import design_scenarios

MARGINS_DEG = (20.0, 30.0, 40.0, 45.0, 50.0, 60.0)
PASSIVE_UP_TO_HZ = (1.0, 3.0, 6.0, 10.0, 20.0)


@dataclass(frozen=True)
class FrontPoint:
    requirement: float
    force_n: float
    m_v: float
    b_v: float

    @property
    def feasible(self) -> bool:
        return math.isfinite(self.force_n)


@dataclass(frozen=True)
class HardwareChange:
    change: str
    #: least force on the profile (N; inf: no design within the bounds), and the design's own on the same set
    force_n: float
    baseline_n: float


@dataclass(frozen=True)
class TradeOff:
    mouse_peak_force_n: float
    margin_front: tuple[FrontPoint, ...]
    passivity_front: tuple[FrontPoint, ...]
    changes: tuple[HardwareChange, ...]


def _point(rp, requirement: float, seed=None) -> FrontPoint:
    ray = best_ray(rp, points=20, refine=1, seed=seed)
    return FrontPoint(requirement, ray.cost_n(rp.a_pk, rp.v_pk), ray.m_v if ray.feasible else math.nan,
                      ray.b_v if ray.feasible else math.nan)


def trade_off(problem: LoopProblem, result, rp) -> TradeOff:
    """``TradeOff`` around ``result`` (an ``AdmittanceResult``) whose last ray problem was ``rp``."""
    adm = admittance_problem(problem)
    # the curves that bind near the design seed every point of the front (they bind near it too)
    seed = top_curves(rp, result.m_v / result.b_v, 2 * ACTIVE_ADD)
    margin_front = tuple(thread_map(lambda m: _point(replace(rp, phase_margin_deg=m + HAIR_PM_DEG), m, seed),
                                    MARGINS_DEG))
    heavy = design_scenarios(problem, [problem.plant.payload_kg.max])
    worst = result.timing.at_delay(result.timing.delays[-1])    # the what-ifs at a range's largest delay
    w = with_mode_points(check_grid_for(worst), result.corners, worst)
    resp = interaction_responses(problem, heavy, w, loops=PiLoops.of(problem, result.controller),
                                 timing=worst, corners=result.corners)
    passivity_front = thread_map(
        lambda f: _point(ray_problem(resp, replace(adm, passivity=Passivity(up_to_hz=f))), f), PASSIVE_UP_TO_HZ)
    baseline = best_ray(ray_problem(resp, adm), points=20, refine=1).cost_n(rp.a_pk, rp.v_pk)

    def change(case) -> HardwareChange:
        label, variant, timing = case
        sc = design_scenarios(variant, [variant.plant.payload_kg.max])
        wv = with_mode_points(check_grid_for(timing), result.corners, timing)
        r = interaction_responses(variant, sc, wv, loops=PiLoops.of(variant, result.controller), timing=timing,
                                  corners=result.corners)
        return HardwareChange(label, best_ray(ray_problem(r, admittance_problem(variant)), points=20,
                                              refine=1).cost_n(rp.a_pk, rp.v_pk), baseline)

    changes = thread_map(change, _variants(problem, worst))
    return TradeOff(adm.mouse.peak_force_n, margin_front, tuple(passivity_front), tuple(changes))


def _variants(problem: LoopProblem, timing: RigTiming):
    """(label, problem, timing) of each hardware change that applies to the spec."""
    family = problem.plant
    pr = family.payload_kg
    if pr.max > pr.min:
        top = max(pr.min, 0.75 * pr.max)
        yield (f"payload up to {top:g} kg instead of {pr.max:g} kg",
               replace(problem, plant=replace(family, payload_kg=replace(pr, max=top,
                                                                           nominal=min(pr.nominal_kg, top)))), timing)
    delay = family.nominal.effect("delay")
    if delay is not None:
        half = float(delay.seconds) / 2
        effects = tuple(replace(e, seconds=half) if e.name == "delay" else e for e in family.nominal.effects)
        unc = dict(family.uncertainty)
        if "delay.seconds" in unc:
            u = unc["delay.seconds"]
            unc["delay.seconds"] = replace(u, min=u.min / 2, max=u.max / 2)
        yield (f"half the drive's delay ({1e3 * half:.3g} ms)",
               replace(problem, plant=replace(family, nominal=replace(family.nominal, effects=effects),
                                              uncertainty=unc)), timing)
    if timing.sampled:
        for k in (2, 10):
            yield (f"admittance update at {k / timing.period_s:g} Hz instead of {1 / timing.period_s:g} Hz", problem,
                   replace(timing, period_s=timing.period_s / k))
        d = timing.delay_samples
        yield (f"{d + 1} sample(s) of computation delay instead of {d} (the law using the previous force reading)",
               problem, replace(timing, delay_samples=d + 1))
        for rule in ("tustin", "zoh"):
            if timing.rule != rule:
                yield (f"the law by {RULE_NAMES[rule]} instead of {RULE_NAMES[timing.rule]}", problem,
                       replace(timing, rule=rule))
    hw = problem.admittance.hardware
    if hw.motor_force_criterion == "worst_sinusoid":
        adm = replace(problem.admittance, hardware=replace(hw, motor_peak_force_n=2 * hw.motor_peak_force_n))
        yield (f"a motor of {2 * hw.motor_peak_force_n:g} N peak instead of {hw.motor_peak_force_n:g} N",
               replace(problem, admittance=adm), timing)
    sampling = family.nominal.effect("sampling")
    if sampling is not None:
        rate = 2 * float(sampling.rate_hz)
        effects = tuple(replace(e, rate_hz=rate) if e.name == "sampling" else e for e in family.nominal.effects)
        yield (f"drive velocity loop at {rate:g} Hz", replace(problem, plant=replace(
            family, nominal=replace(family.nominal, effects=effects))), timing)
