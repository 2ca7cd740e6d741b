"""Robust gains for each loop structure of the two-motor Stage Y (``design.loop.dual``), and the structures
compared on the same plants.

The plants are every carriage position x payload x corner of the uncertainty box (``DualScenarios``); a
structure's gains must keep every one stable with its channels' loop-at-a-time margins (and, when asked, the
simultaneous disk margin at the motor inputs), and among those the gains with the highest worst-case
translation bandwidth are chosen. The search is a scan: a log grid over the gain box, then finer grids
around its best points, each grid scored by lazy cutting planes on the plants that bound earlier candidates
(``_score``; exact: a candidate is dropped only when those plants alone rule it out). Two gains are scanned
at a time, kp and ki of one channel; the common/differential pair first scans both channels with equal gains
(the per-motor design), then its differential channel for the least yaw coupling (rail disagreement per
translation command) with the common one held, then the common channel again for bandwidth with the yaw
coupling held within ``YAW_SLACK`` of what the differential step reached; the last step is kept when its
worst bandwidth is at least the first's, else the first (equal gains) stands. ``design_dual`` then checks
every structure on Monte Carlo draws it was not chosen on (``monte_carlo_scenarios``: positions, payloads
and parameters drawn uniformly in their ranges) and recommends one (``recommend``).
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from design.loop.dual import (
    ChannelForm,
    CommonDifferential,
    Controller,
    DualLoopFigures,
    MasterSlave,
    PerMotor,
    loop_figures,
)
from design.loop.requirement import ScenarioPoint
from design.parallel import thread_map
from plant.errors import SpecError
from plant.physics.dual_drive import DualDriveStageY

#: frequency grid of the evaluation (rad/s): from where the integrators dominate to beyond the drives
W_RAD_S = 2 * np.pi * np.logspace(-2, 3.3, 500)
#: scan: points per gain on the coarse grid; then, from each of its STARTS best points, a FINE x FINE grid
#: spanning one step on either side: it moves to its best point when that lies on its edge and zooms in
#: (its spacing the new step) when inside, until the step is below REFINED_DECADES (at most MAX_MOVES grids)
COARSE, FINE, REFINED_DECADES, STARTS, MAX_MOVES = 21, 7, 0.003, 3, 40
#: the common/differential pair's last step may raise the yaw coupling its differential step reached by this factor
YAW_SLACK = 1.25
#: plants evaluated together when a design is judged (memory: MC_CHUNK x 2 x 2 x frequencies)
MC_CHUNK = 200
#: controller x plant pairs screened together (memory: SCREEN_PLANTS x 2 x 2 x frequencies complex values)
SCREEN_PLANTS = 256


@dataclass(frozen=True)
class DualRequirements:
    phase_margin_deg: float = 45.0
    gain_margin_db: float = 6.0
    #: simultaneous balanced disk margin at the motor inputs (0: not required)
    disk_margin: float = 0.0
    #: margins against the same gain or phase change on both motors at once (0: not required)
    common_phase_margin_deg: float = 0.0
    common_gain_margin_db: float = 0.0

    @classmethod
    def of(cls, r) -> DualRequirements:
        """From a problem's ``design.problem.Requirements``: the common-mode margins default to the
        loop-at-a-time ones (the spec keys' documented default)."""
        return cls(r.phase_margin_deg, r.gain_margin_db, r.disk_margin or 0.0,
                   r.phase_margin_deg if r.common_phase_margin_deg is None else r.common_phase_margin_deg,
                   r.gain_margin_db if r.common_gain_margin_db is None else r.common_gain_margin_db)

    @property
    def common(self) -> bool:
        return self.common_phase_margin_deg > 0 or self.common_gain_margin_db > 0

    def binding(self, worst: Worst) -> tuple[str, ...]:
        """The spec keys of the requirements a design's worst case sits on (within 0.1 deg, 0.1 dB, 0.005)."""
        pairs = [("requirements.phase_margin_deg", worst.phase_margin_deg, self.phase_margin_deg, 0.1),
                 ("requirements.gain_margin_db", worst.gain_margin_db, self.gain_margin_db, 0.1),
                 ("requirements.common_phase_margin_deg", worst.common_phase_margin_deg,
                  self.common_phase_margin_deg, 0.1),
                 ("requirements.common_gain_margin_db", worst.common_gain_margin_db, self.common_gain_margin_db, 0.1),
                 ("requirements.disk_margin", worst.disk_margin, self.disk_margin, 0.005)]
        return tuple(key for key, value, limit, tol in pairs if limit > 0 and value < limit + tol)


@dataclass(frozen=True)
class DualScenarios:
    """A set of plants: ``base`` with, per plant, its carriage position (m), carriage mass (kg) and uncertain
    parameters (a field of ``DualDriveStageY`` or ``effect.parameter`` of its drive effects)."""

    base: DualDriveStageY
    carriage_position_m: np.ndarray
    carriage_mass_kg: np.ndarray
    parameters: dict[str, np.ndarray] = field(default_factory=dict)
    #: Stage X's carriage without the payload: carriage_mass_kg - stage_x_mass_kg is the payload
    stage_x_mass_kg: float = 0.0

    def __len__(self) -> int:
        return int(self.carriage_position_m.size)

    @property
    def payload_kg(self) -> np.ndarray:
        return self.carriage_mass_kg - self.stage_x_mass_kg

    def plants(self) -> DualDriveStageY:
        """Every plant as one batch (fields of shape (n,), effect parameters (n, 1))."""
        return _plants(self.base, self.carriage_position_m, self.carriage_mass_kg, self.parameters)

    def take(self, rows) -> DualScenarios:
        """The plants of ``rows`` (an index array or a boolean mask)."""
        return replace(self, carriage_position_m=self.carriage_position_m[rows],
                       carriage_mass_kg=self.carriage_mass_kg[rows],
                       parameters={k: v[rows] for k, v in self.parameters.items()})

    def row(self, k: int) -> ScenarioPoint:
        return ScenarioPoint(float(self.payload_kg[k]), tuple((n, float(v[k])) for n, v in self.parameters.items()),
                             float(self.carriage_position_m[k]))

    def _rows(self) -> np.ndarray:
        return np.column_stack([self.carriage_position_m, self.payload_kg, *self.parameters.values()])

    def with_row(self, row: ScenarioPoint) -> DualScenarios:
        return replace(self, carriage_position_m=np.append(self.carriage_position_m, row.carriage_position_m),
                       carriage_mass_kg=np.append(self.carriage_mass_kg, row.payload_kg + self.stage_x_mass_kg),
                       parameters={n: np.append(v, row.parameter(n)) for n, v in self.parameters.items()})

    def contains(self, row: ScenarioPoint) -> bool:
        target = np.array([row.carriage_position_m, row.payload_kg, *(row.parameter(n) for n in self.parameters)])
        return bool(np.any(np.all(np.isclose(self._rows(), target, rtol=1e-9, atol=0), axis=1)))

    def frd_of(self, start: int, stop: int) -> np.ndarray:
        """Responses of plants start..stop-1, (n, 2, 2, n_freq) on ``W_RAD_S``."""
        return self.take(slice(start, stop)).plants().frd(W_RAD_S)

    @functools.cached_property
    def frd(self) -> np.ndarray:
        """Every plant's response (n, 2, 2, n_freq): for the design plants, which the scan revisits."""
        return self.frd_of(0, len(self))

    @functools.cached_property
    def _channel_forms(self) -> dict[type[Controller], ChannelForm]:
        return {}

    def channel_form(self, structure: type[Controller]) -> ChannelForm:
        """``frd`` in ``structure``'s channel form (``design.loop.dual.ChannelForm``), kept for the scan's calls."""
        if structure not in self._channel_forms:
            self._channel_forms[structure] = ChannelForm.of(self.frd, structure)
        return self._channel_forms[structure]

    def describe(self, k: int) -> str:
        """'carriage at 0.08 m, payload 40 kg, damping1_n_s_per_m 330, ...' (the carriage's mass when Stage X's is
        not known)."""
        extra = ", ".join(f"{n} {v[k]:.4g}" for n, v in self.parameters.items())
        mass = (f"payload {self.payload_kg[k]:.4g} kg" if self.stage_x_mass_kg else
                f"{self.carriage_mass_kg[k]:.4g} kg")
        return f"carriage at {self.carriage_position_m[k]:.3g} m, {mass}" + (f", {extra}" if extra else "")


def _plants(base: DualDriveStageY, positions: np.ndarray, masses: np.ndarray,
            values: Mapping[str, np.ndarray]) -> DualDriveStageY:
    """``base`` with per-plant positions, masses and values (arrays of one length n) as one batch."""
    fields = {k: np.asarray(v, float) for k, v in values.items() if "." not in k}
    effects = []
    for e in base.effects:
        mine = {k.split(".", 1)[1]: np.asarray(v, float)[:, None] for k, v in values.items()
                if k.split(".", 1)[0] == e.name}
        effects.append(e.with_values(**mine) if mine else e)
    named = {e.split(".", 1)[0] for e in values if "." in e}
    missing = named - {e.name for e in base.effects}
    if missing:
        raise SpecError(f"uncertainty names {sorted(missing)[0]}, which the plant does not have")
    return replace(base, carriage_position_m=np.asarray(positions, float), carriage_mass_kg=np.asarray(masses, float),
                   effects=tuple(effects), **fields)


def dual_scenarios(base: DualDriveStageY, positions_m, carriage_masses_kg,
                   ranges: Mapping[str, tuple[float, float]], stage_x_mass_kg: float = 0.0) -> DualScenarios:
    """Every position x mass x corner of ``ranges`` (parameter -> (min, max))."""
    corners = list(itertools.product(*ranges.values())) or [()]
    grid = list(itertools.product(np.asarray(positions_m, float), np.asarray(carriage_masses_kg, float), corners))
    pos = np.array([g[0] for g in grid])
    mass = np.array([g[1] for g in grid])
    values = {name: np.array([g[2][i] for g in grid]) for i, name in enumerate(ranges)}
    _plants(base, pos[:1], mass[:1], {k: v[:1] for k, v in values.items()})       # names and values checked now
    return DualScenarios(base, pos, mass, values, stage_x_mass_kg)


def monte_carlo_scenarios(base: DualDriveStageY, position_range_m: tuple[float, float],
                          mass_range_kg: tuple[float, float], ranges: Mapping[str, tuple[float, float]],
                          n: int, seed: int, stage_x_mass_kg: float = 0.0) -> DualScenarios:
    """``n`` plants drawn uniformly in the position, mass and parameter ranges (seeded)."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(*position_range_m, n)
    mass = rng.uniform(*mass_range_kg, n)
    values = {name: rng.uniform(lo, hi, n) for name, (lo, hi) in ranges.items()}
    return DualScenarios(base, pos, mass, values, stage_x_mass_kg)


@dataclass(frozen=True)
class Worst:
    """The worst case of a design over a set of plants."""

    feasible: bool
    n_plants: int
    n_failing: int
    unstable: int
    bandwidth_hz: float
    phase_margin_deg: float
    gain_margin_db: float
    disk_margin: float
    disk_gain_margin_db: float
    disk_phase_margin_deg: float
    yaw_coupling: float
    #: the plant of the lowest bandwidth and the plant of the smallest phase margin, in words
    worst_bandwidth_at: str
    worst_phase_margin_at: str
    #: against the same change on both motors (``DualLoopFigures``), and the plant of the smallest common-mode
    #: phase margin
    common_gain_margin_db: float
    common_phase_margin_deg: float
    worst_common_at: str
    #: the least extra delay common to both drives that destabilises a plant (s)
    common_delay_margin_s: float
    #: over Monte Carlo draws, the one-sided 95 % upper bound on the rate of failing plants (``as_drawn``); None on
    #: a set of plants that was not drawn
    rate_upper_bound: float | None = None


def _passes(f: DualLoopFigures, req: DualRequirements) -> np.ndarray:
    disk = f.disk_margin >= req.disk_margin if req.disk_margin > 0 else True
    common = ((f.common_phase_margin_deg >= req.common_phase_margin_deg)
              & (f.common_gain_margin_db >= req.common_gain_margin_db)) if req.common else True
    return ((f.unstable_poles == 0) & (f.phase_margin_deg >= req.phase_margin_deg)
            & (f.gain_margin_db >= req.gain_margin_db) & disk & common & np.isfinite(f.bandwidth_hz))


def _bandwidth(f: DualLoopFigures) -> np.ndarray:
    """The translation bandwidth (Hz), 0 where it is not defined on the grid."""
    return np.where(np.isfinite(f.bandwidth_hz), f.bandwidth_hz, 0.0)


def worst_cases(controllers: list[Controller], scenarios: DualScenarios, req: DualRequirements) -> list[Worst]:
    """``Worst`` of each controller on every plant of ``scenarios`` (plants computed once, in chunks)."""
    def chunk(i: int) -> list[DualLoopFigures]:
        frd = scenarios.frd_of(i, i + MC_CHUNK)
        return [loop_figures(W_RAD_S, frd, c) for c in controllers]

    chunks = thread_map(chunk, range(0, len(scenarios), MC_CHUNK))
    out = []
    for parts in zip(*chunks):
        f = DualLoopFigures(*(np.concatenate([getattr(p, n) for p in parts])
                              for n in DualLoopFigures.__dataclass_fields__))
        ok = _passes(f, req)
        bw = _bandwidth(f)
        kb, kp, kc = int(np.argmin(bw)), int(np.argmin(f.phase_margin_deg)), int(np.argmin(f.common_phase_margin_deg))
        out.append(Worst(bool(ok.all()), int(ok.size), int((~ok).sum()), int((f.unstable_poles > 0).sum()),
                         float(bw.min()), float(f.phase_margin_deg.min()), float(f.gain_margin_db.min()),
                         float(f.disk_margin.min()), float(f.disk_gain_margin_db.min()),
                         float(f.disk_phase_margin_deg.min()), float(f.yaw_coupling.max()), scenarios.describe(kb),
                         scenarios.describe(kp), float(f.common_gain_margin_db.min()),
                         float(f.common_phase_margin_deg.min()), scenarios.describe(kc),
                         float(f.common_delay_margin_s.min())))
    return out


@dataclass(frozen=True)
class _Objective:
    """What a scan maximises: the worst translation bandwidth (Hz), or minus the worst yaw coupling; with a
    bound on the yaw coupling when ``max_yaw_coupling`` is finite."""

    yaw: bool = False
    max_yaw_coupling: float = np.inf

    def passes(self, f: DualLoopFigures, req: DualRequirements) -> np.ndarray:
        """Per plant: the requirements and the yaw-coupling bound hold."""
        return _passes(f, req) & (f.yaw_coupling <= self.max_yaw_coupling)

    def score(self, f: DualLoopFigures, req: DualRequirements) -> np.ndarray:
        """Per controller (the last axis runs over the plants): the objective, -inf where a plant fails."""
        value = -f.yaw_coupling.max(axis=-1) if self.yaw else _bandwidth(f).min(axis=-1)
        return np.where(self.passes(f, req).all(axis=-1), value, -np.inf)


def _score(make: Callable[[np.ndarray, np.ndarray], Controller], kp: np.ndarray, ki: np.ndarray,
           scenarios: DualScenarios, req: DualRequirements, objective: _Objective, active: set[int],
           best: float, want: int = 1) -> np.ndarray:
    """The objective over every plant of the ``want`` best candidates (kp, ki) (flat arrays) that beat ``best``;
    -inf for the others.

    Lazy cutting planes: every candidate is scored on the ``active`` plants (those that bound or failed
    earlier candidates), an upper bound of its true score; the candidate of the highest bound is evaluated
    on every plant, its binding or failing plants join ``active`` and the others' bounds are tightened on
    them, until no bound beats the ``want``-th best true score. The result is the exhaustive scan's."""
    n = kp.size
    out = np.full(n, -np.inf)
    bound = np.full(n, np.inf)
    done = np.zeros(n, dtype=bool)
    new = sorted(active)
    threshold = best
    disk = req.disk_margin > 0
    every = scenarios.channel_form(type(make(kp[:1], ki[:1])))
    while True:
        if new:
            live = np.flatnonzero(~done & (bound > threshold))
            frd = every.take(np.array(new))
            chunk = max(1, SCREEN_PLANTS // len(new))
            for i in range(0, live.size, chunk):
                k = live[i:i + chunk]
                s = objective.score(loop_figures(W_RAD_S, frd, make(kp[k, None], ki[k, None]), disk=disk,
                                                 common=req.common), req)
                bound[k] = np.minimum(bound[k], s)
        found = np.sort(out[np.isfinite(out)])
        threshold = max(best, found[-want]) if found.size >= want else best
        live = np.flatnonzero(~done & (bound > threshold))
        if not live.size:
            return out
        k = int(live[np.argmax(bound[live])])
        f = loop_figures(W_RAD_S, every, make(kp[k], ki[k]), disk=disk, common=req.common)
        out[k] = float(objective.score(f, req))
        done[k] = True
        failing = ~objective.passes(f, req)
        binding = np.flatnonzero(failing)[:4].tolist() or [
            int(np.argmax(f.yaw_coupling)) if objective.yaw else int(np.nanargmin(f.bandwidth_hz))]
        new = [p for p in binding if p not in active]
        active.update(new)


def _grid(make, scenarios, req, objective, active, best, a: np.ndarray, b: np.ndarray, want: int = 1):
    """Scores of the log10 grid a x b (``_score``), as (scores, kp, ki) flat."""
    A, B = np.meshgrid(10**a, 10**b, indexing="ij")
    return _score(make, A.ravel(), B.ravel(), scenarios, req, objective, active, best, want), A.ravel(), B.ravel()


def _scan(make, scenarios, req, kp_box, ki_box, objective: _Objective = _Objective(),
          progress=None) -> tuple[float, float, float]:
    """Best (kp, ki, objective): a coarse log grid over the box, then finer grids (module doc) around each of
    its ``STARTS`` best points; objective -inf: none feasible."""
    lk, li = np.log10(kp_box), np.log10(ki_box)
    active: set[int] = set()
    a, b = np.linspace(*lk, COARSE), np.linspace(*li, COARSE)
    s, kp, ki = _grid(make, scenarios, req, objective, active, -np.inf, a, b, want=STARTS)
    if progress is not None:
        progress()
    order = [k for k in np.argsort(-s) if np.isfinite(s[k])][:STARTS]
    if not order:
        return float("nan"), float("nan"), -np.inf
    best = (float(kp[order[0]]), float(ki[order[0]]), float(s[order[0]]))
    for k in order:
        centre, step = (np.log10(kp[k]), np.log10(ki[k])), (a[1] - a[0], b[1] - b[0])
        for _ in range(MAX_MOVES):
            if max(step) < REFINED_DECADES:
                break
            fa = np.clip(np.linspace(centre[0] - step[0], centre[0] + step[0], FINE), *lk)
            fb = np.clip(np.linspace(centre[1] - step[1], centre[1] + step[1], FINE), *li)
            s2, kp2, ki2 = _grid(make, scenarios, req, objective, active, best[2], fa, fb)
            j = int(np.argmax(s2))
            if s2[j] > best[2]:
                best = (float(kp2[j]), float(ki2[j]), float(s2[j]))
            ia, ib = divmod(j, FINE)
            edge = np.isfinite(s2[j]) and (ia in (0, FINE - 1) and lk[0] < fa[ia] < lk[1]
                                           or ib in (0, FINE - 1) and li[0] < fb[ib] < li[1])
            if np.isfinite(s2[j]):
                centre = (np.log10(kp2[j]), np.log10(ki2[j]))
            if not edge:            # the best point inside the grid: zoom in; on its edge: move there
                step = (2 * step[0] / (FINE - 1), 2 * step[1] / (FINE - 1))
    return best


@dataclass(frozen=True)
class StructureDesign:
    """One structure's robust design: its controller (None when no gains in the box hold the requirements),
    its worst case on the design plants and on the Monte Carlo draws."""

    structure: str
    controller: Controller | None
    design: Worst | None
    monte_carlo: Worst | None
    #: gains within 0.01 decade of the box's bound (the box, not the plants, limits them)
    at_bound: tuple[str, ...] = ()


def _one_pi(cls):
    """The search of a structure with one (kp, ki) pair: the scan of ``_scan``."""
    def search(scenarios, req, kp_box, ki_box, progress):
        kp, ki, bw = _scan(cls, scenarios, req, kp_box, ki_box, progress=progress)
        return cls(kp, ki) if np.isfinite(bw) else None

    return search


def _common_differential(scenarios, req, kp_box, ki_box, progress):
    """Common and differential PIs: both equal first, then the differential one for the yaw coupling, then the
    common one for the bandwidth under the yaw coupling found (kept only when it is no slower)."""
    kp, ki, bw = _scan(lambda a, b: CommonDifferential(a, b, a, b), scenarios, req, kp_box, ki_box,
                       progress=progress)
    if not np.isfinite(bw):
        return None
    dp, di, yaw = _scan(lambda a, b: CommonDifferential(kp, ki, a, b), scenarios, req, kp_box, ki_box,
                        _Objective(yaw=True), progress)
    bound = _Objective(max_yaw_coupling=YAW_SLACK * -yaw)
    cp, ci, bw2 = _scan(lambda a, b: CommonDifferential(a, b, dp, di), scenarios, req, kp_box, ki_box, bound,
                        progress)
    return CommonDifferential(cp, ci, dp, di) if np.isfinite(bw2) and bw2 >= bw else CommonDifferential(kp, ki, kp, ki)


#: each structure's gain search by its name (``design.loop.dual.BY_NAME``): a new structure is its class there and
#: its search here
SEARCHES = {PerMotor.name: _one_pi(PerMotor), MasterSlave.name: _one_pi(MasterSlave),
            CommonDifferential.name: _common_differential}


def synthesise_structure(structure: str, scenarios: DualScenarios, req: DualRequirements, *,
                         kp_box=(1.0, 1e4), ki_box=(1.0, 1e6), progress=None) -> StructureDesign:
    """Gains of ``structure`` (a name of ``design.loop.dual.BY_NAME``) maximising the worst-case translation bandwidth
    on ``scenarios`` under ``req`` (not yet judged on a Monte Carlo: ``monte_carlo`` None)."""
    if structure not in SEARCHES:
        raise SpecError(f"unknown structure {structure!r}; known: {', '.join(SEARCHES)}")
    ctrl = SEARCHES[structure](scenarios, req, kp_box, ki_box, progress)
    if ctrl is None:
        return StructureDesign(structure, None, None, None)
    boxes = {"kp": kp_box, "ki": ki_box}
    at_bound = tuple(name for name, value in ctrl.gains().items()
                     if min(abs(np.log10(value) - np.log10(end)) for end in boxes[name[:2]]) < 0.01)
    return StructureDesign(structure, ctrl, worst_cases([ctrl], scenarios, req)[0], None, at_bound)


@dataclass(frozen=True)
class DesignMap:
    """A design over carriage position x payload, each the worst over the uncertainty corners: arrays
    (n_positions, n_payloads)."""

    carriage_position_m: np.ndarray
    payload_kg: np.ndarray
    bandwidth_hz: np.ndarray
    phase_margin_deg: np.ndarray
    gain_margin_db: np.ndarray
    disk_margin: np.ndarray
    #: every corner stable and within the requirements
    holds: np.ndarray


def design_map(controller: Controller, model: DualDriveStageY, positions_m, payloads_kg, stage_x_mass_kg: float,
               ranges: Mapping[str, tuple[float, float]], req: DualRequirements) -> DesignMap:
    """``DesignMap`` of ``controller`` (positions on threads)."""
    positions, payloads = np.asarray(positions_m, float), np.asarray(payloads_kg, float)
    corners = max(1, int(np.prod([2 for _ in ranges])))

    def row(p: float):
        s = dual_scenarios(model, [p], stage_x_mass_kg + payloads, ranges)
        f = loop_figures(W_RAD_S, s.frd, controller)
        shape = (payloads.size, corners)
        bw = _bandwidth(f).reshape(shape)
        return (bw.min(axis=1), f.phase_margin_deg.reshape(shape).min(axis=1),
                f.gain_margin_db.reshape(shape).min(axis=1), f.disk_margin.reshape(shape).min(axis=1),
                _passes(f, req).reshape(shape).all(axis=1))

    rows = thread_map(row, positions)
    return DesignMap(positions, payloads, *(np.array([r[k] for r in rows]) for k in range(5)))
