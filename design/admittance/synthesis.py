"""Admittance synthesis: the virtual dynamics 1/(m_v s + b_v) a mouse can push with the least
resistance while the coupled gantry-mouse system keeps its margins (physics and the interaction
loop L = K / (m_v s + b_v): ``design.admittance.model``).

Problem: minimise the peak resistance on a trapezoidal profile, m_v a_pk + b_v v_pk (linear),
over the spec's bounds, subject to, at every design scenario (a payload point with a corner of the
spec's ``plant.uncertainty`` box, ``design.synth.scenarios``), every corner of the mouse ranges
and every frequency of the constraint grid:

* margins: L outside the circle through -1/g and e^{j(pi - phi)} (Hast, Astrom, Bernhardsson
  & Boyd 2013; ``design.synth.pi.margin_circle``): |K - x0 z| >= r |z|, z = b_v + j w m_v;
* force-sensor step to current: |z| >= res |C S| / i_max;
* motor force: F_max |z| >= F_pk |T| |1/G - z|.

Every row is "sqrt(alpha) |A(x)| >= sqrt(beta) |B(x)|" with A, B affine in x = (m_v, b_v):
reverse-convex, so the problem is not convex.

Pipeline (``synthesise_admittance``):

1. **ccp** (cvxpy + Clarabel) from the stiffest allowed dynamics (m_v, b_v at their upper
   bounds, which must pass the exact check, else the spec is infeasible; when they miss the
   conservative circle rows, both formulations stay there and step 3 starts from them): |A| is
   replaced by its tangent Re(conj(A_k) A(x)) / |A_k| <= |A|, an
   inner approximation, so each subproblem is a second-order cone program whose solution is
   feasible; rows are added while any is violated (active set), iterations stop when the cost
   stalls.
2. **ipopt** (casadi) on the same rows in log-ratio form, log m_v and log b_v as variables,
   started from the ccp design (a KKT point of the sampled problem to IPOPT's tolerance); the
   better feasible design of the two formulations is kept. (Starts far from the ccp design,
   e.g. the middle of the box, ended at poor local points in the benchmark: 210 N against
   3.19 N, so they are not used.)
3. **exact polish**: the circle is conservative, so m_v and then b_v are lowered by bisection
   while the exact grid margins (``loop_margins``) and hardware peaks hold at the design scenarios
   (two rounds).
4. **robustness** like systune: the design is checked on 50 payloads x the uncertainty corners x
   every mouse corner on the 3000-point grid (plus the neck modes), with Nyquist stability; the
   worst violating scenario joins the design scenarios and the pipeline repeats.
5. **Monte Carlo** (``design.admittance.monte_carlo``): 10,000 independent draws over payload x
   uncertainty x mouse; the worst violator joins the design scenarios and the pipeline repeats on
   fresh draws (at most ``MONTE_CARLO_ROUNDS`` times).
6. **verification** (``design.admittance.verify``): coupled closed-loop poles and python-control
   margins on the rational model, at the design scenarios and the tightest dense ones.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from design.admittance.model import (
    W_DENSE,
    AdmittanceCheck,
    AdmittanceEvaluator,
    MouseModel,
    admittance_problem,
    gantry_loop,
    interaction_gain,
    mouse_corners,
    peak_resistance_n,
    with_neck_modes,
)
from design.admittance.monte_carlo import AdmittanceMonteCarlo, admittance_monte_carlo
from design.admittance.verify import AdmittanceVerification, verify_admittance
from design.problem import LoopProblem
from design.synth.pi import MONTE_CARLO_ROUNDS, VERIFY_TIGHTEST, margin_circle
from design.synth.scenarios import Scenarios, design_scenarios, grid, parameter_sets, uncertainty_ranges
from design.synth.solvers import raise_if_interrupted
from plant.errors import SpecError
from plant.grid import log_grid_rad_s

#: constraint grid of the optimiser: 10 mHz - 3 kHz, 700 points, plus points around the neck modes
W_DESIGN = log_grid_rad_s(0.01, 3000.0, 700)


#: the optimiser works a hair inside the limits so the design holds on the denser check grid:


#: circle radius x 1.003, hardware limits x 0.997; the exact polish keeps PM + 0.1 deg, GM + 0.05 dB
ROW_HAIR = 0.003
POLISH_HAIR = (0.1, 0.05, 0.002)


#: rows whose slack (log of the ratio of the two sides) is below this join the active set
ACTIVE_SLACK = 0.1
MAX_ACTIVE = 3000
MAX_ROUNDS = 4


# --- constraint rows ---------------------------------------------------------------------------------


@dataclass(frozen=True)


class Rows:
    """Constraints alpha |A|^2 >= beta |B|^2, A = (c1 - c2 b) + j (c3 - c4 m), B = (e1 - e2 b) + j (e3 - e4 m),
    with m = m_v, b = b_v; ``coef`` columns alpha, c1..c4, beta, e1..e4."""

    coef: np.ndarray
    family: np.ndarray    # 0 margin circle, 1 sensor-step current, 2 motor force
    payload: np.ndarray   # kg
    corner: np.ndarray    # index into the mouse corners, -1 for hardware rows
    f_hz: np.ndarray

    def sides(self, m: float, b: float) -> tuple[np.ndarray, np.ndarray]:
        c = self.coef
        return ((c[:, 1] - c[:, 2] * b) + 1j * (c[:, 3] - c[:, 4] * m),
                (c[:, 6] - c[:, 7] * b) + 1j * (c[:, 8] - c[:, 9] * m))

    def slack(self, m: float, b: float) -> np.ndarray:
        """log(alpha |A|^2) - log(beta |B|^2): >= 0 where the row holds."""
        a, bb = self.sides(m, b)
        c = self.coef
        with np.errstate(divide="ignore"):
            return np.log(c[:, 0] * np.abs(a) ** 2) - np.log(c[:, 5] * np.abs(bb) ** 2)

    def take(self, idx) -> Rows:
        return Rows(self.coef[idx], self.family[idx], self.payload[idx], self.corner[idx], self.f_hz[idx])


def build_rows(problem: LoopProblem, scenarios, corners, *, kp: float, ki: float) -> Rows:
    """The sampled constraints at ``scenarios`` (or payloads, kg) x ``corners`` x ``W_DESIGN`` (module
    docstring)."""
    adm = admittance_problem(problem)
    hw = adm.hardware
    loop = gantry_loop(problem, with_neck_modes(W_DESIGN, corners), scenarios, kp=kp, ki=ki)
    w = loop.w_rad_s
    W = np.broadcast_to(w, loop.plant.shape)
    Mk = np.broadcast_to(loop.payload_kg[:, None], W.shape)
    zeros, ones = np.zeros(W.shape), np.ones(W.shape)
    x0, r = margin_circle(adm.phase_margin_deg, adm.gain_margin_db)
    r2 = (r * (1 + ROW_HAIR)) ** 2
    blocks = []
    for k, mouse in enumerate(corners):
        K = interaction_gain(loop, mouse)
        coef = np.stack([ones, K.real, x0 * ones, K.imag, x0 * W, r2 * ones, zeros, -ones, zeros, -W], -1)
        blocks.append((coef.reshape(-1, 10), 0, k))
    rho = hw.force_sensor_resolution_n * np.abs(loop.controller * loop.sensitivity) / (
        hw.max_current_per_sensor_step_a * (1 - ROW_HAIR))
    coef = np.stack([ones, zeros, -ones, zeros, -W, rho**2, ones, zeros, zeros, zeros], -1)
    blocks.append((coef.reshape(-1, 10), 1, -1))
    zg = 1.0 / loop.mobility
    coef = np.stack([(hw.motor_peak_force_n * (1 - ROW_HAIR)) ** 2 * ones, zeros, -ones, zeros, -W,
                     (adm.mouse.peak_force_n * np.abs(loop.complementary)) ** 2, zg.real, ones, zg.imag, W], -1)
    blocks.append((coef.reshape(-1, 10), 2, -1))
    n = W.size
    return Rows(np.concatenate([b[0] for b in blocks]),
                np.concatenate([np.full(n, b[1]) for b in blocks]),
                np.tile(Mk.ravel(), len(blocks)),
                np.concatenate([np.full(n, b[2]) for b in blocks]),
                np.tile(W.ravel(), len(blocks)) / (2 * np.pi))


# --- formulation 1: convex-concave procedure in cvxpy + Clarabel -----------------------------------


def _socp(rows: Rows, x_k: np.ndarray, lo: np.ndarray, hi: np.ndarray, weights: np.ndarray) -> np.ndarray | None:
    """One CCP subproblem: min weights . x s.t. sqrt(beta) |B(x)| <= sqrt(alpha) Re(conj(n) A(x)), n = A(x_k)/|A(x_k)|.
    Variables are scaled by x_k (y = x / x_k); returns x or None when the solver fails."""
    import cvxpy as cp

    c = rows.coef
    a_k, b_k = rows.sides(*x_k)
    n = a_k / np.maximum(np.abs(a_k), 1e-300)
    sa, sb = np.sqrt(c[:, 0]), np.sqrt(c[:, 5])
    # each row divided by its right side at x_k (a positive scale; conditioning for the solver)
    scale = 1.0 / np.maximum(sb * np.abs(b_k), 1e-300)
    sa, sb = sa * scale, sb * scale
    # Re(conj(n) A) = nr (c1 - c2 b) + ni (c3 - c4 m)
    t0 = sa * (n.real * c[:, 1] + n.imag * c[:, 3])
    T = np.column_stack([-sa * n.imag * c[:, 4] * x_k[0], -sa * n.real * c[:, 2] * x_k[1]])
    U = np.column_stack([np.zeros(len(c)), -sb * c[:, 7] * x_k[1]])
    V = np.column_stack([-sb * c[:, 9] * x_k[0], np.zeros(len(c))])
    y = cp.Variable(2)
    cons = [cp.SOC(t0 + T @ y, cp.vstack([sb * c[:, 6] + U @ y, sb * c[:, 8] + V @ y]), axis=0),
            y >= lo / x_k, y <= hi / x_k]
    problem = cp.Problem(cp.Minimize((weights * x_k) @ y), cons)
    try:
        with warnings.catch_warnings():      # "optimal_inaccurate": the caller re-checks every row at the solution
            warnings.simplefilter("ignore", UserWarning)
            problem.solve(solver=cp.CLARABEL)
    except cp.error.SolverError:
        return None
    if problem.status not in ("optimal", "optimal_inaccurate") or y.value is None:
        return None
    return np.asarray(y.value) * x_k


def _nearest(slack: np.ndarray, below: float = ACTIVE_SLACK) -> np.ndarray:
    """The rows with slack below ``below``, at most the ``MAX_ACTIVE`` with the least (rows the
    subproblem then violates are added on top)."""
    near = slack < below
    if near.sum() > MAX_ACTIVE:
        near[:] = False
        near[np.argpartition(slack, MAX_ACTIVE)[:MAX_ACTIVE]] = True
    return near


def ccp_design(rows: Rows, start: np.ndarray, lo, hi, weights, *, iterations: int = 30) -> tuple[np.ndarray, dict]:
    """CCP from the feasible ``start`` (m_v, b_v); every accepted iterate meets every row."""
    x = np.asarray(start, float)
    active = _nearest(rows.slack(*x))
    solves = 0
    for _ in range(iterations):
        for _ in range(20):       # active set: add the rows the subproblem's solution violates most
            x_new = _socp(rows.take(active), x, lo, hi, weights)
            solves += 1
            if x_new is None:
                return x, {"socp_solves": solves, "active_rows": int(active.sum())}
            g = rows.slack(*x_new)
            violated = np.flatnonzero((g < -1e-9) & ~active)
            if not violated.size:
                break
            active[violated[np.argsort(g[violated])[:MAX_ACTIVE]]] = True
        if g.min() < -1e-9:       # still violated: keep the last feasible iterate
            break
        gain = weights @ x - weights @ x_new
        x = x_new
        active |= _nearest(g)
        if gain <= 1e-5 * (weights @ x):
            break
    return x, {"socp_solves": solves, "active_rows": int(active.sum())}


# --- formulation 2: nonlinear program in casadi + IPOPT ----------------------------------------------


def _ipopt(rows: Rows, start, lo, hi, weights) -> np.ndarray:
    """min log(weights . x) over log m_v, log b_v within the bounds s.t. the rows (log-ratio form)."""
    import casadi as ca

    v = ca.MX.sym("v", 2)
    m, b = ca.exp(v[0]), ca.exp(v[1])
    c = [ca.DM(rows.coef[:, i]) for i in range(10)]
    lhs = c[0] * ((c[1] - c[2] * b) ** 2 + (c[3] - c[4] * m) ** 2)
    rhs = c[5] * ((c[6] - c[7] * b) ** 2 + (c[8] - c[9] * m) ** 2)
    solver = ca.nlpsol("admittance", "ipopt",
                       {"x": v, "f": ca.log(weights[0] * m + weights[1] * b), "g": ca.log(lhs) - ca.log(rhs)},
                       {"ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False, "ipopt.max_iter": 300,
                        "ipopt.tol": 1e-10, "ipopt.constr_viol_tol": 1e-10})
    res = solver(x0=np.clip(np.log(start), np.log(lo), np.log(hi)), lbx=np.log(lo), ubx=np.log(hi), lbg=0.0,
                 ubg=np.inf)
    raise_if_interrupted(solver)
    return np.exp(np.asarray(res["x"]).ravel())


def ipopt_design(rows: Rows, start, lo, hi, weights, *, rounds: int = 20) -> np.ndarray:
    """IPOPT on the rows near or past their bound (slack < 0.3), adding the rows its solution
    violates or nears until none is added (the optimum of no rows is the lower corner)."""
    x = np.asarray(start, float)
    active = _nearest(rows.slack(*x), 0.3)
    for _ in range(rounds):
        x = _ipopt(rows.take(active), x, lo, hi, weights) if active.any() else np.asarray(lo, float)
        g = rows.slack(*x)
        add = (g < 0.3) & ~active
        if not add.any():
            break
        idx = np.flatnonzero(add)
        active[idx[np.argsort(g[idx])[:MAX_ACTIVE]]] = True
    return x


# --- exact polish -------------------------------------------------------------------------------------


def _meets_exactly(ev: AdmittanceEvaluator, m: float, b: float) -> bool:
    """Exact grid margins and hardware peaks, a hair inside the requirements (``POLISH_HAIR``)."""
    c = ev.evaluate(m, b, bandwidth=False)
    a, hw = ev.adm, ev.adm.hardware
    d_pm, d_gm, f = POLISH_HAIR
    return bool(np.all(c.phase_margin_deg >= a.phase_margin_deg + d_pm)
                and np.all(c.gain_margin_db >= a.gain_margin_db + d_gm)
                and np.all(c.sensor_current_a <= hw.max_current_per_sensor_step_a * (1 - f))
                and np.all(c.motor_force_n <= hw.motor_peak_force_n * (1 - f)))


def polish(ev: AdmittanceEvaluator, x: np.ndarray, lo, *, rounds: int = 2,
           rtol: float = 1e-3) -> tuple[np.ndarray, int]:
    """Lower m_v, then b_v, by bisection in log while ``_meets_exactly`` holds (x must meet it)."""
    x = np.asarray(x, float).copy()
    evaluations = 0
    for _ in range(rounds):
        for i in (0, 1):
            trial = x.copy()
            trial[i] = lo[i]
            evaluations += 1
            if _meets_exactly(ev, *trial):
                x = trial
                continue
            a, b = math.log(lo[i]), math.log(x[i])      # a fails, b meets
            while b - a > rtol:
                trial[i] = math.exp(0.5 * (a + b))
                evaluations += 1
                if _meets_exactly(ev, *trial):
                    b = math.log(trial[i])
                else:
                    a = math.log(trial[i])
            x[i] = math.exp(b)
    return x, evaluations


# --- result -------------------------------------------------------------------------------------------


@dataclass(frozen=True)


class AdmittanceResult:
    """Chosen virtual dynamics with their dense check and independent verification."""

    status: str                 # "optimal" | "infeasible"
    message: str
    m_v: float
    b_v: float
    kp: float
    ki: float
    peak_resistance_n: float
    check: AdmittanceCheck
    verification: AdmittanceVerification | None
    #: the tightest requirement at the design: {"constraint", "payload_kg", "mouse", "value", "limit", "detail"}
    binding: dict
    active: tuple[str, ...]
    corners: tuple[MouseModel, ...]
    seconds: float
    solver: dict = field(default_factory=dict)
    #: the independent draws over payload x uncertainty x mouse
    monte_carlo: AdmittanceMonteCarlo | None = None
    #: designed for the nominal parameters only (the uncertainty ignored), for comparison
    nominal: bool = False

    @property
    def verified(self) -> bool:
        return bool(self.status == "optimal" and self.verification is not None and self.verification.verified)


_HINTS = {"sensor_current": "allow a larger m_v / b_v, a larger admittance.hardware.max_current_per_sensor_step_a, "
                            "or a finer force sensor",
          "motor_force": "raise admittance.hardware.motor_peak_force_n, lower admittance.mouse.peak_force_n, or "
                         "allow a larger m_v",
          "phase_margin": "allow a larger m_v / b_v, a lower margin requirement, or a better damped velocity loop",
          "gain_margin": "allow a larger m_v / b_v, a lower margin requirement, or a better damped velocity loop",
          "stability": "allow a larger m_v / b_v or a better damped velocity loop"}


def binding_constraint(ev: AdmittanceEvaluator, check: AdmittanceCheck, lo) -> tuple[dict, tuple[str, ...]]:
    """The requirement with the least relative slack at ``check`` (and every one within 1 %, and
    bounds the design sits on)."""
    a, hw = ev.adm, ev.adm.hardware
    slack = {"phase_margin": (check.phase_margin_deg - a.phase_margin_deg) / max(a.phase_margin_deg, 1.0),
             "gain_margin": (check.gain_margin_db - a.gain_margin_db) / max(a.gain_margin_db, 1.0),
             "sensor_current": 1 - check.sensor_current_a / hw.max_current_per_sensor_step_a,
             "motor_force": 1 - check.motor_force_n / hw.motor_peak_force_n}
    least = {k: float(np.min(v)) for k, v in slack.items()}
    active = tuple(k for k in sorted(least, key=least.get) if least[k] < 0.01)
    active += tuple(name for name, x, bound in (("m_v_min", check.m_v, lo[0]), ("b_v_min", check.b_v, lo[1]))
                    if x <= bound * (1 + 1e-9))
    name = min(least, key=least.get)
    idx = np.unravel_index(int(np.argmin(slack[name])), np.shape(slack[name]))
    j = idx[-1]
    mouse = ev.corners[idx[0]] if len(idx) == 2 else None
    mk, where = float(check.payload_kg[j]), check.scenarios.describe(j)
    if name in ("phase_margin", "gain_margin"):
        value = float(getattr(check, f"{name}_{'deg' if name == 'phase_margin' else 'db'}")[idx])
        limit = a.phase_margin_deg if name == "phase_margin" else a.gain_margin_db
        detail = f"interaction-loop {name.replace('_', ' ')} {value:.2f} (required {limit:g}) at {where} with " \
                 f"mouse ({mouse.label()})"
    elif name == "sensor_current":
        value, limit = float(check.sensor_current_a[j]), hw.max_current_per_sensor_step_a
        detail = f"one force-sensor step drives {value:.4g} A (limit {limit:g} A) at {where}, " \
                 f"{check.sensor_peak_hz[j]:.3g} Hz"
    else:
        value, limit = float(check.motor_force_n[j]), hw.motor_peak_force_n
        detail = f"motor force {value:.4g} N (limit {limit:g} N) at {where}, {check.motor_peak_hz[j]:.3g} Hz"
    return ({"constraint": name, "payload_kg": mk, "scenario": check.scenarios.row(j),
             "mouse": None if mouse is None else mouse.as_dict(), "value": value, "limit": limit,
             "detail": detail}, active)


def _gains(problem: LoopProblem, kp, ki) -> tuple[float, float]:
    kp = problem.controller.kp.value if kp is None else kp
    ki = problem.controller.ki.value if ki is None else ki
    for name, v in (("kp", kp), ("ki", ki)):
        if v is None:
            raise SpecError(f"controller.{name}.value is needed for admittance synthesis (or pass {name}=...)")
        if not (math.isfinite(v) and v >= 0):
            raise SpecError(f"controller.{name}: must be finite and >= 0, got {v}")
    return float(kp), float(ki)


def _design(problem: LoopProblem, scenarios: Scenarios, corners, lo, hi, weights, *, kp: float, ki: float,
            notes: dict) -> np.ndarray:
    """Steps 1-3 of the pipeline on ``scenarios``: the best of ccp and ipopt, then the exact polish."""
    rows = build_rows(problem, scenarios, corners, kp=kp, ki=ki)
    x_ccp, info = ccp_design(rows, hi, lo, hi, weights)
    candidates = {"ccp": x_ccp}
    candidates["ipopt from ccp"] = ipopt_design(rows, x_ccp, lo, hi, weights)
    feasible = {k: x for k, x in candidates.items() if rows.slack(*x).min() >= -1e-7}
    # the stiffest dynamics may pass the exact check but not the (conservative) circle rows: then
    # neither formulation moves, and the exact polish starts from them
    best = min(feasible, key=lambda k: weights @ feasible[k]) if feasible else "upper bounds (no circle-feasible point)"
    x = feasible[best] if feasible else np.asarray(hi, float)
    ev = AdmittanceEvaluator(problem, scenarios, W_DESIGN, kp=kp, ki=ki)
    polished, evaluations = polish(ev, x, lo) if _meets_exactly(ev, *x) else (x, 0)
    notes.update({"rows": int(len(rows.family)), **info, "best_formulation": best,
                  "circle_cost_n": {k: float(weights @ x) for k, x in feasible.items()},
                  "exact_polish_evaluations": notes.get("exact_polish_evaluations", 0) + evaluations})
    return polished


def check_scenarios(problem: LoopProblem) -> Scenarios:
    """The dense check: ``DENSE_PAYLOADS`` payloads x the corners of the uncertainty box (the random
    draws of the PI check are left to the Monte Carlo, which also draws the mouse: every scenario
    here is evaluated at every mouse corner on the 3000-point grid)."""
    return grid(problem.plant.payload_kg.check_points(), parameter_sets(uncertainty_ranges(problem), draws=0))


def verification_scenarios(points: Scenarios, check: AdmittanceCheck, adm) -> Scenarios:
    """Where the poles are computed: every dense scenario without uncertainty; else every scenario
    designed for and the ``VERIFY_TIGHTEST`` dense scenarios with the least slack."""
    if not check.scenarios.parameters:
        return check.scenarios
    out = points
    for j in np.argsort(check.slack(adm))[:VERIFY_TIGHTEST]:
        row = check.scenarios.row(int(j))
        if not out.contains(row):
            out = out.with_row(row)
    return out


def synthesise_admittance(problem: LoopProblem, *, kp: float | None = None, ki: float | None = None,
                          nominal: bool = False) -> AdmittanceResult:
    """Choose (m_v, b_v) minimising the peak resistance m_v a_pk + b_v v_pk subject to the
    interaction-loop margins at every design scenario (payload x corners of ``plant.uncertainty``) and
    mouse corner, the motor's peak force and the force-sensor-step current; then the dense check,
    the independent verification and the Monte Carlo check, whose worst violator joins the design
    scenarios (at most ``MONTE_CARLO_ROUNDS`` times). PI gains default to the spec's ``controller``
    values; ``nominal`` ignores the uncertainty (the design for the nominal parameters, for comparison)."""
    t0 = time.perf_counter()
    if nominal:
        problem = replace(problem, plant=replace(problem.plant, uncertainty={}))
    adm = admittance_problem(problem)
    kp, ki = _gains(problem, kp, ki)
    corners = mouse_corners(problem)
    loc = adm.locomotion
    weights = np.array([loc.peak_acceleration_m_per_s2, loc.peak_speed_m_per_s])
    lo, hi = np.array([adm.m_v.min, adm.b_v.min]), np.array([adm.m_v.max, adm.b_v.max])
    dense = AdmittanceEvaluator(problem, check_scenarios(problem), W_DENSE, kp=kp, ki=ki)

    def result(status, message, x, check, verification, binding, active, mc=None, **solver):
        return AdmittanceResult(status, message, float(x[0]), float(x[1]), kp, ki,
                                peak_resistance_n(*x, peak_speed_m_per_s=loc.peak_speed_m_per_s,
                                                  peak_acceleration_m_per_s2=loc.peak_acceleration_m_per_s2),
                                check, verification, binding, active, corners, time.perf_counter() - t0, solver,
                                monte_carlo=mc, nominal=nominal)

    # the stiffest virtual dynamics allowed are the safest: when they fail, nothing in the box passes
    safest = dense.evaluate(*hi)
    if not safest.meets:
        worst = min(safest.violations, key=_relative_slack)
        msg = (f"infeasible: even the stiffest virtual dynamics the spec allows (admittance.m_v.max = {hi[0]:g} kg, "
               f"admittance.b_v.max = {hi[1]:g} N*s/m) fail: {worst['detail']}; {_HINTS[worst['constraint']]}")
        binding = {k: worst[k] for k in ("constraint", "payload_kg", "mouse", "value", "limit", "detail")}
        return result("infeasible", msg, hi, safest, None, binding, (worst["constraint"],), rounds=0)

    scenarios = design_scenarios(problem)
    notes: dict = {}
    for mc_round in range(MONTE_CARLO_ROUNDS + 1):
        x, check, backed_off, rounds = _robust(problem, dense, scenarios, safest, corners, lo, hi, weights,
                                               kp=kp, ki=ki, notes=notes)
        mc = admittance_monte_carlo(problem, kp=kp, ki=ki, m_v=x[0], b_v=x[1],
                                    seed=problem.verification.seed + mc_round)
        if mc.violations == 0 or mc_round == MONTE_CARLO_ROUNDS or scenarios.contains(mc.worst_scenario):
            break
        scenarios = scenarios.with_row(mc.worst_scenario)
    verification = verify_admittance(problem, check, kp=kp, ki=ki,
                                     scenarios=verification_scenarios(scenarios, check, adm))
    binding, active = binding_constraint(dense, check, lo)
    r = peak_resistance_n(*x, peak_speed_m_per_s=loc.peak_speed_m_per_s,
                          peak_acceleration_m_per_s2=loc.peak_acceleration_m_per_s2)
    status = "optimal" if verification.verified and mc.violations == 0 else "infeasible"
    if not verification.verified:
        msg = "NOT verified: " + "; ".join(verification.failures[:3])
    elif mc.violations:
        msg = (f"verified on the {len(scenarios)} design scenarios, but {mc.violations} of {mc.samples} Monte Carlo "
               f"draws over payload, uncertainty and mouse violate the requirements (worst at "
               f"{_describe(mc.worst_scenario)}, mouse {_describe_mouse(mc.worst_mouse)})")
    else:
        msg = (f"verified on {len(scenarios)} design scenarios; 0 of {mc.samples} Monte Carlo draws over payload, "
               f"uncertainty and mouse violate (95 % upper bound {100 * mc.rate_upper_bound:.2g} %)")
    if r > adm.mouse.peak_force_n:
        msg += (f"; note: the resistance on the locomotion profile ({r:.3g} N) exceeds the mouse's peak force "
                f"({adm.mouse.peak_force_n:g} N), so the mouse cannot perform that profile")
    return result(status, msg, x, check, verification, binding, active, mc, rounds=rounds,
                  monte_carlo_rounds=mc_round, design_scenarios=len(scenarios),
                  payload_points=sorted({float(p) for p in scenarios.payload_kg}), backed_off_factor=backed_off,
                  **notes)


def _robust(problem, dense: AdmittanceEvaluator, scenarios: Scenarios, safest: AdmittanceCheck, corners, lo, hi,
            weights, *, kp: float, ki: float, notes: dict):
    """Design on ``scenarios``, the dense check's worst violator joining them round by round; a design
    that still fails is scaled up along the ray to the nearest passing point. Returns (x, check,
    backed-off factor, rounds)."""
    for rounds in range(1, MAX_ROUNDS + 1):
        x = _design(problem, scenarios, corners, lo, hi, weights, kp=kp, ki=ki, notes=notes)
        check = dense.evaluate(*x)
        if check.meets:
            return x, check, 1.0, rounds
        worst = min(check.violations, key=_relative_slack)["scenario"]
        if scenarios.contains(worst):
            break
        scenarios = scenarios.with_row(worst)
    t_lo, t_hi = 0.0, float(np.min(np.log(hi / x)))
    for _ in range(30):
        t = 0.5 * (t_lo + t_hi)
        if dense.evaluate(*(x * math.exp(t)), bandwidth=False).meets:
            t_hi = t
        else:
            t_lo = t
    check = dense.evaluate(*(x * math.exp(t_hi)))
    if check.meets:
        return x * math.exp(t_hi), check, math.exp(t_hi), rounds
    # the ray ends on one bound, short of the stiffest point, which passes
    return np.asarray(hi, float), safest, float("nan"), rounds


def _describe(row: dict) -> str:
    return ", ".join(f"{k} = {v:.4g}" for k, v in row.items())


def _describe_mouse(mouse: dict) -> str:
    return MouseModel(**mouse).label()


def _relative_slack(violation: dict) -> float:
    if violation["constraint"] == "stability":
        return -math.inf
    return (violation["limit"] - violation["value"]) / max(abs(violation["limit"]), 1e-12) * (
        1 if violation["constraint"] in ("sensor_current", "motor_force") else -1)

