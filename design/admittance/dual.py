"""Admittance control of the two-motor Stage Y: the mouse pushes along Y at the head clamp, which rides on
Stage X's carriage anywhere along the beam, and the virtual dynamics 1/(m_v s + b_v) command the translation
of a loop structure designed by ``design.synth.dual``.

Physics (SI units, s complex). The beam with the carriage (``plant.physics.dual_drive``) has the mobility
between the points rail Y1, rail Y2 and the carriage ``point_mobility``: G_rr (rails per rail forces), g_rc,
g_cr (rails per carriage force, carriage per rail forces) and g_cc. The structure's controller C (2 x 2,
``design.loop.dual``) turns the rail velocity errors into motor currents u = C (v_ref [1, 1] - H v_rails),
each motor pushes f = K E u (K = diag(k1, k2), E the drive's effects, H the sensor's). With P = H G_rr K E
and S_in = (I + C P)^-1:

    u / v_ref = S_in C [1, 1]^T,   u / F_s = -S_in C H g_rc,   f = K E u,   v = g_cr f + g_cc F_s

so the clamp's velocity per reference is R = g_cr K E S_in C [1, 1]^T and per sensed force (reference held)
S G = g_cc + g_cr (f / F_s). These are the R and S G of the one-motor derivation (``design.admittance.model``:
with one motor and the carriage at the rail they reduce to it), whose interaction loop, margins, Nyquist
tests, rig timing, hardware peaks (here per motor), mouse and Monte Carlo apply unchanged. The velocity loops
without the mouse are the structure's design, stable on every plant it was checked on; the mouse closes a
scalar loop around them at the clamp.

Synthesis (``synthesise_dual_admittance``) follows ``design.admittance.synthesis`` without the co-design (the
structure's gains are fixed by its own robust design): rays on the design plants (carriage positions x
payloads x uncertainty corners) x the mice, a dense check on more positions and payloads with the worst
violator added, the Monte Carlo over position x payload x uncertainty x a drawn mouse, and the force the
mouse feels on its locomotion profile at the ends and the middle of the travel.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from design.admittance.between import HeldBetween, between_failure, between_text, two_motor_space
from design.admittance.delays import WorstFelt, evaluator
from design.admittance.dual_codesign_record import DualCodesignRecord
from design.admittance.feel import MouseFeel, mouse_feel
from design.admittance.latency import LatencyCheck, latency_check
from design.admittance.model import (
    AdmittanceCheck,
    GantryLoop,
    admittance_problem,
    check_grid_for,
    mice,
    rendered_admittance,
    virtual_impedance_frd,
    with_mode_points,
)
from design.admittance.monte_carlo import AdmittanceMonteCarlo
from design.admittance.mouse import MouseModel
from design.admittance.rig import DiscreteAdmittance, RigTiming
from design.admittance.sampled import dual_free_gantry, pade_order_for
from design.admittance.synthesis import design_rounds
from design.admittance.verdict import admittance_verdict
from design.loop.dual import Controller
from design.loop.requirement import Binding
from design.problem import LoopProblem
from design.synth.dual import DualScenarios, dual_scenarios, monte_carlo_scenarios
from plant.errors import SpecError
from plant.physics.dual_drive import DualDriveStageY

#: what could let the mouse drive a design the interaction loop's margins make too heavy
HINT = ("a lighter design needs faster velocity loops on the heavy beam (lower requirements.phase_margin_deg or "
        "gain_margin_db of the loops, a faster drive), lower admittance.phase_margin_deg / gain_margin_db, or a "
        "slower locomotion profile")
#: and where the structure's own gains are kept: their integral action, tuned for bandwidth, stiffens the loop
#: against a braced mouse
CODESIGN_HINT = HINT.replace("needs ", "needs admittance.codesign = true (the structure's translation gains chosen "
                             "for the mouse), ", 1)
#: carriage positions and payloads of the dense check (evenly over their ranges)
CHECK_POSITIONS, CHECK_PAYLOADS = 9, 4
#: grid points the rays put within +-20 % of each mouse mode (``with_mode_points``): the heavy gantry holds the
#: head nearly still, the body rings on the neck (12 Hz, damping ratio 0.04 for the bundled spec's lightest-damped
#: mouse) and its phase swings too fast for the one-motor grid's interpolated bounds (at 16 points the bundled
#: spec's ray missed the exact phase margin by 0.7 deg, at 32 by none)
RAY_MODE_POINTS = 32
#: scenarios whose loops are computed together (the 2 x 2 algebra keeps some 40 arrays of rows x frequencies)
AT_ROWS = 64


def _per_plant(chain, n: int, n_f: int) -> np.ndarray:
    """A chain response (``DualDriveStageY.chain``) as (n, n_freq)."""
    a = np.asarray(chain, complex)
    return np.broadcast_to(a[..., 0, 0, :] if a.ndim == 4 else a, (n, n_f))


@dataclass(frozen=True)
class DualLoops:
    """The two-motor Stage Y under ``controller``, seen from the head clamp on the carriage (module doc)."""

    controller: Controller

    def at(self, s, scenarios: DualScenarios) -> GantryLoop:
        """``GantryLoop`` of ``scenarios`` at complex ``s``: per motor arrays (2, n_scenario, n_freq); the 2 x 2
        algebra of the module doc written out entry by entry, ``AT_ROWS`` scenarios at a time (memory)."""
        s = np.asarray(s, complex)
        if len(scenarios) <= AT_ROWS:
            return self._at(s, scenarios)
        parts = [self._at(s, scenarios.take(slice(i, i + AT_ROWS))) for i in range(0, len(scenarios), AT_ROWS)]
        return GantryLoop(s, scenarios, *(np.concatenate([getattr(p, f) for p in parts], axis=axis) for f, axis in
                                          (("sensitivity_mobility", 0), ("reference", 0), ("current", 1),
                                           ("motor_force", 1), ("motor_reference", 1))))

    def free_state_space(self, scenarios: DualScenarios, *, period_s: float | None = None):
        """The free gantries of ``scenarios`` as one batch (``design.admittance.sampled.dual_free_gantry``), the
        delays' Pade order chosen for a path sampled every ``period_s``."""
        plants = scenarios.plants()
        return dual_free_gantry(plants, len(scenarios), self.controller, pade_order=pade_order_for(plants, period_s))

    def _at(self, s: np.ndarray, scenarios: DualScenarios) -> GantryLoop:
        plants = scenarios.plants()
        n, n_f = len(scenarios), s.size
        G = np.broadcast_to(plants.point_mobility(s), (n, 3, 3, n_f))
        k = np.broadcast_to(plants.force_constants(), (n, 2))
        E = _per_plant(plants.chain(s, "drive"), n, n_f)
        H = _per_plant(plants.chain(s, "sensor"), n, n_f)
        ke = (k[:, :1] * E, k[:, 1:] * E)
        C = self.controller.at(s)                                          # (2, 2, n_f)
        c = ((C[0, 0], C[0, 1]), (C[1, 0], C[1, 1]))
        # P_ij = H G_ij k_j E, A = I + C P, S_in = A^-1
        P = [[H * G[:, i, j] * ke[j] for j in range(2)] for i in range(2)]
        A = [[(i == j) + c[i][0] * P[0][j] + c[i][1] * P[1][j] for j in range(2)] for i in range(2)]
        det = A[0][0] * A[1][1] - A[0][1] * A[1][0]
        S = ((A[1][1] / det, -A[0][1] / det), (-A[1][0] / det, A[0][0] / det))
        c1 = (c[0][0] + c[0][1], c[1][0] + c[1][1])                        # C [1, 1]^T
        x = (H * G[:, 0, 2], H * G[:, 1, 2])                              # H g_rc
        cx = (c[0][0] * x[0] + c[0][1] * x[1], c[1][0] * x[0] + c[1][1] * x[1])
        u_ref = np.stack([S[i][0] * c1[0] + S[i][1] * c1[1] for i in range(2)])
        u_force = np.stack([-(S[i][0] * cx[0] + S[i][1] * cx[1]) for i in range(2)])
        f_ref = u_ref * np.stack(ke)
        f_force = u_force * np.stack(ke)
        g_cr = np.moveaxis(G[:, 2, :2], 1, 0)                             # (2, n, n_f)
        return GantryLoop(s, scenarios, G[:, 2, 2] + (g_cr * f_force).sum(axis=0), (g_cr * f_ref).sum(axis=0),
                          u_ref, f_force, f_ref)


@dataclass(frozen=True)
class PositionRow:
    """The design at one carriage position: the worst over payloads, uncertainty corners and mice."""

    carriage_position_m: float
    phase_margin_deg: float
    gain_margin_db: float
    #: the rendered admittance stays within 3 dB / 30 deg of the virtual dynamics up to here (Hz)
    rendered_bandwidth_hz: float
    motor_force_n: float


@dataclass(frozen=True)
class DualAdmittanceResult:
    """(m_v, b_v) on a two-motor structure, with its dense check, Monte Carlo and what the mouse feels.
    ``status`` as ``design.admittance.synthesis.AdmittanceResult``: optimal, mouse_cannot_drive or infeasible."""

    status: str
    message: str
    structure: str
    controller: Controller
    m_v: float
    b_v: float
    #: m_v a_pk + b_v v_pk (N)
    peak_resistance_n: float
    check: AdmittanceCheck
    monte_carlo: AdmittanceMonteCarlo | None
    feel: MouseFeel | None
    #: the tightest requirement at the design, where it binds and in words
    binding: Binding[MouseModel]
    by_position: tuple[PositionRow, ...]
    corners: tuple[MouseModel, ...]
    timing: RigTiming
    design_scenarios: int
    seconds: float
    discrete: DiscreteAdmittance | None = None
    #: the latency the design tolerates and its margins with one more sample (``design.admittance.latency``)
    latency: LatencyCheck | None = None
    #: the search between the dense check's points (``design.admittance.between``) and the scale-up it asked for
    between: HeldBetween | None = None
    #: the translation gains chosen for the mouse and their velocity-loop checks (``admittance.codesign = true``)
    codesign: DualCodesignRecord | None = None

    @property
    def gains(self) -> dict[str, float]:
        """The structure's gains by name (A/(m/s), A/m)."""
        return self.controller.gains()

    @property
    def worst_position(self) -> PositionRow:
        """The carriage position of the least phase-margin slack."""
        return min(self.by_position, key=lambda r: r.phase_margin_deg)


def by_position(check: AdmittanceCheck, scenarios: DualScenarios) -> tuple[PositionRow, ...]:
    """``PositionRow`` of every carriage position of ``check`` (made on ``scenarios``)."""
    rows = []
    for p in np.unique(scenarios.carriage_position_m):
        at = scenarios.carriage_position_m == p
        rows.append(PositionRow(float(p), float(np.nanmin(check.phase_margin_deg[:, at])),
                                float(np.nanmin(check.gain_margin_db[:, at])),
                                float(np.nanmin(np.nan_to_num(check.rendered_bandwidth_hz[at], nan=np.inf))),
                                float(np.max(check.motor_force_n[at]))))
    return tuple(rows)


def synthesise_dual_admittance(problem: LoopProblem, *, structure: str, controller: Controller,
                               model: DualDriveStageY, travel_m: tuple[float, float], design_positions: int,
                               stage_x_mass_kg: float, ranges: Mapping[str, tuple[float, float]],
                               progress: Callable[[str], None] | None = None,
                               codesign: DualCodesignRecord | None = None) -> DualAdmittanceResult:
    """(m_v, b_v) for ``controller`` (the structure ``structure``) over the carriage travel ``travel_m`` (m), the
    spec's payloads and ``ranges`` of the uncertain parameters (module doc); ``problem`` gives the admittance
    section, the payload range and the Monte Carlo settings; ``codesign``: the co-design whose gains replace
    ``controller`` (``design.admittance.dual_codesign``, required when the spec asks for it)."""
    t0 = time.perf_counter()
    say = progress or (lambda stage: None)
    adm = admittance_problem(problem)
    timing = RigTiming.of(adm.rig)
    if adm.codesign and codesign is None:
        raise SpecError("admittance.codesign: the two-motor co-design (design.admittance.dual_codesign) chooses the "
                        "gains this synthesis then takes as its controller")
    if codesign is not None:
        controller = codesign.controller
    loops = DualLoops(controller)
    corners = mice(problem)
    pr = problem.plant.payload_kg
    lo, hi = travel_m

    def plants(positions, payloads, box) -> DualScenarios:
        return dual_scenarios(model, positions, stage_x_mass_kg + np.asarray(payloads, float), box, stage_x_mass_kg)

    scenarios = plants(np.linspace(lo, hi, design_positions), pr.design_points(), ranges)
    dense_set = plants(np.linspace(lo, hi, CHECK_POSITIONS), np.linspace(pr.min, pr.max, CHECK_PAYLOADS)
                       if pr.max > pr.min else [pr.min], ranges)
    feel_set = plants(np.unique([lo, 0.5 * (lo + hi), hi]), np.unique([pr.min, pr.max]), {})
    say("dense check set up")
    felt = WorstFelt(problem, feel_set, corners, loops=loops, timing=timing)
    dense = evaluator(problem, dense_set, loops=loops, timing=timing, corners=corners)
    w_design = with_mode_points(check_grid_for(timing), corners, timing, points=RAY_MODE_POINTS)
    samples, seed = problem.verification.monte_carlo_samples, problem.verification.seed
    masses = (stage_x_mass_kg + pr.min, stage_x_mass_kg + pr.max)
    rounds = design_rounds(problem, scenarios, loops=loops, dense=dense, felt=felt, w_design=w_design, timing=timing,
                           corners=corners, say=say, dtype=np.complex64, draws_label="carriage position, payload",
                           draws=lambda k: monte_carlo_scenarios(model, (lo, hi), masses, ranges, samples, seed + k,
                                                                 stage_x_mass_kg),
                           between=two_motor_space(problem, model, (lo, hi), stage_x_mass_kg, ranges))
    ray, x, check, mc = rounds.ray, rounds.x, rounds.check, rounds.monte_carlo
    if not ray.feasible:
        return _infeasible(problem, ray, structure, controller, dense, dense_set, corners, timing, len(scenarios), t0,
                           codesign)
    binding = rounds.binding(problem, corners, timing)
    say("what the mouse feels")
    worst_felt = felt.worst(*x)
    feel = mouse_feel(problem, loops=loops, m_v=x[0], b_v=x[1], scenarios=feel_set, corners=corners,
                      timing=worst_felt.timing, felt=worst_felt)
    say("latency margin")
    latency = latency_check(rounds.rp_scenarios, corners, loops=loops, timing=timing.at_delay(timing.delays[-1]),
                            m_v=x[0], b_v=x[1])
    loc = adm.locomotion
    r = float(x[0] * loc.peak_acceleration_m_per_s2 + x[1] * loc.peak_speed_m_per_s)
    held = rounds.between
    failures = [v.detail for v in check.violations[:3]]
    if held is not None and not held.search.holds:
        failures.insert(0, between_failure(held.search))
    status, msg = admittance_verdict(
        adm, failures="the dense check fails: " + "; ".join(failures[:3]) if failures else None,
        held_on=f"the {structure} loops, {len(dense_set)} plants x {len(corners)} mice{between_text(held)}",
        draws_over="carriage position, payload, uncertainty", monte_carlo=mc, feel=feel, binding=binding,
        m_v=x[0], b_v=x[1], hint=HINT if codesign is not None else CODESIGN_HINT)
    return DualAdmittanceResult(
        status, msg, structure, controller, float(x[0]), float(x[1]), r, check, mc, feel, binding,
        by_position(check, dense_set), corners, timing, len(rounds.scenarios), time.perf_counter() - t0,
        DiscreteAdmittance.of_timing(float(x[0]), float(x[1]), timing) if timing.sampled else None, latency, held,
        codesign)


def _infeasible(problem, ray, structure, controller, dense, dense_set, corners, timing, n_design,
                t0, codesign) -> DualAdmittanceResult:
    """No ray holds every requirement within the bounds of (m_v, b_v)."""
    adm = admittance_problem(problem)
    hi = np.array([adm.m_v.max, adm.b_v.max])
    x = np.minimum(np.array([ray.m_v, ray.b_v]), hi) if math.isfinite(ray.b_v) else hi
    msg = (f"infeasible: no (m_v, b_v) within admittance.m_v.max = {hi[0]:g} kg and admittance.b_v.max = {hi[1]:g} "
           f"N*s/m holds every requirement on the {structure} loops: {ray.binding} needs b_v = {ray.b_v:.4g} N*s/m "
           f"along the best ray (m_v / b_v = {ray.tau_s:.3g} s)")
    check = dense.evaluate(*x)
    binding = Binding(ray.binding, value=float(ray.b_v), limit=float(hi[1]), detail=msg)
    loc = adm.locomotion
    return DualAdmittanceResult("infeasible", msg, structure, controller, float(x[0]), float(x[1]),
                                float(x[0] * loc.peak_acceleration_m_per_s2 + x[1] * loc.peak_speed_m_per_s), check,
                                None, None, binding, by_position(check, dense_set), corners, timing, n_design,
                                time.perf_counter() - t0, codesign=codesign)


@dataclass(frozen=True)
class RenderedByPosition:
    """The rendered admittance a mouse meets on the recommended structure, at the heaviest payload and nominal
    parameters with the carriage at the travel's ends and middle, beside the virtual one (m/s per N)."""

    frequency_hz: np.ndarray
    carriage_position_m: tuple[float, ...]
    payload_kg: float
    virtual: np.ndarray
    #: (n_positions, n_f): the fundamental under a sampled law
    rendered: np.ndarray


def rendered_by_position(result: DualAdmittanceResult, spec) -> RenderedByPosition:
    """``RenderedByPosition`` of ``result`` on ``spec``'s two-motor model (to 0.49 of the law's rate when
    sampled, else to 300 Hz)."""
    d = spec.dual_drive
    travel = d.carriage_position_m
    places = (travel.min, (travel.min + travel.max) / 2, travel.max)
    heavy = dual_scenarios(spec.dual_model(), list(places), [d.stage_x_mass_kg + spec.plant.payload_kg.max], {},
                           d.stage_x_mass_kg)
    top = 0.49 / result.timing.period_s if result.timing.sampled else 300.0
    f = np.geomspace(0.1, top, 600)
    w = 2 * np.pi * f
    yr = rendered_admittance(DualLoops(result.controller).at(1j * w, heavy), result.m_v, result.b_v, result.timing)
    return RenderedByPosition(f, places, float(spec.plant.payload_kg.max),
                              1.0 / virtual_impedance_frd(w, result.m_v, result.b_v), yr)
