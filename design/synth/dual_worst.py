"""The worst case of a two-motor design between the points of its design grid: what "verified" means for Stage Y.

A design holds its requirements on the design grid (carriage positions x payloads x the corners of the
uncertainty box) by construction; between those points a margin can dip below them (the worst cases of a
yaw mode sit where the carriage and the payload tune it, not on the grid). The check: every requirement on a
``DENSE`` grid of positions x payloads over the whole travel and payload range, at every corner of the box, then
a compass search (``design.loop.compass``, every start's trial points in one batch; first step a cell of the
grid) on position and payload, the corner held, from every local minimum of a margin's slack there that comes
within ``BAND`` of failing, for the point of least slack between them, and from that point a last search over
position, payload and the uncertain parameters inside their box (not only at its corners). The slack of a
plant is its least relative margin over the requirements (``slack``: negative where one fails, -1 where the
loop is unstable). A search that finds a failing point hands it back to the synthesis, which adds it to the
design plants and designs again (``design.synth.dual_design.design_dual``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from design.loop.compass import compass_search
from design.loop.dual import Controller, DualLoopFigures, loop_figures
from design.loop.requirement import ScenarioPoint
from design.parallel import thread_map
from design.synth.dual import W_RAD_S, DualRequirements, DualScenarios, Worst, dual_scenarios, worst_cases
from plant.physics.dual_drive import DualDriveStageY

#: carriage positions x payloads of the dense grid (at every corner of the uncertainty box): where the search starts
DENSE = (13, 8)
#: dense plants evaluated together (memory: CHUNK x 2 x 2 x frequencies complex values)
CHUNK = 200
#: a local minimum of a margin's slack on the dense grid is searched from when it is within this of failing (a
#: fraction of the requirement: 0.12 dB of 6 dB, 0.9 deg of 45 deg), the lowest ``MAX_SEARCHES`` of them
BAND = 0.02
MAX_SEARCHES = 24
#: the search's first step (a cell of the dense grid's payloads, the coarser of its two axes) and its tolerance,
#: as fractions of each coordinate's range
SEARCH_STEP = 1.0 / (DENSE[1] - 1)
SEARCH_XTOL = 1e-3


def slacks(f: DualLoopFigures, req: DualRequirements) -> np.ndarray:
    """Per required margin (rows) and plant: its relative excess over its requirement; -1 where the loop is
    unstable."""
    parts = [(f.phase_margin_deg - req.phase_margin_deg) / max(req.phase_margin_deg, 1.0),
             (f.gain_margin_db - req.gain_margin_db) / max(req.gain_margin_db, 1.0)]
    if req.common:
        parts += [(f.common_phase_margin_deg - req.common_phase_margin_deg) / max(req.common_phase_margin_deg, 1.0),
                  (f.common_gain_margin_db - req.common_gain_margin_db) / max(req.common_gain_margin_db, 1.0)]
    if req.disk_margin > 0:
        parts.append((f.disk_margin - req.disk_margin) / req.disk_margin)
    values = np.stack([np.where(np.isfinite(p), p, np.inf) for p in np.broadcast_arrays(*parts)])
    return np.where(f.unstable_poles > 0, -1.0, values)


def slack(f: DualLoopFigures, req: DualRequirements) -> np.ndarray:
    """Per plant: the least of ``slacks``."""
    return slacks(f, req).min(axis=0)


def _starts(values: np.ndarray, shape: tuple[int, int, int]) -> list[int]:
    """Dense plants to search from: every local minimum of a margin's slack over the position x payload grid of a
    corner (plants ordered position, payload, corner as ``dual_scenarios``) within ``BAND`` of failing, the lowest
    ``MAX_SEARCHES`` of them; at least the lowest minimum of each margin."""
    found: dict[int, float] = {}
    for v in values:
        grid = v.reshape(shape)                                   # (positions, payloads, corners)
        pad = np.pad(grid, ((1, 1), (1, 1), (0, 0)), constant_values=np.inf)
        core = pad[1:-1, 1:-1]
        local = ((core <= pad[:-2, 1:-1]) & (core <= pad[2:, 1:-1]) & (core <= pad[1:-1, :-2])
                 & (core <= pad[1:-1, 2:]))
        idx = np.flatnonzero(local.ravel())
        idx = idx[np.argsort(v[idx])]
        for k in [*idx[:1], *idx[v[idx] < BAND]]:
            found[int(k)] = min(found.get(int(k), np.inf), float(v[k]))
    return sorted(found, key=found.get)[:MAX_SEARCHES]


@dataclass(frozen=True)
class BetweenCheck:
    """A design between its grid's points: its worst case on the dense grid and the searched points together,
    the searched point of least slack (its scenario) and that slack, and how it was covered."""

    worst: Worst
    least_slack: float
    worst_point: ScenarioPoint
    dense_plants: int
    searches: int
    evaluations: int

    @property
    def holds(self) -> bool:
        return self.worst.feasible

    def coverage(self) -> str:
        return (f"a {DENSE[0]} x {DENSE[1]} grid of carriage positions x payloads at every corner of the uncertainty "
                f"box ({self.dense_plants} plants) and a search between its points from the {self.searches} of "
                f"least slack, the last inside the uncertainty box too ({self.evaluations} plants)")


def between_check(controller: Controller, model: DualDriveStageY, *, travel_m: tuple[float, float],
                  carriage_masses_kg: tuple[float, float], ranges: Mapping[str, tuple[float, float]],
                  req: DualRequirements, stage_x_mass_kg: float) -> BetweenCheck:
    """``controller`` checked between the design grid's points (module doc)."""
    (p0, p1), (m0, m1) = travel_m, carriage_masses_kg
    dense = dual_scenarios(model, np.linspace(p0, p1, DENSE[0]), np.linspace(m0, m1, DENSE[1]), ranges,
                           stage_x_mass_kg)
    values = np.concatenate(thread_map(lambda i: slacks(loop_figures(W_RAD_S, dense.frd_of(i, i + CHUNK), controller),
                                                        req), range(0, len(dense), CHUNK)), axis=1)
    s = values.min(axis=0)
    starts = np.array(_starts(values, (DENSE[0], DENSE[1], len(dense) // (DENSE[0] * DENSE[1]))))
    span = np.array([max(p1 - p0, 1e-12), max(m1 - m0, 1e-12)])
    low = np.array([p0, m0])
    names = list(ranges)
    lo_u = np.array([ranges[n][0] for n in names])
    du = np.array([max(ranges[n][1] - ranges[n][0], 1e-300) for n in names])
    evaluations = 0

    def plants(rows: np.ndarray, u: np.ndarray) -> DualScenarios:
        """Dense plants ``rows`` moved to unit coordinates ``u`` (position, payload[, each uncertain parameter])."""
        x = low + np.clip(u[:, :2], 0.0, 1.0) * span
        at = replace(dense.take(rows), carriage_position_m=x[:, 0], carriage_mass_kg=x[:, 1])
        if u.shape[1] > 2:
            values = lo_u + np.clip(u[:, 2:], 0.0, 1.0) * du
            at = replace(at, parameters={n: values[:, j] for j, n in enumerate(names)})
        return at

    def search(rows: np.ndarray, u0: np.ndarray, free: np.ndarray):
        """Every start at once (``design.loop.compass``): a start's row rides along as a fixed coordinate."""
        nonlocal evaluations

        def evaluate(v):
            return (slack(loop_figures(W_RAD_S, plants(v[:, -1].astype(int), v[:, :-1]).frd, controller,
                                       disk=req.disk_margin > 0), req),)

        r = compass_search(evaluate, np.column_stack([u0, rows]), free, step=SEARCH_STEP, tol=SEARCH_XTOL)
        evaluations += r.evaluations
        return r.u[:, :-1], r.value

    u0 = (np.column_stack([dense.carriage_position_m[starts], dense.carriage_mass_kg[starts]]) - low) / span
    u, found = search(starts, u0, np.arange(2))
    best = int(np.argmin(found))           # a search's value is at most its start's (it evaluates the start first)
    least, point = float(found[best]), plants(starts[best:best + 1], u[best:best + 1])
    moved = [plants(starts[i:i + 1], u[i:i + 1]) for i in np.flatnonzero(found < s[starts])]
    if ranges:
        # from the point of least slack, inside the uncertainty box too (not only at its corners)
        v0 = np.concatenate([u[best], (np.array([point.parameters[n][0] for n in names]) - lo_u) / du])
        v, value = search(starts[best:best + 1], v0[None, :], np.arange(2 + len(names)))
        if value[0] < least:
            least, point = float(value[0]), plants(starts[best:best + 1], v)
            moved.append(point)
    both = dense
    for one in moved:
        both = both.with_row(one.row(0))
    worst = worst_cases([controller], both, req)[0]
    return BetweenCheck(worst, least, point.row(0), len(dense), len(starts), evaluations)
