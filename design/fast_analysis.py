"""Loop margins and bandwidth of large plant batches: coarse grid plus cubic crossing refinement.

``design.analysis.analyse_loop`` evaluates every plant on the 3000-point default grid and
interpolates crossings linearly. For Monte Carlo batches (tens of thousands of plants) this
module evaluates the loop on a coarse log-uniform grid over the same range (default 40
points per decade, 281 points). Crossings are detected with real arithmetic only (|L|^2
against 1, the sign of Im L, |L|^2 against |1 + L|^2 / 2), and each one is located inside
its grid interval as the root of a cubic Lagrange interpolant through four neighbouring
points of log|L|, phase or log|T| against log w: the interpolation error is O(h^4)
instead of O(h^2), and at 40 points per decade it is about the default grid's own error
(``benchmarks/bench_sweep.py``). The conventions are those of ``design.margins`` (python-
control 0.10 ``stability_margins``): of several crossings the gain margin closest to
0 dB and the phase margin smallest in magnitude are kept; the bandwidth is the first
-3 dB point of T = L/(1 + L); no crossing gives an infinite margin or a nan bandwidth.

Limits: two crossings closer together than one coarse interval (e.g. a dip of |T| below
-3 dB inside a narrow notch) can be missed, and the phase must not turn by more than
180 deg between neighbouring coarse points where a crossing lies.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from design.loops import open_loop_frd
from plant.errors import GridError
from plant.grid import log_grid_rad_s

#: coarse grid density (points per decade) of the fast path
POINTS_PER_DECADE = 40
#: the coarse grid spans the same range as ``design.analysis.ANALYSIS_GRID_RAD_S`` (Hz)
F_LOW_HZ, F_HIGH_HZ = 1e-3, 1e4
_NEWTON_STEPS = 6


@dataclass(frozen=True)
class LoopNumbers:
    """Margins and bandwidth of the velocity loop P (Kp + Ki/s), arrays of the batch shape."""

    closed_loop_bandwidth_hz: np.ndarray
    phase_margin_deg: np.ndarray
    gain_margin_db: np.ndarray
    #: where |L| = 1 (Hz); nan when it never does
    gain_crossover_hz: np.ndarray
    #: where the phase of L crosses -180 deg (Hz); nan when it never does
    phase_crossover_hz: np.ndarray


def coarse_grid_rad_s(points_per_decade: int = POINTS_PER_DECADE) -> np.ndarray:
    """Log-uniform grid from ``F_LOW_HZ`` to ``F_HIGH_HZ`` with ``points_per_decade`` (rad/s)."""
    if points_per_decade < 4:
        raise GridError(f"points_per_decade must be >= 4 for the cubic refinement, got {points_per_decade}")
    decades = np.log10(F_HIGH_HZ / F_LOW_HZ)
    return log_grid_rad_s(F_LOW_HZ, F_HIGH_HZ, int(round(decades * points_per_decade)) + 1)


def _cubic(f: np.ndarray):
    """Coefficients c0..c3 of the cubic in u through values at u = -1, 0, 1, 2 (last axis)."""
    fm, f0, f1, f2 = f[..., 0], f[..., 1], f[..., 2], f[..., 3]
    return (f0, -fm / 3 - f0 / 2 + f1 - f2 / 6, fm / 2 - f0 + f1 / 2, -fm / 6 + f0 / 2 - f1 / 2 + f2 / 6)


def _eval(c, u):
    return c[0] + u * (c[1] + u * (c[2] + u * c[3]))


def _root(c, level, lo):
    """Root of cubic(u) = level for u in [lo, lo + 1], where the endpoints bracket it (Newton, clipped)."""
    f0 = _eval(c, lo) - level
    f1 = _eval(c, lo + 1) - level
    with np.errstate(invalid="ignore", divide="ignore"):
        u = lo + np.clip(np.where(f0 == f1, 0.0, f0 / (f0 - f1)), 0.0, 1.0)
        for _ in range(_NEWTON_STEPS):
            slope = c[1] + u * (2 * c[2] + 3 * u * c[3])
            step = np.where(slope != 0, (_eval(c, u) - level) / slope, 0.0)
            u = np.clip(u - np.nan_to_num(step), lo, lo + 1)
    return u


def _stencils(L: np.ndarray, rows: np.ndarray, k: np.ndarray):
    """Loop values at four neighbouring grid points around interval [k, k + 1] of each row:
    the values (n, 4), the interval's position ``lo`` in stencil coordinates u (nodes at
    u = -1, 0, 1, 2) and the grid index of the node u = 0."""
    start = np.clip(k - 1, 0, L.shape[-1] - 4)
    return L[rows[:, None], start[:, None] + np.arange(4)], (k - start - 1).astype(float), start + 1


def _local_phase_deg(Ls: np.ndarray) -> np.ndarray:
    """Phase of stencil values in degrees, unwrapped locally around the node u = 0."""
    ref = Ls[:, 1:2]
    return np.degrees(np.angle(ref) + np.angle(Ls / ref))


def _pick(rows: np.ndarray, score: np.ndarray, n: int):
    """For each of ``n`` rows, the candidate (index into ``rows``) with the smallest ``score``."""
    order = np.lexsort((score, rows))
    first_rows, first = np.unique(rows[order], return_index=True)
    return first_rows, order[first]


def fast_analyse_loop(plant, kp, ki, *, points_per_decade: int = POINTS_PER_DECADE) -> LoopNumbers:
    """Margins and closed-loop bandwidth of a ``Plant`` (batch) under PI gains ``kp`` (A per m/s) and
    ``ki`` (A per m); agrees with ``design.analysis.analyse_loop`` to about 1e-5 (relative)."""
    w = coarse_grid_rad_s(points_per_decade)
    x = np.log(w)
    h = x[1] - x[0]
    L3 = open_loop_frd(plant, w, kp, ki)
    batch = L3.shape[:-1]
    L = L3.reshape(-1, w.size)
    n = L.shape[0]
    re, im = L.real, L.imag
    mag2 = re * re + im * im

    # gain crossovers |L| = 1 (all of them refined; the phase margin smallest in magnitude is kept)
    above = mag2 > 1.0
    rows, k = np.nonzero(above[:, :-1] != above[:, 1:])
    Ls, lo, node = _stencils(L, rows, k)
    u = _root(_cubic(np.log(np.abs(Ls))), 0.0, lo)
    pm_all = np.remainder(_eval(_cubic(_local_phase_deg(Ls)), u), 360.0) - 180.0
    r, j = _pick(rows, np.abs(pm_all), n)
    pm = np.full(n, np.inf)
    wc = np.full(n, np.nan)
    pm[r] = pm_all[j]
    wc[r] = np.exp(x[node[j]] + u[j] * h) / (2 * np.pi)

    # phase crossovers: Im L changes sign and the phase passes an odd multiple of 180 deg
    # (-180 + 360 j); the gain margin closest to 0 dB is kept
    upper = im > 0
    rows, k = np.nonzero(upper[:, :-1] != upper[:, 1:])
    Ls, lo, node = _stencils(L, rows, k)
    ph = _local_phase_deg(Ls)
    ends = np.take_along_axis(ph, (lo[:, None] + np.array([1, 2])).astype(int), -1)
    level = 180.0 * np.ceil(ends.min(axis=-1) / 180.0)
    odd = np.remainder(level, 360.0) == 180.0
    rows, Ls, lo, node, ph, level = rows[odd], Ls[odd], lo[odd], node[odd], ph[odd], level[odd]
    u = _root(_cubic(ph), level, lo)
    gm_all = -_eval(_cubic(np.log(np.abs(Ls))), u) * 20 / np.log(10)
    r, j = _pick(rows, np.abs(gm_all), n)
    gm = np.full(n, np.inf)
    wpc = np.full(n, np.nan)
    gm[r] = gm_all[j]
    wpc[r] = np.exp(x[node[j]] + u[j] * h) / (2 * np.pi)

    # closed-loop bandwidth: first point where |T| = |L/(1 + L)| < |T(0)|/sqrt 2, i.e.
    # |L|^2 < (|T(0)|^2 / 2) |1 + L|^2; T(0) = 1 with integral action, else |T| at the first point
    one_plus2 = (1 + re) ** 2 + im * im
    dc2 = np.ones((n, 1)) if np.all(np.asarray(ki) > 0) else (mag2 / one_plus2)[:, :1]
    below = mag2 < 0.5 * dc2 * one_plus2
    below[:, 0] = False
    i = np.argmax(below, axis=-1)
    rows = np.nonzero(below[np.arange(n), i])[0]
    Ls, lo, node = _stencils(L, rows, i[rows] - 1)
    Ts = Ls / (1 + Ls)
    u = _root(_cubic(np.log(np.abs(Ts))), 0.5 * np.log(dc2[rows, 0] / 2), lo)
    bw = np.full(n, np.nan)
    bw[rows] = np.exp(x[node] + u * h) / (2 * np.pi)
    return LoopNumbers(*(v.reshape(batch) for v in (bw, pm, gm, wc, wpc)))
