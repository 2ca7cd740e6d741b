"""A coarse global scan of the drive filters, to start the local optimisers in the right basin.

The gains-and-filters problem has several local optima: on the payload-sensed resonant spec, IPOPT
started from a notch on the resonance moved to a narrow notch (6.6 Hz worst-case bandwidth) while a
wide, shallow notch reaches 12.4 Hz. So, before the pipeline runs on a few filter starts, every
setting of a coarse grid (each designed filter left out, or its designed parameters on
``SCAN_POINTS`` points of their ranges) is scored by the best worst-case bandwidth of a ``SCAN_GAINS``
x ``SCAN_GAINS`` log grid of (Kp, Ki) meeting the phase and gain margins, closed loops stable
(Nyquist on the grid), on the design scenarios (the gains meeting them at the lightest and heaviest
payloads are checked at the others). The plant is evaluated once; a setting only changes
the filters' response. The best settings become filter starts; the other requirements (Ms, noise
limit) are left to the pipeline, which designs and verifies every start.
"""

from __future__ import annotations

import itertools

import numpy as np

from design.loop.controller import PI
from design.loop.margins import closed_loop_bandwidth_hz, crossover_margins, nyquist_stable
from design.problem import LoopProblem
from design.synth.scan import GAIN_CHUNK
from design.synth.scenarios import Scenarios
from plant.grid import log_grid_rad_s
from plant.physics.drive_filters import FILTERS, KINDS

#: points of each designed notch parameter's range (frequency and damping log-spaced, depth linear); a
#: low-pass gets 3 per parameter
SCAN_POINTS = {"frequency_hz": 6, "damping_ratio": 4, "depth": 3}
SCAN_GAINS = 10
#: 0.1 Hz - 5 kHz
W_SCAN = log_grid_rad_s(0.2 * np.pi, 1e4 * np.pi, 500)


def filter_settings(problem: LoopProblem) -> list[list[dict | None]]:
    """Every setting of the scan grid: per filter None (a designed filter left out) or its parameters."""
    per_filter = []
    for f in problem.controller.filters:
        axes = []
        for name, (lo, hi) in sorted(f.ranges.items()):
            n = SCAN_POINTS[name] if f.kind == "notch" else 3
            axes.append([(name, float(v)) for v in (np.linspace(lo, hi, n) if name == "depth" or lo <= 0
                                                    else np.geomspace(lo, hi, n))])
        options = [{**f.fixed, **dict(combo)} for combo in itertools.product(*axes)]
        per_filter.append(([None] if f.designed else []) + options)
    return [list(s) for s in itertools.product(*per_filter)]


def _meets(L: np.ndarray, req) -> np.ndarray:
    """Per gain (first axis): phase and gain margins met and the closed loop stable on every scenario."""
    gm, pm = crossover_margins(W_SCAN, L)
    return np.all((pm >= req.phase_margin_deg) & (gm >= req.gain_margin_db) & nyquist_stable(L), axis=1)


def scan_filters(problem: LoopProblem, scenarios: Scenarios, *, top: int = 3) -> list[tuple[float, list]]:
    """(worst-case bandwidth in Hz, filter values) of the ``top`` best settings with a filter in use, best first."""
    c, req = problem.controller, problem.requirements
    base = problem.plant.plant()
    bare = base.with_effects(*[e for e in base.effects if e.name not in FILTERS])
    P = np.broadcast_to(scenarios.plants(bare).frd(W_SCAN), (len(scenarios), W_SCAN.size))
    kp = np.geomspace(max(c.kp.min, 1e-4 * c.kp.max), c.kp.max, SCAN_GAINS)
    ki = np.geomspace(max(c.ki.min, 1e-4 * c.ki.max), c.ki.max, SCAN_GAINS)
    KP, KI = (g.ravel() for g in np.meshgrid(kp, ki, indexing="ij"))
    C = PI(KP, KI).frd(W_SCAN)                                          # (n_gain, n_freq)
    s = 1j * W_SCAN
    extremes = np.isin(scenarios.payload_kg, [np.min(scenarios.payload_kg), np.max(scenarios.payload_kg)])
    scored = []
    for values in filter_settings(problem):
        if all(v is None for v in values):
            continue
        F = np.ones(W_SCAN.size, complex)
        for f, v in zip(c.filters, values):
            if v is not None:
                F = F * KINDS[f.kind](**v).response(s)
        best = -np.inf
        for start in range(0, KP.size, GAIN_CHUNK):
            CF = (C[start:start + GAIN_CHUNK] * F)[:, None, :]
            ok = _meets(P[None, extremes] * CF, req)         # the lightest and heaviest payloads first
            if ok.any() and not extremes.all():
                ok[ok] = _meets(P[None] * CF[ok], req)
            if ok.any():
                L = P[None] * CF[ok]
                bw = closed_loop_bandwidth_hz(W_SCAN, L / (1 + L), dc_gain=1.0, level2=req.level2)
                best = max(best, float(np.max(np.min(np.nan_to_num(bw, nan=0.0), axis=1))))
        if best > -np.inf:
            scored.append((best, values))
    scored.sort(key=lambda sv: -sv[0])
    return scored[:top]
