"""Margins and bandwidth from frequency responses against python-control 0.10.2.

Fair comparison: both sides see the same rational loop (Pade order 4 for the delay), python-
control through its exact polynomial method (``stability_margins``, ``bandwidth``), ours
through that loop's response on the default 3000-point analysis grid. So the check isolates
the crossing detection and refinement, not the Pade approximation.
"""

import math

import control
import numpy as np
import pytest

from design.analysis import ANALYSIS_GRID_RAD_S as W
from design.loops import pi_tf
from design.margins import closed_loop_bandwidth_hz, loop_margins
from plant import CurrentLoop, Delay, Resonance, stage_x, stage_y


def random_loops(n=60, seed=2024):
    rng = np.random.default_rng(seed)
    for k in range(n):
        make = stage_x if k % 2 else stage_y
        p = make(mass_kg=rng.uniform(5, 40), damping_n_s_per_m=rng.uniform(330, 550)) \
            * Delay(rng.uniform(1e-4, 2e-3)) * CurrentLoop(rng.uniform(100, 2000))
        if k % 5 == 0:
            fr = rng.uniform(80, 300)
            p = p * Resonance(fr, fr * rng.uniform(0.6, 0.9), rng.uniform(0.05, 0.2))
        kp = float(np.exp(rng.uniform(np.log(50), np.log(1500))))
        ki = kp * rng.uniform(1, 300)
        yield p.to_control(pade_order=4) * pi_tf(kp, ki)


@pytest.mark.parametrize("k, L", list(enumerate(random_loops())))
def test_margins_and_bandwidth_match_python_control(k, L):
    resp = L(1j * W)
    ours = loop_margins(W, resp)
    gm, pm, _, wpc, wgc, _ = control.stability_margins(L)
    assert ours.phase_margin_deg == pytest.approx(pm, rel=1e-3)
    assert ours.gain_crossover_hz == pytest.approx(wgc / (2 * math.pi), rel=1e-3)
    if np.isfinite(gm):
        assert ours.gain_margin_db == pytest.approx(20 * math.log10(gm), rel=1e-3, abs=1e-3)
        assert ours.phase_crossover_hz == pytest.approx(wpc / (2 * math.pi), rel=1e-3)
    T = control.feedback(L, 1)
    if np.all(np.real(control.poles(T)) < 0):    # bandwidth of an unstable loop is meaningless
        bw = control.bandwidth(T, dbdrop=-20 * math.log10(math.sqrt(2))) / (2 * math.pi)
        assert closed_loop_bandwidth_hz(W, resp / (1 + resp), dc_gain=1.0) == pytest.approx(bw, rel=1e-3)


def test_disk_margin_and_peak_sensitivity_match_python_control():
    for L in list(random_loops(10, seed=7)):
        resp = L(1j * W)
        ours = loop_margins(W, resp)
        dm, dgm, dpm = control.disk_margins(L, W)
        assert ours.disk_margin == pytest.approx(np.min(dm), rel=1e-9)
        assert ours.disk_phase_margin_deg == pytest.approx(np.min(dpm), rel=1e-6)
        assert ours.peak_sensitivity == pytest.approx(np.max(np.abs(1 / (1 + resp))), rel=1e-12)


def test_batch_equals_one_by_one():
    loops = [L(1j * W) for L in random_loops(8, seed=3)]
    batch = loop_margins(W, np.array(loops))
    for k, resp in enumerate(loops):
        one = loop_margins(W, resp)
        assert batch.phase_margin_deg[k] == one.phase_margin_deg
        assert batch.gain_margin_db[k] == one.gain_margin_db


def test_no_crossing_gives_infinite_margins():
    # the thesis loop without lags never reaches -180 deg: GM infinite (thesis Fig. 3.13b)
    resp = stage_x().frd(W) * (236 + 47 / (1j * W))
    m = loop_margins(W, resp)
    assert math.isinf(m.gain_margin_db) and math.isnan(m.phase_crossover_hz)
