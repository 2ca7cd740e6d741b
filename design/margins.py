"""Stability margins and bandwidth from frequency responses, vectorised over a batch.

Every function takes responses shaped ``(..., n_freq)`` on a strictly increasing grid
``w_rad_s`` and returns arrays shaped ``(...)``. Crossings are located between grid points
and refined by interpolation (log-magnitude and unwrapped phase linear in log-frequency).
Conventions follow python-control 0.10 ``stability_margins`` so results can be checked
against it: of several crossings, the gain margin is the one closest to 0 dB and the phase
margin the one smallest in magnitude; a margin with no crossing is ``inf``.
"""

from __future__ import annotations

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


def unwrapped_phase_deg(resp: np.ndarray) -> np.ndarray:
    """Phase in degrees unwrapped along frequency, starting in (-180, 180] at the lowest frequency."""
    return np.degrees(np.unwrap(np.angle(resp), axis=-1))


def _per_row_min(rows: np.ndarray, key: np.ndarray, n_rows: int):
    """For candidates (row, key), the index of the smallest key in each row (first on ties) and a
    mask of the rows that have a candidate."""
    order = np.lexsort((np.arange(rows.size), key, rows))
    rows_sorted = rows[order]
    first = np.flatnonzero(np.r_[True, rows_sorted[1:] != rows_sorted[:-1]]) if rows.size else rows
    chosen = np.full(n_rows, -1)
    chosen[rows_sorted[first]] = order[first]
    return chosen, chosen >= 0


def loop_margins(w_rad_s, loop) -> Margins:
    """Gain, phase and disk margins and peak sensitivity of loops ``loop`` = L(jw), shape (..., n).

    Only the grid intervals that contain a crossing are interpolated, so a large batch costs a
    few real array operations per point. Between grid points log|L| and the phase are linear in
    log w; the phase increment of an interval is arg(L[i+1]/L[i]) (as ``numpy.unwrap``).
    """
    w = check_grid(w_rad_s)
    L = np.asarray(loop, dtype=complex)
    if L.shape[-1] != w.size:
        raise GridError(f"loop response has {L.shape[-1]} frequencies but the grid has {w.size}")
    batch = L.shape[:-1]
    L2 = L.reshape(-1, w.size)
    n_rows = L2.shape[0]
    re, im = L2.real, L2.imag
    mag2 = re * re + im * im
    lw = np.log(w)

    def phase_step(r, i):
        """Phase at point i (rad, in (-pi, pi]) and its increment to point i + 1."""
        return np.angle(L2[r, i]), np.angle(L2[r, i + 1] * np.conj(L2[r, i]))

    def log_mag(r, i):
        with np.errstate(divide="ignore"):
            return 0.5 * np.log(mag2[r, i])

    # gain crossovers |L| = 1 -> phase margin; keep the smallest |PM| (python-control convention)
    above = mag2 > 1.0
    r, i = np.nonzero(above[:, :-1] != above[:, 1:])
    a, b = log_mag(r, i), log_mag(r, i + 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.clip(np.where(a == b, 0.0, a / (a - b)), 0.0, 1.0)
    phi, dphi = phase_step(r, i)
    pm_all = np.remainder(np.degrees(phi + t * dphi), 360.0) - 180.0
    k, found = _per_row_min(r, np.abs(pm_all), n_rows)
    pm = np.full(n_rows, np.inf)
    wc = np.full(n_rows, np.nan)
    pm[found] = pm_all[k[found]]
    kf = k[found]
    wc[found] = np.exp(lw[i[kf]] + t[kf] * (lw[i[kf] + 1] - lw[i[kf]]))

    # phase crossovers: the phase passes -180 + 360 j (Im L changes sign with Re L < 0) -> gain
    # margin; keep the one closest to 0 dB
    upper = im > 0
    r, i = np.nonzero(upper[:, :-1] != upper[:, 1:])
    phi, dphi = phase_step(r, i)
    q0 = (np.degrees(phi) + 180.0) / 360.0
    q1 = q0 + np.degrees(dphi) / 360.0
    cross = np.floor(q0) != np.floor(q1)
    r, i, q0, q1 = r[cross], i[cross], q0[cross], q1[cross]
    boundary = np.maximum(np.floor(q0), np.floor(q1))
    with np.errstate(invalid="ignore", divide="ignore"):
        tq = np.clip((q0 - boundary) / (q0 - q1), 0.0, 1.0)
    a, b = log_mag(r, i), log_mag(r, i + 1)
    gm_log_all = -(a + tq * (b - a))  # ln(1/|L|)
    j, found_g = _per_row_min(r, np.abs(gm_log_all), n_rows)
    gm_db = np.full(n_rows, np.inf)
    wpc = np.full(n_rows, np.nan)
    jf = j[found_g]
    gm_db[found_g] = gm_log_all[jf] * 20 / np.log(10)
    wpc[found_g] = np.exp(lw[i[jf]] + tq[jf] * (lw[i[jf] + 1] - lw[i[jf]]))

    # |S| = 1/|1 + L| and |S - 1/2| = |1 - L| / (2 |1 + L|), in real arithmetic
    plus2 = (1.0 + re) ** 2 + im * im
    minus2 = (1.0 - re) ** 2 + im * im
    with np.errstate(divide="ignore", invalid="ignore"):
        ms = 1.0 / np.sqrt(plus2.min(axis=-1))
        alpha = 2.0 / np.sqrt(np.max(minus2 / plus2, axis=-1))
    half = alpha / 2
    with np.errstate(divide="ignore", invalid="ignore"):
        dgm = np.where(half < 1, 20 * np.log10((1 + half) / (1 - half)), np.inf)
    dpm = np.degrees(2 * np.arctan(half))
    return Margins(*(x.reshape(batch) for x in (gm_db, pm, wpc / (2 * np.pi), wc / (2 * np.pi), alpha, dgm,
                                                  dpm, ms)))


def closed_loop_bandwidth_hz(w_rad_s, closed_loop, *, dc_gain=None) -> np.ndarray:
    """First frequency (Hz) where |T| falls below |T(0)|/sqrt(2); ``nan`` if it never does on the grid.

    ``dc_gain`` is |T(0)|; by default |T| at the lowest grid frequency (pass 1.0 for loops
    with integral action, whose T(0) = 1 exactly). The crossing is interpolated with log|T|
    linear in log w.
    """
    w = check_grid(w_rad_s)
    T = np.asarray(closed_loop, dtype=complex)
    if T.shape[-1] != w.size:
        raise GridError(f"closed-loop response has {T.shape[-1]} frequencies but the grid has {w.size}")
    return first_drop_hz(w, T.real**2 + T.imag**2, None if dc_gain is None else np.asarray(dc_gain, float) ** 2)


def first_drop_hz(w_rad_s: np.ndarray, mag2: np.ndarray, dc_gain2=None) -> np.ndarray:
    """``closed_loop_bandwidth_hz`` from squared magnitudes |T|^2 (and |T(0)|^2) on a checked grid."""
    w = np.asarray(w_rad_s, float)
    batch = mag2.shape[:-1]
    m2 = mag2.reshape(-1, w.size)
    dc2 = m2[:, 0] if dc_gain2 is None else np.broadcast_to(np.asarray(dc_gain2, float), batch).reshape(-1)
    level2 = dc2 / 2
    below = m2 < level2[:, None]
    below[:, 0] = False  # the first grid point defines the reference
    i = np.argmax(below, axis=-1)  # first index below the level
    rows = np.arange(m2.shape[0])
    found = below[rows, i]
    i0 = np.maximum(i - 1, 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        x0 = np.log(m2[rows, i0]) - np.log(level2)
        x1 = np.log(m2[rows, i]) - np.log(level2)
        t = np.clip(np.where(x0 == x1, 0.0, x0 / (x0 - x1)), 0.0, 1.0)
    lw = np.log(w)
    lw_c = lw[i0] + t * (lw[i] - lw[i0])
    return np.where(found, np.exp(lw_c) / (2 * np.pi), np.nan).reshape(batch)
