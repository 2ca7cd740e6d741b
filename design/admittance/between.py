"""The worst interaction margins of an admittance design between the points of its check: what "verified" means
over the whole declared box, not only on its grid.

The dense check computes the margins on a grid: payload points x the corners of ``plant.uncertainty`` x the mice
of ``design.admittance.mouse.mouse_set`` (the corners of the mouse's ranges and a few leg stiffnesses). A margin
can dip between those points (a mouse's neck or legs tune a mode against the loop's crossover). The search: from
the ``STARTS`` curves of least margin slack on the check (half of them floating mice, half braced, when the spec has
both), a compass search over every continuous coordinate of the box at once — the payload, each uncertain
parameter and each mouse parameter, scaled to [0, 1] over its declared range (the leg stiffness in log over a
range of more than a decade, as the Monte Carlo draws it; a floating mouse keeps its feet off the ground) — each
trial point's margins computed exactly as the dense check computes them (``paired_margins``: the exactly sampled
loop on the check grid with the trial mouse's mode points, stability from the coupled discrete loop's poles). All
starts' trial points are evaluated in one batch per step; a start moves to its best trial point when that is
lower, else halves its step, from a quarter of each range down to 1/512 of it (``design.loop.compass``).

The slack of a curve is its least relative margin, min((PM - PM_req) / PM_req, (GM - GM_req) / GM_req), -1 where a
loop is unstable (as ``design.synth.dual_worst``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from design.admittance.bounds import curve_bounds, polar
from design.admittance.model import admittance_problem, check_grid_for, coupled_gain, paired_margins, with_mode_points
from design.admittance.mouse import FIELDS, MouseModel, stack
from design.admittance.rig import RigTiming
from design.loop.compass import UnitBox, compass_search, unit_box
from design.loop.requirement import ScenarioPoint
from design.problem import LoopProblem
from design.synth.scenarios import Scenarios, describe_row, uncertainty_ranges

#: curves of least slack on the check the search starts from
STARTS = 4


@dataclass(frozen=True)
class BetweenCheck:
    """The least interaction-margin slack found between the dense check's points (module docstring), and where."""

    starts: int
    #: trial points whose margins were computed
    evaluations: int
    #: the least slack on the check's computed curves, and the least the search found from its tightest ones
    grid_slack: float
    slack: float
    phase_margin_deg: float
    gain_margin_db: float
    stable: bool
    scenario: ScenarioPoint
    mouse: MouseModel
    #: the coordinates searched (carriage position for two motors, payload, uncertain parameters, the mouse's) and
    #: their values at the point found
    coordinates: tuple[str, ...]
    values: tuple[float, ...]

    @property
    def holds(self) -> bool:
        return self.slack >= 0


@dataclass(frozen=True)
class SearchBox(UnitBox):
    """The searched coordinates of the floating or of the braced mice (``design.loop.compass.UnitBox``): the first
    ``n_scenario`` make a scenario (``make``: rows of their values to a scenario set; ``read``: scenario ``j`` of a
    set to its values), the rest are the mouse's fields (``design.admittance.mouse.FIELDS``)."""

    n_scenario: int
    make: Callable[[np.ndarray], object]
    read: Callable[[object, int], list[float]]

    def point(self, x: np.ndarray) -> tuple[object, list[MouseModel]]:
        """Rows of values to their scenarios and mice."""
        x = np.atleast_2d(x)
        return self.make(x[:, :self.n_scenario]), [MouseModel(*(float(v) for v in r)) for r in x[:, self.n_scenario:]]

    def row(self, scenarios, j: int, mouse: MouseModel) -> np.ndarray:
        """The values of scenario ``j`` of ``scenarios`` with ``mouse``."""
        return np.array([*self.read(scenarios, j), *(getattr(mouse, f) for f in FIELDS)], float)


def _mouse_ranges(problem: LoopProblem, grounded: bool) -> list[tuple[str, float, float, bool]]:
    mouse = admittance_problem(problem).mouse
    out = []
    for f in FIELDS:
        r = getattr(mouse, f)
        if f.startswith("leg_") and not grounded:
            out.append((f, 0.0, 0.0, False))                # a floating mouse keeps its feet off the ground
        else:
            out.append((f, r.min, r.max, f == "leg_stiffness_n_per_m" and r.min > 0 and r.max > 10 * r.min))
    return out


def _search_box(ranges, n_scenario: int, make, read) -> SearchBox:
    b = unit_box(ranges)
    return SearchBox(b.names, b.lo, b.hi, b.log, n_scenario, make, read)


def one_motor_space(problem: LoopProblem) -> Callable[[bool], SearchBox]:
    """The box of the one-motor design: payload x ``plant.uncertainty`` x the mouse (floating or braced)."""
    rp = problem.plant.payload_kg
    uncertain = uncertainty_ranges(problem)
    names = tuple(uncertain)
    scenario = [("payload_kg", rp.min, rp.max, False)] + [(n, lo, hi, False) for n, (lo, hi) in uncertain.items()]

    def make(x):
        return Scenarios(x[:, 0].copy(), {n: x[:, 1 + i].copy() for i, n in enumerate(names)})

    def read(sc, j):
        return [sc.payload_kg[j], *(sc.parameters[n][j] for n in names)]

    return lambda grounded: _search_box(scenario + _mouse_ranges(problem, grounded), len(scenario), make, read)


def two_motor_space(problem: LoopProblem, model, travel_m: tuple[float, float], stage_x_mass_kg: float,
                    ranges: Mapping[str, tuple[float, float]]) -> Callable[[bool], SearchBox]:
    """The box of the two-motor Stage Y design: carriage position over ``travel_m`` x payload x ``ranges`` x the
    mouse (``design.synth.dual.DualScenarios`` of ``model``, the carriage ``stage_x_mass_kg`` plus the payload)."""
    from design.synth.dual import DualScenarios

    rp = problem.plant.payload_kg
    names = tuple(ranges)
    scenario = ([("carriage_position_m", travel_m[0], travel_m[1], False), ("payload_kg", rp.min, rp.max, False)]
                + [(n, lo, hi, False) for n, (lo, hi) in ranges.items()])

    def make(x):
        return DualScenarios(model, x[:, 0].copy(), stage_x_mass_kg + x[:, 1], {n: x[:, 2 + i].copy()
                                                                                 for i, n in enumerate(names)},
                             stage_x_mass_kg)

    def read(sc, j):
        return [sc.carriage_position_m[j], sc.payload_kg[j], *(sc.parameters[n][j] for n in names)]

    return lambda grounded: _search_box(scenario + _mouse_ranges(problem, grounded), len(scenario), make, read)


def slack_of(pm, gm, stable, phase_margin_deg: float, gain_margin_db: float) -> np.ndarray:
    """Per curve: the least relative margin over the two requirements, -1 where a loop is unstable."""
    pm, gm = np.asarray(pm, float), np.asarray(gm, float)
    s = np.minimum(np.where(np.isfinite(pm), (pm - phase_margin_deg) / max(phase_margin_deg, 1.0), np.inf),
                   np.where(np.isfinite(gm), (gm - gain_margin_db) / max(gain_margin_db, 1.0), np.inf))
    return np.where(np.asarray(stable, bool), s, -1.0)


def _starts(check, slack: np.ndarray, grounded: bool, n: int) -> list[tuple[int, int]]:
    """The ``n`` (mouse, scenario) pairs of least slack among the floating or the braced mice."""
    rows = np.flatnonzero([m.grounded == grounded for m in check.mice])
    order = np.argsort(slack[rows], axis=None, kind="stable")[:n]
    return [(int(rows[k]), int(j)) for k, j in zip(*np.unravel_index(order, (rows.size, slack.shape[1])))]


def search_between(problem: LoopProblem, check, *, loops, timing: RigTiming, space=None,
                   starts: int = STARTS) -> BetweenCheck:
    """``BetweenCheck`` of the design of ``check`` (an ``AdmittanceCheck`` on the dense scenarios and mice) under
    the velocity ``loops`` at the rig ``timing`` (module docstring), over ``space(grounded)`` (default
    ``one_motor_space``)."""
    space = space or one_motor_space(problem)
    adm = admittance_problem(problem)
    req = (adm.phase_margin_deg, adm.gain_margin_db)
    m_v, b_v = check.m_v, check.b_v
    grid = slack_of(np.nan_to_num(check.phase_margin_deg, nan=np.inf),
                    np.nan_to_num(check.gain_margin_db, nan=np.inf), check.stable, *req)   # (n_mouse, n_scenario)
    base_w = check_grid_for(timing)
    kinds = [g for g in (False, True) if any(m.grounded == g for m in check.mice)]
    evaluations, total_starts, best = 0, 0, None

    def evaluate(box: SearchBox, u: np.ndarray):
        scenarios, one = box.point(box.value(u))
        w = with_mode_points(base_w, one, timing)
        pm, gm, st = paired_margins(loops, scenarios, stack(one), w, timing, m_v, b_v)
        return slack_of(pm, gm, st, *req), pm, gm, st

    for grounded in kinds:
        box = space(grounded)
        picks = _starts(check, grid, grounded, max(1, starts // len(kinds)))
        total_starts += len(picks)
        u = box.unit(np.array([box.row(check.scenarios, j, check.mice[k]) for k, j in picks]))
        found = compass_search(lambda points: evaluate(box, points), u, box.free)
        u, f, (pm, gm, st) = found.u, found.value, found.extra
        evaluations += found.evaluations
        i = int(np.argmin(f))
        if best is None or f[i] < best[0]:
            scenarios, one = box.point(box.value(u[i]))
            best = (float(f[i]), float(pm[i]), float(gm[i]), bool(st[i]), scenarios.row(0), one[0], box.names,
                    tuple(float(v) for v in box.value(u[i])))
    slack, pm, gm, stable, scenario, mouse, names, values = best
    return BetweenCheck(total_starts, evaluations, float(np.min(grid)), slack, pm, gm, stable, scenario, mouse, names,
                        values)


#: rounds of search and scale-up (``hold_between``) at most
ROUNDS = 3


@dataclass(frozen=True)
class HeldBetween:
    """A design made to hold between the check's points: (m_v, b_v), its dense check, the last search (which holds
    unless ``ROUNDS`` did not suffice), the first search's failing point when there was one, and the factor the
    design was scaled up its ray by (1: not at all)."""

    x: np.ndarray
    check: object
    search: BetweenCheck
    failed: BetweenCheck | None
    scale: float
    rounds: int


def _search(problem, check, loops, timing: RigTiming, space) -> tuple[BetweenCheck, RigTiming]:
    """The least slack over the rig's computation delays, and the delay's timing where it lies."""
    runs = [(search_between(problem, check, loops=loops, timing=t, space=space), t) for t in timing.per_delay()]
    return min(runs, key=lambda r: r[0].slack)


def _needed_b_v(problem, found: BetweenCheck, box: SearchBox, *, loops, timing: RigTiming, tau_s: float) -> float:
    """The least b_v on the ray m_v / b_v = ``tau_s`` that holds the margins at the search's point (its ray bound,
    ``design.admittance.bounds.curve_bounds``, on the check grid with the point's mouse modes)."""
    adm = admittance_problem(problem)
    scenario, one = box.point(np.array(found.values))
    w = with_mode_points(check_grid_for(timing), one, timing)
    gain = coupled_gain(loops, scenario, stack(one), w, timing, paired=True)
    bound = curve_bounds(*polar(gain), timing.impedance(w, tau_s, 1.0), adm.phase_margin_deg,
                         10 ** (adm.gain_margin_db / 20), timing.sampled)
    return float(bound[0])


def hold_between(problem: LoopProblem, dense, x: np.ndarray, check, *, loops, timing: RigTiming,
                 space=None) -> HeldBetween:
    """Search between the dense check's points (``search_between`` over ``space``, default ``one_motor_space``, at
    every computation delay); where a point fails, scale (m_v, b_v) up its ray to that point's bound (the margins
    of every curve that held hold above it too), check the dense set again (``dense.evaluate``) and search again,
    at most ``ROUNDS`` times."""
    space = space or one_motor_space(problem)
    x = np.asarray(x, float)
    scale, failed = 1.0, None
    for n in range(1, ROUNDS + 1):
        found, t = _search(problem, check, loops, timing, space)
        if found.holds or n == ROUNDS:
            return HeldBetween(x, check, found, failed, scale, n)
        failed = failed or found
        need = _needed_b_v(problem, found, space(found.mouse.grounded), loops=loops, timing=t, tau_s=x[0] / x[1])
        s = max(need / x[1], 1.0 + 1e-4)
        x, scale = x * s, scale * s
        check = dense.evaluate(*x, recorded=True)
    raise AssertionError("unreachable")


def _over(search: BetweenCheck) -> str:
    return ("carriage position, payload, uncertainty and mouse" if search.coordinates[0] == "carriage_position_m"
            else "payload, uncertainty and mouse")


def between_text(held: HeldBetween | None) -> str:
    """What the search covered and found, for a verdict's "verified on ..." ("" without a search)."""
    if held is None:
        return ""
    s = held.search
    return (f" and between the dense check's points (a compass search from {s.starts} starts over {_over(s)}, "
            f"{s.evaluations} points; least slack at PM {s.phase_margin_deg:.2f} deg, GM {s.gain_margin_db:.2f} dB)")


def between_failure(search: BetweenCheck) -> str:
    """A failing point of the search, in words."""
    return (f"between the check's points PM {search.phase_margin_deg:.2f} deg, GM {search.gain_margin_db:.2f} dB"
            f"{'' if search.stable else ', unstable'} at {describe_row(search.scenario)} with mouse "
            f"({search.mouse.label()})")


def worst_by_legs(check, held: HeldBetween | None) -> dict[str, tuple[float, float]]:
    """Worst (phase margin deg, gain margin dB) of the floating and of the grounded mice over the dense check
    (``AdmittanceCheck.worst_by_legs``) and the point the search between its points found."""
    legs = dict(check.worst_by_legs())
    if held is not None:
        s = held.search
        name = "grounded" if s.mouse.grounded else "floating"
        pm, gm = legs.get(name, (np.inf, np.inf))
        legs[name] = (min(pm, s.phase_margin_deg), min(gm, s.gain_margin_db))
    return legs
