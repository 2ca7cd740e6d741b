"""PI gain synthesis: maximise the worst-case closed-loop bandwidth over the payload range
subject to phase- and gain-margin requirements at every payload, then verify independently.

The loop L_m(jw) = P_m(jw) (kp + ki/jw) is affine in (kp, ki) for every payload m, so plants
may be models or measured responses. The pipeline (``synthesise_pi``):

Each stage has its module: ``design.synth.evaluation`` (a design judged on scenarios, the requirement
circles), ``design.synth.scan``, ``design.synth.ccp``, ``design.synth.exact``; this module is the driver.

1. **scan**: a 20 x 20 log grid of (kp, ki) evaluated at the spec's payload points on the
   constraint grid ``W_OPT`` in one vectorised call (grid margins, ~0.1 s): seeds for the
   solvers and a bracket for the bandwidth.
2. **ccp** (cvxpy + Clarabel), after Hast, Astrom, Bernhardsson & Boyd (2013): both
   requirements are "stay outside a circle" constraints on the Nyquist curve,
   - margins: the circle centred on the real axis through -1/g and e^{j(pi - phi)}
     (centre x0 = (1 - 1/g^2) / (2 (1/g - cos phi)), radius |x0 + 1/g|); outside it the
     curve crosses the unit circle with PM >= phi and the negative real axis right of
     -1/g, so GM >= g (conservative); optional Ms and disk-margin circles likewise;
   - bandwidth >= w_b  <=>  |T(jw)| >= 1/sqrt 2 for w <= w_b  <=>  |L - 1| >= sqrt 2 there
     (2|L|^2 >= |1 + L|^2  <=>  |L|^2 - 2 Re L - 1 >= 0);
   each reverse-convex constraint is replaced by the tangent half-plane at the current
   iterate (an inner approximation, so a feasible iterate stays feasible): a small LP per
   iteration; bisection on w_b, bracketed by the scan, maximises the worst-case bandwidth.
3. **exact** (casadi + IPOPT), multi-start from the ccp design and the best scan seeds:
   exact margins through crossing variables per payload, |L(jw_c)| = 1 with
   Re L(jw_c) >= -cos(phi) (PM >= phi), Im L(jw_p) = 0 with Re L(jw_p) >= -1/g (GM >= g),
   |T(jw_b)| = 1/sqrt 2 with t <= log w_b; maximise t. P(jw) is written symbolically from the
   plant's parameters (``design.synth.exact._casadi_frd``). The first crossings are tracked; a resonance may cross
   again higher up, so when no exact design passes the dense check, a further solve from the first
   start also keeps the margin circle above twice the first crossover (100 points per decade).
4. **robustness** like systune: every candidate is checked at ``DENSE_PAYLOADS`` payloads with
   the cubic-refined margins of ``design.loop.fast``; if none meets the requirements the
   worst violator joins the payload points and the solve repeats.
5. **verification** (``design.synth.verify``): python-control on the Pade model at every dense
   payload; the best verified candidate is reported, and a design that fails is never
   reported as optimal.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from design.loop.analysis import ANALYSIS_GRID_RAD_S
from design.loop.controller import PI
from design.loop.discrete import DiscreteCheck, DiscreteDesign, check_discrete, discretise
from design.loop.requirement import ScenarioPoint
from design.problem import LoopProblem, with_filter_values
from design.synth.between import PiBetween, search_pi_between
from design.synth.ccp import ccp_design
from design.synth.evaluation import Evaluation, evaluate
from design.synth.exact import exact_design
from design.synth.filter_scan import scan_filters
from design.synth.monte_carlo import MonteCarloCheck, monte_carlo_check
from design.synth.scan import W_OPT, Scan, ScanDiagnosis, scan_gains
from design.synth.scenarios import Scenarios, check_scenarios, describe_row, design_scenarios
from design.synth.solver_record import (
    Candidate,
    ChosenFilter,
    ExactStart,
    FilterTrial,
    JointExact,
    SolverRecord,
    VerifiedCandidate,
)
from design.synth.verify import Verification, verify
from plant.errors import SpecError
from plant.grid import log_grid_rad_s
from plant.physics.effects import EFFECTS

#: the thesis's hand-tuned gains (Kp A/(m/s), Ki A/m), a baseline
THESIS_GAINS = PI(236.0, 47.0)

#: effects that limit the achievable bandwidth (phase lag growing with frequency)
PHASE_LIMITING = tuple(n for n, cls in EFFECTS.items() if cls.limits_bandwidth and cls.in_synthesis and cls.searched)
UNSUPPORTED = tuple(n for n, cls in EFFECTS.items() if not cls.in_synthesis)










#: exact (IPOPT) starts besides the ccp design
EXTRA_STARTS = 1


#: check scenarios with the least slack verified with python-control beside the design scenarios
VERIFY_TIGHTEST = 40




#: check scenarios with the least slack on which the discrete loop is checked beside the payload points
DISCRETE_TIGHTEST = 8


#: dense-check evaluations the local polish may spend, and its bisection steps towards a faster design
POLISH_EVALUATIONS = 80
POLISH_BISECTIONS = 8


#: Monte Carlo checks that may add their worst violator to the design scenarios
MONTE_CARLO_ROUNDS = 2


# --- baselines -------------------------------------------------------------------------------


def classical_rule(problem: LoopProblem, *, phase_margin_deg: float = 60.0) -> tuple[float, float]:
    """Single-model rule at the nominal payload: crossover where the plant phase is
    -180 + PM + 5.7 deg, kp = 1/|P| there, PI zero a decade below (costing 5.7 deg)."""

    plant = problem.plant.plant()
    P = plant.frd(ANALYSIS_GRID_RAD_S)
    phase = np.degrees(np.unwrap(np.angle(P)))
    target = -180.0 + phase_margin_deg + math.degrees(math.atan(0.1))
    i = int(np.argmax(phase < target)) if np.any(phase < target) else len(P) - 1
    wc = ANALYSIS_GRID_RAD_S[i]
    kp = min(1.0 / abs(P[i]) / math.sqrt(1 + 0.01), problem.controller.kp.max)
    return PI(float(kp), float(min(kp * wc / 10, problem.controller.ki.max)))


def baselines(problem: LoopProblem) -> tuple[tuple[Evaluation, ...], tuple[str, ...]]:
    """The thesis gains and the classical single-model rule, evaluated on the problem."""
    checks = check_scenarios(problem)
    return ((evaluate(problem, THESIS_GAINS, checks), evaluate(problem, classical_rule(problem), checks)),
            ("thesis gains", "classical rule (PM 60 deg at nominal payload, PI zero a decade below crossover)"))


# --- the driver -----------------------------------------------------------------------------------


@dataclass(frozen=True)


class SynthesisResult:
    status: str                      # "optimal" | "unbounded" | "infeasible"
    message: str
    evaluation: Evaluation | None
    verification: Verification | None
    method: str
    seconds: float
    baselines: tuple[Evaluation, ...] = ()
    baseline_names: tuple[str, ...] = ()
    payload_points_used: tuple[float, ...] = ()
    #: how the synthesis went (``design.synth.solver_record``)
    record: SolverRecord = field(default_factory=SolverRecord)
    #: why no gains meet the requirements (infeasible problems): its binding overrides the evaluation's
    diagnosis: ScanDiagnosis | None = None
    #: independent draws over payload x the uncertainty (problems with uncertainty, optimal designs)
    monte_carlo: MonteCarloCheck | None = None
    #: the design at ``controller.loop_rate_hz`` and python-control's check of its discrete loop
    discrete: tuple[DiscreteDesign, DiscreteCheck] | None = None
    #: the drive filters the design runs with
    filters: tuple[ChosenFilter, ...] = ()
    #: ``requirements.bandwidth_definition`` of every bandwidth reported
    bandwidth_definition: str = "half_power"
    #: the search between the dense check's points (``design.synth.between``; None when the box has no extent or the
    #: design did not get that far)
    between: PiBetween | None = None


def check_supported(problem: LoopProblem) -> None:
    bad = [e for e in problem.plant.effects if e in UNSUPPORTED]
    if "tilt_coupling" in bad:
        raise SpecError("plant.effects.tilt_coupling: the beam yaws on its two rails, which a one-loop Stage Y design "
                        "cannot hold; design it as the two-motor Stage Y with a [dual_drive] section (as "
                        "specs/stage_y_dual.toml: dual_drive.yaw_stiffness_n_m_per_rad is the tilt's stiffness)")
    if bad:
        raise SpecError(f"plant.effects.{bad[0]}: synthesis needs a linear plant without {', '.join(UNSUPPORTED)}; "
                        "design on the linear model and check the effect with gantry simulate")


def unbounded_message(problem: LoopProblem) -> str:
    return ("nothing in the plant limits the bandwidth (plant.effects has none of "
            f"{', '.join(PHASE_LIMITING)}): the loop of a first-order plant with PI control keeps more than 90 deg "
            "of phase margin and an infinite gain margin at any gain, so the optimum is at the gain bounds. Add "
            "the effects that limit a real loop to plant.effects, e.g. delay = { seconds = 0.0005 } and "
            "current_loop = { bandwidth_hz = 1000.0 }.")


@dataclass
class _Tally:
    """What the rounds of a synthesis add up (``SolverRecord``'s counts)."""

    scan_designs: int = 0
    lp_solves: int = 0
    exact_starts: list[ExactStart] = field(default_factory=list)


def _solve(problem: LoopProblem, scenarios: Scenarios, dense: Scenarios, method: str,
           tally: _Tally) -> tuple[list[tuple[str, PI, Evaluation | None]], Scan]:
    """Candidate designs (label, PI, its evaluation on ``dense`` when already made) for the design
    scenarios: the best scan seeds, the ccp design and the exact refinements from the ccp design and the best
    seeds (method "ccp": the ccp design); and the scan."""
    P = scenarios.response(problem.plant.plant(), W_OPT)
    scan = scan_gains(problem, P, scenarios.payload_kg)
    tally.scan_designs += scan.kp.size
    seeds = scan.best(scan.meets, scan.worst_bandwidth_hz, EXTRA_STARTS)
    if not seeds:   # nothing meets the requirements: start from the least violating gains
        seeds = scan.best(np.ones(scan.kp.size, bool), scan.relative_slack, 1)
    cands = [(f"scan seed {k + 1}", PI(float(scan.kp[i]), float(scan.ki[i])), None) for k, i in enumerate(seeds)]
    ccp = ccp_design(problem, P, scan)
    tally.lp_solves += ccp.lp_solves
    starts = list(cands)
    if math.isfinite(ccp.kp):
        cands.append(("ccp (cvxpy+CLARABEL)", PI(ccp.kp, ccp.ki), None))
        starts.insert(0, cands[-1])
        if method == "ccp":     # the circle design alone (the seeds only when it failed)
            cands = cands[-1:]
    if method == "ccp+exact":
        solvers: dict = {}

        def exact(label, start: PI, high):
            ex = exact_design(problem, scenarios, start, high_circle=high, solvers=solvers)
            name = f"exact (casadi+IPOPT{', high-frequency circle' if high else ''}) from {label}"
            tally.exact_starts.append(ExactStart(name, start.kp, start.ki, ex.controller.kp, ex.controller.ki,
                                                 ex.note))
            if ex.success:
                # starts that converge to the same gains (to 12 digits) share one dense evaluation
                same = [ev for _, c, ev in cands if ev is not None and np.allclose(c.parameters,
                                                                                   ex.controller.parameters,
                                                                                   rtol=1e-12, atol=0.0)]
                ev = replace(same[0], controller=ex.controller) if same else evaluate(problem, ex.controller, dense)
                cands.append((name, ex.controller, ev))
                return ev.meets
            return False

        met = [exact(*start[:2], False) for start in starts]
        if not any(met):      # e.g. a resonance crossing again above the tracked crossover
            exact(*starts[0][:2], True)
    return cands, scan


def polish(problem: LoopProblem, ev: Evaluation, dense: Scenarios, *, outer: Evaluation | None = None,
           budget: int = POLISH_EVALUATIONS) -> tuple[Evaluation, int]:
    """Local search in (log kp, log ki) with the dense check as the oracle, for designs the exact
    formulation cannot reach (a mode whose peak crosses |L| = 1 again: the first-crossing design is too
    fast, the margin-circle guard too slow). First bisection from ``ev`` (meets) towards ``outer`` (a
    faster design that fails), then a compass search (8 directions, steps 4 % down to 0.25 %) keeping the
    gain bounds; returns the best design meeting the requirements and the evaluations spent."""
    c = problem.controller
    lo = np.log([max(c.kp.min, 1e-12), max(c.ki.min, 1e-12)])
    hi = np.log([c.kp.max, c.ki.max])
    x, best, used = np.log(np.maximum(ev.controller.parameters, 1e-12)), ev, 0

    def trial(y):
        nonlocal used
        used += 1
        y = np.clip(y, lo, hi)
        return y, evaluate(problem, PI.of(np.exp(y)), dense)

    if outer is not None:
        a, b = 0.0, 1.0
        target = np.log(np.maximum(outer.controller.parameters, 1e-12))      # a gain of 0: its lower bound
        for _ in range(POLISH_BISECTIONS):
            t = 0.5 * (a + b)
            _, e = trial(x + t * (target - x))
            if e.meets and e.worst_bandwidth_hz > best.worst_bandwidth_hz:
                a, best = t, e
            else:
                b = t
        x = np.log(np.maximum(best.controller.parameters, 1e-12))
    step = 0.04
    directions = [np.array(d, float) / np.hypot(*d) for d in ((1, 0), (0, 1), (-1, 0), (0, -1), (1, 1), (-1, -1),
                                                              (1, -1), (-1, 1))]
    while step >= 0.0025 and used < budget:
        for d in directions:
            y, e = trial(x + step * d)
            if e.meets and e.worst_bandwidth_hz > best.worst_bandwidth_hz * (1 + 1e-9):
                x, best = y, e
                break
        else:
            step /= 2
    return best, used


def verification_scenarios(points: Scenarios, dense: Scenarios, ev: Evaluation) -> Scenarios:
    """Where python-control checks a design: every dense payload when there is no uncertainty; else every
    scenario designed for and the ``VERIFY_TIGHTEST`` check scenarios with the least slack (with the one
    of the lowest bandwidth)."""
    if not dense.parameters:
        return dense
    out = points
    for i in ev.tightest(VERIFY_TIGHTEST):
        row = dense.row(int(i))
        if not out.contains(row):
            out = out.with_row(row)
    return out


def synthesise_pi(problem: LoopProblem, *, method: str = "ccp+exact", max_rounds: int = 6,
                  nominal: bool = False, progress: Callable[[str], None] | None = None) -> SynthesisResult:
    """Robust PI synthesis on ``problem`` (see the module doc). Never reports an unverified design as optimal.

    With ``plant.uncertainty`` the design holds on every payload point x corner of the uncertainty box
    (and the violators the checks add); the Monte Carlo check then draws independent plants
    (``problem.verification``: how many, the first seed), and while it finds a violator (at most
    ``MONTE_CARLO_ROUNDS`` times) the worst joins the design scenarios and the design is repeated,
    checked again on fresh draws. ``nominal`` ignores the uncertainty (the design for the nominal
    parameters, for comparison). ``progress(stage)`` hears each stage begin."""
    say = progress or (lambda stage: None)
    if nominal:
        problem = replace(problem, plant=replace(problem.plant, uncertainty={}))
    if any(f.designed for f in problem.controller.filters):
        result = _with_designed_filters(problem, method, max_rounds, say)
    else:
        result = _robust(problem, method, max_rounds, say)
    return replace(result, bandwidth_definition=problem.requirements.bandwidth_definition)


def _robust(problem: LoopProblem, method: str, max_rounds: int, say: Callable[[str], None]) -> SynthesisResult:
    """The design on the scenarios, repeated with the Monte Carlo check's worst violators added."""
    extra: list[ScenarioPoint] = []
    for k in range(MONTE_CARLO_ROUNDS + 1):
        result = _synthesise(problem, method, max_rounds, extra, problem.verification.seed + k, say)
        mc, between = result.monte_carlo, result.between
        if between is not None and not between.holds and k < MONTE_CARLO_ROUNDS:
            extra.append(between.scenario)
            continue
        if mc is None or mc.violations == 0 or k == MONTE_CARLO_ROUNDS:
            return result
        extra.append(mc.worst_scenario)
    raise AssertionError("unreachable")


#: modes of the plant a notch may be placed on (their frequency starts the notch's)
MODE_EFFECTS = ("resonance", "payload_resonance", "second_resonance")


def resonance_peak_hz(problem: LoopProblem) -> float | None:
    """Frequency (Hz) where the nominal plant's modes lift its response most above the rigid body's,
    or None without modes."""
    plant = problem.plant.plant()
    if not any(e.name in MODE_EFFECTS for e in plant.effects):
        return None
    rigid = replace(plant, effects=tuple(e for e in plant.effects if e.name not in MODE_EFFECTS))
    w = log_grid_rad_s(1.0, 5000.0, 2000)
    return float(w[np.argmax(np.abs(plant.frd(w) / rigid.frd(w)))] / (2 * np.pi))


def filter_starts(problem: LoopProblem) -> list[list[dict | None]]:
    """Starting parameters of the drive filters: a notch on the plant's resonance (when it has one), every
    designed parameter at the middle of its range, and each designed filter left out (None), down to PI
    alone, so that the filters never make the design worse than PI alone."""
    import itertools

    filters = problem.controller.filters
    peak = resonance_peak_hz(problem)
    on = []
    for f in filters:
        v = f.start()
        if peak is not None and f.kind == "notch" and "frequency_hz" in f.ranges:
            lo, hi = f.ranges["frequency_hz"]
            v["frequency_hz"] = float(np.clip(peak, lo, hi))
        on.append(v)
    starts = [on] if peak is not None else []
    starts.append([f.start() for f in filters])
    for off in itertools.product(*[(False, True) if f.designed else (False,) for f in filters]):
        if any(off):
            starts.append([None if o else v for o, v in zip(off, on)])
    return starts


def as_designed(problem: LoopProblem, result: SynthesisResult) -> LoopProblem:
    """The problem with its drive filters as the synthesis chose them (itself when it designed none)."""
    return with_chosen_filters(problem, result.filters)


def with_chosen_filters(problem: LoopProblem, filters: tuple[ChosenFilter, ...]) -> LoopProblem:
    """The problem with its drive filters set as ``filters`` (the chosen ones; itself when there are none)."""
    if not filters:
        return problem
    return with_filter_values(problem, [dict(f.values) if f.used else None for f in filters])


def _with_designed_filters(problem: LoopProblem, method: str, max_rounds: int,
                           say: Callable[[str], None]) -> SynthesisResult:
    """PI gains and filter parameters together: for each start of the filters (``filter_starts``) the gains by
    the pipeline (scan, ccp, exact on the gains; the filters fixed, so the loop is affine in the gains), then
    IPOPT on the gains and the filters together (with the margin circle guarding the re-crossings near a
    mode) from the best two starts with filters, and the pipeline once more at the filters it found."""

    t0 = time.perf_counter()
    starts = filter_starts(problem)
    scanned = scan_filters(problem, design_scenarios(problem))
    starts += [values for _, values in scanned if values not in starts]
    tried = [(values, _robust(with_filter_values(problem, values), method, max_rounds, say)) for values in starts]

    def bw(r):
        return r.evaluation.worst_bandwidth_hz if r.status == "optimal" and r.evaluation is not None else -1.0

    joint: list[JointExact] = []
    if method == "ccp+exact":
        designed = [vr for vr in tried if bw(vr[1]) > 0 and any(
            v is not None and f.designed for v, f in zip(vr[0], problem.controller.filters))]
        with_filters = sorted(designed, key=lambda vr: -bw(vr[1]))
        for values, r in with_filters[:2]:
            p = with_filter_values(problem, values)
            ex = exact_design(p, design_scenarios(p), r.evaluation.controller, design_filters=True,
                              high_circle=True)
            found_bw = None
            if ex.success:
                found = list(ex.filter_values)
                tried.append((found, _robust(with_filter_values(problem, found), method, max_rounds, say)))
                found_bw = bw(tried[-1][1])
            joint.append(JointExact(tuple(values), ex.note, tuple(ex.filter_values), found_bw))
    values, best = max(tried, key=lambda vr: bw(vr[1]))
    kinds = [ChosenFilter(f.kind, v is not None, dict(v or {}), tuple(sorted(f.ranges)))
             for f, v in zip(problem.controller.filters, values)]
    record = replace(best.record, filter_scan=tuple(FilterTrial(tuple(v), b) for b, v in scanned),
                     filter_starts=tuple(FilterTrial(tuple(v), bw(r), r.status) for v, r in tried[:len(starts)]),
                     joint_exact=tuple(joint))
    return replace(best, seconds=time.perf_counter() - t0, filters=tuple(kinds), record=record)


def _synthesise(problem: LoopProblem, method: str, max_rounds: int, extra: list[ScenarioPoint],
                seed: int, say: Callable[[str], None]) -> SynthesisResult:
    check_supported(problem)
    if method not in ("ccp", "ccp+exact"):
        raise SpecError(f"method must be 'ccp' or 'ccp+exact', got {method!r}")
    if not any(e in PHASE_LIMITING for e in problem.plant.effects):
        b, names = baselines(problem)
        return SynthesisResult("unbounded", unbounded_message(problem), None, None, method, 0.0, b, names,
                               record=SolverRecord(missing_effects=tuple(PHASE_LIMITING)))
    say("loading cvxpy and casadi")
    i0 = time.perf_counter()
    import casadi  # noqa: F401  (the one-off imports are timed apart from the solve)
    import cvxpy  # noqa: F401

    import_seconds = time.perf_counter() - i0
    t0, c0 = time.perf_counter(), time.process_time()
    points = design_scenarios(problem)
    for row in extra:
        points = points.with_row(row)
    dense = check_scenarios(problem, np.union1d(problem.plant.payload_kg.check_points(),
                                                problem.plant.payload_kg.design_points()))
    tally = _Tally()
    rounds, best_bad, first_scan = 0, None, None
    good: list[tuple[str, Evaluation]] = []
    failed: list[Evaluation] = []
    for rounds in range(1, max_rounds + 1):
        steps = "cvxpy+Clarabel, casadi+IPOPT" if method == "ccp+exact" else "cvxpy+Clarabel"
        say(f"design on {len(points)} scenarios: gain scan, {steps}")
        cands, scan = _solve(problem, points, dense, method, tally)
        first_scan = first_scan or (scan, points)
        evs = [(label, ev or evaluate(problem, c, dense)) for label, c, ev in cands]
        good += [(label, ev) for label, ev in evs if ev.meets]
        bad = [(label, ev) for label, ev in evs if not ev.meets]
        failed += [ev for _, ev in bad if ev.stable]
        if bad:
            least = max(bad, key=lambda b: b[1].min_relative_slack)
            best_bad = least if best_bad is None or least[1].min_relative_slack > best_bad[1].min_relative_slack \
                else best_bad
        # systune-like: while the fastest candidate fails the dense check, add its worst violator
        top = max(evs, key=lambda e: e[1].worst_bandwidth_hz if e[1].stable else -1.0)[1] if evs else None
        best_good = max((ev.worst_bandwidth_hz for _, ev in good), default=-1.0)
        if top is None or top.meets or top.worst_bandwidth_hz <= best_good:
            if good:
                break
            top = best_bad[1] if best_bad else None
        if top is None or top.binding.payload_kg is None or points.contains(top.worst_scenario):
            break
        points = points.with_row(top.worst_scenario)
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    record = SolverRecord(
        cpu_seconds=cpu, import_seconds=import_seconds, rounds=rounds, scan_designs=tally.scan_designs,
        lp_solves=tally.lp_solves, exact_starts=tuple(tally.exact_starts) if tally.exact_starts else None,
        solver_ccp="cvxpy+CLARABEL", solver_exact="casadi+IPOPT" if method == "ccp+exact" else None,
        dense_check=f"{len(dense)} scenarios ({np.unique(dense.payload_kg).size} payloads"
                    + (f" x {len(dense) // np.unique(dense.payload_kg).size} parameter sets: corners and "
                       "seeded draws of plant.uncertainty" if dense.parameters else "")
                    + "), cubic-refined grid margins (design.loop.fast)")
    base, names = baselines(problem)
    pts = tuple(float(p) for p in np.unique(points.payload_kg))
    if not good:
        scan, scanned = first_scan
        if scan.screened:
            scan = scan_gains(problem, scanned.plants(problem.plant.plant()).frd(W_OPT))
        d = scan.diagnose(scanned)
        what, where, slack = d.binding.constraint.replace("_", " "), d.where, d.binding.relative_slack
        short = (f"kp = {d.kp:.4g}, ki = {d.ki:.4g} miss it by {-100 * slack:.1f} %"
                 if slack > -1 else f"the closed loop is unstable, e.g. kp = {d.kp:.4g}, ki = {d.ki:.4g}")
        message = (f"no gains within the controller bounds meet the requirements at {where}: the {what} falls short "
                   f"there even for the gains best for that payload alone ({short})" if d.alone else
                   f"each payload alone can meet the requirements, but no single pair of gains within the controller "
                   f"bounds meets them at every payload: the {what} at {where} binds (the least violating gains "
                   f"{short})")
        ev = evaluate(problem, PI(d.kp, d.ki), dense)
        return SynthesisResult("infeasible", message, ev, None, method, seconds, base, names, pts, record,
                               diagnosis=d)
    # designs that agree to 9 digits are one design, named after the first candidate that found it
    good.sort(key=lambda g: -float(f"{g[1].worst_bandwidth_hz:.9g}"))
    faster = [ev for ev in failed if ev.worst_bandwidth_hz > good[0][1].worst_bandwidth_hz]
    if faster:      # a faster candidate that fails the check shows room the best passing one leaves
        outer = max(faster, key=lambda e: e.worst_bandwidth_hz)
        polished, evaluations = polish(problem, good[0][1], dense, outer=outer)
        record = replace(record, polish_evaluations=evaluations)
        if polished.worst_bandwidth_hz > good[0][1].worst_bandwidth_hz:
            good.insert(0, (f"polished on the dense check from {good[0][0]}", polished))
    say("independent check of the design (python-control)")
    t1 = time.perf_counter()
    tried = []
    for label, ev in good[:3]:      # the best verified of the three best candidates
        v = verify(problem, ev.controller, verification_scenarios(points, dense, ev),
                   claimed_worst_bandwidth_hz=ev.worst_bandwidth_hz)
        tried.append(VerifiedCandidate(label, v.verified))
        if v.verified:
            break
    record = replace(record, verification_seconds=time.perf_counter() - t1, chosen=label,
                      verified_candidates=tuple(tried),
                      candidates=tuple(Candidate(lb, e.controller.kp, e.controller.ki, e.worst_bandwidth_hz)
                                       for lb, e in good))
    if not v.verified:
        return SynthesisResult("infeasible", "the optimised designs failed the independent check: "
                               + "; ".join(v.failures[:3]), ev, v, method, seconds, base, names, pts, record)
    req_bw = problem.requirements.min_bandwidth_hz
    if req_bw is not None and ev.worst_bandwidth_hz < req_bw:
        i = int(np.argmin(ev.bandwidth_hz))
        b = ev.binding
        where = "" if b.payload_kg is None else f" at {b.payload_kg:.1f} kg"
        return SynthesisResult(
            "infeasible", f"the best worst-case bandwidth is {ev.worst_bandwidth_hz:.2f} Hz at {ev.payload_kg[i]:.1f} "
            f"kg (kp = {ev.controller.kp:.4g}, ki = {ev.controller.ki:.4g}), below requirements.min_bandwidth_hz = "
            f"{req_bw:g}; "
            f"the {b.constraint.replace('_', ' ')}{where} "
            "limits it", ev, v, method, seconds, base, names, pts, record)
    discrete = None
    if problem.controller.loop_rate_hz is not None:
        discrete = _discrete(problem, ev, points, dense)
        if not discrete[1].verified:
            return SynthesisResult("infeasible", "the discrete loop at controller.loop_rate_hz misses the "
                                   "requirements: " + "; ".join(discrete[1].failures[:3]), ev, v, method, seconds,
                                   base, names, pts, record, discrete=discrete)
    say("search between the dense check's points")
    between = search_pi_between(problem, ev.controller, dense)
    if between is not None and not between.holds:
        return SynthesisResult("infeasible", f"verified on the {len(points)} design scenarios ({label}), but between "
                               f"the dense check's points the requirements fail (least relative slack "
                               f"{between.slack:.3g} at {describe_row(between.scenario)})", ev, v, method, seconds,
                               base, names, pts, record, discrete=discrete, between=between)
    if not dense.parameters:
        return SynthesisResult("optimal", f"verified ({label})", ev, v, method, seconds, base, names, pts, record,
                               discrete=discrete, between=between)
    say("Monte Carlo check over the uncertainty")
    mc = monte_carlo_check(problem, ev.controller, seed=seed)
    record = replace(record, design_scenarios=len(points))
    if mc.violations:
        return SynthesisResult("infeasible", f"verified on the {len(points)} design scenarios ({label}), but "
                               f"{mc.violations} of {mc.samples} Monte Carlo draws over the uncertainty violate the "
                               f"requirements (worst at {describe_row(mc.worst_scenario)})", ev, v, method, seconds,
                               base, names, pts, record, monte_carlo=mc, discrete=discrete, between=between)
    return SynthesisResult("optimal", f"verified ({label}) on {len(points)} design scenarios; 0 of {mc.samples} "
                           f"Monte Carlo draws violate (95 % upper bound {100 * mc.rate_upper_bound:.2g} %)", ev, v,
                           method, seconds, base, names, pts, record, monte_carlo=mc, discrete=discrete,
                           between=between)


def _discrete(problem: LoopProblem, ev: Evaluation, points: Scenarios, dense: Scenarios):
    """The design as the drive runs it at ``controller.loop_rate_hz``, checked with python-control on the
    discrete loop at the payload points (nominal parameters) and the ``DISCRETE_TIGHTEST`` tightest checks."""

    base = problem.plant.plant()
    payloads = np.unique(points.payload_kg)
    rows = Scenarios(payloads, {n: np.full(payloads.size, base.parameters()[n].value) for n in dense.parameters})
    for i in ev.tightest(DISCRETE_TIGHTEST):
        if not rows.contains(dense.row(int(i))):
            rows = rows.with_row(dense.row(int(i)))
    design = discretise(base, ev.controller, problem.controller.loop_rate_hz)
    req = problem.requirements
    check = check_discrete([(rows.describe(k), rows.plant(base, k)) for k in range(len(rows))], design,
                           phase_margin_deg=req.phase_margin_deg, gain_margin_db=req.gain_margin_db)
    return design, check
