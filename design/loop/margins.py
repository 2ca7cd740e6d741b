"""Stability margins and bandwidth from frequency responses, vectorised over a batch.

Every function takes responses shaped ``(..., n_freq)`` on a strictly increasing grid
``w_rad_s`` and returns arrays shaped ``(...)``. Crossings are located between grid points
and refined on the cubic through the four nearest grid points (log-magnitude and unwrapped
phase against log-frequency).
Conventions follow python-control 0.10 ``stability_margins`` so results can be checked
against it: of several crossings, the gain margin is the one closest to 0 dB and the phase
margin the one smallest in magnitude; a margin with no crossing is ``inf``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from plant.errors import GridError
from plant.grid import check_grid


@dataclass(frozen=True)
class Margins:
    """Loop margins of a batch of loops L(jw) (arrays of the batch shape)."""

    gain_margin_db: np.ndarray
    phase_margin_deg: np.ndarray
    #: where the phase crosses -180 deg (Hz); nan when it never does
    phase_crossover_hz: np.ndarray
    #: where |L| crosses 1 (Hz); nan when it never does
    gain_crossover_hz: np.ndarray
    #: balanced (skew 0) disk margin alpha = 1 / max|S - 1/2| (Seiler, Packard & Gahinet 2020)
    disk_margin: np.ndarray
    disk_gain_margin_db: np.ndarray
    disk_phase_margin_deg: np.ndarray
    #: peak sensitivity Ms = max |1 / (1 + L)|
    peak_sensitivity: np.ndarray
    #: closed loop stable by the Nyquist criterion on the grid (``nyquist_stable``; open loops without
    #: unstable poles); the margins of an unstable loop are no guarantee of anything
    closed_loop_stable: np.ndarray
    #: |L| > 1 at the lowest and < 1 at the highest grid frequency: every gain crossover lies on the grid
    crossings_on_grid: np.ndarray


def unwrapped_phase_deg(resp: np.ndarray) -> np.ndarray:
    """Phase in degrees unwrapped along frequency, starting in (-180, 180] at the lowest frequency."""
    return np.degrees(np.unwrap(np.angle(resp), axis=-1))


def sampled_nyquist_stable(loop: np.ndarray) -> np.ndarray:
    """Stability of a discrete-time loop sampled from low frequency up to the Nyquist frequency, where it
    is real (open loop without poles outside the unit circle): the phase of 1 + L changes by -90 to
    +90 deg over the grid and 1 + L > 0 at the Nyquist frequency."""
    a = 1 + np.asarray(loop)
    turn = np.angle(a[..., 1:] / a[..., :-1]).sum(axis=-1)
    return (turn > -math.pi / 4) & (a[..., -1].real > 0)


def nyquist_stable(loop: np.ndarray) -> np.ndarray:
    """Closed-loop stability of loops ``(..., n_freq)`` sampled on a rising grid from where an integrator
    (or the DC gain) dominates to where |L| < 1, for open loops without right-half-plane poles (the
    Nyquist criterion on positive frequencies): stable, the phase of 1 + L changes by -90 to +90 deg
    over the grid; each unstable closed-loop pole takes 180 deg more away. False when |L| >= 1 at the
    top of the grid (the winding is not complete there)."""
    L = np.asarray(loop)
    a = 1 + L
    return (phase_change(a) > -math.pi / 4) & (np.abs(L[..., -1]) < 1)


def phase_change(z: np.ndarray) -> np.ndarray:
    """The change of the phase of ``z`` (..., n) from its first to its last point (rad), unwrapped as
    ``numpy.unwrap`` does (each step taken below pi in magnitude): the principal phases at the ends, and
    2 pi for every step across the negative real axis (Im z changes sign where the step's shorter rotation
    passes pi), so the arctangent is taken at the ends and the crossings only."""
    flat = z.reshape(-1, z.shape[-1])
    low = np.signbit(flat.imag)
    r, i = np.nonzero(low[:, 1:] != low[:, :-1])
    a, b = flat[r, i], flat[r, i + 1]
    cross = a.real * b.imag - a.imag * b.real        # Im(b conj(a)): the sign of the shorter rotation a -> b
    up = low[r, i] & (cross < 0)                     # lower -> upper through pi: the principal phase jumps +2 pi
    down = ~low[r, i] & (cross > 0)                  # upper -> lower through pi: it jumps -2 pi
    wraps = np.bincount(r, weights=up.astype(float) - down, minlength=flat.shape[0])
    ends = np.angle(flat[:, -1]) - np.angle(flat[:, 0])
    return (ends - 2 * math.pi * wraps).reshape(z.shape[:-1])


def _per_row_min(rows: np.ndarray, key: np.ndarray, n_rows: int):
    """For candidates (row, key), the index of the smallest key in each row (first on ties) and a
    mask of the rows that have a candidate."""
    order = np.lexsort((np.arange(rows.size), key, rows))
    rows_sorted = rows[order]
    first = np.flatnonzero(np.r_[True, rows_sorted[1:] != rows_sorted[:-1]]) if rows.size else rows
    chosen = np.full(n_rows, -1)
    chosen[rows_sorted[first]] = order[first]
    return chosen, chosen >= 0


def _stencil(i: np.ndarray, n: int) -> np.ndarray:
    """Indices (k, 4) of the four grid points around each interval [i, i + 1] (shifted inside the grid)."""
    return np.clip(i - 1, 0, n - 4)[:, None] + np.arange(4)


def _cubic(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Newton divided differences (k, 4) of the cubics through the points (x, y), each (k, 4)."""
    c = np.array(y, dtype=float)
    for j in range(1, 4):
        c[:, j:] = (c[:, j:] - c[:, j - 1:-1]) / (x[:, j:] - x[:, :-j])
    return c


def _cubic_at(x: np.ndarray, c: np.ndarray, at: np.ndarray) -> np.ndarray:
    return c[:, 0] + (at - x[:, 0]) * (c[:, 1] + (at - x[:, 1]) * (c[:, 2] + (at - x[:, 2]) * c[:, 3]))


#: the root's tolerance, relative to the grid step, and the most steps (bisection's 44 halvings reach ~6e-14)
ROOT_TOL = 1e-13
ROOT_STEPS = 60


def _root(x: np.ndarray, y: np.ndarray, ia: np.ndarray) -> np.ndarray:
    """Root between stencil nodes ``ia`` and ``ia + 1``, where ``y`` changes sign, of the cubic
    through the four points (x, y); the linear interpolation's root where the cubic is not finite.

    Newton's method on the cubic from the linear root, kept inside the bracket (a step that leaves it bisects
    the bracket instead, so it converges as bisection does at worst), until every step is below ``ROOT_TOL``
    of the bracket (or the rounding of the root itself): the root bisection to that width finds, in a few steps
    instead of 44 (tests)."""
    k = np.arange(x.shape[0])
    a, b, ya, yb = x[k, ia], x[k, ia + 1], y[k, ia], y[k, ia + 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.clip(np.where(ya == yb, 0.0, ya / (ya - yb)), 0.0, 1.0)
    linear = a + t * (b - a)
    if x.shape[1] < 4 or not k.size:
        return linear
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        c = _cubic(x, y)
        ok = np.all(np.isfinite(c), axis=1) & np.isfinite(ya) & np.isfinite(yb)
        fa = np.where(ok, ya, 1.0)
        # the step that counts as converged: ROOT_TOL of the bracket, or the rounding of a root this far out
        tol = np.maximum(ROOT_TOL * np.abs(b - a), 8 * np.finfo(float).eps * np.maximum(np.abs(a), np.abs(b)))
        x0, x1, x2 = x[:, 0], x[:, 1], x[:, 2]
        c0, c1, c2, c3 = c[:, 0], c[:, 1], c[:, 2], c[:, 3]
        at = np.where(ok, linear, a)
        active = ok.copy()             # each root stops where it converged: a batch gives what each row alone gives
        for _ in range(ROOT_STEPS):
            u0, u1 = at - x0, at - x1
            g2 = c2 + (at - x2) * c3
            g1 = c1 + u1 * g2
            f = c0 + u0 * g1
            same = np.sign(f) == np.sign(fa)
            a, fa, b = np.where(same, at, a), np.where(same, f, fa), np.where(same, b, at)
            dx = f / (g1 + u0 * (g2 + u1 * c3))
            done = (np.abs(dx) <= tol) | (f == 0)
            step = np.where(f == 0, at, at - dx)
            nxt = np.where(done | ((step - a) * (step - b) < 0), step, 0.5 * (a + b))
            at = np.where(active, np.minimum(np.maximum(nxt, a), b), at)        # a < b throughout
            active &= ~done
            if not active.any():
                break
    return np.where(ok, at, linear)


def _interpolate(x: np.ndarray, y: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Value at ``at`` of the cubic through the four points (x, y) (linear where that is not finite)."""
    if x.shape[1] < 4:
        t = (at - x[:, 0]) / (x[:, 1] - x[:, 0])
        return y[:, 0] + t * (y[:, 1] - y[:, 0])
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        cubic = _cubic_at(x, _cubic(x, y), at)
        j = np.clip(np.sum(x[:, 1:-1] <= at[:, None], axis=1), 0, x.shape[1] - 2)
        k = np.arange(x.shape[0])
        t = (at - x[k, j]) / (x[k, j + 1] - x[k, j])
        linear = y[k, j] + t * (y[k, j + 1] - y[k, j])
    return np.where(np.isfinite(cubic), cubic, linear)


def loop_margins(w_rad_s, loop, *, sampled: bool = False) -> Margins:
    """Gain, phase and disk margins and peak sensitivity of loops ``loop`` = L(jw), shape (..., n).

    Gain and phase margins as ``crossover_margins``. |S| and |S - 1/2| have their extremes refined
    between grid points on the complex quadratic through L at them and their neighbours (in log w).
    ``sampled``: L is a discrete-time loop on a grid that ends at its Nyquist frequency, where it is real: the
    gain margin is also read there (a real L below -1 / g is a phase crossover the grid's end holds) and the
    stability is the discrete loop's (``sampled_nyquist_stable``).
    """
    w = check_grid(w_rad_s)
    L = np.asarray(loop, dtype=complex)
    if L.shape[-1] != w.size:
        raise GridError(f"loop response has {L.shape[-1]} frequencies but the grid has {w.size}")
    batch = L.shape[:-1]
    L2 = L.reshape(-1, w.size)
    re, im = L2.real, L2.imag
    mag2 = re * re + im * im
    lw = np.log(w)
    gm_db, pm, wpc, wc = _crossovers(lw, L2, mag2)
    # |S| = 1/|1 + L| and |S - 1/2| = |1 - L| / (2 |1 + L|), in real arithmetic
    plus2 = (1.0 + re) ** 2 + im * im
    minus2 = (1.0 - re) ** 2 + im * im
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = minus2 / plus2
        fine = _near(lw, L2, np.argmin(plus2, axis=-1))
        ms = 1.0 / np.sqrt(np.min(np.abs(1.0 + fine) ** 2, axis=-1))
        fine = _near(lw, L2, np.argmax(np.where(np.isnan(ratio), -np.inf, ratio), axis=-1))
        alpha = 2.0 / np.sqrt(np.max(np.abs(1.0 - fine) ** 2 / np.abs(1.0 + fine) ** 2, axis=-1))
    half = alpha / 2
    with np.errstate(divide="ignore", invalid="ignore"):
        dgm = np.where(half < 1, 20 * np.log10((1 + half) / (1 - half)), np.inf)
    dpm = np.degrees(2 * np.arctan(half))
    if sampled:
        end = L2[:, -1].real
        at_nyquist = np.where(end < 0, -20 * np.log10(np.maximum(-end, 1e-300)), np.inf)
        there = np.abs(at_nyquist) < np.abs(gm_db)
        gm_db, wpc = np.where(there, at_nyquist, gm_db), np.where(there, w[-1], wpc)
        stable = sampled_nyquist_stable(L2)
    else:
        stable = nyquist_stable(L2)
    on_grid = (mag2[:, 0] > 1.0) & (mag2[:, -1] < 1.0)
    return Margins(*(x.reshape(batch) for x in (gm_db, pm, wpc / (2 * np.pi), wc / (2 * np.pi), alpha, dgm,
                                                  dpm, ms, stable, on_grid)))


def crossover_margins(w_rad_s, loop) -> tuple[np.ndarray, np.ndarray]:
    """Gain margin (dB) and phase margin (deg) of loops ``loop`` = L(jw), shape (..., n), alone (the part of
    ``loop_margins`` a scan needs).

    Crossings are detected between grid points and refined on the cubic through the four
    nearest points (log|L| and the phase against log w; error O(h^4) in the grid step h,
    against O(h^2) for linear interpolation). The phase is unwrapped locally: the increment
    of an interval is arg(L[i+1]/L[i]), as in ``numpy.unwrap``. Only the intervals that hold
    a crossing are refined, so a large batch costs a few real array operations per point.
    """
    w = check_grid(w_rad_s)
    L = np.asarray(loop, dtype=complex)
    if L.shape[-1] != w.size:
        raise GridError(f"loop response has {L.shape[-1]} frequencies but the grid has {w.size}")
    L2 = L.reshape(-1, w.size)
    gm_db, pm, _, _ = _crossovers(np.log(w), L2, L2.real**2 + L2.imag**2)
    return gm_db.reshape(L.shape[:-1]), pm.reshape(L.shape[:-1])


def _stencil_values(lw: np.ndarray, L2: np.ndarray, mag2: np.ndarray, r: np.ndarray, i: np.ndarray):
    """Log-frequency, log-magnitude and locally unwrapped phase (rad) of rows ``r`` at the stencil of [i, i+1],
    and the position of i in it."""
    n = lw.size
    idx = _stencil(i, n) if n >= 4 else np.stack([i, i + 1], axis=1)
    z = L2[r[:, None], idx]
    with np.errstate(divide="ignore"):
        logmag = 0.5 * np.log(mag2[r[:, None], idx])
    steps = np.angle(z[:, 1:] * np.conj(z[:, :-1]))
    phase = np.angle(z[:, :1]) + np.concatenate([np.zeros((z.shape[0], 1)), np.cumsum(steps, axis=1)], axis=1)
    return lw[idx], logmag, phase, i - idx[:, 0]


def _gain_crossings(lw: np.ndarray, L2: np.ndarray, mag2: np.ndarray):
    """Every gain crossover |L| = 1 of rows L2: (row, log frequency, phase margin deg in (-180, 180])."""
    above = mag2 > 1.0
    r, i = np.nonzero(above[:, :-1] != above[:, 1:])
    x, logmag, phase, ia = _stencil_values(lw, L2, mag2, r, i)
    x_c = _root(x, logmag, ia)
    return r, x_c, np.remainder(np.degrees(_interpolate(x, phase, x_c)), 360.0) - 180.0


def delay_margin_s(w_rad_s, loop) -> np.ndarray:
    """The least extra delay (s) that brings stable loops ``loop`` = L(jw) (..., n) to the stability boundary: at
    each gain crossover the phase a delay must take away to reach -180 deg (the phase margin taken in [0, 360)
    deg, in rad) over its frequency, the least of them; inf without a crossover (crossings refined as
    ``crossover_margins``; for a loop that is already unstable the figure means nothing)."""
    w = check_grid(w_rad_s)
    L = np.asarray(loop, dtype=complex)
    L2 = L.reshape(-1, w.size)
    r, x_c, pm = _gain_crossings(np.log(w), L2, L2.real**2 + L2.imag**2)
    out = np.full(L2.shape[0], np.inf)
    np.minimum.at(out, r, np.radians(np.mod(pm, 360.0)) / np.exp(x_c))
    return out.reshape(L.shape[:-1])


def _crossovers(lw: np.ndarray, L2: np.ndarray, mag2: np.ndarray):
    """(gain margin dB, phase margin deg, phase and gain crossover rad/s) of rows L2 (n_rows, n) on log
    frequencies ``lw``, |L|^2 ``mag2`` (``crossover_margins``)."""
    n_rows = L2.shape[0]

    def stencil(r, i):
        return _stencil_values(lw, L2, mag2, r, i)

    # gain crossovers |L| = 1 -> phase margin; keep the smallest |PM| (python-control convention)
    r, x_c, pm_all = _gain_crossings(lw, L2, mag2)
    k, found = _per_row_min(r, np.abs(pm_all), n_rows)
    pm = np.full(n_rows, np.inf)
    wc = np.full(n_rows, np.nan)
    pm[found] = pm_all[k[found]]
    wc[found] = np.exp(x_c[k[found]])

    # phase crossovers: the phase passes -180 + 360 j (Im L changes sign with Re L < 0) -> gain
    # margin; keep the one closest to 0 dB
    upper = L2.imag > 0
    r, i = np.nonzero(upper[:, :-1] != upper[:, 1:])
    x, logmag, phase, ia = stencil(r, i)
    q = (np.degrees(phase) + 180.0) / 360.0
    rows = np.arange(r.size)
    q0, q1 = q[rows, ia], q[rows, ia + 1]
    cross = np.floor(q0) != np.floor(q1)
    r, x, logmag, ia = r[cross], x[cross], logmag[cross], ia[cross]
    boundary = np.maximum(np.floor(q0), np.floor(q1))[cross]
    x_p = _root(x, q[cross] - boundary[:, None], ia)
    gm_log_all = -_interpolate(x, logmag, x_p)  # ln(1/|L|)
    j, found_g = _per_row_min(r, np.abs(gm_log_all), n_rows)
    gm_db = np.full(n_rows, np.inf)
    wpc = np.full(n_rows, np.nan)
    gm_db[found_g] = gm_log_all[j[found_g]] * 20 / np.log(10)
    wpc[found_g] = np.exp(x_p[j[found_g]])
    return gm_db, pm, wpc, wc


def _near(x: np.ndarray, L: np.ndarray, i: np.ndarray, points: int = 65) -> np.ndarray:
    """L of each row (n_rows, n) at ``points`` log-frequencies from grid point i-1 to i+1, on the complex
    quadratic (Lagrange, in log w) through L there; the grid values themselves are among them."""
    rows = np.arange(L.shape[0])
    j = np.clip(i, 1, L.shape[1] - 2)[:, None]
    x0, x1, x2 = x[j - 1], x[j], x[j + 1]
    t = x0 + (x2 - x0) * np.linspace(0.0, 1.0, points)
    t = np.sort(np.concatenate([t, x1], axis=1), axis=1)
    l0 = (t - x1) * (t - x2) / ((x0 - x1) * (x0 - x2))
    l1 = (t - x0) * (t - x2) / ((x1 - x0) * (x1 - x2))
    l2 = (t - x0) * (t - x1) / ((x2 - x0) * (x2 - x1))
    r = rows[:, None]
    return L[r, j - 1] * l0 + L[r, j] * l1 + L[r, j + 1] * l2


#: closed-loop bandwidth definitions: |T(w_b)|^2 / |T(0)|^2 (half power is |T(0)|/sqrt 2, -3.01 dB;
#: MATLAB's ``bandwidth`` uses -3 dB)
BANDWIDTH_LEVELS2 = {"half_power": 0.5, "minus_3_db": 10 ** (-0.3)}


def closed_loop_bandwidth_hz(w_rad_s, closed_loop, *, dc_gain=None, level2: float = 0.5) -> np.ndarray:
    """First frequency (Hz) where |T|^2 falls below ``level2`` |T(0)|^2 (default half power, |T(0)|/sqrt 2);
    ``nan`` if it never does on the grid, or if |T| is below that level from the lowest grid frequency on.

    ``dc_gain`` is |T(0)|; by default |T| at the lowest grid frequency (pass 1.0 for loops
    with integral action, whose T(0) = 1 exactly). The crossing is refined like those of
    ``loop_margins`` (cubic in log|T| against log w through the four nearest grid points).
    """
    w = check_grid(w_rad_s)
    T = np.asarray(closed_loop, dtype=complex)
    if T.shape[-1] != w.size:
        raise GridError(f"closed-loop response has {T.shape[-1]} frequencies but the grid has {w.size}")
    return first_drop_hz(w, T.real**2 + T.imag**2, None if dc_gain is None else np.asarray(dc_gain, float) ** 2,
                         level2=level2)


def first_drop_hz(w_rad_s: np.ndarray, mag2: np.ndarray, dc_gain2=None, *, level2: float = 0.5) -> np.ndarray:
    """``closed_loop_bandwidth_hz`` from squared magnitudes |T|^2 (and |T(0)|^2) on a checked grid."""
    w = np.asarray(w_rad_s, float)
    n = w.size
    batch = mag2.shape[:-1]
    m2 = mag2.reshape(-1, n)
    dc2 = m2[:, 0] if dc_gain2 is None else np.broadcast_to(np.asarray(dc_gain2, float), batch).reshape(-1)
    level = dc2 * level2
    below = m2 < level[:, None]
    starts_below = below[:, 0].copy()       # below the level from the start (a P-only loop's |T(0)| < 1): nan
    below[:, 0] = False
    i = np.argmax(below, axis=-1)  # first index below the level
    rows = np.flatnonzero(below[np.arange(m2.shape[0]), i] & ~starts_below)
    i0 = i[rows] - 1
    idx = _stencil(i0, n) if n >= 4 else np.stack([i0, i0 + 1], axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        y = np.log(m2[rows[:, None], idx]) - np.log(level[rows])[:, None]
    out = np.full(m2.shape[0], np.nan)
    out[rows] = np.exp(_root(np.log(w)[idx], y, i0 - idx[:, 0])) / (2 * np.pi)
    return out.reshape(batch)
