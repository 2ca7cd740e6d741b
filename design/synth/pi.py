"""PI gain synthesis: maximise the worst-case closed-loop bandwidth over the payload range
subject to phase- and gain-margin requirements at every payload, then verify independently.

The loop L_m(jw) = P_m(jw) (kp + ki/jw) is affine in (kp, ki) for every payload m, so plants
may be models or measured responses. The pipeline (``synthesise_pi``):

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
   plant's parameters (``_casadi_frd``). The first crossings are tracked; a resonance may cross
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
from dataclasses import dataclass, field, replace

import numpy as np

from design.loop.discrete import DiscreteCheck, DiscreteDesign
from design.loop.fast import F_LOW_HZ, fast_analyse_loop
from design.loop.margins import closed_loop_bandwidth_hz, loop_margins, nyquist_stable
from design.problem import LoopProblem
from design.synth.filter_scan import scan_filters
from design.synth.monte_carlo import MonteCarloCheck, monte_carlo_check
from design.synth.scenarios import Scenarios, check_scenarios, describe_row, design_scenarios
from design.synth.solvers import raise_if_interrupted
from design.synth.verify import Verification, verify
from plant.errors import SpecError
from plant.grid import log_grid_rad_s
from plant.physics.algebra import CASADI, Pair
from plant.physics.drive_filters import FILTERS, KINDS
from plant.physics.effects import EFFECTS
from plant.physics.models import Plant

#: effects that limit the achievable bandwidth (phase lag growing with frequency)
PHASE_LIMITING = tuple(n for n, cls in EFFECTS.items() if cls.limits_bandwidth and cls.in_synthesis and cls.searched)
UNSUPPORTED = tuple(n for n, cls in EFFECTS.items() if not cls.in_synthesis)


#: constraint grid of the scan and the optimisation: 1 mHz - 10 kHz, 40 points per decade
W_OPT = log_grid_rad_s(1e-3, 1.0e4, 281)
THESIS_GAINS = (236.0, 47.0)


#: the solvers aim this far inside the requirements (deg, dB) so the design meets them on the checks
MARGIN_HAIR = 0.01


#: scan grid size per gain
SCAN_POINTS = 20


#: bisection on the bandwidth target stops at this ratio; the exact step takes it from there
BISECTION_RATIO = 1.05


#: exact (IPOPT) starts besides the ccp design
EXTRA_STARTS = 1


#: check scenarios with the least slack verified with python-control beside the design scenarios
VERIFY_TIGHTEST = 40


#: the noise limit is checked on this many frequencies from ``requirements.high_frequency_hz`` up to HF_TOP_HZ
HF_POINTS = 120
HF_TOP_HZ = 20_000.0


#: check scenarios with the least slack on which the discrete loop is checked beside the payload points
DISCRETE_TIGHTEST = 8


#: dense-check evaluations the local polish may spend, and its bisection steps towards a faster design
POLISH_EVALUATIONS = 80
POLISH_BISECTIONS = 8


#: Monte Carlo checks that may add their worst violator to the design scenarios
MONTE_CARLO_ROUNDS = 2


#: a gain within this relative distance of its upper bound is "on the bound"
ON_BOUND = 1e-3


#: requirements within this relative slack of their limit are listed as active
ACTIVE = 5e-3


# --- evaluation ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Evaluation:
    """Gains evaluated on a set of scenarios (cubic-refined grid margins of ``design.loop.fast``); the
    per-payload arrays are the worst over the scenarios of each payload."""

    kp: float
    ki: float
    payload_kg: np.ndarray
    bandwidth_hz: np.ndarray
    phase_margin_deg: np.ndarray
    gain_margin_db: np.ndarray
    meets: bool
    #: every scenario's closed loop stable (PM > 0 and GM > 0 for this stable open loop)
    stable: bool
    worst_bandwidth_hz: float
    #: the tightest requirement, or a gain's upper bound: {"constraint", "payload_kg", "slack", "active"},
    #: with "scenario" (the uncertain parameters' values there) when the problem has uncertainty
    binding: dict
    #: the smallest slack of any requirement relative to the requirement (negative: violated)
    min_relative_slack: float
    #: the scenario where the tightest requirement binds (payload_kg and the uncertain parameters)
    worst_scenario: dict = field(default_factory=dict)
    #: per scenario: the least relative slack of any requirement, and the bandwidth (Hz; 0: below the grid)
    row_relative_slack: np.ndarray = field(default_factory=lambda: np.zeros(0))
    row_bandwidth_hz: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def tightest(self, k: int) -> np.ndarray:
        """Rows of the ``k`` scenarios with the least slack, and the one with the lowest bandwidth."""
        return np.union1d(np.argsort(self.row_relative_slack, kind="stable")[:k], [np.argmin(self.row_bandwidth_hz)])


def evaluate(problem: LoopProblem, kp: float, ki: float, scenarios: Scenarios | None = None) -> Evaluation:
    """Margins and bandwidth of (kp, ki) on every scenario (default: the check scenarios)."""
    s = check_scenarios(problem) if scenarios is None else scenarios
    plant = s.plants(problem.plant.plant())
    req = problem.requirements
    n = fast_analyse_loop(plant, kp, ki, level2=req.level2)
    pm, gm = np.ravel(n.phase_margin_deg), np.ravel(n.gain_margin_db)
    # a bandwidth at the grid's lowest frequency is below the grid: unknown, counted as 0
    bw = np.ravel(np.where(n.closed_loop_bandwidth_hz > 1.01 * F_LOW_HZ, n.closed_loop_bandwidth_hz, 0.0))
    slack = {"phase_margin": pm - req.phase_margin_deg,
             "gain_margin": np.where(np.isfinite(gm), gm - req.gain_margin_db, np.inf)}
    scale = {"phase_margin": max(req.phase_margin_deg, 1.0), "gain_margin": max(req.gain_margin_db, 1.0)}
    if req.peak_sensitivity is not None or req.disk_margin is not None:
        from design.loop.analysis import analyse_loop

        margins = analyse_loop(plant, kp, ki).margins
        if req.peak_sensitivity is not None:
            slack["peak_sensitivity"] = req.peak_sensitivity - np.ravel(margins.peak_sensitivity)
            scale["peak_sensitivity"] = req.peak_sensitivity
        if req.disk_margin is not None:
            slack["disk_margin"] = np.ravel(margins.disk_margin) - req.disk_margin
            scale["disk_margin"] = req.disk_margin
    stable = bool(np.all(n.stable) and np.all(pm > 0) and np.all(gm > 0))
    hf = high_frequency_gain(problem, kp, ki)
    if hf is not None:
        slack["high_frequency_gain"] = np.full(len(s), req.max_high_frequency_gain - hf)
        scale["high_frequency_gain"] = req.max_high_frequency_gain
    meets = bool(all(np.all(v >= -1e-6) for v in slack.values()) and np.all(bw > 0) and stable)
    rel = {k: float(np.min(v)) / scale[k] for k, v in slack.items()}
    name = min(rel, key=rel.get)
    i = int(np.argmin(slack[name]))
    active = sorted({k for k, v in slack.items() if np.min(v) / scale[k] < ACTIVE})
    worst = s.row(i)
    binding = {"constraint": name, "payload_kg": float(s.payload_kg[i]), "slack": float(slack[name][i]),
               "active": active}
    if s.parameters:
        binding["scenario"] = {k: v for k, v in worst.items() if k != "payload_kg"}
    c = problem.controller
    for gain, value, bound in (("kp", kp, c.kp.max), ("ki", ki, c.ki.max)):
        if meets and value >= bound * (1 - ON_BOUND) and rel[name] > ON_BOUND:
            binding = {"constraint": f"controller.{gain}.max", "payload_kg": None, "slack": 0.0,
                       "active": active + [f"controller.{gain}.max"]}
    m, inverse = np.unique(s.payload_kg, return_inverse=True)
    per = {}
    for key, v in (("bw", np.where(bw > 0, bw, np.nan)), ("pm", pm), ("gm", gm)):
        out = np.full(m.size, np.inf)
        np.minimum.at(out, inverse, np.where(np.isnan(v), -np.inf, v))
        per[key] = np.where(out == -np.inf, np.nan, out)
    row_rel = np.min([v / scale[k] for k, v in slack.items()], axis=0)
    return Evaluation(float(kp), float(ki), m, per["bw"], per["pm"], per["gm"], meets, stable, float(np.min(bw)),
                      binding, rel[name], worst, row_rel, bw)


def margin_circle(phase_margin_deg: float, gain_margin_db: float) -> tuple[float, float]:
    """Centre (real) and radius of the circle through -1/g and e^{j(pi - phi)}."""
    g = 10 ** (gain_margin_db / 20)
    phi = math.radians(phase_margin_deg)
    if abs(1 / g - math.cos(phi)) < 1e-9:   # both points at the same abscissa: use the unit-circle point
        g *= 1.0001
    x0 = (1 - 1 / g**2) / (2 * (1 / g - math.cos(phi)))
    return x0, abs(x0 + 1 / g)


def disk_margin_circle(alpha: float) -> tuple[float, float]:
    """Balanced (skew 0) disk margin >= alpha  <=>  |1/(1+L) - 1/2| <= 1/alpha  <=>  z = 1 + L outside the
    Apollonius circle |z - 2| = k |z|, k = 2/alpha > 1: centre 2/(1 - k^2) - 1 and radius 2k/(k^2 - 1) in L."""
    k = 2.0 / alpha
    return 2.0 / (1 - k**2) - 1.0, 2.0 * k / (k**2 - 1)


def high_frequency_rows(problem: LoopProblem) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(w, a, b) with the controller's response kp a + ki b = (kp + ki/jw) F(jw) at ``HF_POINTS`` frequencies
    from ``requirements.high_frequency_hz`` to ``HF_TOP_HZ`` (or just below the loop rate's Nyquist
    frequency), F the drive filters the plant carries; None without a noise limit."""

    req = problem.requirements
    if req.max_high_frequency_gain is None:
        return None
    top = HF_TOP_HZ if problem.controller.loop_rate_hz is None else 0.49 * problem.controller.loop_rate_hz
    w = 2 * np.pi * np.geomspace(req.high_frequency_hz, max(top, 1.01 * req.high_frequency_hz), HF_POINTS)
    F = np.ones(w.size, complex)
    for e in problem.plant.plant().effects:
        if e.name in FILTERS:
            F = F * e.response(1j * w)
    return w, F, F / (1j * w)


def high_frequency_gain(problem: LoopProblem, kp: float, ki: float) -> float | None:
    """max |(kp + ki/jw) F(jw)| above ``requirements.high_frequency_hz`` (A per m/s), or None."""
    rows = high_frequency_rows(problem)
    return None if rows is None else float(np.max(np.abs(kp * rows[1] + ki * rows[2])))


def bandwidth_circle(level2: float) -> tuple[float, float]:
    """(centre, radius) of the circle outside which |T|^2 = |L/(1 + L)|^2 >= level2 (T(0) = 1):
    |L|^2 >= g |1 + L|^2  <=>  |L - g/(1 - g)| >= sqrt(g)/(1 - g), g = level2 (half power: |L - 1| >= sqrt 2)."""
    return level2 / (1 - level2), math.sqrt(level2) / (1 - level2)


def requirement_circles(problem: LoopProblem) -> list[tuple[float, float]]:
    """(centre, radius) of every circle the Nyquist curve must stay outside."""
    req = problem.requirements
    circles = [margin_circle(req.phase_margin_deg, req.gain_margin_db)]
    if req.peak_sensitivity is not None:      # |1 + L| >= 1/Ms
        circles.append((-1.0, 1.0 / req.peak_sensitivity))
    if req.disk_margin is not None:
        circles.append(disk_margin_circle(req.disk_margin))
    return circles


def _gain_grid(lo: float, hi: float, n: int) -> np.ndarray:
    return np.array([hi]) if hi <= lo else np.geomspace(max(lo, hi * 1e-6), hi, n)


@dataclass(frozen=True)


class Scan:
    """A log grid of gains evaluated on ``W_OPT`` at the payload points (linear-interpolated margins)."""

    kp: np.ndarray
    ki: np.ndarray
    #: meets PM, GM (and Ms, disk margin) at every point
    meets: np.ndarray
    worst_bandwidth_hz: np.ndarray
    #: meets the requirements and the Nyquist curves stay outside the requirement circles
    circle_ok: np.ndarray
    #: highest grid frequency (Hz) up to which |L - 1| >= sqrt 2 at every point
    circle_bandwidth_hz: np.ndarray
    #: least requirement slack relative to the requirement (for infeasible problems)
    relative_slack: np.ndarray
    #: relative slack per requirement, each shaped (gains, scenarios)
    slack: dict

    def diagnose(self, scenarios: Scenarios) -> dict:
        """Why nothing on the scan meets the requirements: the payload where the best gains for that
        payload alone fall furthest short, or, when each payload alone is feasible, the conflict."""
        per = np.min(np.array(list(self.slack.values())), axis=0)          # (gains, payloads)
        alone = per.max(axis=0)
        j = int(np.argmin(alone))
        if alone[j] < 0:
            i = int(np.argmax(per[:, j]))
            name = min(self.slack, key=lambda k: self.slack[k][i, j])
            return {"constraint": name, "payload_kg": float(scenarios.payload_kg[j]), "where": scenarios.describe(j),
                    "relative_slack": float(alone[j]), "kp": float(self.kp[i]), "ki": float(self.ki[i]),
                    "alone": True}
        i = int(np.argmax(per.min(axis=1)))
        j = int(np.argmin(per[i]))
        name = min(self.slack, key=lambda k: self.slack[k][i, j])
        return {"constraint": name, "payload_kg": float(scenarios.payload_kg[j]), "where": scenarios.describe(j),
                "relative_slack": float(per[i, j]), "kp": float(self.kp[i]), "ki": float(self.ki[i]), "alone": False}

    def best(self, mask: np.ndarray, score: np.ndarray, k: int = 1) -> list[int]:
        """Indices of the ``k`` best entries of ``score`` under ``mask`` (distinct gains)."""
        idx = np.flatnonzero(mask)
        return [int(i) for i in idx[np.argsort(-score[idx])][:k]]


def scan_gains(problem: LoopProblem, P: np.ndarray, *, n: int = SCAN_POINTS) -> Scan:
    """Evaluate an n x n log grid of (kp, ki) on the responses ``P`` (scenarios x ``W_OPT``)."""
    c, req = problem.controller, problem.requirements
    KP, KI = np.meshgrid(_gain_grid(c.kp.min, c.kp.max, n), _gain_grid(c.ki.min, c.ki.max, n), indexing="ij")
    kp, ki = KP.ravel(), KI.ravel()
    L = P[None] * (kp[:, None, None] + ki[:, None, None] / (1j * W_OPT))
    mg = loop_margins(W_OPT, L)
    bw = closed_loop_bandwidth_hz(W_OPT, L / (1 + L), dc_gain=np.ones(L.shape[:-1]), level2=req.level2)
    # Nyquist: with no open-loop poles in the right half-plane, the phase of 1 + L rises by 0 to 90 deg
    # from the lowest to the highest grid frequency when the closed loop is stable, and falls by 180 deg
    # more per unstable closed-loop pole; an unstable loop's margins are wrapped angles: count PM as 0
    stable = nyquist_stable(L)
    pm = np.where(stable, mg.phase_margin_deg, 0.0)
    slack = {"phase_margin": (pm - req.phase_margin_deg) / max(req.phase_margin_deg, 1.0),
             "gain_margin": np.minimum(mg.gain_margin_db - req.gain_margin_db, 1e3) / max(req.gain_margin_db, 1.0),
             "bandwidth_on_grid": np.where(np.isfinite(bw), 0.0, -1.0)}
    if req.peak_sensitivity is not None:
        slack["peak_sensitivity"] = (req.peak_sensitivity - mg.peak_sensitivity) / req.peak_sensitivity
    if req.disk_margin is not None:
        slack["disk_margin"] = (mg.disk_margin - req.disk_margin) / req.disk_margin
    rel = np.min(np.min(np.array(list(slack.values())), axis=0), axis=-1)
    circle_ok = rel >= 0     # outside the circles, and on the stable side of them
    for centre, radius in requirement_circles(problem):
        circle_ok &= np.all(np.abs(L - centre) >= radius * 1.003, axis=(-2, -1))
    bc, br = bandwidth_circle(req.level2)
    inside = np.abs(L - bc) < br
    inside[..., 0] = False
    first = np.where(inside.any(axis=-1), np.argmax(inside, axis=-1), W_OPT.size - 1)
    circle_bw = W_OPT[np.maximum(np.min(first, axis=-1) - 1, 0)] / (2 * np.pi)
    with np.errstate(invalid="ignore"):
        worst_bw = np.nan_to_num(np.min(bw, axis=-1))
    return Scan(kp, ki, rel >= 0, worst_bw, circle_ok, circle_bw, rel, slack)


# --- convex-concave procedure (cvxpy + Clarabel) -----------------------------------------------


class _CCP:
    """Tangent-half-plane LP of the circle constraints, built once with cvxpy parameters."""

    def __init__(self, P: np.ndarray, w: np.ndarray, problem: LoopProblem):
        import cvxpy as cp

        c = problem.controller
        self.scale = np.array([max(c.kp.max, 1e-9), max(c.ki.max, 1e-9)])
        # L = a kp + b ki per (payload, frequency), flattened
        self.a = P.ravel()
        self.b = (P / (1j * w)).ravel()
        self.wrow = np.broadcast_to(w, P.shape).ravel()
        self.circles = requirement_circles(problem)
        self.bandwidth = bandwidth_circle(problem.requirements.level2)
        self.lp_solves = 0
        n = self.a.size
        nm = n * len(self.circles)
        self.x = cp.Variable(2)
        self.t = cp.Variable()
        self.Am = cp.Parameter((nm, 2))
        self.bm = cp.Parameter(nm)
        self.Ab = cp.Parameter((n, 2))
        self.bb = cp.Parameter(n)
        lo = np.array([c.kp.min, c.ki.min]) / self.scale
        cons = [self.Am @ self.x >= self.bm, self.Ab @ self.x - self.t >= self.bb, self.x >= lo, self.x <= 1.0,
                self.t <= 1.0]
        hf = high_frequency_rows(problem)
        if hf is not None:      # |kp a + ki b| <= limit: second-order cones, convex as they stand
            _, a, b = hf
            re = np.column_stack([a.real, b.real]) * self.scale
            im = np.column_stack([a.imag, b.imag]) * self.scale
            lim = problem.requirements.max_high_frequency_gain * (1 - MARGIN_HAIR / 100)
            cons.append(cp.norm(cp.vstack([re @ self.x, im @ self.x]), 2, axis=0) <= lim)
        self.problem = cp.Problem(cp.Maximize(self.t), cons)

    def _rows(self, L0, centre, radius):
        n = (L0 - centre) / np.maximum(np.abs(L0 - centre), 1e-12)
        A = np.column_stack([np.real(np.conj(n) * self.a), np.real(np.conj(n) * self.b)]) * self.scale
        rhs = radius + centre * np.real(n)
        return A, rhs

    def solve(self, x0: np.ndarray, w_b: float, *, iterations: int = 30) -> tuple[np.ndarray, float]:
        """CCP from ``x0`` (scaled gains) for bandwidth target ``w_b``; returns (x, t), t >= 0: feasible."""
        import cvxpy as cp

        x, t_prev, t = x0, -math.inf, -math.inf
        active = self.wrow <= w_b
        for _ in range(iterations):
            L0 = self.a * x[0] * self.scale[0] + self.b * x[1] * self.scale[1]
            # radii 0.3 % larger: a hair inside the requirements, so the design meets them on the dense grid
            rows = [self._rows(L0, c, 1.003 * r) for c, r in self.circles]
            Am, bm = np.vstack([r[0] for r in rows]), np.concatenate([r[1] for r in rows])
            Ab, bb = self._rows(L0, *self.bandwidth)
            Ab[~active] = 0.0
            bb[~active] = -1e3
            self.Am.value, self.bm.value, self.Ab.value, self.bb.value = Am, bm, Ab, bb
            self.problem.solve(solver=cp.CLARABEL)
            self.lp_solves += 1
            if self.problem.status not in ("optimal", "optimal_inaccurate") or self.x.value is None:
                return x, -math.inf
            x, t = np.asarray(self.x.value), float(self.t.value)
            if t >= 0 or t - t_prev < 1e-3:     # feasible, or stalled below 0
                return x, t
            t_prev = t
        return x, t


@dataclass(frozen=True)


class CCPDesign:
    kp: float
    ki: float
    #: the bandwidth target (Hz) the design was proven feasible for on ``W_OPT`` (0: none)
    target_hz: float
    lp_solves: int


def _circle_bandwidth(P: np.ndarray, w: np.ndarray, gains: np.ndarray, level2: float) -> float:
    """Highest grid frequency (rad/s) below which L stays outside the bandwidth circle at every payload."""
    L = P * (gains[0] + gains[1] / (1j * w))
    bc, br = bandwidth_circle(level2)
    inside = np.abs(L - bc) < br
    inside[..., 0] = False
    first = np.where(inside.any(axis=-1), np.argmax(inside, axis=-1), w.size - 1)
    return float(w[max(int(np.min(first)) - 1, 0)])


def ccp_design(problem: LoopProblem, P: np.ndarray, scan: Scan) -> CCPDesign:
    """Bisection on the bandwidth target (log scale) with the CCP as feasibility test, bracketed by
    the scan: the best circle-feasible seed is feasible at its bandwidth; the circles are
    conservative, so the ccp optimum lies below the best seed meeting the exact requirements
    (up to the scan's resolution, hence the margin of 1.5 and the doubling if it does not)."""
    ok = scan.circle_ok & (scan.circle_bandwidth_hz > W_OPT[0] / (2 * np.pi))
    if ok.any():
        i = scan.best(ok, scan.circle_bandwidth_hz)[0]
        lo = math.log(2 * math.pi * scan.circle_bandwidth_hz[i])
        # two decades below the seed's bandwidth |L| >> 1 lies far outside every circle: leave those rows out
        keep = W_OPT >= math.exp(lo) / 100
        w, P = W_OPT[keep], P[..., keep]
        ccp = _CCP(P, w, problem)
        best = np.array([scan.kp[i], scan.ki[i]]) / ccp.scale
    else:
        w = W_OPT
        ccp = _CCP(P, w, problem)
        c = problem.controller
        x, t = ccp.solve(np.array([max(c.kp.min, 1e-6 * c.kp.max), max(c.ki.min, 1e-6 * c.ki.max)]) / ccp.scale,
                         W_OPT[0])
        if t < 0:
            return CCPDesign(math.nan, math.nan, 0.0, ccp.lp_solves)
        best, lo = x, math.log(w[0])
    top = max(np.max(scan.worst_bandwidth_hz, where=scan.meets, initial=0.0), math.exp(lo) / (2 * np.pi))
    hi = min(math.log(2 * math.pi * 1.5 * top), math.log(W_OPT[-1]))

    def feasible(target):
        """CCP at ``target``; on success move ``lo`` to the bandwidth the design achieves on the grid."""
        nonlocal lo, best
        x, t = ccp.solve(best, math.exp(target))
        if t < 0:
            return False
        best, lo = x, max(target, math.log(_circle_bandwidth(P, w, x * ccp.scale, problem.requirements.level2)))
        return True

    while hi < math.log(W_OPT[-1]) and feasible(hi):          # widen until infeasible
        hi = min(lo + math.log(2.0), math.log(W_OPT[-1]))
    while hi - lo > math.log(BISECTION_RATIO):
        mid = 0.5 * (lo + hi)
        if not feasible(mid):
            hi = mid
    kp, ki = (best * ccp.scale).tolist()
    return CCPDesign(kp, ki, math.exp(lo) / (2 * np.pi), ccp.lp_solves)


# --- exact margins (casadi + IPOPT) ---------------------------------------------------------------


def _casadi_frd(plant: Plant, w):
    """(Re, Im) of P(jw) as casadi expressions of w: the plant's own response formula
    (``Plant.response``) built with casadi arithmetic."""
    out = plant.response(Pair(0.0, w), CASADI)
    return out.re, out.im


def _first_crossing(w, f):
    """w where f changes sign first (linear interpolation in log w), or None."""
    ok = np.isfinite(f[:-1]) & np.isfinite(f[1:])
    s = np.flatnonzero(ok & (np.sign(f[:-1]) != np.sign(f[1:])))
    if s.size == 0:
        return None
    i = s[0]
    lw = np.log(w)
    return float(np.exp(lw[i] + (lw[i + 1] - lw[i]) * f[i] / (f[i] - f[i + 1])))


@dataclass(frozen=True)


class ExactDesign:
    kp: float
    ki: float
    success: bool
    note: str
    #: the designed filters' parameters, one dict per filter of ``problem.controller.filters`` (None: left out)
    filter_values: tuple[dict | None, ...] = ()


def exact_design(problem: LoopProblem, scenarios: Scenarios, kp0: float, ki0: float, *,
                 high_circle: bool = False, design_filters: bool = False) -> ExactDesign:
    """IPOPT on the exact crossings from the start (kp0, ki0); ``high_circle`` also keeps the Nyquist curve
    outside the margin circle above twice the first crossover (see the module doc). ``design_filters``:
    the parameters with ranges of ``problem.controller.filters`` are variables too, started from the values
    the problem's plant carries."""
    import casadi as ca

    from plant.physics.effect_base import replace_unchecked

    req, c = problem.requirements, problem.controller
    g = 10 ** ((req.gain_margin_db + MARGIN_HAIR) / 20)
    cos_phi = math.cos(math.radians(req.phase_margin_deg + MARGIN_HAIR))
    base = problem.plant.plant()
    kps, kis = max(kp0, 1e-9 * c.kp.max, 1e-12), max(ki0, 1e-9 * c.ki.max, 1e-12)
    u = ca.SX.sym("u", 2)           # gains relative to the start
    kp, ki = u[0] * kps, u[1] * kis
    t = ca.SX.sym("t")              # log of the worst-case bandwidth (rad/s)
    xs, x0, lbx, ubx = [u, t], [kp0 / kps, ki0 / kis], [c.kp.min / kps, c.ki.min / kis], [c.kp.max / kps,
                                                                                          c.ki.max / kis]
    # designed filter parameters: x = value / start (depth: the value itself)
    symbolic: dict[str, dict[str, object]] = {}
    variables: list[tuple[int, str, float]] = []
    if design_filters:
        for i, f in enumerate(c.filters):
            name = KINDS[f.kind].name
            start = base.effect(name)
            if start is None:       # left out of this design
                continue
            for field, (lo, hi) in f.ranges.items():
                s0 = float(getattr(start, field))
                scale = 1.0 if field == "depth" or s0 <= 0 else s0
                v = ca.SX.sym(f"{name}_{field}")
                xs.append(v)
                x0.append(s0 / scale)
                lbx.append(lo / scale)
                ubx.append(hi / scale)
                symbolic.setdefault(name, {})[field] = v * scale
                variables.append((i, field, scale))
    gs, lbg, ubg, t_start = [], [], [], []
    P = scenarios.plants(base).frd(W_OPT)
    for k in range(len(scenarios)):
        numeric = scenarios.plant(base, k)
        plant = numeric if not symbolic else replace(numeric, effects=tuple(
            replace_unchecked(e, symbolic[e.name]) if e.name in symbolic else e for e in numeric.effects))
        L0 = P[k] * (kp0 + ki0 / (1j * W_OPT))
        starts = {"c": _first_crossing(W_OPT, np.abs(L0) ** 2 - 1),
                  "p": _first_crossing(W_OPT, np.where(np.real(L0) < 0, np.imag(L0), np.nan)),
                  "b": _first_crossing(W_OPT, np.abs(L0) ** 2 - req.level2 * np.abs(1 + L0) ** 2)}
        for kind, w0 in starts.items():
            if w0 is None:
                continue
            lw = ca.SX.sym(f"lw_{kind}{k}")
            xs.append(lw)
            x0.append(math.log(w0))
            lbx.append(max(math.log(w0) - 1.5, math.log(W_OPT[0])))
            ubx.append(min(math.log(w0) + 1.5, math.log(W_OPT[-1])))
            w = ca.exp(lw)
            pr, pi_ = _casadi_frd(plant, w)
            lr = pr * kp + pi_ * ki / w         # L = P (kp - j ki / w)
            li = pi_ * kp - pr * ki / w
            if kind == "c":
                gs += [lr**2 + li**2 - 1, lr + cos_phi]
                lbg += [0.0, 0.0]
                ubg += [0.0, math.inf]
            elif kind == "p":
                gs += [li, lr + 1 / g]
                lbg += [0.0, 0.0]
                ubg += [0.0, math.inf]
            else:
                g2 = req.level2     # |L|^2 = g2 |1 + L|^2
                gs += [(1 - g2) * (lr**2 + li**2) - 2 * g2 * lr - g2, lw - t]
                lbg += [0.0, 0.0]
                ubg += [0.0, math.inf]
                t_start.append(math.log(w0))
        # sampled circles |L - centre|^2 >= radius^2: Ms and disk margin on W_OPT; the margin circle
        # from twice the first crossover on (resonances can cross again up there: the exact crossings
        # above track only the first ones)
        circles = [(c_, r_, W_OPT) for c_, r_ in requirement_circles(problem)[1:]]
        if high_circle and starts["c"] is not None and 2 * starts["c"] < W_OPT[-1]:
            high = np.geomspace(2 * starts["c"], W_OPT[-1], max(int(100 * np.log10(W_OPT[-1] / starts["c"] / 2)), 2))
            circles.append((*requirement_circles(problem)[0], high))
        rest = replace(numeric, effects=tuple(e for e in numeric.effects if e.name not in symbolic)) \
            if symbolic else None
        for centre, radius, wg in circles:
            if symbolic:    # P = P_0 F(theta): the numeric response without the designed filters, times theirs
                p0 = rest.frd(wg)
                pf = Pair(ca.DM(p0.real), ca.DM(p0.imag))
                for e in plant.effects:
                    if e.name in symbolic:
                        pf = pf * e.response(Pair(0.0, ca.DM(wg)), CASADI)
                cre, cim = kp, -ki / ca.DM(wg)          # kp + ki/(jw) = kp - j ki/w
                re = pf.re * cre - pf.im * cim - centre
                im = pf.re * cim + pf.im * cre
            else:
                a = numeric.frd(wg) if wg is not W_OPT else P[k]
                b = a / (1j * wg)
                re = ca.DM(a.real) * kp + ca.DM(b.real) * ki - centre
                im = ca.DM(a.imag) * kp + ca.DM(b.imag) * ki
            gs.append(re**2 + im**2 - radius**2 * 1.003**2)
            lbg += [0.0] * wg.size
            ubg += [math.inf] * wg.size
    hf = high_frequency_rows(problem)
    if hf is not None:      # the noise limit |(kp + ki/jw) F(jw)|^2 <= limit^2, F symbolic where designed
        w_hf, a, _ = hf
        fixed = np.ones(w_hf.size, complex)
        f_sym = Pair(ca.DM(np.ones(w_hf.size)), ca.DM(np.zeros(w_hf.size)))
        for e in base.effects:
            if e.name in symbolic:
                f_sym = f_sym * replace_unchecked(e, symbolic[e.name]).response(Pair(0.0, ca.DM(w_hf)), CASADI)
            elif e.name in FILTERS:
                fixed = fixed * e.response(1j * w_hf)
        f = f_sym * Pair(ca.DM(fixed.real), ca.DM(fixed.imag))
        cre, cim = kp, -ki / ca.DM(w_hf)
        gs.append((f.re * cre - f.im * cim) ** 2 + (f.re * cim + f.im * cre) ** 2)
        lbg += [0.0] * w_hf.size
        ubg += [(req.max_high_frequency_gain * (1 - MARGIN_HAIR / 100)) ** 2] * w_hf.size
    if not t_start:
        return ExactDesign(kp0, ki0, False, "no bandwidth crossing at the start")
    x0.insert(2, min(t_start))
    lbx.insert(2, math.log(W_OPT[0]))
    ubx.insert(2, math.log(W_OPT[-1]))
    # the vector: the gains, t, the filter variables, then the crossings
    nlp = {"x": ca.vertcat(*xs), "f": -t, "g": ca.vertcat(*gs)}
    solver = ca.nlpsol("exact_pi", "ipopt", nlp, {"print_time": False, "ipopt": {
        "print_level": 0, "sb": "yes", "max_iter": 200, "tol": 1e-9}})
    sol = solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
    stats = raise_if_interrupted(solver)
    x = np.asarray(sol["x"]).ravel()
    # IPOPT may leave a bound by its relaxation (1e-8 relative): clip onto the box
    present = [base.effect(KINDS[f.kind].name) for f in c.filters] if design_filters else []
    values = [None if e is None else {k: float(getattr(e, k)) for k in KINDS[f.kind].bounds}
              for e, f in zip(present, c.filters)]
    for j, (i, field, scale) in enumerate(variables):
        lo, hi = c.filters[i].ranges[field]
        values[i][field] = float(np.clip(x[3 + j] * scale, lo, hi))
    return ExactDesign(float(np.clip(x[0] * kps, c.kp.min, c.kp.max)), float(np.clip(x[1] * kis, c.ki.min, c.ki.max)),
                       bool(stats["success"]), stats["return_status"], tuple(values))


# --- baselines -------------------------------------------------------------------------------


def classical_rule(problem: LoopProblem, *, phase_margin_deg: float = 60.0) -> tuple[float, float]:
    """Single-model rule at the nominal payload: crossover where the plant phase is
    -180 + PM + 5.7 deg, kp = 1/|P| there, PI zero a decade below (costing 5.7 deg)."""
    from design.loop.analysis import ANALYSIS_GRID_RAD_S

    plant = problem.plant.plant()
    P = plant.frd(ANALYSIS_GRID_RAD_S)
    phase = np.degrees(np.unwrap(np.angle(P)))
    target = -180.0 + phase_margin_deg + math.degrees(math.atan(0.1))
    i = int(np.argmax(phase < target)) if np.any(phase < target) else len(P) - 1
    wc = ANALYSIS_GRID_RAD_S[i]
    kp = min(1.0 / abs(P[i]) / math.sqrt(1 + 0.01), problem.controller.kp.max)
    return float(kp), float(min(kp * wc / 10, problem.controller.ki.max))


def baselines(problem: LoopProblem) -> tuple[tuple[Evaluation, ...], tuple[str, ...]]:
    """The thesis gains and the classical single-model rule, evaluated on the problem."""
    kp, ki = classical_rule(problem)
    return ((evaluate(problem, *THESIS_GAINS), evaluate(problem, kp, ki)),
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
    details: dict = field(default_factory=dict)
    #: overrides the evaluation's binding (infeasible problems: from the scan's diagnosis)
    binding: dict | None = None
    #: independent draws over payload x the uncertainty (problems with uncertainty, optimal designs)
    monte_carlo: MonteCarloCheck | None = None
    #: the design at ``controller.loop_rate_hz`` and python-control's check of its discrete loop
    discrete: tuple[DiscreteDesign, DiscreteCheck] | None = None
    #: the drive filters the design runs with: {"kind", parameters..., "designed": [the chosen ones]}
    filters: tuple[dict, ...] = ()
    #: ``requirements.bandwidth_definition`` of every bandwidth reported
    bandwidth_definition: str = "half_power"


def check_supported(problem: LoopProblem) -> None:
    bad = [e for e in problem.plant.effects if e in UNSUPPORTED]
    if bad:
        raise SpecError(f"plant.effects.{bad[0]}: synthesis needs a linear plant without {', '.join(UNSUPPORTED)}; "
                        "design on the linear model and check the effect with gantry simulate")


def unbounded_message(problem: LoopProblem) -> str:
    return ("nothing in the plant limits the bandwidth (plant.effects has none of "
            f"{', '.join(PHASE_LIMITING)}): the loop of a first-order plant with PI control keeps more than 90 deg "
            "of phase margin and an infinite gain margin at any gain, so the optimum is at the gain bounds. Add "
            "the effects that limit a real loop to plant.effects, e.g. delay = { seconds = 0.0005 } and "
            "current_loop = { bandwidth_hz = 1000.0 }.")


def _solve(problem: LoopProblem, scenarios: Scenarios, dense: Scenarios, method: str,
           notes: dict) -> tuple[list[tuple[str, float, float]], Scan]:
    """Candidate designs (label, kp, ki) for the design scenarios: the best scan seeds, the ccp design and
    the exact refinements from the ccp design and the best seeds (method "ccp": the ccp design); and
    the scan."""
    P = scenarios.plants(problem.plant.plant()).frd(W_OPT)
    scan = scan_gains(problem, P)
    notes["scan_designs"] = notes.get("scan_designs", 0) + scan.kp.size
    seeds = scan.best(scan.meets, scan.worst_bandwidth_hz, EXTRA_STARTS)
    if not seeds:   # nothing meets the requirements: start from the least violating gains
        seeds = scan.best(np.ones(scan.kp.size, bool), scan.relative_slack, 1)
    cands = [(f"scan seed {k + 1}", float(scan.kp[i]), float(scan.ki[i])) for k, i in enumerate(seeds)]
    ccp = ccp_design(problem, P, scan)
    notes["lp_solves"] = notes.get("lp_solves", 0) + ccp.lp_solves
    starts = list(cands)
    if math.isfinite(ccp.kp):
        cands.append(("ccp (cvxpy+CLARABEL)", ccp.kp, ccp.ki))
        starts.insert(0, cands[-1])
        if method == "ccp":     # the circle design alone (the seeds only when it failed)
            cands = cands[-1:]
    if method == "ccp+exact":
        def exact(label, kp0, ki0, high):
            ex = exact_design(problem, scenarios, kp0, ki0, high_circle=high)
            name = f"exact (casadi+IPOPT{', high-frequency circle' if high else ''}) from {label}"
            notes.setdefault("exact_starts", []).append({"design": name, "kp0": kp0, "ki0": ki0, "kp": ex.kp,
                                                         "ki": ex.ki, "ipopt": ex.note})
            if ex.success:
                cands.append((name, ex.kp, ex.ki))
                return evaluate(problem, ex.kp, ex.ki, dense).meets
            return False

        met = [exact(*start, False) for start in starts]
        if not any(met):      # e.g. a resonance crossing again above the tracked crossover
            exact(*starts[0], True)
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
    x, best, used = np.log(np.maximum([ev.kp, ev.ki], 1e-12)), ev, 0

    def trial(y):
        nonlocal used
        used += 1
        y = np.clip(y, lo, hi)
        return y, evaluate(problem, *np.exp(y), dense)

    if outer is not None:
        a, b = 0.0, 1.0
        target = np.log(np.maximum([outer.kp, outer.ki], 1e-12))      # a gain of 0: its lower bound
        for _ in range(POLISH_BISECTIONS):
            t = 0.5 * (a + b)
            _, e = trial(x + t * (target - x))
            if e.meets and e.worst_bandwidth_hz > best.worst_bandwidth_hz:
                a, best = t, e
            else:
                b = t
        x = np.log(np.maximum([best.kp, best.ki], 1e-12))
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
                  nominal: bool = False) -> SynthesisResult:
    """Robust PI synthesis on ``problem`` (see the module doc). Never reports an unverified design as optimal.

    With ``plant.uncertainty`` the design holds on every payload point x corner of the uncertainty box
    (and the violators the checks add); the Monte Carlo check then draws independent plants
    (``problem.verification``: how many, the first seed), and while it finds a violator (at most
    ``MONTE_CARLO_ROUNDS`` times) the worst joins the design scenarios and the design is repeated,
    checked again on fresh draws. ``nominal`` ignores the uncertainty (the design for the nominal
    parameters, for comparison)."""
    if nominal:
        problem = replace(problem, plant=replace(problem.plant, uncertainty={}))
    if any(f.designed for f in problem.controller.filters):
        result = _with_designed_filters(problem, method, max_rounds)
    else:
        result = _robust(problem, method, max_rounds)
    return replace(result, bandwidth_definition=problem.requirements.bandwidth_definition)


def _robust(problem: LoopProblem, method: str, max_rounds: int) -> SynthesisResult:
    """The design on the scenarios, repeated with the Monte Carlo check's worst violators added."""
    extra: list[dict] = []
    for k in range(MONTE_CARLO_ROUNDS + 1):
        result = _synthesise(problem, method, max_rounds, extra, problem.verification.seed + k)
        mc = result.monte_carlo
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
    from design.problem import with_filter_values

    if not result.filters:
        return problem
    values = [{k: v for k, v in f.items() if k not in ("kind", "used", "designed")} if f["used"] else None
              for f in result.filters]
    return with_filter_values(problem, values)


def _with_designed_filters(problem: LoopProblem, method: str, max_rounds: int) -> SynthesisResult:
    """PI gains and filter parameters together: for each start of the filters (``filter_starts``) the gains by
    the pipeline (scan, ccp, exact on the gains; the filters fixed, so the loop is affine in the gains), then
    IPOPT on the gains and the filters together (with the margin circle guarding the re-crossings near a
    mode) from the best two starts with filters, and the pipeline once more at the filters it found."""
    from design.problem import with_filter_values

    t0 = time.perf_counter()
    starts = filter_starts(problem)
    scanned = scan_filters(problem, design_scenarios(problem))
    starts += [values for _, values in scanned if values not in starts]
    tried = [(values, _robust(with_filter_values(problem, values), method, max_rounds)) for values in starts]

    def bw(r):
        return r.evaluation.worst_bandwidth_hz if r.status == "optimal" and r.evaluation is not None else -1.0

    notes = {"filter_scan": [{"filters": v, "worst_bandwidth_hz": b} for b, v in scanned],
             "filter_starts": [{"filters": v, "status": r.status, "worst_bandwidth_hz": bw(r)} for v, r in tried],
             "joint_exact": []}
    if method == "ccp+exact":
        designed = [vr for vr in tried if bw(vr[1]) > 0 and any(
            v is not None and f.designed for v, f in zip(vr[0], problem.controller.filters))]
        with_filters = sorted(designed, key=lambda vr: -bw(vr[1]))
        for values, r in with_filters[:2]:
            p = with_filter_values(problem, values)
            ex = exact_design(p, design_scenarios(p), r.evaluation.kp, r.evaluation.ki, design_filters=True,
                              high_circle=True)
            note = {"from": values, "ipopt": ex.note, "filters": list(ex.filter_values)}
            if ex.success:
                found = list(ex.filter_values)
                tried.append((found, _robust(with_filter_values(problem, found), method, max_rounds)))
                note["worst_bandwidth_hz"] = bw(tried[-1][1])
            notes["joint_exact"].append(note)
    values, best = max(tried, key=lambda vr: bw(vr[1]))
    kinds = [{"kind": f.kind, "used": v is not None, **(v or {}), "designed": sorted(f.ranges)}
             for f, v in zip(problem.controller.filters, values)]
    return replace(best, seconds=time.perf_counter() - t0, filters=tuple(kinds),
                   details={**best.details, **notes})


def _synthesise(problem: LoopProblem, method: str, max_rounds: int, extra: list[dict],
                seed: int) -> SynthesisResult:
    check_supported(problem)
    if method not in ("ccp", "ccp+exact"):
        raise SpecError(f"method must be 'ccp' or 'ccp+exact', got {method!r}")
    if not any(e in PHASE_LIMITING for e in problem.plant.effects):
        b, names = baselines(problem)
        return SynthesisResult("unbounded", unbounded_message(problem), None, None, method, 0.0, b, names,
                               details={"missing_effects": list(PHASE_LIMITING)})
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
    notes: dict = {}
    rounds, best_bad, first_scan = 0, None, None
    good: list[tuple[str, Evaluation]] = []
    failed: list[Evaluation] = []
    for rounds in range(1, max_rounds + 1):
        cands, scan = _solve(problem, points, dense, method, notes)
        first_scan = first_scan or (scan, points)
        evs = [(label, evaluate(problem, kp, ki, dense)) for label, kp, ki in cands]
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
        if top is None or top.binding["payload_kg"] is None or points.contains(top.worst_scenario):
            break
        points = points.with_row(top.worst_scenario)
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    details = {"cpu_seconds": cpu, "import_seconds": import_seconds, "rounds": rounds, **notes,
               "solver_ccp": "cvxpy+CLARABEL",
               "solver_exact": "casadi+IPOPT" if method == "ccp+exact" else None,
               "dense_check": f"{len(dense)} scenarios ({np.unique(dense.payload_kg).size} payloads"
                              + (f" x {len(dense) // np.unique(dense.payload_kg).size} parameter sets: corners and "
                                 "seeded draws of plant.uncertainty" if dense.parameters else "")
                              + "), cubic-refined grid margins (design.loop.fast)"}
    base, names = baselines(problem)
    pts = tuple(float(p) for p in np.unique(points.payload_kg))
    if not good:
        d = first_scan[0].diagnose(first_scan[1])
        what, where = d["constraint"].replace("_", " "), d["where"]
        short = (f"kp = {d['kp']:.4g}, ki = {d['ki']:.4g} miss it by {-100 * d['relative_slack']:.1f} %"
                 if d["relative_slack"] > -1 else f"the closed loop is unstable, e.g. kp = {d['kp']:.4g}, "
                                                 f"ki = {d['ki']:.4g}")
        message = (f"no gains within the controller bounds meet the requirements at {where}: the {what} falls short "
                   f"there even for the gains best for that payload alone ({short})" if d["alone"] else
                   f"each payload alone can meet the requirements, but no single pair of gains within the controller "
                   f"bounds meets them at every payload: the {what} at {where} binds (the least violating gains "
                   f"{short})")
        ev = evaluate(problem, d["kp"], d["ki"], dense)
        return SynthesisResult("infeasible", message, ev, None, method, seconds, base, names, pts,
                               {**details, "diagnosis": d},
                               binding={"constraint": d["constraint"], "payload_kg": d["payload_kg"],
                                        "relative_slack": d["relative_slack"]})
    good.sort(key=lambda g: -g[1].worst_bandwidth_hz)
    faster = [ev for ev in failed if ev.worst_bandwidth_hz > good[0][1].worst_bandwidth_hz]
    if faster:      # a faster candidate that fails the check shows room the best passing one leaves
        outer = max(faster, key=lambda e: e.worst_bandwidth_hz)
        polished, evaluations = polish(problem, good[0][1], dense, outer=outer)
        details["polish_evaluations"] = evaluations
        if polished.worst_bandwidth_hz > good[0][1].worst_bandwidth_hz:
            good.insert(0, (f"polished on the dense check from {good[0][0]}", polished))
    t1 = time.perf_counter()
    tried = []
    for label, ev in good[:3]:      # the best verified of the three best candidates
        v = verify(problem, ev.kp, ev.ki, verification_scenarios(points, dense, ev),
                   claimed_worst_bandwidth_hz=ev.worst_bandwidth_hz)
        tried.append({"design": label, "verified": v.verified})
        if v.verified:
            break
    details.update(verification_seconds=time.perf_counter() - t1, chosen=label, verified_candidates=tried,
                   candidates=[{"design": lb, "kp": e.kp, "ki": e.ki, "worst_bandwidth_hz": e.worst_bandwidth_hz}
                               for lb, e in good])
    if not v.verified:
        return SynthesisResult("infeasible", "the optimised designs failed the independent check: "
                               + "; ".join(v.failures[:3]), ev, v, method, seconds, base, names, pts, details)
    req_bw = problem.requirements.min_bandwidth_hz
    if req_bw is not None and ev.worst_bandwidth_hz < req_bw:
        i = int(np.argmin(ev.bandwidth_hz))
        b = ev.binding
        where = "" if b["payload_kg"] is None else f" at {b['payload_kg']:.1f} kg"
        return SynthesisResult(
            "infeasible", f"the best worst-case bandwidth is {ev.worst_bandwidth_hz:.2f} Hz at {ev.payload_kg[i]:.1f} "
            f"kg (kp = {ev.kp:.4g}, ki = {ev.ki:.4g}), below requirements.min_bandwidth_hz = {req_bw:g}; "
            f"the {b['constraint'].replace('_', ' ')}{where} "
            "limits it", ev, v, method, seconds, base, names, pts, details)
    discrete = None
    if problem.controller.loop_rate_hz is not None:
        discrete = _discrete(problem, ev, points, dense)
        if not discrete[1].verified:
            return SynthesisResult("infeasible", "the discrete loop at controller.loop_rate_hz misses the "
                                   "requirements: " + "; ".join(discrete[1].failures[:3]), ev, v, method, seconds,
                                   base, names, pts, details, discrete=discrete)
    if not dense.parameters:
        return SynthesisResult("optimal", f"verified ({label})", ev, v, method, seconds, base, names, pts, details,
                               discrete=discrete)
    mc = monte_carlo_check(problem, ev.kp, ev.ki, seed=seed)
    details["design_scenarios"] = len(points)
    if mc.violations:
        return SynthesisResult("infeasible", f"verified on the {len(points)} design scenarios ({label}), but "
                               f"{mc.violations} of {mc.samples} Monte Carlo draws over the uncertainty violate the "
                               f"requirements (worst at {describe_row(mc.worst_scenario)})", ev, v, method, seconds,
                               base, names, pts, details, monte_carlo=mc, discrete=discrete)
    return SynthesisResult("optimal", f"verified ({label}) on {len(points)} design scenarios; 0 of {mc.samples} "
                           f"Monte Carlo draws violate (95 % upper bound {100 * mc.rate_upper_bound:.2g} %)", ev, v,
                           method, seconds, base, names, pts, details, monte_carlo=mc, discrete=discrete)


def _discrete(problem: LoopProblem, ev: Evaluation, points: Scenarios, dense: Scenarios):
    """The design as the drive runs it at ``controller.loop_rate_hz``, checked with python-control on the
    discrete loop at the payload points (nominal parameters) and the ``DISCRETE_TIGHTEST`` tightest checks."""
    from design.loop.discrete import check_discrete, discretise

    base = problem.plant.plant()
    payloads = np.unique(points.payload_kg)
    rows = Scenarios(payloads, {n: np.full(payloads.size, base.parameters()[n].value) for n in dense.parameters})
    for i in ev.tightest(DISCRETE_TIGHTEST):
        if not rows.contains(dense.row(int(i))):
            rows = rows.with_row(dense.row(int(i)))
    design = discretise(base, ev.kp, ev.ki, problem.controller.loop_rate_hz)
    req = problem.requirements
    check = check_discrete([(rows.describe(k), rows.plant(base, k)) for k in range(len(rows))], design,
                           phase_margin_deg=req.phase_margin_deg, gain_margin_db=req.gain_margin_db)
    return design, check
