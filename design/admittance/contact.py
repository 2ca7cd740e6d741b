"""The stiffest grounded contact an admittance design stays stable with: the clamp held to the ground by
a spring k_e (a mouse bracing with a rigid neck, a hand, an end stop), Z_e = k_e / s.

For each scenario the coupled loop L_e = W K_e Y_v, K_e = Z_e R / (1 + S G Z_e)
(``design.admittance.model``; sampled rigs through their step-invariant sum) is tested for Nyquist
stability on a log grid of k_e from ``K_MIN`` to ``K_MAX`` N/m, and the boundary is refined by bisection
between the last stable and the first unstable stiffness. The design's stiffest contact is the least of
those over the scenarios.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from design.admittance.model import (
    admittance_problem,
    check_grid_for,
)
from design.admittance.rig import RigTiming, force_filter_frd
from design.admittance.sampled import closed_loop_radius, discretised_paths, spring_loads
from design.loop.margins import loop_margins
from design.parallel import thread_map
from design.problem import LoopProblem
from design.synth.scenarios import Scenarios

K_MIN, K_MAX = 1.0, 1.0e8
GRID = 29
BISECTIONS = 12


@dataclass(frozen=True)
class ContactLimit:
    """Stiffest stable grounded spring (N/m) per scenario; inf when every stiffness up to ``K_MAX`` is stable,
    0 when even ``K_MIN`` is not."""

    scenarios: Scenarios
    stiffness_n_per_m: np.ndarray

    @property
    def worst_n_per_m(self) -> float:
        return float(np.min(self.stiffness_n_per_m))

    @property
    def worst_scenario(self) -> str:
        return self.scenarios.describe(int(np.argmin(self.stiffness_n_per_m)))


def _stable(scenarios, k_e: np.ndarray, *, loops, m_v, b_v, timing: RigTiming, w: np.ndarray) -> np.ndarray:
    """Is the loop closed on the spring k_e[j] stable at scenario j? Sampled with a state space: the coupled
    discrete loop's poles (``design.admittance.sampled``); else the Nyquist test on ``w``."""
    if timing.sampled:
        paths = discretised_paths(loops, scenarios, spring_loads(k_e), timing)
        return closed_loop_radius(paths, timing.law(m_v, b_v), timing.delay_samples) < 1.0

    def path(s, weight):
        loop = loops.at(s, scenarios)
        return loop.reference * weight / (loop.s / k_e[:, None] + loop.sensitivity_mobility)

    gain = path(1j * w, force_filter_frd(1j * w, timing.filter_hz, timing.filter_order) * np.ones(w.size))
    stable = loop_margins(w, gain / timing.impedance(w, m_v, b_v), sampled=timing.sampled).closed_loop_stable
    return stable


def stiffest_contact(problem: LoopProblem, scenarios, *, loops, m_v: float, b_v: float,
                     timing: RigTiming | None = None) -> ContactLimit:
    """``ContactLimit`` of (m_v, b_v) at ``scenarios``."""
    timing = timing or RigTiming.of(admittance_problem(problem).rig)
    w = check_grid_for(timing)
    n = len(scenarios)
    grid = np.geomspace(K_MIN, K_MAX, GRID)
    ok = np.stack(thread_map(lambda k: _stable(scenarios, np.full(n, k), loops=loops, m_v=m_v, b_v=b_v,
                                               timing=timing, w=w), grid))    # (GRID, n)
    first_bad = np.where(ok.all(axis=0), GRID, np.argmin(ok, axis=0))
    lo = np.where(first_bad > 0, grid[np.maximum(first_bad - 1, 0)], 0.0)
    hi = np.where(first_bad < GRID, grid[np.minimum(first_bad, GRID - 1)], np.inf)
    refine = (first_bad > 0) & (first_bad < GRID)
    for _ in range(BISECTIONS):
        if not refine.any():
            break
        mid = np.where(refine, np.sqrt(np.maximum(lo, K_MIN) * np.where(np.isfinite(hi), hi, K_MAX)), K_MIN)
        st = _stable(scenarios, mid, loops=loops, m_v=m_v, b_v=b_v, timing=timing, w=w)
        lo = np.where(refine & st, mid, lo)
        hi = np.where(refine & ~st, mid, hi)
    return ContactLimit(scenarios, np.where(first_bad == GRID, np.inf, lo))
