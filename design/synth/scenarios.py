"""Scenarios: the plants a design must hold on. A scenario is one payload with one value of every
uncertain parameter (``plant.uncertainty`` of the spec); a set of them is a batch of plants.

A design is computed on the payload points times the corners of the uncertainty box, and checked
on the dense payloads times the corners and a fixed set of seeded random draws; the worst violator
of the check joins the design set round by round (as systune does with its sampled uncertainty).
Every range is uniform and independent, as in ``design.loop.sweep``.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from design.loop.requirement import ScenarioPoint
from design.loop.sweep import checked_ranges
from design.problem import LoopProblem
from plant.physics.models import Plant

#: seeded random draws of the uncertain parameters added to the corners in the check set
CHECK_DRAWS = 24
#: more uncertain parameters than this: the corners (2^n) are replaced by the draws alone
MAX_CORNER_PARAMETERS = 6
#: payloads of the admittance's dense check (each of its curves is an exactly sampled loop per mouse, so fewer than
#: the PI loop's ``PayloadRange.check_points``)
ADMITTANCE_CHECK_PAYLOADS = 25


@dataclass(frozen=True)
class Scenarios:
    """Rows of (payload, uncertain parameter values): ``payload_kg`` (n,), ``parameters`` name -> (n,)."""

    payload_kg: np.ndarray
    parameters: dict[str, np.ndarray] = field(default_factory=dict)
    #: responses of ``plants`` already computed, by (base plant, grid size, grid ends): a design evaluates
    #: many gains on the same scenarios, and the plants' response does not depend on the gains
    _responses: dict = field(default_factory=dict, compare=False, repr=False)

    def __len__(self) -> int:
        return int(self.payload_kg.size)

    def values(self, rows=None) -> dict[str, np.ndarray]:
        """``Plant.with_values`` arguments of the rows as (n, 1) batches."""
        r = slice(None) if rows is None else rows
        return {"mass_kg": self.payload_kg[r][:, None], **{k: v[r][:, None] for k, v in self.parameters.items()}}

    def plants(self, base: Plant, rows=None) -> Plant:
        """The scenarios as one (n, 1) batch of ``base``."""
        return base.with_values(self.values(rows))

    def response(self, base: Plant, w_rad_s: np.ndarray) -> np.ndarray:
        """``plants(base).frd(w_rad_s)``, computed once per base plant and grid (m/s per A, (n, n_freq))."""
        try:
            key = (base, w_rad_s.size, float(w_rad_s[0]), float(w_rad_s[-1]))
            hash(key)
        except TypeError:       # a plant with batch parameters: not kept
            return self.plants(base).frd(w_rad_s)
        if key not in self._responses:
            self._responses[key] = self.plants(base).frd(w_rad_s)
        return self._responses[key]

    def plant(self, base: Plant, k: int) -> Plant:
        """Scenario ``k`` as a scalar plant."""
        return base.with_values({"mass_kg": float(self.payload_kg[k]),
                                 **{n: float(v[k]) for n, v in self.parameters.items()}})

    def row(self, k: int) -> ScenarioPoint:
        return ScenarioPoint(float(self.payload_kg[k]), tuple((n, float(v[k])) for n, v in self.parameters.items()))

    def describe(self, k: int) -> str:
        """'5.0 kg' or '5.0 kg, damping_n_s_per_m = 330, delay.seconds = 0.0008'."""
        extra = "".join(f", {n} = {v[k]:.4g}" for n, v in self.parameters.items())
        return f"{self.payload_kg[k]:.1f} kg{extra}"

    def with_row(self, row: ScenarioPoint) -> Scenarios:
        return Scenarios(np.append(self.payload_kg, row.payload_kg),
                         {n: np.append(v, row.parameter(n)) for n, v in self.parameters.items()})

    def contains(self, row: ScenarioPoint) -> bool:
        same = np.isclose(self.payload_kg, row.payload_kg, rtol=1e-9, atol=0)
        for n, v in self.parameters.items():
            same &= np.isclose(v, row.parameter(n), rtol=1e-9, atol=0)
        return bool(np.any(same))

    def take(self, rows) -> Scenarios:
        """The scenarios of ``rows`` (an index array or a boolean mask)."""
        return Scenarios(self.payload_kg[rows], {n: v[rows] for n, v in self.parameters.items()})

    def at_payload(self, payload_kg: float) -> Scenarios:
        """The rows of one payload (for a gain schedule)."""
        return self.take(np.isclose(self.payload_kg, payload_kg, rtol=1e-12, atol=0))


def uncertainty_ranges(problem: LoopProblem) -> dict[str, tuple[float, float]]:
    """The problem's uncertain parameters and their (min, max), checked against the plant (sorted by name)."""

    return dict(sorted(checked_ranges(problem.plant.uncertainty, problem.plant.plant()).items()))


def parameter_sets(ranges: dict[str, tuple[float, float]], *, draws: int, seed: int = 0) -> dict[str, np.ndarray]:
    """Corners of the box (every min/max combination, up to ``MAX_CORNER_PARAMETERS`` parameters) and
    ``draws`` seeded uniform draws; a degenerate range (min = max) contributes one value."""
    names = list(ranges)
    if not names:
        return {}
    sets = []
    if len(names) <= MAX_CORNER_PARAMETERS:
        sets += list(itertools.product(*[sorted({lo, hi}) for lo, hi in ranges.values()]))
    rng = np.random.default_rng(seed)
    sets += [tuple(rng.uniform(lo, hi) for lo, hi in ranges.values()) for _ in range(draws)]
    cols = np.array(sets, float).T
    return {n: cols[i] for i, n in enumerate(names)}


def grid(payload_kg, sets: dict[str, np.ndarray]) -> Scenarios:
    """Every payload with every parameter set, payload-major."""
    m = np.asarray(payload_kg, float).ravel()
    n_s = len(next(iter(sets.values()))) if sets else 1
    return Scenarios(np.repeat(m, n_s), {n: np.tile(v, m.size) for n, v in sets.items()})


def design_scenarios(problem: LoopProblem, payload_kg=None) -> Scenarios:
    """The payload design points (or ``payload_kg``) times the corners of the uncertainty box."""
    m = problem.plant.payload_kg.design_points() if payload_kg is None else payload_kg
    return grid(m, parameter_sets(uncertainty_ranges(problem), draws=0))


def check_scenarios(problem: LoopProblem, payload_kg=None) -> Scenarios:
    """The dense payloads (or ``payload_kg``) times the corners and ``CHECK_DRAWS`` seeded draws."""
    m = problem.plant.payload_kg.check_points() if payload_kg is None else payload_kg
    ranges = uncertainty_ranges(problem)
    return grid(m, parameter_sets(ranges, draws=CHECK_DRAWS if ranges else 0))


def admittance_check_scenarios(problem: LoopProblem) -> Scenarios:
    """The admittance's dense check: ``ADMITTANCE_CHECK_PAYLOADS`` payloads evenly over the range x the corners
    of the uncertainty box (random draws are left to its Monte Carlo, which also draws the mouse)."""
    pr = problem.plant.payload_kg
    payloads = np.linspace(pr.min, pr.max, ADMITTANCE_CHECK_PAYLOADS) if pr.max > pr.min else np.array([pr.min])
    return grid(payloads, parameter_sets(uncertainty_ranges(problem), draws=0))


def random_scenarios(problem: LoopProblem, samples: int, *, seed: int) -> Scenarios:
    """``samples`` independent uniform draws over payload x the uncertainty box."""
    rng = np.random.default_rng(seed)
    rp = problem.plant.payload_kg
    m = rng.uniform(rp.min, rp.max, samples) if rp.max > rp.min else np.full(samples, rp.min)
    return Scenarios(m, {n: rng.uniform(lo, hi, samples) for n, (lo, hi) in uncertainty_ranges(problem).items()})


def describe_row(row: ScenarioPoint) -> str:
    """A scenario (``Scenarios.row``) as 'payload_kg = 40, damping_n_s_per_m = 330, ...'."""
    return ", ".join(f"{k} = {v:.4g}" for k, v in row.as_dict().items())


@dataclass(frozen=True)
class Coverage:
    """How much of the declared box (payload range x ``plant.uncertainty``) each stage of a design covers: the
    design set, the dense check, python-control's re-check and the Monte Carlo (this module's policy, stated
    once for every report and the JSON)."""

    payload_range_kg: tuple[float, float]
    uncertain: tuple[str, ...]
    #: corners of the uncertainty box used (2^n; 1 without uncertainty, 0 beyond ``MAX_CORNER_PARAMETERS``)
    corners: int
    design_payloads: int
    dense_payloads: int
    dense_draws: int
    admittance_payloads: int
    monte_carlo_samples: int
    monte_carlo_seed: int
    #: the problem has an admittance stage (its dense check is stated too)
    admittance: bool = False

    @property
    def design_scenarios(self) -> int:
        return self.design_payloads * max(self.corners, 1)

    @property
    def dense_scenarios(self) -> int:
        return self.dense_payloads * (max(self.corners, 1) + self.dense_draws)

    def text(self) -> str:
        """The policy in words."""
        box = ("the nominal parameters (no plant.uncertainty)" if not self.uncertain else
               f"{self.corners} corners of the uncertainty box ({', '.join(self.uncertain)})" if self.corners else
               f"{self.dense_draws} seeded draws of the uncertainty box ({', '.join(self.uncertain)})")
        lo, hi = self.payload_range_kg
        draws = f" and {self.dense_draws} seeded draws" if self.uncertain and self.corners and self.dense_draws else ""
        return (f"designed on {self.design_payloads} payloads x {box}; checked on {self.dense_payloads} payloads "
                f"evenly over {lo:g}-{hi:g} kg x the same{draws} ({self.dense_scenarios} scenarios) and by "
                f"python-control on the design scenarios and the tightest checked ones"
                + (f"; the admittance on {self.admittance_payloads} payloads x the corners x every mouse corner"
                   if self.admittance else "")
                + (f"; between these points only the Monte Carlo covers the box ({self.monte_carlo_samples} uniform "
                   f"draws over payload x uncertainty, seed {self.monte_carlo_seed})" if not self.admittance else
                   f"; between these points the Monte Carlo ({self.monte_carlo_samples} uniform draws over payload x "
                   f"uncertainty x mouse, seed {self.monte_carlo_seed}) and, for the interaction margins, a search "
                   "over payload x uncertainty x mouse from the admittance check's tightest curves"))

    def as_dict(self) -> dict:
        return {"payload_range_kg": list(self.payload_range_kg), "uncertain_parameters": list(self.uncertain),
                "corners": self.corners, "design": {"payloads": self.design_payloads,
                                                    "scenarios": self.design_scenarios},
                "dense_check": {"payloads": self.dense_payloads, "seeded_draws": self.dense_draws,
                                "scenarios": self.dense_scenarios},
                **({"admittance_dense_check": {"payloads": self.admittance_payloads,
                                               "scenarios": self.admittance_payloads * max(self.corners, 1),
                                               "with": "every mouse of admittance.mouse (its corners)"}}
                   if self.admittance else {}),
                "monte_carlo": {"samples": self.monte_carlo_samples, "seed": self.monte_carlo_seed},
                **({"between_admittance_points": "admittance.between_grid"} if self.admittance else {}),
                "text": self.text()}


def coverage(problem: LoopProblem) -> Coverage:
    """The ``Coverage`` of ``problem`` under this module's policy."""
    ranges = uncertainty_ranges(problem)
    corners = (int(np.prod([len({lo, hi}) for lo, hi in ranges.values()])) if len(ranges) <= MAX_CORNER_PARAMETERS
               else 0)
    pr = problem.plant.payload_kg
    return Coverage((float(pr.min), float(pr.max)), tuple(ranges), corners, len(pr.design_points()),
                    len(pr.check_points()), CHECK_DRAWS if ranges else 0,
                    ADMITTANCE_CHECK_PAYLOADS if pr.max > pr.min else 1, problem.verification.monte_carlo_samples,
                    problem.verification.seed, problem.admittance is not None)
