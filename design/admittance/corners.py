"""A given admittance setting (the lab's, or any design's gains) checked at every corner the spec declares: the
dense check's payloads x the uncertainty corners x every mouse (``design.admittance.model.AdmittanceEvaluator``,
the interaction loop sampled exactly), with the requirements it misses and where it is unstable."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from design.admittance.delays import evaluator
from design.admittance.model import PiLoops, admittance_problem
from design.admittance.rig import RigTiming
from design.loop.controller import PI
from design.problem import LoopProblem
from design.synth.scenarios import admittance_check_scenarios


@dataclass(frozen=True)
class CornerCheck:
    """How a setting fares over the spec's box."""

    scenarios: int
    mice: int
    #: (scenario, mouse) pairs whose coupled loop is unstable, and the first few of them in words
    unstable: int
    unstable_at: tuple[str, ...]
    worst_phase_margin_deg: float
    worst_gain_margin_db: float
    #: how many requirements it misses besides stability, and the first few in words
    violation_count: int
    violations: tuple[str, ...]

    @property
    def stable(self) -> bool:
        return self.unstable == 0


def corner_check(problem: LoopProblem, *, controller: PI, m_v: float, b_v: float,
                 shown: int = 3) -> CornerCheck:
    """``CornerCheck`` of the one-motor setting (the PI ``controller``, m_v, b_v) at the dense check's scenarios x
    the spec's mice (at every computation delay of the spec's range)."""
    scenarios = admittance_check_scenarios(problem)
    timing = RigTiming.of(admittance_problem(problem).rig)
    check = evaluator(problem, scenarios, loops=PiLoops.of(problem, controller), timing=timing).evaluate(m_v, b_v)
    k, j = np.nonzero(~check.stable)
    where = tuple(f"{scenarios.describe(jj)} with mouse ({check.mice[kk].label()})" for kk, jj in zip(k, j))
    return CornerCheck(len(scenarios), len(check.mice), int(k.size), where[:shown],
                       float(np.nanmin(np.where(check.stable, check.phase_margin_deg, np.nan))),
                       float(np.nanmin(np.where(check.stable, check.gain_margin_db, np.nan))),
                       *_first([v.detail for v in check.violations if v.constraint != "stability"], shown))


def _first(items: list[str], shown: int) -> tuple[int, tuple[str, ...]]:
    return len(items), tuple(items[:shown])
