"""The convex-concave stage of ``design.synth.pi`` (cvxpy + Clarabel; Hast, Astrom, Bernhardsson & Boyd 2013):
the requirement circles and the bandwidth as reverse-convex constraints replaced by tangent half-planes at
the iterate, an LP per iteration, bisection on the bandwidth target."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from design.problem import LoopProblem
from design.synth.evaluation import MARGIN_HAIR, bandwidth_circle, high_frequency_rows, requirement_circles
from design.synth.scan import W_OPT, Scan

#: bisection on the bandwidth target stops at this ratio; the exact step takes it from there
BISECTION_RATIO = 1.05
#: rows whose point L lies farther than this many radii from its circle's centre are left out of an LP
#: until its solution violates them (a few hundred rows of thousands remain; the re-solves with the violated
#: rows make the result that of the LP on all rows)
SCREEN_RADII = 1.25
#: bandwidth rows further than this above the closest one are left out likewise
SCREEN_GAP = 0.5
#: a left-out row counts as violated below its bound by more than this (relative)
LP_TOLERANCE = 1e-7



class _CCP:
    """Tangent-half-plane LP of the circle constraints. Each LP is solved on the rows near their circles at
    the iterate (``SCREEN_RADII``), and again with every row it violates until it violates none: then it is
    the solution of the LP on all rows (a relaxation whose optimum is feasible for the whole is optimal)."""

    def __init__(self, P: np.ndarray, w: np.ndarray, problem: LoopProblem):
        c = problem.controller
        self.scale = np.array([max(c.kp.max, 1e-9), max(c.ki.max, 1e-9)])
        # L = a kp + b ki per (payload, frequency), flattened
        self.a = P.ravel()
        self.b = (P / (1j * w)).ravel()
        self.wrow = np.broadcast_to(w, P.shape).ravel()
        self.circles = requirement_circles(problem)
        self.bandwidth = bandwidth_circle(problem.requirements.level2)
        self.lo = np.array([c.kp.min, c.ki.min]) / self.scale
        self.lp_solves = 0
        self.hf = None
        hf = high_frequency_rows(problem)
        if hf is not None:      # |kp a + ki b| <= limit: second-order cones, convex as they stand
            _, a, b = hf
            self.hf = (np.column_stack([a.real, b.real]) * self.scale, np.column_stack([a.imag, b.imag]) * self.scale,
                       problem.requirements.max_high_frequency_gain * (1 - MARGIN_HAIR / 100))

    def _rows(self, L0, centre, radius):
        d = np.abs(L0 - centre)
        n = (L0 - centre) / np.maximum(d, 1e-12)
        A = np.column_stack([np.real(np.conj(n) * self.a), np.real(np.conj(n) * self.b)]) * self.scale
        rhs = radius + centre * np.real(n)
        return A, rhs, d <= SCREEN_RADII * radius

    def _lp(self, Am, bm, Ab, bb):
        """max t s.t. Am x >= bm, Ab x - t >= bb, the gain box, t <= 1 (and the noise cones): (x, t) or None."""
        import cvxpy as cp

        x, t = cp.Variable(2), cp.Variable()
        cons = [x >= self.lo, x <= 1.0, t <= 1.0]
        if Am.shape[0]:
            cons.append(Am @ x >= bm)
        if Ab.shape[0]:
            cons.append(Ab @ x - t >= bb)
        if self.hf is not None:
            re, im, lim = self.hf
            cons.append(cp.norm(cp.vstack([re @ x, im @ x]), 2, axis=0) <= lim)
        problem = cp.Problem(cp.Maximize(t), cons)
        problem.solve(solver=cp.CLARABEL)
        self.lp_solves += 1
        if problem.status not in ("optimal", "optimal_inaccurate") or x.value is None:
            return None
        return np.asarray(x.value), float(t.value)

    def solve(self, x0: np.ndarray, w_b: float, *, iterations: int = 30) -> tuple[np.ndarray, float]:
        """CCP from ``x0`` (scaled gains) for bandwidth target ``w_b``; returns (x, t), t >= 0: feasible."""
        x, t_prev, t = x0, -math.inf, -math.inf
        active = self.wrow <= w_b
        for _ in range(iterations):
            L0 = self.a * x[0] * self.scale[0] + self.b * x[1] * self.scale[1]
            # radii 0.3 % larger: a hair inside the requirements, so the design meets them on the dense grid
            rows = [self._rows(L0, c, 1.003 * r) for c, r in self.circles]
            Am, bm = np.vstack([r[0] for r in rows]), np.concatenate([r[1] for r in rows])
            keep_m = np.concatenate([r[2] for r in rows])
            Ab, bb, _ = self._rows(L0, *self.bandwidth)
            Ab, bb = Ab[active], bb[active]
            gap = Ab @ x - bb
            keep_b = gap <= (np.min(gap, initial=np.inf) + SCREEN_GAP)
            while True:
                sol = self._lp(Am[keep_m], bm[keep_m], Ab[keep_b], bb[keep_b])
                if sol is None:
                    return x, -math.inf
                x_new, t = sol
                tol = LP_TOLERANCE * (1 + np.abs(bm))
                miss_m = ~keep_m & (Am @ x_new < bm - tol)
                miss_b = ~keep_b & (Ab @ x_new - t < bb - LP_TOLERANCE * (1 + np.abs(bb)))
                if not (miss_m.any() or miss_b.any()):
                    break
                keep_m |= miss_m
                keep_b |= miss_b
            x = x_new
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
