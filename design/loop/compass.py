"""A compass search on the unit cube, every start's trial points evaluated in one batch: the search between a
design's check points (``design.synth.between`` for the PI loop, ``design.admittance.between`` for the
admittance) finds with it the least slack of a design over the declared box.

From each start, the 2 d points one step along and against each free coordinate (clipped to [0, 1]); a start moves
to its best trial point when that is lower, else halves its step, from ``step`` down to ``tol`` (Kolda, Lewis &
Torczon, "Optimization by direct search", SIAM Review 45 (2003): the compass search, with its convergence to a
stationary point of a smooth function as the step shrinks).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

#: first step and the step the search stops at, as fractions of each coordinate's range; steps at most
STEP = 0.25
STEP_TOL = 2.0 ** -9
MAX_STEPS = 60


@dataclass(frozen=True)
class UnitBox:
    """Named coordinates and their declared ranges, mapped onto the unit cube the search moves in (those in ``log``
    by their logarithm; a coordinate whose range has no extent stays at its one value)."""

    names: tuple[str, ...]
    lo: np.ndarray
    hi: np.ndarray
    log: np.ndarray

    @property
    def free(self) -> np.ndarray:
        """The coordinates with a range to search (indices)."""
        return np.flatnonzero(self.hi > self.lo)

    def _ends(self) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = self.lo.copy(), self.hi.copy()
        lo[self.log], hi[self.log] = np.log(lo[self.log]), np.log(hi[self.log])
        return lo, hi

    def value(self, u: np.ndarray) -> np.ndarray:
        """Rows of coordinates in [0, 1] to values."""
        lo, hi = self._ends()
        x = lo + u * (hi - lo)
        x[..., self.log] = np.exp(x[..., self.log])
        return x

    def unit(self, x: np.ndarray) -> np.ndarray:
        """Rows of values to coordinates in [0, 1] (clipped)."""
        lo, hi = self._ends()
        x = np.array(x, float)
        x[..., self.log] = np.log(x[..., self.log])
        span = np.where(hi > lo, hi - lo, 1.0)
        return np.clip(np.where(hi > lo, (x - lo) / span, 0.0), 0.0, 1.0)


def unit_box(ranges) -> UnitBox:
    """``UnitBox`` of (name, lo, hi, log) rows."""
    names, lo, hi, log = zip(*ranges)
    return UnitBox(tuple(names), np.array(lo, float), np.array(hi, float), np.array(log, bool))


@dataclass(frozen=True)
class CompassResult:
    """Each start's point (rows of unit coordinates), its value and the evaluation's other outputs there."""

    u: np.ndarray
    value: np.ndarray
    extra: tuple[np.ndarray, ...]
    evaluations: int


def compass_search(evaluate: Callable[[np.ndarray], tuple[np.ndarray, ...]], u0: np.ndarray, free: np.ndarray, *,
                   step: float = STEP, tol: float = STEP_TOL, max_steps: int = MAX_STEPS) -> CompassResult:
    """Minimise ``evaluate`` (rows of unit coordinates -> (value per row, other per-row outputs...)) from the starts
    ``u0`` (rows) over the coordinates ``free`` (indices; the others stay as they start)."""
    u = np.array(u0, float)
    value, *extra = (np.array(a) for a in evaluate(u))
    evaluations = len(u)
    steps = np.full(len(u), float(step))
    for _ in range(max_steps):
        trials = [(a, i, sign) for a in np.flatnonzero(steps >= tol) for i in free for sign in (1.0, -1.0)]
        if not trials:
            break
        points = u[[a for a, _, _ in trials]].copy()
        for r, (a, i, sign) in enumerate(trials):
            points[r, i] = min(1.0, max(0.0, points[r, i] + sign * steps[a]))
        tv, *te = (np.asarray(a) for a in evaluate(points))
        evaluations += len(points)
        owner = np.array([a for a, _, _ in trials])
        for a in np.unique(owner):
            mine = np.flatnonzero(owner == a)
            r = mine[np.argmin(tv[mine])]
            if tv[r] < value[a] - 1e-12:
                u[a], value[a] = points[r], tv[r]
                for e, t in zip(extra, te):
                    e[a] = t[r]
            else:
                steps[a] /= 2
    return CompassResult(u, value, tuple(extra), evaluations)
