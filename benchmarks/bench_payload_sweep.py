"""Payload-sweep speed: vectorised margins and bandwidth against the same sweep in a python-control loop.

Run:  python benchmarks/bench_payload_sweep.py

200 payloads 5-40 kg, Stage X (thesis Eq. 3.15) with a 0.5 ms delay and a 300 Hz current-loop
lag, thesis PI gains Kp = 236, Ki = 47 (Appendix A). For every payload: phase margin, gain
margin and closed-loop -3 dB bandwidth.

* ours: ``design.loop.analysis.payload_sweep`` (one vectorised call on the default 3000-point grid
  ``ANALYSIS_GRID_RAD_S``, exact delay, crossings interpolated between grid points);
* python-control 0.10: per payload ``Plant.to_control()`` (Pade order 6 for the delay) times the
  PI, ``stability_margins``, ``feedback`` and ``bandwidth(T, dbdrop=-20 log10 sqrt 2)``.

Prints both times (best of several runs, the machine is shared), the ratio (target >= 20x) and the
largest differences of the numbers (they include the Pade approximation of the delay).
``design.loop.fast.fast_analyse_loop`` (the coarse-grid path of ``gantry sweep``) is timed too.
"""

import math
import time

import as_commands  # noqa: F401  (BLAS on one thread, as the commands run it)
import control
import numpy as np

from design.loop.analysis import payload_sweep
from design.loop.controller import PI
from design.loop.fast import fast_analyse_loop
from plant import CurrentLoop, Delay, stage_x

KP, KI = 236.0, 47.0                      # thesis Appendix A
PLANT = stage_x() * Delay(0.0005) * CurrentLoop(300.0)
PAYLOADS_KG = np.linspace(5.0, 40.0, 200)
DBDROP = -20 * math.log10(math.sqrt(2))   # |T(0)|/sqrt 2, the definition used by design.loop.margins


def best_time(fn, repeats):
    """Smallest wall time of ``repeats`` runs and the last result."""
    best, out = math.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def ours():
    return payload_sweep(PLANT, PI(KP, KI), PAYLOADS_KG)


def fast():
    return fast_analyse_loop(PLANT.with_payload(PAYLOADS_KG), PI(KP, KI))


def python_control_loop():
    pm, gm, bw = [], [], []
    for m in PAYLOADS_KG:
        L = PLANT.with_payload(float(m)).to_control() * PI(KP, KI).tf()
        g, p, _, _, _, _ = control.stability_margins(L)
        T = control.feedback(L, 1)
        bw.append(control.bandwidth(T, dbdrop=DBDROP) / (2 * math.pi))
        pm.append(p)
        gm.append(20 * math.log10(g))
    return np.array(pm), np.array(gm), np.array(bw)


def main():
    payload_sweep(PLANT, PI(KP, KI), PAYLOADS_KG[:2])      # warm-up: imports and caches
    fast_analyse_loop(PLANT.with_payload(PAYLOADS_KG[:2]), PI(KP, KI))
    t_ours, r = best_time(ours, 7)
    t_fast, f = best_time(fast, 7)
    t_pc, (pm, gm, bw) = best_time(python_control_loop, 2)

    print("200-payload sweep (PM, GM, closed-loop bandwidth), Stage X + 0.5 ms delay + 300 Hz current loop")
    print(f"  python-control loop            {t_pc * 1e3:9.1f} ms")
    print(f"  design.loop.analysis.payload_sweep  {t_ours * 1e3:9.1f} ms   ratio {t_pc / t_ours:6.1f}x (target >= 20x)")
    print(f"  design.loop.fast (coarse)  {t_fast * 1e3:9.1f} ms   ratio {t_pc / t_fast:6.1f}x")
    for name, res in (("payload_sweep", (r.phase_margin_deg, r.gain_margin_db, r.closed_loop_bandwidth_hz)),
                      ("fast_analysis", (f.phase_margin_deg, f.gain_margin_db, f.closed_loop_bandwidth_hz))):
        d_pm = np.max(np.abs(res[0] - pm))
        d_gm = np.max(np.abs(res[1] - gm))
        d_bw = np.max(np.abs(res[2] / bw - 1))
        print(f"  {name}: max |PM diff| {d_pm:.2e} deg (rel {np.max(np.abs(res[0] / pm - 1)):.1e}), "
              f"max |GM diff| {d_gm:.2e} dB (rel {np.max(np.abs(res[1] / gm - 1)):.1e}), "
              f"max rel bandwidth diff {d_bw:.1e}")
    print(f"  ranges: PM {pm.min():.2f}-{pm.max():.2f} deg, GM {gm.min():.2f}-{gm.max():.2f} dB, "
          f"bandwidth {bw.min():.2f}-{bw.max():.2f} Hz")


if __name__ == "__main__":
    main()
