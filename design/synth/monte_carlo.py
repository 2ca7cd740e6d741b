"""Monte Carlo verification of a design: independent uniform draws over payload x the spec's
uncertainty, none of them a design scenario, and the violation rate with its exact (Clopper-Pearson)
one-sided 95 % upper bound: what a design can claim beyond the scenarios it was computed for.

The draws use the fast path of ``design.loop.fast`` (cubic-refined margins, Nyquist stability on
its grid; ``benchmarks/bench_sweep.py`` checks it against python-control), in chunks, so 10,000
plants take about a second.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from design.loop.controller import PI
from design.loop.fast import fast_analyse_batch
from design.loop.requirement import ScenarioPoint
from design.problem import LoopProblem
from design.synth.scenarios import random_scenarios
from design.synth.verify import MARGIN_TOLERANCE
from plant.errors import ParameterError

#: one-sided confidence of the upper bound on the violation rate
CONFIDENCE = 0.95
CHUNK = 2048


@dataclass(frozen=True)
class MonteCarloDraws:
    """Every draw of a check: payload (kg), phase margin (deg), gain margin (dB), bandwidth (Hz) and whether its
    closed loop is stable, each shaped (samples,)."""

    payload_kg: np.ndarray
    phase_margin_deg: np.ndarray
    gain_margin_db: np.ndarray
    bandwidth_hz: np.ndarray
    stable: np.ndarray


@dataclass(frozen=True)
class MonteCarloCheck:
    """Requirements checked on ``samples`` independent draws (seed ``seed``)."""

    samples: int
    seed: int
    violations: int
    #: the one-sided ``CONFIDENCE`` upper bound on the violation rate (Clopper-Pearson)
    rate_upper_bound: float
    worst_phase_margin_deg: float
    worst_gain_margin_db: float
    worst_bandwidth_hz: float
    #: the draw with the least slack
    worst_scenario: ScenarioPoint
    unstable: int
    #: every draw (the report plots them; not compared)
    draws: MonteCarloDraws | None = field(default=None, repr=False, compare=False)

    @property
    def rate(self) -> float:
        return self.violations / self.samples


@dataclass(frozen=True)
class Tally:
    """What every Monte Carlo check says of its draws: how many violate, the one-sided ``CONFIDENCE`` upper bound on
    the violation rate (Clopper-Pearson), how many are unstable, and the draw with the least slack (an unstable draw
    before any stable one)."""

    samples: int
    violations: int
    rate_upper_bound: float
    unstable: int
    worst: int


def tally(violated: np.ndarray, slack: np.ndarray, stable: np.ndarray) -> Tally:
    """``Tally`` of draws flagged ``violated``, with their relative ``slack`` and closed-loop stability."""
    violated, stable = np.asarray(violated, bool), np.asarray(stable, bool)
    k = int(violated.sum())
    return Tally(violated.size, k, clopper_pearson_upper(k, violated.size), int((~stable).sum()),
                 int(np.argmin(np.where(stable, slack, -np.inf))))


def as_drawn(worst):
    """A worst case computed over Monte Carlo draws (``design.synth.dual.Worst``, ``design.synth.planar.PlanarWorst``:
    ``n_failing`` of ``n_plants``) with the upper bound on its violation rate, as every Monte Carlo check states."""
    return replace(worst, rate_upper_bound=clopper_pearson_upper(worst.n_failing, worst.n_plants))


def clopper_pearson_upper(violations: int, samples: int, confidence: float = CONFIDENCE) -> float:
    """Exact one-sided upper confidence bound on a binomial rate; 1 - (1 - confidence)^(1/n) for 0 of n."""
    from scipy.special import betaincinv

    if violations >= samples:
        return 1.0
    return float(betaincinv(violations + 1, samples - violations, confidence))    # the Beta(k+1, n-k) quantile


def draw_settings(problem: LoopProblem, samples: int | None, seed: int | None) -> tuple[int, int]:
    """(samples, seed) of a Monte Carlo check: as given, else the problem's ``verification`` settings."""
    samples = problem.verification.monte_carlo_samples if samples is None else samples
    seed = problem.verification.seed if seed is None else seed
    if isinstance(samples, bool) or int(samples) != samples or samples < 1:
        raise ParameterError(f"Monte Carlo samples must be a positive integer, got {samples!r}")
    return int(samples), int(seed)


def monte_carlo_check(problem: LoopProblem, controller: PI, *, samples: int | None = None,
                      seed: int | None = None) -> MonteCarloCheck:
    """Phase and gain margin, stability and bandwidth of the PI ``controller`` on ``samples`` uniform draws over
    payload x ``plant.uncertainty`` (default: the problem's ``verification`` settings); a draw violates
    when a margin falls short of its requirement by more than ``MARGIN_TOLERANCE`` or its closed loop
    is unstable."""
    samples, seed = draw_settings(problem, samples, seed)
    s = random_scenarios(problem, samples, seed=seed)
    base, req = problem.plant.plant(), problem.requirements
    n = fast_analyse_batch(lambda rows: s.plants(base, rows), len(s), controller, level2=req.level2, chunk=CHUNK)
    pm, gm, bw, stable = n.phase_margin_deg, n.gain_margin_db, n.closed_loop_bandwidth_hz, n.stable
    slack = np.minimum((pm - req.phase_margin_deg) / max(req.phase_margin_deg, 1.0),
                       np.where(np.isfinite(gm), gm - req.gain_margin_db, np.inf) / max(req.gain_margin_db, 1.0))
    t = tally((pm < req.phase_margin_deg - MARGIN_TOLERANCE) | (gm < req.gain_margin_db - MARGIN_TOLERANCE) | ~stable,
              slack, stable)
    return MonteCarloCheck(samples, seed, t.violations, t.rate_upper_bound, float(np.min(pm)),
                           float(np.min(gm)), float(np.nanmin(bw)) if np.any(np.isfinite(bw)) else float("nan"),
                           s.row(t.worst), t.unstable,
                           MonteCarloDraws(np.asarray(s.payload_kg, float), pm, gm, bw, stable))
