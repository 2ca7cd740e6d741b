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


def _interval_crossings(x: np.ndarray, level: np.ndarray | float = 0.0):
    """Intervals [i, i+1] where x - level changes sign, and the fraction t within each."""
    a = x[..., :-1] - level
    b = x[..., 1:] - level
    hit = (a == 0) | (np.sign(a) != np.sign(b)) & np.isfinite(a) & np.isfinite(b)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(a == b, 0.0, a / (a - b))
    return hit, np.clip(t, 0.0, 1.0)


def _lerp(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    return x[..., :-1] + t * (x[..., 1:] - x[..., :-1])


def unwrapped_phase_deg(resp: np.ndarray) -> np.ndarray:
    """Phase in degrees unwrapped along frequency, starting in (-180, 180] at the lowest frequency."""
    return np.degrees(np.unwrap(np.angle(resp), axis=-1))


def loop_margins(w_rad_s, loop) -> Margins:
    """Gain, phase and disk margins and peak sensitivity of loops ``loop`` = L(jw), shape (..., n)."""
    w = check_grid(w_rad_s)
    L = np.asarray(loop, dtype=complex)
    lw = np.log(w)
    with np.errstate(divide="ignore"):
        logmag = np.log(np.abs(L))
    phase = unwrapped_phase_deg(L)

    # gain crossover(s): |L| = 1 -> phase margin; keep the smallest |PM| (python-control convention)
    hit, t = _interval_crossings(logmag)
    pm_all = np.remainder(_lerp(phase, t), 360.0) - 180.0
    pm_abs = np.where(hit, np.abs(pm_all), np.inf)
    k = np.argmin(pm_abs, axis=-1)[..., None]
    found = np.take_along_axis(hit, k, -1)[..., 0]
    pm = np.where(found, np.take_along_axis(pm_all, k, -1)[..., 0], np.inf)
    wc = np.exp(np.take_along_axis(_lerp(np.broadcast_to(lw, L.shape), t), k, -1)[..., 0])
    wc = np.where(found, wc, np.nan)

    # phase crossover(s): phase = -180 + 360 j -> gain margin; keep the one closest to 0 dB
    q = (phase + 180.0) / 360.0
    fq = np.floor(q)
    cross = fq[..., :-1] != fq[..., 1:]
    boundary = np.maximum(fq[..., :-1], fq[..., 1:])
    with np.errstate(invalid="ignore", divide="ignore"):
        tq = np.clip((q[..., :-1] - boundary) / (q[..., :-1] - q[..., 1:]), 0.0, 1.0)
    gm_log_all = -_lerp(logmag, tq)  # ln(1/|L|)
    gm_abs = np.where(cross, np.abs(gm_log_all), np.inf)
    j = np.argmin(gm_abs, axis=-1)[..., None]
    found_g = np.take_along_axis(cross, j, -1)[..., 0]
    gm_db = np.where(found_g, np.take_along_axis(gm_log_all, j, -1)[..., 0] * 20 / np.log(10), np.inf)
    wpc = np.exp(np.take_along_axis(_lerp(np.broadcast_to(lw, L.shape), tq), j, -1)[..., 0])
    wpc = np.where(found_g, wpc, np.nan)

    S = 1.0 / (1.0 + L)
    ms = np.max(np.abs(S), axis=-1)
    alpha = 1.0 / np.max(np.abs(S - 0.5), axis=-1)
    half = alpha / 2
    with np.errstate(divide="ignore", invalid="ignore"):
        dgm = np.where(half < 1, 20 * np.log10((1 + half) / (1 - half)), np.inf)
    dpm = np.degrees(2 * np.arctan(half))
    return Margins(gm_db, pm, wpc / (2 * np.pi), wc / (2 * np.pi), alpha, dgm, dpm, ms)


def closed_loop_bandwidth_hz(w_rad_s, closed_loop, *, dc_gain=None) -> np.ndarray:
    """First frequency (Hz) where |T| falls below |T(0)|/sqrt(2); ``nan`` if it never does on the grid.

    ``dc_gain`` is |T(0)|; by default |T| at the lowest grid frequency (pass 1.0 for loops
    with integral action, whose T(0) = 1 exactly).
    """
    w = check_grid(w_rad_s)
    T = np.asarray(closed_loop, dtype=complex)
    mag = np.abs(T)
    dc = mag[..., :1] if dc_gain is None else np.asarray(dc_gain, float)[..., None]
    with np.errstate(divide="ignore"):
        x = np.log(mag) - np.log(dc / np.sqrt(2))
    below = x < 0
    below[..., 0] = False  # the first grid point defines the reference
    i = np.argmax(below, axis=-1)  # first index below the level
    found = np.take_along_axis(below, i[..., None], -1)[..., 0]
    i0 = np.maximum(i - 1, 0)[..., None]
    x0 = np.take_along_axis(x, i0, -1)[..., 0]
    x1 = np.take_along_axis(x, i[..., None], -1)[..., 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.clip(np.where(x0 == x1, 0.0, x0 / (x0 - x1)), 0.0, 1.0)
    lw = np.log(w)
    lw_c = lw[i0[..., 0]] + t * (lw[i] - lw[i0[..., 0]])
    return np.where(found, np.exp(lw_c) / (2 * np.pi), np.nan)
