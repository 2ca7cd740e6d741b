"""How much latency an admittance design tolerates: the extra delay in the interaction loop that brings its
worst curve (scenario x mouse) to instability, and the margins with one more sample of computation delay.

* **Latency margin.** At each gain crossover w_i of the interaction loop (|L| = 1, up to the law's Nyquist
  frequency when sampled) an extra delay D turns L by -w_i D: the loop reaches -1 at D_i = (arg L(w_i) + pi mod
  2 pi) / w_i. The margin is the least D_i over the crossovers and the curves (seconds, and in samples of the
  law's period). For a sampled law a delay of whole samples is exact (z^-k); between them it is the delay of the
  held output, read on the fundamental.
* **One more sample.** The interaction loop with the computation delay d + 1 (the law using the previous force
  reading, or one more bus cycle): its margins and the coupled discrete loop's poles
  (``design.admittance.sampled.closed_loop_radius``), exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from design.admittance.model import check_grid_for, coupled_gain, with_mode_points
from design.admittance.mouse import stack
from design.admittance.rig import RigTiming
from design.admittance.sampled import closed_loop_radius, mice_paths, sampled_gain
from design.loop.margins import loop_margins


@dataclass(frozen=True)
class LatencyCheck:
    """The latency a design tolerates at its worst curve, and its margins with one more sample."""

    #: least extra delay (s) that destabilises a curve; inf when no curve has a gain crossover
    margin_s: float
    #: that delay in samples of the law's period (None: continuous law)
    margin_samples: float | None
    #: where it is least: the scenario and the mouse
    worst: str
    #: the computation delay the design was made for (samples) and the worst margins and stability with one more
    delay_samples: int | None
    one_more_phase_margin_deg: float | None
    one_more_gain_margin_db: float | None
    one_more_stable: bool | None


def delay_margin_s(w_rad_s, loop) -> np.ndarray:
    """Least extra delay (s) bringing loops ``loop`` (..., n) on the grid ``w_rad_s`` to -1: at every gain
    crossover (|L| = 1 between grid points, interpolated in log w), the phase to -180 deg over the frequency;
    inf where |L| never crosses 1."""
    w = np.asarray(w_rad_s, float)
    L = np.asarray(loop, complex)
    lm = np.log(np.maximum(np.abs(L), 1e-300))
    phase = np.unwrap(np.angle(L), axis=-1)
    cross = (lm[..., :-1] > 0) != (lm[..., 1:] > 0)
    t = np.divide(lm[..., :-1], lm[..., :-1] - lm[..., 1:], out=np.zeros_like(lm[..., :-1]),
                  where=lm[..., :-1] != lm[..., 1:])
    lw = np.log(w)
    t = np.where(cross, t, 0.0)
    wc = np.exp(lw[:-1] + t * (lw[1:] - lw[:-1]))
    ph = phase[..., :-1] + t * (phase[..., 1:] - phase[..., :-1])
    d = np.mod(ph + math.pi, 2 * math.pi) / wc
    return np.min(np.where(cross, d, np.inf), axis=-1)


#: curves whose frequency responses one block of the check holds (memory: a few complex arrays of this x the grid)
BLOCK_CURVES = 256


def latency_check(scenarios, corners, *, loops, timing: RigTiming, m_v: float, b_v: float) -> LatencyCheck:
    """``LatencyCheck`` of (m_v, b_v) on ``scenarios`` x the mice ``corners`` (exactly sampled when the law is),
    ``BLOCK_CURVES`` curves at a time."""
    w = with_mode_points(check_grid_for(timing), corners, timing)
    n_m, n_s = len(corners), len(scenarios)
    z = timing.impedance(w, m_v, b_v)
    margin, pm, gm = (np.full(n_m * n_s, np.nan) for _ in range(3))
    stable = np.ones(n_m * n_s, bool)
    T, d = timing.period_s, timing.delay_samples
    one_more = None if not timing.sampled else np.exp(-1j * w * T)

    def judge(curves, L, radius=None):
        margin[curves] = delay_margin_s(w, L)
        if one_more is None:
            return
        m = loop_margins(w, L * one_more, sampled=timing.sampled)
        p, g, st = m.phase_margin_deg, m.gain_margin_db, m.closed_loop_stable
        pm[curves], gm[curves] = p, g
        stable[curves] = st if radius is None else radius < 1.0

    if timing.sampled:
        law = timing.law(m_v, b_v)
        for curves, part in mice_paths(loops, scenarios, stack(corners), timing, paired=False):
            for i in range(0, curves.size, BLOCK_CURVES):
                block = part.take(slice(i, i + BLOCK_CURVES))
                judge(curves[i:i + BLOCK_CURVES], sampled_gain(block, w, timing) / z,
                      closed_loop_radius(block, law, d + 1))
    else:
        for j in range(0, n_s, max(1, BLOCK_CURVES // n_m)):
            rows = np.arange(j, min(j + max(1, BLOCK_CURVES // n_m), n_s))
            gain = coupled_gain(loops, scenarios.take(rows), stack(corners), w, timing)       # (n_m, n_rows, n_f)
            judge((np.arange(n_m)[:, None] * n_s + rows[None, :]).ravel(), gain.reshape(-1, w.size) / z)
    k, j = np.unravel_index(int(np.argmin(margin)), (n_m, n_s))
    worst = f"{scenarios.describe(j)} with mouse ({corners[k].label()})"
    least = float(margin[k * n_s + j])
    if not timing.sampled:
        return LatencyCheck(least, None, worst, None, None, None, None)
    return LatencyCheck(least, least / T, worst, d,
                        float(np.nanmin(np.where(stable, pm, np.nan))) if stable.any() else math.nan,
                        float(np.nanmin(np.where(stable, gm, np.nan))) if stable.any() else math.nan,
                        bool(stable.all()))
