"""Admittance synthesis: the virtual dynamics 1/(m_v s + b_v) a mouse can push with the least force while
the coupled gantry-mouse system keeps its margins (physics and the interaction loop:
``design.admittance.model``; the rig's sampled law: ``design.admittance.rig``).

Problem: minimise the force the virtual dynamics ask at the corner of the locomotion profile,
m_v a_pk + b_v v_pk, over the spec's bounds, subject to, at every design scenario (a payload point with
a corner of the spec's ``plant.uncertainty`` box) and every mouse of the spec (corners of its ranges,
floating and on its legs): the interaction loop's phase and gain margins, the motor's peak force, and
the optional requirements (current per force-sensor step, drift at rest, passivity up to a frequency).

Pipeline (``synthesise_admittance``):

0. **co-design** (``codesign = true``, ``design.admittance.codesign``): the PI gains and a ranged force
   filter chosen with (m_v, b_v), the velocity loop keeping the PI requirements;
1. **rays** (``design.admittance.ray``): along each ray m_v / b_v = tau every requirement is a bound on the
   scale b_v in closed form (the margins exactly along the ray, with the crossings interpolated); the
   cheapest ray is found by a scan of tau and refinement, on an active set of curves (scenario x mouse)
   grown until every curve holds: the optimum of the sampled problem, to the scan's resolution;
2. **robustness** like systune: the design is checked on 25 payloads x the uncertainty corners x every
   mouse on the dense grid (exact margins and Nyquist stability where a curve comes near its bound, the
   ray bound certifying the others); the worst violating scenario joins the design scenarios and step 1
   repeats;
3. **Monte Carlo** (``design.admittance.monte_carlo``): 10,000 independent draws over payload x
   uncertainty x a drawn mouse; the worst violator joins the design scenarios (at most
   ``MONTE_CARLO_ROUNDS`` times);
4. **verification** (``design.admittance.verify``): coupled closed-loop poles and python-control margins
   on the rational model, continuous or sampled by ``control.c2d``, at the tightest pairs;
5. **the mouse** (``design.admittance.feel``, ``design.admittance.contact``): the force felt on the profile,
   the reach of its force budget, the passive band, the stiffest contact, the latency it tolerates
   (``design.admittance.latency``); a design the declared mouse
   cannot drive has the status ``mouse_cannot_drive``, and any design that is not optimal gets the
   trade-off front and the hardware changes that would move it (``design.admittance.tradeoff``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from design.admittance.between import HeldBetween, between_failure, between_text, hold_between, one_motor_space
from design.admittance.bounds import curve_bounds
from design.admittance.codesign import codesign
from design.admittance.contact import ContactLimit, stiffest_contact
from design.admittance.delays import (
    WorstFelt,
    evaluator,
    join_monte_carlo,
    join_verifications,
    samples_text,
    span_ray_problem,
)
from design.admittance.feel import MouseFeel, feel_scenarios, mouse_feel
from design.admittance.latency import LatencyCheck, latency_check
from design.admittance.model import (
    AdmittanceCheck,
    PiLoops,
    admittance_problem,
    check_grid_for,
    interaction_responses,
    mice,
    relative_slack,
    with_mode_points,
)
from design.admittance.monte_carlo import AdmittanceMonteCarlo, admittance_monte_carlo
from design.admittance.mouse import MouseModel
from design.admittance.ray import RayBound, best_ray, ray_problem
from design.admittance.rig import DiscreteAdmittance, RigTiming
from design.admittance.tradeoff import trade_off
from design.admittance.verdict import admittance_verdict
from design.admittance.verify import AdmittanceVerification, verify_admittance
from design.loop.controller import PI
from design.loop.requirement import Binding
from design.problem import LoopProblem
from design.synth.scenarios import Scenarios, admittance_check_scenarios, design_scenarios
from plant.errors import SpecError

#: rounds of the dense check adding its worst violator, and of the Monte Carlo check
MAX_ROUNDS = 4
MONTE_CARLO_ROUNDS = 2
@dataclass(frozen=True)
class AdmittanceSolverRecord:
    """How an admittance synthesis went: the ray's ratio m_v / b_v (s), and (a design made) the rounds of design
    and dense check, the design scenarios, the Monte Carlo rounds and the payload points designed on."""

    tau_s: float
    rounds: int | None = None
    design_scenarios: int | None = None
    monte_carlo_rounds: int | None = None
    payload_points: tuple[float, ...] | None = None


@dataclass(frozen=True)
class AdmittanceResult:
    """Chosen virtual dynamics with their dense check, independent verification and what the mouse feels.

    ``status``: "optimal" (verified, and the declared mouse can drive the declared profile),
    "mouse_cannot_drive" (verified, but the force felt exceeds the mouse's peak force) or "infeasible"
    (no design holds every requirement, or the design failed its checks)."""

    status: str
    message: str
    m_v: float
    b_v: float
    controller: PI
    #: m_v a_pk + b_v v_pk (N)
    peak_resistance_n: float
    check: AdmittanceCheck
    verification: AdmittanceVerification | None
    #: the tightest requirement at the design, where it binds and in words
    binding: Binding[MouseModel]
    active: tuple[str, ...]
    corners: tuple[MouseModel, ...]
    seconds: float
    timing: RigTiming
    solver: AdmittanceSolverRecord = field(default_factory=lambda: AdmittanceSolverRecord(math.nan))
    monte_carlo: AdmittanceMonteCarlo | None = None
    feel: MouseFeel | None = None
    contact: ContactLimit | None = None
    discrete: DiscreteAdmittance | None = None
    #: the trade-off front and the hardware changes (``design.admittance.tradeoff``) when not optimal
    tradeoff: object | None = None
    #: designed for the nominal parameters only (the uncertainty ignored), for comparison
    nominal: bool = False
    #: the co-design's record when the PI gains were chosen with the admittance
    codesign: object | None = None
    #: the latency the design tolerates and its margins with one more sample (``design.admittance.latency``)
    latency: LatencyCheck | None = None
    #: the search between the dense check's points (``design.admittance.between``) and the scale-up it asked for
    between: HeldBetween | None = None

    @property
    def verified(self) -> bool:
        return bool(self.status in ("optimal", "mouse_cannot_drive") and self.verification is not None
                    and self.verification.verified)


def _controller(problem: LoopProblem, controller: PI | None) -> PI:
    """``controller``, or the spec's ``controller`` values."""
    if controller is not None:
        return controller
    for name in ("kp", "ki"):
        v = getattr(problem.controller, name).value
        if v is None:
            raise SpecError(f"controller.{name}.value is needed for admittance synthesis (or pass a controller)")
        if not (math.isfinite(v) and v >= 0):
            raise SpecError(f"controller.{name}: must be finite and >= 0, got {v}")
    return PI(float(problem.controller.kp.value), float(problem.controller.ki.value))


#: curves whose bounds ``ray_binding`` computes together (memory: a few float arrays of rows x frequencies)
BINDING_ROWS = 2048


_HINTS = {"sensor_current": "allow a larger m_v / b_v, a larger admittance.hardware.max_current_per_sensor_step_a, "
                            "or a finer force sensor",
          "motor_force": "raise admittance.hardware.motor_peak_force_n, slow the locomotion profile "
                         "(admittance.locomotion) or lighten the payload",
          "margins": "allow a larger m_v / b_v, lower admittance.phase_margin_deg / gain_margin_db, or make the "
                     "velocity loop better damped (codesign = true)",
          "drift": "tare more finely (admittance.sensor.bias_after_tare_n), add a deadband, or accept more drift",
          "passivity": "lower admittance.passivity.up_to_hz or allow a larger m_v / b_v",
          "b_v_min": "lower admittance.b_v.min", "m_v_min": "lower admittance.m_v.min",
          "b_v_max": "raise admittance.b_v.max", "m_v_max": "raise admittance.m_v.max"}


_HINT_OF = {"phase_margin": "margins", "gain_margin": "margins"}
_NAMES = {"margins": "the interaction-loop margins (admittance.phase_margin_deg, admittance.gain_margin_db)",
          "motor_force": "the motor's peak force (admittance.hardware.motor_peak_force_n)",
          "sensor_current": "the current per force-sensor step (admittance.hardware.max_current_per_sensor_step_a)",
          "passivity": "passivity (admittance.passivity.up_to_hz)", "b_v_min": "admittance.b_v.min",
          "m_v_min": "admittance.m_v.min"}


def ray_binding(problem: LoopProblem, rp, ray: RayBound, corners, scenarios: Scenarios,
                delays=(0,)) -> Binding[MouseModel]:
    """The requirement that sets the design's scale, with the scenario and mouse where it binds (``rp`` built on
    the mice ``corners`` x ``scenarios`` at each computation delay of ``delays``)."""
    adm = admittance_problem(problem)
    if ray.binding != "margins":
        details = {"b_v_min": f"b_v at its lower bound admittance.b_v.min = {adm.b_v.min:g} N*s/m",
                   "m_v_min": f"m_v at its lower bound admittance.m_v.min = {adm.m_v.min:g} kg",
                   "drift": "the drift at rest (admittance.sensor.max_drift_mm_per_s) sets b_v",
                   "sensor_current": "the current per force-sensor step (admittance.hardware."
                                     "max_current_per_sensor_step_a) sets the scale of (m_v, b_v)",
                   "motor_force": "the motor's peak force sets the scale of (m_v, b_v)",
                   "passivity": "passivity (admittance.passivity) sets the scale of (m_v, b_v)"}
        name = "drift" if ray.binding == "b_v_min" and rp.t_min > adm.b_v.min else ray.binding
        return Binding(name, value=ray.b_v, limit=ray.b_v, detail=details.get(name, name))
    q = rp.impedance.ray(ray.tau_s)
    t_pm, t_gm = (np.concatenate(p) for p in zip(*(
        curve_bounds(rp.log_mag[i:i + BINDING_ROWS], rp.psi[i:i + BINDING_ROWS], q, rp.phase_margin_deg,
                     rp.gain_margin, rp.sampled, parts=True) for i in range(0, len(rp.log_mag), BINDING_ROWS))))
    gm_binds = t_gm.max() >= t_pm.max()
    c = int(np.argmax(t_gm if gm_binds else t_pm))
    i, k, j = np.unravel_index(c, (len(delays), len(corners), len(scenarios)))
    mouse = corners[k]
    name = "gain_margin" if gm_binds else "phase_margin"
    limit = adm.gain_margin_db if gm_binds else adm.phase_margin_deg
    at_delay = "" if len(delays) == 1 else f" with {samples_text(delays[i])}"
    return Binding(name, float(scenarios.payload_kg[j]), scenarios.row(j), mouse, limit, limit,
                   detail=f"interaction-loop {name.replace('_', ' ')} (admittance.{name}_"
                          f"{'db' if gm_binds else 'deg'} = {limit:g}) at {scenarios.describe(j)} with mouse "
                          f"({mouse.label()}){at_delay}")


def synthesise_admittance(problem: LoopProblem, *, controller: PI | None = None,
                          nominal: bool = False, progress: Callable[[str], None] | None = None,
                          tradeoff: bool = True) -> AdmittanceResult:
    """Choose (m_v, b_v) (and with ``codesign`` the PI gains and force filter) as the module docstring says.
    PI gains default to the spec's ``controller`` values; ``nominal`` ignores the uncertainty (the design
    for the nominal parameters, for comparison); ``progress(stage)`` is told each stage as it starts."""
    t0 = time.perf_counter()
    say = progress or (lambda stage: None)
    if nominal:
        problem = replace(problem, plant=replace(problem.plant, uncertainty={}))
    adm = admittance_problem(problem)
    if problem.plant.nominal.stage != "x":
        raise SpecError("plant.stage: the one-motor admittance design is Stage X's; Stage Y's two motors and yaw "
                        "mode are designed with a [dual_drive] section (specs/stage_y_admittance.toml)")
    controller = _controller(problem, controller)
    timing = RigTiming.of(adm.rig)
    record = None
    if adm.codesign and not nominal:
        say("co-design of the PI gains, force filter and virtual dynamics")
        # at the range's largest delay (the checks below cover every delay of it)
        record = codesign(problem, controller=controller, timing=timing.at_delay(timing.delays[-1]))
        controller = record.controller
        timing = replace(record.timing, delay_samples=timing.delay_samples, delay_samples_max=timing.delay_samples_max)
    corners = mice(problem)
    loops = PiLoops.of(problem, controller)
    loc = adm.locomotion
    w_design = with_mode_points(check_grid_for(timing), corners, timing)
    say("dense check set up")
    feel_set = feel_scenarios(problem)
    felt = WorstFelt(problem, feel_set, corners, loops=loops, timing=timing)
    dense = evaluator(problem, admittance_check_scenarios(problem), loops=loops, timing=timing, corners=corners)
    scenarios = design_scenarios(problem)
    rounds = design_rounds(problem, scenarios, loops=loops, dense=dense, felt=felt, w_design=w_design, timing=timing,
                           corners=corners, say=say, between=one_motor_space(problem))
    rp, ray, x, check, mc = rounds.rp, rounds.ray, rounds.x, rounds.check, rounds.monte_carlo
    if not ray.feasible:
        return _infeasible(problem, ray, rp, rounds.rp_scenarios, controller, timing, corners, t0, record)
    scenarios, mc_round = rounds.scenarios, rounds.monte_carlo_rounds
    del dense
    say("verification on the rational model (python-control)")
    verification = join_verifications([verify_admittance(problem, check, controller=controller, timing=t)
                                       for t in timing.per_delay()], timing.delays)
    binding = rounds.binding(problem, corners, timing)
    say("what the mouse feels")
    worst_felt = felt.worst(*x)
    feel = mouse_feel(problem, loops=loops, m_v=x[0], b_v=x[1], scenarios=feel_set, corners=corners,
                      timing=worst_felt.timing, felt=worst_felt)
    contact = min((stiffest_contact(problem, design_scenarios(problem), loops=loops, m_v=x[0], b_v=x[1], timing=t)
                   for t in timing.per_delay()), key=lambda c: c.worst_n_per_m)
    say("latency margin")
    latency = latency_check(design_scenarios(problem), corners, loops=loops, timing=timing.at_delay(timing.delays[-1]),
                            m_v=x[0], b_v=x[1])
    r = x[0] * loc.peak_acceleration_m_per_s2 + x[1] * loc.peak_speed_m_per_s
    span = ("" if len(timing.delays) == 1 else
            f" at every computation delay from {timing.delays[0]} to {timing.delays[-1]} samples")
    held = rounds.between
    failures = list(verification.failures[:3])
    if held is not None and not held.search.holds:
        failures.insert(0, between_failure(held.search))
    status, msg = admittance_verdict(
        adm, failures="NOT verified: " + "; ".join(failures[:3]) if failures else None,
        held_on=f"{len(scenarios)} design scenarios x {len(corners)} mice{span}{between_text(held)}",
        draws_over="payload, uncertainty",
        monte_carlo=mc, feel=feel, binding=binding, m_v=x[0], b_v=x[1],
        hint=_HINTS.get(_HINT_OF.get(binding.constraint, binding.constraint), ""))
    active = tuple(sorted({binding.constraint} | {v.constraint for v in check.violations}))
    result = AdmittanceResult(
        status, msg, float(x[0]), float(x[1]), controller, float(r), check, verification, binding, active, corners,
        time.perf_counter() - t0, timing,
        AdmittanceSolverRecord(ray.tau_s, rounds.rounds, len(scenarios), mc_round,
                               tuple(sorted({float(p) for p in scenarios.payload_kg}))),
        mc, feel, contact,
        DiscreteAdmittance.of_timing(float(x[0]), float(x[1]), timing) if timing.sampled else None, None, nominal,
        record, latency, held)
    if status != "optimal" and tradeoff and not nominal:
        say("trade-off front and hardware changes")
        result = replace(result, tradeoff=trade_off(problem, result, rp), seconds=time.perf_counter() - t0)
    return result


@dataclass(frozen=True)
class Rounds:
    """Steps 1-3 of the module doc: the last ray problem and ray, on the design scenarios they were made on, the
    design x = (m_v, b_v) with its dense check and Monte Carlo; when the ray is infeasible the rounds stop there
    (``x``, ``check`` and ``monte_carlo`` None)."""

    rp: object
    ray: RayBound
    rp_scenarios: object
    scenarios: object
    x: np.ndarray | None
    check: AdmittanceCheck | None
    monte_carlo: AdmittanceMonteCarlo | None
    rounds: int
    monte_carlo_rounds: int
    #: the dense check's worst violation at the ray's design when the design had to be scaled up its ray
    #: (``back_off``) to hold: the requirement that binds it then
    backed_off: Binding[MouseModel] | None = None
    #: the search between the dense check's points and what it made of the design (``design.admittance.between``;
    #: None where the caller asked for none)
    between: HeldBetween | None = None

    def binding(self, problem: LoopProblem, corners, timing: RigTiming) -> Binding[MouseModel]:
        """The requirement that binds the design: the ray's (``ray_binding``), the one the back-off cured, or the
        point between the check's points that the design was scaled up to hold."""
        held = self.between
        if held is not None and held.failed is not None:
            return between_binding(problem, held)
        if self.backed_off is None:
            return ray_binding(problem, self.rp, self.ray, corners, self.rp_scenarios, timing.delays)
        return replace(self.backed_off, detail=self.backed_off.detail + " at the ray's design; (m_v, b_v) scaled up "
                       "the ray until it holds")


def between_binding(problem: LoopProblem, held: HeldBetween) -> Binding[MouseModel]:
    """The margin that failed between the dense check's points, at the ray's design, and the scale-up that cured
    it (``design.admittance.between.hold_between``)."""
    adm = admittance_problem(problem)
    f = held.failed
    pm_short = (f.phase_margin_deg - adm.phase_margin_deg) / max(adm.phase_margin_deg, 1.0)
    gm_short = (f.gain_margin_db - adm.gain_margin_db) / max(adm.gain_margin_db, 1.0)
    gm_binds = gm_short < pm_short
    name, key = ("gain_margin", "gain_margin_db") if gm_binds else ("phase_margin", "phase_margin_deg")
    value, limit = (f.gain_margin_db, adm.gain_margin_db) if gm_binds else (f.phase_margin_deg, adm.phase_margin_deg)
    unit = "dB" if gm_binds else "deg"
    cured = ("until it holds" if held.search.holds else
             f"and after {held.rounds} rounds it still fails (least slack {held.search.slack:.3g})")
    at = Scenarios(np.array([f.scenario.payload_kg]), {n: np.array([v]) for n, v in f.scenario.parameters})
    return Binding(name, f.scenario.payload_kg, f.scenario, f.mouse, limit, limit,
                   detail=f"interaction-loop {name.replace('_', ' ')} (admittance.{key} = {limit:g}) at "
                          f"{at.describe(0)} with mouse ({f.mouse.label()}), between the check's points: "
                          f"{value:.2f} {unit} at the ray's design; (m_v, b_v) scaled up the ray by "
                          f"{100 * (held.scale - 1):.2f} % {cured}")


def design_rounds(problem: LoopProblem, scenarios, *, loops, dense, felt, w_design,
                  timing: RigTiming, corners, say, draws=None, dtype=complex, draws_label: str = "payload",
                  between=None) -> Rounds:
    """Rays on ``scenarios`` x ``corners`` (the force ``felt`` their objective), the ``dense`` check adding its worst
    violator (at most ``MAX_ROUNDS`` rays), the back-off when it still fails, with ``between`` the search between the
    dense check's points over the box ``between(grounded)`` (``design.admittance.between``: ``one_motor_space``,
    ``two_motor_space``; ``hold_between`` scales the design up its ray where a point fails), then the Monte Carlo
    (``draws(k)``: the scenario draws of round k, default the problem's payload x uncertainty draws) adding its
    worst violator (at most ``MONTE_CARLO_ROUNDS`` times). ``dtype``: the rays' responses
    (``interaction_responses``)."""
    adm = admittance_problem(problem)
    seed = problem.verification.seed
    n, backed_off = 0, None
    record = "" if adm.locomotion.force_record is None else ", the motor on the force record"
    for mc_round in range(MONTE_CARLO_ROUNDS + 1):
        for _ in range(MAX_ROUNDS):
            n += 1
            say(f"rays on {len(scenarios)} scenarios x {len(corners)} mice")
            rp_scenarios = scenarios
            rp = span_ray_problem([ray_problem(interaction_responses(problem, scenarios, w_design, loops=loops,
                                                                     timing=t, corners=corners, dtype=dtype), adm)
                                   for t in timing.per_delay()])
            ray = best_ray(rp, objective=lambda r: felt(r.m_v, r.b_v))
            if not ray.feasible:
                return Rounds(rp, ray, rp_scenarios, scenarios, None, None, None, n, mc_round, None)
            x = np.array([ray.m_v, ray.b_v])
            say(f"dense check ({len(dense.scenarios)} scenarios x {len(corners)} mice{record})")
            check = dense.evaluate(*x, recorded=True)
            if check.meets:
                break
            worst = min(check.violations, key=relative_slack)
            if worst.scenario is None or worst.source == "force_record" or scenarios.contains(worst.scenario):
                break
            scenarios = scenarios.with_row(worst.scenario)
        if not check.meets:
            backed_off = min(check.violations, key=relative_slack)
            x, check = back_off(dense, x, adm)
        held = None
        if between is not None:
            say("search between the dense check's points")
            held = hold_between(problem, dense, x, check, loops=loops, timing=timing, space=between)
            x, check = held.x, held.check
        say(f"Monte Carlo over {draws_label}, uncertainty and mouse")
        drawn = None if draws is None else draws(mc_round)
        mc = join_monte_carlo([admittance_monte_carlo(problem, loops=loops, m_v=x[0], b_v=x[1], timing=t,
                                                      seed=seed + mc_round, draws=drawn) for t in timing.per_delay()])
        if mc.violations == 0 or mc_round == MONTE_CARLO_ROUNDS or scenarios.contains(mc.worst_scenario):
            break
        scenarios = scenarios.with_row(mc.worst_scenario)
    return Rounds(rp, ray, rp_scenarios, scenarios, x, check, mc, n, mc_round, backed_off, held)


def back_off(dense, x: np.ndarray, adm) -> tuple[np.ndarray, AdmittanceCheck]:
    """The nearest point up the ray from ``x`` that the dense check passes: the first passing scale of
    1.002, 1.006, 1.018, ... (x3 in log each step) up to the bounds, then bisection to 0.1 %."""
    top = math.log(max(min(adm.m_v.max / x[0], adm.b_v.max / x[1]), 1.0))
    lo, hi, step = 0.0, None, math.log(1.002)
    while hi is None and lo < top:
        trial = min(lo + step, top)
        if dense.evaluate(*(x * math.exp(trial)), bandwidth=False, recorded=True).meets:
            hi = trial
        else:
            lo, step = trial, 3 * step
    if hi is None:
        return x * math.exp(top), dense.evaluate(*(x * math.exp(top)), recorded=True)
    while hi - lo > 1e-3:
        mid = 0.5 * (lo + hi)
        if dense.evaluate(*(x * math.exp(mid)), bandwidth=False, recorded=True).meets:
            hi = mid
        else:
            lo = mid
    x = x * math.exp(hi)
    return x, dense.evaluate(*x, recorded=True)


def _infeasible(problem, ray: RayBound, rp, scenarios, controller: PI, timing, corners, t0, record) -> AdmittanceResult:
    """No ray holds every requirement within the bounds: name the requirement and the bound that conflict."""
    adm = admittance_problem(problem)
    hi = np.array([adm.m_v.max, adm.b_v.max])
    need = ray.binding
    msg = (f"infeasible: no (m_v, b_v) within admittance.m_v.max = {hi[0]:g} kg and admittance.b_v.max = "
           f"{hi[1]:g} N*s/m holds every requirement: the least scale along the best ray (m_v / b_v = "
           f"{ray.tau_s:.3g} s) is set by {_NAMES.get(need, need)} at b_v = {ray.b_v:.4g} N*s/m, above what the "
           f"upper bounds {'and passivity ' if adm.passivity is not None else ''}allow; {_HINTS.get(need, '')}")
    ev = evaluator(problem, scenarios, loops=PiLoops.of(problem, controller), timing=timing, corners=corners)
    x = np.minimum(np.array([ray.m_v, ray.b_v]), hi) if math.isfinite(ray.b_v) else hi
    check = ev.evaluate(*x)
    binding = Binding(need, value=ray.b_v, limit=float(hi[1]), detail=msg)
    r = float(x[0] * adm.locomotion.peak_acceleration_m_per_s2 + x[1] * adm.locomotion.peak_speed_m_per_s)
    result = AdmittanceResult("infeasible", msg, float(x[0]), float(x[1]), controller, r, check, None, binding, (need,),
                              corners, time.perf_counter() - t0, timing, AdmittanceSolverRecord(ray.tau_s),
                              codesign=record)
    return replace(result, tradeoff=trade_off(problem, result, rp))
