"""Payload sweep speed: vectorised margins + bandwidth against a python-control loop.

Run:  python benchmarks/bench_payload_sweep.py
200 payloads 5-40 kg, Stage X with a 0.5 ms delay and a 300 Hz current loop, thesis gains.
Ours, two vectorised paths: design.fast_analysis.fast_analyse_loop (coarse grid with cubic
crossing refinement, used by ``gantry sweep``) and design.analysis.payload_sweep (3000-point
grid, linear interpolation, used by ``gantry reproduce``); both with the exact delay. python-control: for every payload, the Pade(6) rational loop, stability_margins,
feedback and bandwidth. Both times, the ratio and the largest differences are printed
(the differences include the Pade approximation of the delay).
"""

import math
import time

import control
import numpy as np

from design.analysis import payload_sweep
from design.fast_analysis import fast_analyse_loop
from design.loops import pi_tf
from plant import CurrentLoop, Delay, stage_x

KP, KI = 236.0, 47.0
plant = stage_x() * Delay(0.0005) * CurrentLoop(300.0)
payloads = np.linspace(5, 40, 200)

payload_sweep(plant, KP, KI, payloads[:2])       # warm-up (imports, caches)
fast_analyse_loop(plant.with_payload(payloads[:2]), KP, KI)
t0 = time.perf_counter()
fast = fast_analyse_loop(plant.with_payload(payloads), KP, KI)
t_fast = time.perf_counter() - t0
t0 = time.perf_counter()
ours = payload_sweep(plant, KP, KI, payloads)
t_ours = time.perf_counter() - t0

t0 = time.perf_counter()
pm, gm, bw = [], [], []
for m in payloads:
    L = plant.with_payload(float(m)).to_control() * pi_tf(KP, KI)
    g, p, _, _, _, _ = control.stability_margins(L)
    bw.append(control.bandwidth(control.feedback(L, 1), dbdrop=-20 * math.log10(math.sqrt(2))) / (2 * math.pi))
    pm.append(p)
    gm.append(20 * math.log10(g))
t_pc = time.perf_counter() - t0

print(f"200-payload sweep: python-control loop {t_pc * 1e3:.1f} ms; fast path {t_fast * 1e3:.1f} ms "
      f"(ratio {t_pc / t_fast:.1f}x, target >= 20x); 3000-point grid {t_ours * 1e3:.1f} ms (ratio {t_pc / t_ours:.1f}x)")
for name, r in (("fast path", fast), ("3000-point grid", ours)):
    bw_r = r.closed_loop_bandwidth_hz
    print(f"  {name}: max |PM difference| {np.max(np.abs(r.phase_margin_deg - pm)):.2e} deg, "
          f"max |GM difference| {np.max(np.abs(r.gain_margin_db - gm)):.2e} dB, "
          f"max relative bandwidth difference {np.max(np.abs(bw_r / bw - 1)):.2e}")
