"""The gantry's loops designed and verified as one planar machine: Stage X, Stage Y's two-motor structure and the
rotation stage on the carriage, on the planar mechanics (``plant.physics.planar``).

About rest, the planar mechanics split exactly in two (``plant.physics.planar.matrices``): the carriage's
coordinate meets no other, so Stage X's loop is its own loop (designed and verified over its own box by the PI
synthesis), while the beam's rails and the rotation stage are one coupled plant: the rotation motor's reaction
turns the carriage and with it the beam, whose yaw the rotation stage's encoder (relative to the carriage) reads.
That (Y1, Y2, rotation) plant, currents (i1, i2, i_r) to velocities (v1, v2, phi'), is built per scenario from the
mechanics and each drive's chain (``PlanarScenarios``).

Sequential loop closing (Maciejowski, Multivariable Feedback Design, 1989, section 4.4): Stage Y's structure is
designed first, on its own two-motor model; the rotation PI is then designed on the rotation channel with Stage Y's
loops closed (``design_rotation``: a log scan of (kp, ki) for the highest worst-case rotation bandwidth under its
margins, by lazy cutting planes over the design plants, zoomed around its best point). The whole loop is then
judged as one (``planar_figures``): Stage Y's requirements (loop-at-a-time, common-mode, disk) on its plant with the
rotation loop closed, the rotation channel's margins with Stage Y's loops closed, and stability of the whole from the
winding of det(I + K P) = (1 + c_r P_rr) det(I + C_y P_y,eff). Verified means on the design plants (carriage
positions x payloads x every corner of both boxes), on a dense grid between them at every corner with a compass
search from its least-slack points, and on Monte Carlo draws (``check``).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from design.loop.compass import compass_search
from design.loop.controller import PI
from design.loop.dual import Controller, DualLoopFigures, loop_figures, matmul, mimo_unstable_poles
from design.loop.margins import closed_loop_bandwidth_hz, crossover_margins
from design.parallel import thread_map
from design.synth.dual import W_RAD_S, DualRequirements, DualScenarios, dual_scenarios, monte_carlo_scenarios
from design.synth.dual_worst import BAND, slacks
from design.synth.monte_carlo import as_drawn
from plant.errors import SpecError
from plant.physics.planar import matrices, mobility

#: plants evaluated together (memory: CHUNK x 3 x 3 x frequencies complex values)
CHUNK = 200
#: the dense grid between the design points: carriage positions x payloads, at every corner of both boxes
DENSE = (9, 6)
#: compass searches from the dense grid's least-slack points (at most), first step one payload cell
MAX_SEARCHES = 8
#: the rotation scan: points per gain on the coarse log grid, then FINE x FINE grids one step either side of the
#: best, ZOOMS times, each a third of the step before
COARSE, FINE, ZOOMS = 25, 7, 5


@dataclass(frozen=True)
class RotationStage:
    """The rotation stage: what turns (kg m^2), its bearing (N m s/rad), its motor (N m/A) and its drive's chain
    effects; per-plant values of a batch are arrays."""

    inertia_kg_m2: float | np.ndarray
    damping_n_m_s_per_rad: float | np.ndarray
    torque_constant_n_m_per_a: float | np.ndarray
    effects: tuple = ()

    def with_values(self, values: Mapping[str, np.ndarray]) -> RotationStage:
        """A batch: ``values`` names fields or ``effect.parameter`` (arrays of one length)."""
        effects = []
        for e in self.effects:
            mine = {k.split(".", 1)[1]: np.asarray(v, float)[:, None] for k, v in values.items()
                    if k.split(".", 1)[0] == e.name}
            effects.append(e.with_values(**mine) if mine else e)
        missing = {k.split(".", 1)[0] for k in values if "." in k} - {e.name for e in self.effects}
        if missing:
            raise SpecError(f"rotation.uncertainty names {sorted(missing)[0]}, which rotation.effects does not have")
        return replace(self, effects=tuple(effects),
                       **{k: np.asarray(v, float) for k, v in values.items() if "." not in k})

    def chain(self, s) -> np.ndarray:
        out = np.ones(np.shape(s), complex)
        for e in self.effects:
            out = out * e.response(np.asarray(s, complex))
        return out


@dataclass(frozen=True)
class PlanarScenarios:
    """Coupled (Y1, Y2, rotation) plants: Stage Y's two-motor plants (``DualScenarios``) and, per plant, the
    rotation stage's uncertain values."""

    y: DualScenarios
    rotation: RotationStage
    rotation_values: dict[str, np.ndarray] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.y)

    def take(self, rows) -> PlanarScenarios:
        return replace(self, y=self.y.take(rows), rotation_values={k: v[rows] for k, v in self.rotation_values.items()})

    def frd_of(self, start: int, stop: int, w_rad_s=W_RAD_S) -> np.ndarray:
        """Velocities (v1, v2, phi') per current (i1, i2, i_r) of plants start..stop-1, (n, 3, 3, n_freq)."""
        part = self.take(slice(start, stop))
        y = part.y.plants()
        n = len(part)
        r = part.rotation.with_values(part.rotation_values)
        M, D, K = matrices(carriage_position_m=y.carriage_position_m, beam_mass_kg=y.beam_mass_kg,
                           beam_inertia_kg_m2=y.beam_inertia_kg_m2, carriage_mass_kg=y.carriage_mass_kg,
                           carriage_inertia_kg_m2=y.carriage_inertia_kg_m2, rail_separation_m=y.rail_separation_m,
                           damping1_n_s_per_m=y.damping1_n_s_per_m, damping2_n_s_per_m=y.damping2_n_s_per_m,
                           damping_x_n_s_per_m=1.0, yaw_stiffness_n_m_per_rad=y.yaw_stiffness_n_m_per_rad,
                           rotation_inertia_kg_m2=r.inertia_kg_m2,
                           rotation_damping_n_m_s_per_rad=r.damping_n_m_s_per_rad)
        keep = np.array([0, 1, 3])                              # the carriage's coordinate meets none of these
        M, D, K = (np.broadcast_to(a, (n, 4, 4))[:, keep][:, :, keep] for a in (M, D, K))
        s = 1j * np.asarray(w_rad_s, float)
        H = mobility(s, M, D, K)
        k = np.broadcast_to(y.force_constants(), (n, 2))
        drive_y = np.broadcast_to(y.chain(s, "drive"), (n, 1, 1, s.size))[:, 0, 0]
        sensor_y = np.broadcast_to(y.chain(s, "sensor"), (n, 1, 1, s.size))[:, 0, 0]
        drive_r = np.broadcast_to(r.chain(s), (n, s.size)) * np.broadcast_to(
            np.asarray(r.torque_constant_n_m_per_a, float), (n,))[:, None]
        cols = np.stack([k[:, 0, None] * drive_y, k[:, 1, None] * drive_y, drive_r], axis=1)    # (n, 3, nf)
        rows = np.stack([sensor_y, sensor_y, np.ones_like(sensor_y)], axis=1)
        return H * cols[:, None, :, :] * rows[:, :, None, :]

    def describe(self, k: int) -> str:
        extra = ", ".join(f"rotation.{n} {v[k]:.4g}" for n, v in self.rotation_values.items())
        return self.y.describe(k) + (f", {extra}" if extra else "")

    def point(self, k: int) -> dict[str, float]:
        row = self.y.row(k)
        return {"carriage_position_m": row.carriage_position_m, "payload_kg": row.payload_kg,
                **dict(row.parameters), **{f"rotation.{n}": float(v[k]) for n, v in self.rotation_values.items()}}


def planar_scenarios(y_model, rotation: RotationStage, positions_m, carriage_masses_kg,
                     y_ranges: Mapping[str, tuple[float, float]], rotation_ranges: Mapping[str, tuple[float, float]],
                     stage_x_mass_kg: float) -> PlanarScenarios:
    """Every position x mass x corner of Stage Y's box x corner of the rotation stage's box (in that order: the
    rotation corner varies fastest)."""
    y = dual_scenarios(y_model, positions_m, carriage_masses_kg, y_ranges, stage_x_mass_kg)
    corners = list(itertools.product(*rotation_ranges.values())) or [()]
    rows = np.repeat(np.arange(len(y)), len(corners))
    values = {n: np.tile([c[i] for c in corners], len(y)).astype(float) for i, n in enumerate(rotation_ranges)}
    out = PlanarScenarios(y.take(rows), rotation, values)
    out.frd_of(0, 1, W_RAD_S[:2])                            # names and values checked now
    return out


def monte_carlo(y_model, rotation: RotationStage, travel_m, mass_range_kg, y_ranges, rotation_ranges, n: int,
                seed: int, stage_x_mass_kg: float) -> PlanarScenarios:
    """``n`` plants drawn uniformly in the travel, the carriage's mass and both boxes (seeded)."""
    y = monte_carlo_scenarios(y_model, travel_m, mass_range_kg, y_ranges, n, seed, stage_x_mass_kg)
    rng = np.random.default_rng(seed + 1)
    return PlanarScenarios(y, rotation, {k: rng.uniform(lo, hi, n) for k, (lo, hi) in rotation_ranges.items()})


@dataclass(frozen=True)
class RotationRequirements:
    phase_margin_deg: float = 45.0
    gain_margin_db: float = 6.0


@dataclass(frozen=True)
class PlanarFigures:
    """What the whole loop does on a batch of plants (arrays of the batch's shape)."""

    #: Stage Y's structure on its plant with the rotation loop closed
    y: DualLoopFigures
    #: the rotation channel with Stage Y's loops closed: margins, and the -3 dB bandwidth of its command to phi'
    rotation_gain_margin_db: np.ndarray
    rotation_phase_margin_deg: np.ndarray
    rotation_bandwidth_hz: np.ndarray
    #: closed-loop poles of the whole in the right half-plane
    unstable_poles: np.ndarray


def _inverse2(a, b, c, d):
    det = a * d - b * c
    return d / det, -b / det, -c / det, a / det


def rotation_channel(w_rad_s, P: np.ndarray, y_controller: Controller) -> np.ndarray:
    """The rotation channel's plant with Stage Y's loops closed, P_rr - P_ry C_y (I + P_yy C_y)^-1 P_yr, (n, nf)."""
    Cy = y_controller.frd(w_rad_s)
    Pyy, Pyr, Pry = P[:, :2, :2], P[:, :2, 2:], P[:, 2:, :2]
    X = matmul(Pyy, np.broadcast_to(Cy, (P.shape[0], *Cy.shape)))
    i11, i12, i21, i22 = _inverse2(1 + X[:, 0, 0], X[:, 0, 1], X[:, 1, 0], 1 + X[:, 1, 1])
    inv = np.stack([np.stack([i11, i12], 1), np.stack([i21, i22], 1)], 1)
    through = matmul(matmul(matmul(Pry, np.broadcast_to(Cy, (P.shape[0], *Cy.shape))), inv), Pyr)
    return P[:, 2, 2] - through[:, 0, 0]


def rotation_figures(w_rad_s, channel: np.ndarray, pi: PI):
    """(GM dB, PM deg, bandwidth Hz) of the rotation PI on channel plants (..., nf); gains shaped (k, 1) give
    (k, n)."""
    loop = pi.frd(w_rad_s) * channel
    gm, pm = crossover_margins(w_rad_s, loop)
    return gm, pm, closed_loop_bandwidth_hz(w_rad_s, loop / (1 + loop), dc_gain=1.0)


def planar_figures(w_rad_s, P: np.ndarray, y_controller: Controller, rotation_pi: PI, *,
                   disk: bool = True) -> PlanarFigures:
    """``PlanarFigures`` of the two controllers on plants ``P`` (n, 3, 3, nf) (module doc)."""
    cr = rotation_pi.frd(w_rad_s)
    Prr = P[:, 2, 2]
    g = cr / (1 + cr * Prr)
    Peff = P[:, :2, :2] - matmul(P[:, :2, 2:], P[:, 2:, :2]) * g[:, None, None, :]
    y = loop_figures(w_rad_s, Peff, y_controller, disk=disk)
    A = matmul(np.broadcast_to(y_controller.frd(w_rad_s), Peff.shape), Peff)
    det = (1 + cr * Prr) * ((1 + A[:, 0, 0]) * (1 + A[:, 1, 1]) - A[:, 0, 1] * A[:, 1, 0])
    gm, pm, bw = rotation_figures(w_rad_s, rotation_channel(w_rad_s, P, y_controller), rotation_pi)
    return PlanarFigures(y, gm, pm, bw, mimo_unstable_poles(w_rad_s, det))


def planar_slack(f: PlanarFigures, y_req: DualRequirements, r_req: RotationRequirements) -> np.ndarray:
    """Per plant: the least relative excess over every requirement (Stage Y's and the rotation channel's), -1 where
    the whole loop is unstable."""
    rot = np.minimum((f.rotation_phase_margin_deg - r_req.phase_margin_deg) / max(r_req.phase_margin_deg, 1.0),
                     (f.rotation_gain_margin_db - r_req.gain_margin_db) / max(r_req.gain_margin_db, 1.0))
    rot = np.where(np.isfinite(f.rotation_bandwidth_hz), rot, -1.0)
    s = np.minimum(slacks(f.y, y_req).min(axis=0), np.where(np.isnan(rot), np.inf, rot))
    return np.where(f.unstable_poles > 0, -1.0, s)


@dataclass(frozen=True)
class PlanarWorst:
    """The worst case of the whole loop over a set of plants."""

    n_plants: int
    n_failing: int
    unstable: int
    least_slack: float
    y_phase_margin_deg: float
    y_gain_margin_db: float
    y_common_phase_margin_deg: float
    y_common_gain_margin_db: float
    y_disk_margin: float
    y_bandwidth_hz: float
    rotation_phase_margin_deg: float
    rotation_gain_margin_db: float
    rotation_bandwidth_hz: float
    #: the plant of least slack, in words and as values
    worst_at: str
    worst_point: dict[str, float]
    #: over Monte Carlo draws, the one-sided 95 % upper bound on the rate of failing plants
    #: (``design.synth.monte_carlo.as_drawn``); None on a set of plants that was not drawn
    rate_upper_bound: float | None = None

    @property
    def holds(self) -> bool:
        return self.n_failing == 0


def _gathered(scenarios: PlanarScenarios, y_controller, rotation_pi, y_req, r_req):
    def chunk(i):
        f = planar_figures(W_RAD_S, scenarios.frd_of(i, i + CHUNK), y_controller, rotation_pi,
                           disk=y_req.disk_margin > 0)
        return f, planar_slack(f, y_req, r_req)

    parts = thread_map(chunk, range(0, len(scenarios), CHUNK))
    cat = np.concatenate
    y = DualLoopFigures(*(cat([getattr(p.y, n) for p, _ in parts]) for n in DualLoopFigures.__dataclass_fields__))
    f = PlanarFigures(y, *(cat([getattr(p, n) for p, _ in parts]) for n in
                           ("rotation_gain_margin_db", "rotation_phase_margin_deg", "rotation_bandwidth_hz",
                            "unstable_poles")))
    return f, cat([s for _, s in parts])


def worst(scenarios: PlanarScenarios, y_controller, rotation_pi, y_req, r_req) -> tuple[PlanarWorst, np.ndarray]:
    """``PlanarWorst`` over ``scenarios`` and each plant's slack."""
    f, s = _gathered(scenarios, y_controller, rotation_pi, y_req, r_req)
    k = int(np.argmin(s))
    bw = np.where(np.isfinite(f.y.bandwidth_hz), f.y.bandwidth_hz, 0.0)
    rbw = np.where(np.isfinite(f.rotation_bandwidth_hz), f.rotation_bandwidth_hz, 0.0)
    return PlanarWorst(len(scenarios), int((s < 0).sum()), int((f.unstable_poles > 0).sum()), float(s[k]),
                       float(f.y.phase_margin_deg.min()), float(f.y.gain_margin_db.min()),
                       float(f.y.common_phase_margin_deg.min()), float(f.y.common_gain_margin_db.min()),
                       float(f.y.disk_margin.min()), float(bw.min()), float(f.rotation_phase_margin_deg.min()),
                       float(f.rotation_gain_margin_db.min()), float(rbw.min()), scenarios.describe(k),
                       scenarios.point(k)), s


def _merged(a: PlanarWorst, b: PlanarWorst) -> PlanarWorst:
    """The worst of two sets of plants."""
    lower = a if a.least_slack <= b.least_slack else b
    least = {n: min(getattr(a, n), getattr(b, n)) for n in PlanarWorst.__dataclass_fields__
             if n.endswith(("_deg", "_db", "_hz", "disk_margin"))}
    return replace(lower, n_plants=a.n_plants + b.n_plants, n_failing=a.n_failing + b.n_failing,
                   unstable=a.unstable + b.unstable, **least)


@dataclass(frozen=True)
class RotationDesign:
    pi: PI | None
    #: the worst rotation bandwidth (Hz) on the design plants with Stage Y's loops closed
    bandwidth_hz: float
    #: plants the scan's cutting planes used, of the design plants
    active_plants: int
    evaluations: int


def _scores(w, channels: np.ndarray, kp: np.ndarray, ki: np.ndarray, req: RotationRequirements):
    """Worst bandwidth (Hz; -1 where a requirement fails) of each (kp, ki) over ``channels`` (m, nf)."""
    gm, pm, bw = rotation_figures(w, channels[None], PI(kp[:, None], ki[:, None]))
    ok = (pm >= req.phase_margin_deg) & (gm >= req.gain_margin_db) & np.isfinite(bw)
    unstable = mimo_unstable_poles(w, 1 + PI(kp[:, None], ki[:, None]).frd(w) * channels[None]) > 0
    ok &= ~unstable
    return np.where(ok.all(axis=1), np.where(np.isfinite(bw), bw, 0).min(axis=1), -1.0)


def design_rotation(channels: np.ndarray, req: RotationRequirements, kp_box, ki_box) -> RotationDesign:
    """The rotation PI of the highest worst-case bandwidth whose margins hold on every design plant's channel
    (``rotation_channel``, (n, nf) on ``W_RAD_S``): a log scan of the gain box, the candidates scored on the
    plants that bound earlier candidates (a plant is added where the best candidate fails on it: exact, as a
    candidate is dropped only when those plants rule it out), zoomed around the best ``ZOOMS`` times."""
    w = W_RAD_S
    lo = np.log10([max(kp_box[0], kp_box[1] * 1e-6), max(ki_box[0], ki_box[1] * 1e-6)])
    hi = np.log10([kp_box[1], ki_box[1]])
    active = [0]
    evaluations = 0
    best = None
    axes = [np.linspace(lo[j], hi[j], COARSE) for j in range(2)]
    step = (hi - lo) / (COARSE - 1)
    for zoom in range(ZOOMS + 1):
        a, b = np.meshgrid(*axes, indexing="ij")
        kp, ki = 10 ** a.ravel(), 10 ** b.ravel()
        while True:
            score = _scores(w, channels[active], kp, ki, req)
            evaluations += kp.size * len(active)
            j = int(np.argmax(score))
            if score[j] < 0:
                return RotationDesign(None, 0.0, len(active), evaluations) if best is None else best
            full = _scores(w, channels, kp[j:j + 1], ki[j:j + 1], req)
            evaluations += len(channels)
            if full[0] >= 0:
                break
            gm, pm, bw = rotation_figures(w, channels, PI(kp[j], ki[j]))
            slack = np.minimum((pm - req.phase_margin_deg) / max(req.phase_margin_deg, 1),
                               (gm - req.gain_margin_db) / max(req.gain_margin_db, 1))
            slack = np.where(np.isfinite(bw), np.where(np.isnan(slack), np.inf, slack), -1.0)
            worst_k = int(np.argmin(slack))
            if worst_k in active:                  # unstable there by the winding count: add the least stable
                worst_k = next(i for i in np.argsort(slack) if i not in active)
            active.append(worst_k)
        if best is None or full[0] >= best.bandwidth_hz:
            best = RotationDesign(PI(float(kp[j]), float(ki[j])), float(full[0]), len(active), evaluations)
        step = step * (2 / (FINE - 1))
        centre = np.log10([best.pi.kp, best.pi.ki])
        axes = [np.clip(centre[i] + step[i] * np.arange(-(FINE // 2), FINE // 2 + 1), lo[i], hi[i]) for i in range(2)]
    return replace(best, active_plants=len(active), evaluations=evaluations)


@dataclass(frozen=True)
class PlanarCheck:
    """The whole loop on the design plants, between them (dense grid and searches) and on Monte Carlo draws."""

    design: PlanarWorst
    between: PlanarWorst
    monte_carlo: PlanarWorst | None
    dense_plants: int
    searches: int
    search_evaluations: int

    @property
    def holds(self) -> bool:
        return self.design.holds and self.between.holds and (self.monte_carlo is None or self.monte_carlo.holds)

    def coverage(self) -> str:
        return (f"{self.design.n_plants} design plants; between them a {DENSE[0]} x {DENSE[1]} grid of carriage "
                f"positions x payloads at every corner of both boxes ({self.dense_plants} plants) and compass "
                f"searches over position, payload and both boxes from its {self.searches} least-slack points "
                f"({self.search_evaluations} plants)"
                + (f"; {self.monte_carlo.n_plants} Monte Carlo draws" if self.monte_carlo else ""))


def check(y_controller, rotation_pi, *, design: PlanarScenarios, y_model, rotation: RotationStage, travel_m,
          mass_range_kg, y_ranges, rotation_ranges, y_req, r_req, stage_x_mass_kg, samples: int,
          seed: int) -> PlanarCheck:
    """The whole loop verified (module doc): on ``design``, on the dense grid and from its least-slack points a
    compass search over position, payload and every uncertain parameter inside both boxes, on ``samples`` draws."""
    on_design, _ = worst(design, y_controller, rotation_pi, y_req, r_req)
    dense = planar_scenarios(y_model, rotation, np.linspace(*travel_m, DENSE[0]), np.linspace(*mass_range_kg,
                             DENSE[1]), y_ranges, rotation_ranges, stage_x_mass_kg)
    on_dense, s = worst(dense, y_controller, rotation_pi, y_req, r_req)
    corners = len(dense) // (DENSE[0] * DENSE[1])
    grid = s.reshape(DENSE[0], DENSE[1], corners)
    pad = np.pad(grid, ((1, 1), (1, 1), (0, 0)), constant_values=np.inf)
    core = pad[1:-1, 1:-1]
    local = np.flatnonzero(((core <= pad[:-2, 1:-1]) & (core <= pad[2:, 1:-1]) & (core <= pad[1:-1, :-2])
                            & (core <= pad[1:-1, 2:])).ravel())
    local = local[np.argsort(s[local])]
    starts = [*local[:1], *local[1:][s[local[1:]] < BAND]][:MAX_SEARCHES]
    names_y, names_r = list(y_ranges), list(rotation_ranges)
    lo = np.array([travel_m[0], mass_range_kg[0], *(y_ranges[n][0] for n in names_y),
                   *(rotation_ranges[n][0] for n in names_r)])
    hi = np.array([travel_m[1], mass_range_kg[1], *(y_ranges[n][1] for n in names_y),
                   *(rotation_ranges[n][1] for n in names_r)])
    span = np.where(hi > lo, hi - lo, 1.0)

    def plants(u: np.ndarray) -> PlanarScenarios:
        x = lo + np.clip(u, 0, 1) * span
        y = replace(dense.y.take(np.zeros(len(u), int)), carriage_position_m=x[:, 0], carriage_mass_kg=x[:, 1],
                    parameters={n: x[:, 2 + i] for i, n in enumerate(names_y)})
        return PlanarScenarios(y, rotation, {n: x[:, 2 + len(names_y) + i] for i, n in enumerate(names_r)})

    def evaluate(u):
        p = plants(u)
        f = planar_figures(W_RAD_S, p.frd_of(0, len(p)), y_controller, rotation_pi, disk=y_req.disk_margin > 0)
        return (planar_slack(f, y_req, r_req),)

    rows = []
    for k in starts:
        ps = dense.point(int(k))
        rows.append([ps["carriage_position_m"], ps["payload_kg"] + stage_x_mass_kg,
                     *(ps[n] for n in names_y), *(ps[f"rotation.{n}"] for n in names_r)])
    u0 = (np.array(rows) - lo) / span
    free = np.flatnonzero(hi > lo)
    r = compass_search(evaluate, u0, free, step=1.0 / (DENSE[1] - 1), tol=1e-3)
    on_found, _ = worst(plants(r.u), y_controller, rotation_pi, y_req, r_req)
    between = _merged(on_dense, on_found)
    mc = None
    if samples:
        draws = monte_carlo(y_model, rotation, travel_m, mass_range_kg, y_ranges, rotation_ranges, samples, seed,
                            stage_x_mass_kg)
        mc = as_drawn(worst(draws, y_controller, rotation_pi, y_req, r_req)[0])
    return PlanarCheck(on_design, between, mc, len(dense), len(starts), r.evaluations)
