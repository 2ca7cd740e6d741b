"""The worst requirement slack of a PI design between the points of its dense check: "verified" over the declared
box, not only on its grid.

The dense check evaluates the design on payload points x the corners and seeded draws of ``plant.uncertainty``
(``design.synth.scenarios.check_scenarios``). From its ``STARTS`` rows of least slack a compass search
(``design.loop.compass``) moves over the payload and every uncertain parameter at once, each scaled to [0, 1] over its
declared range, every trial point evaluated as the dense check evaluates its rows (``design.synth.evaluation``: the
requirements' relative slack, -1 where the closed loop's bandwidth cannot be read). A point that fails joins the
design scenarios and the design is made again (``design.synth.pi``), as a Monte Carlo violator does. A second
search from the check's rows of lowest closed-loop bandwidth finds the least bandwidth between the points, beside
the worst case the design reports from the check.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from design.loop.compass import compass_search, unit_box
from design.loop.controller import PI
from design.loop.requirement import ScenarioPoint
from design.problem import LoopProblem
from design.synth.evaluation import evaluate
from design.synth.scenarios import Scenarios, uncertainty_ranges

#: rows of least slack on the dense check the search starts from
STARTS = 4


@dataclass(frozen=True)
class PiBetween:
    """The least relative slack found between the dense check's points, and where."""

    starts: int
    evaluations: int
    #: the dense check's least row slack, and the least the search found from its tightest rows
    grid_slack: float
    slack: float
    scenario: ScenarioPoint
    #: the coordinates searched (payload, uncertain parameters) and their values at the point found
    coordinates: tuple[str, ...]
    values: tuple[float, ...]
    #: the check's lowest closed-loop bandwidth (Hz), the least the second search found and where
    grid_bandwidth_hz: float = float("nan")
    least_bandwidth_hz: float = float("nan")
    bandwidth_scenario: ScenarioPoint | None = None

    @property
    def holds(self) -> bool:
        return self.slack >= -1e-6


def row_slack(problem: LoopProblem, controller: PI, scenarios: Scenarios) -> tuple[np.ndarray, np.ndarray]:
    """Per scenario: the requirements' least relative slack (``Evaluation.row_relative_slack``), -1 where the closed
    loop's bandwidth cannot be read (as ``Evaluation.meets`` counts it), and the bandwidth (Hz; 0: unread)."""
    ev = evaluate(problem, controller, scenarios)
    bw = np.asarray(ev.row_bandwidth_hz, float)
    return np.where(bw > 0, ev.row_relative_slack, -1.0), bw


def search_pi_between(problem: LoopProblem, controller: PI, dense: Scenarios, *,
                      starts: int = STARTS) -> PiBetween | None:
    """``PiBetween`` of ``controller`` from the dense check ``dense`` (module docstring); None when the box has no
    extent (one payload, no uncertainty)."""
    pr = problem.plant.payload_kg
    box = unit_box([("payload_kg", float(pr.min), float(pr.max), False)]
                   + [(n, lo, hi, False) for n, (lo, hi) in uncertainty_ranges(problem).items()])
    names, free, values = box.names, box.free, box.value
    if not free.size:
        return None

    def scenarios(x: np.ndarray) -> Scenarios:
        return Scenarios(x[:, 0].copy(), {n: x[:, 1 + i].copy() for i, n in enumerate(names[1:])})

    def starts_at(rows):
        return box.unit([[dense.payload_kg[j], *(dense.parameters[n][j] for n in names[1:])] for j in rows])

    grid, grid_bw = row_slack(problem, controller, dense)
    rows = np.argsort(grid, kind="stable")[:starts]
    found = compass_search(lambda u: row_slack(problem, controller, scenarios(values(u)))[:1], starts_at(rows), free)
    slowest = compass_search(lambda u: row_slack(problem, controller, scenarios(values(u)))[1:],
                             starts_at(np.argsort(grid_bw, kind="stable")[:starts]), free)
    i, b = int(np.argmin(found.value)), int(np.argmin(slowest.value))
    x = values(found.u[i:i + 1])
    return PiBetween(len(rows), found.evaluations + slowest.evaluations, float(np.min(grid)), float(found.value[i]),
                     scenarios(x).row(0), names, tuple(float(v) for v in x[0]), float(np.min(grid_bw)),
                     float(slowest.value[b]), scenarios(values(slowest.u[b:b + 1])).row(0))
