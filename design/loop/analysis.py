"""Velocity-loop numbers for a batch of plants: margins, bandwidth, payload sweeps."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from design.loop.controller import PI
from design.loop.loops import open_loop_frd, plant_frd
from design.loop.margins import Margins, first_drop_hz, loop_margins
from plant.grid import check_grid, log_grid_rad_s
from plant.physics.models import Plant

#: default analysis grid: 1 mHz to 10 kHz, 3000 log-spaced points (~430 per decade)
ANALYSIS_GRID_RAD_S = log_grid_rad_s(1e-3, 1e4, 3000)


@dataclass(frozen=True)
class LoopAnalysis:
    """Margins and bandwidth of the velocity loop P (Kp + Ki/s) for a batch of plants."""

    margins: Margins
    #: closed-loop -3 dB bandwidth (first |T| < 1/sqrt 2 of the reference, |T| = 1), Hz
    closed_loop_bandwidth_hz: np.ndarray
    #: -3 dB frequency of the plant itself (the corner b/(2 pi M) for the thesis plants), Hz
    open_loop_corner_hz: np.ndarray


#: decades the analysis grid may grow by, below and above, to hold every gain crossover
EXTEND_DECADES = (4, 3)


def extended_grid(plant: Plant, controller: PI, w_rad_s) -> np.ndarray:
    """``w_rad_s`` extended by whole decades (same points per decade, at most ``EXTEND_DECADES``) until
    |L| > 1 at its lowest and |L| < 1 at its highest frequency for every plant of the batch, so that no
    crossover lies outside it (a PI loop's |L| grows without bound towards 0 rad/s)."""
    w = check_grid(w_rad_s)
    per_decade = (w.size - 1) / np.log10(w[-1] / w[0])
    lo, hi = w[0], w[-1]
    for _ in range(EXTEND_DECADES[0]):
        if np.all(np.abs(open_loop_frd(plant, np.array([lo]), controller)) > 1):
            break
        lo /= 10
    for _ in range(EXTEND_DECADES[1]):
        if np.all(np.abs(open_loop_frd(plant, np.array([hi]), controller)) < 1):
            break
        hi *= 10
    if lo == w[0] and hi == w[-1]:
        return w
    return np.geomspace(lo, hi, int(round(per_decade * np.log10(hi / lo))) + 1)


def analyse_loop(plant, controller: PI, *, w_rad_s=ANALYSIS_GRID_RAD_S, level2: float = 0.5) -> LoopAnalysis:
    """Analyse the loop for a ``Plant`` (possibly a payload batch; the grid then grows until it holds every
    crossover, ``extended_grid``) or a measured response array (``margins.crossings_on_grid`` says
    whether it does). Check ``margins.closed_loop_stable`` before trusting a margin. ``level2``: the
    bandwidth definition, |T(w_b)|^2 / |T(0)|^2 (``design.loop.margins.BANDWIDTH_LEVELS2``)."""
    w = extended_grid(plant, controller, w_rad_s) if isinstance(plant, Plant) else check_grid(w_rad_s)
    P = plant_frd(plant, w)
    L = open_loop_frd(P, w, controller)
    margins = loop_margins(w, L)
    # |T|^2 = |L|^2 / |1 + L|^2 of T = L / (1 + L) (Eq. 3.19/3.20), in real arithmetic; the bandwidth against
    # the reference |T| = 1 (T(0) = 1 with integral action; a P-only loop's |T(0)| < 1 is not rewarded)
    T2 = (L.real**2 + L.imag**2) / ((1.0 + L.real) ** 2 + L.imag**2)
    bw = first_drop_hz(w, T2, 1.0, level2=level2)
    corner = first_drop_hz(w, P.real**2 + P.imag**2)
    return LoopAnalysis(margins, bw, corner)


@dataclass(frozen=True)
class PayloadSweep:
    """Loop numbers against payload (thesis Figure 4.31, extended with margins)."""

    stage: str
    payload_kg: np.ndarray
    open_loop_corner_hz: np.ndarray
    closed_loop_bandwidth_hz: np.ndarray
    phase_margin_deg: np.ndarray
    gain_margin_db: np.ndarray
    #: closed loop stable (Nyquist on the analysis grid); the margins of an unstable loop mean nothing
    closed_loop_stable: np.ndarray



def payload_sweep(plant: Plant, controller: PI, payload_kg, *, w_rad_s=ANALYSIS_GRID_RAD_S,
                  level2: float = 0.5) -> PayloadSweep:
    """Evaluate all payloads at once (one vectorised call); ``level2`` as in ``analyse_loop``."""
    m = np.asarray(payload_kg, dtype=float).ravel()
    a = analyse_loop(plant.with_payload(m), controller, w_rad_s=w_rad_s, level2=level2)
    return PayloadSweep(plant.stage, m, a.open_loop_corner_hz, a.closed_loop_bandwidth_hz,
                        a.margins.phase_margin_deg, a.margins.gain_margin_db, a.margins.closed_loop_stable)
