"""Synthesis benchmark: solve time per spec, worst-case bandwidth against a dense brute-force
search over (Kp, Ki) on the same spec, and the bandwidth gained over the baselines.

Run:  python benchmarks/bench_synthesis.py
The brute force evaluates a log grid of (Kp, Ki) at the spec's dense payloads with the fast
margin path (design.fast_analysis), keeps the best design meeting PM and GM at every payload,
then refines on a finer grid around it; its best is re-checked on the exact analysis grid.
"""

import time
from pathlib import Path

import numpy as np

from design.fast_analysis import fast_analyse_loop
from design.spec import load_spec
from design.synthesis import dense_payloads, evaluate, synthesise_pi

ROOT = Path(__file__).resolve().parents[1]


def brute_force(spec, kp_grid, ki_grid):
    m = dense_payloads(spec)
    plant = spec.plant.plant().with_payload(m)
    req = spec.requirements
    KP, KI = np.meshgrid(kp_grid, ki_grid, indexing="ij")
    best = (-np.inf, None, None)
    for kp, ki in zip(KP.ravel(), KI.ravel()):
        n = fast_analyse_loop(plant, kp, ki)
        ok = np.all(n.phase_margin_deg >= req.phase_margin_deg) and np.all(n.gain_margin_db >= req.gain_margin_db)
        if ok:
            bw = np.min(np.nan_to_num(n.closed_loop_bandwidth_hz, nan=0.0))
            if bw > best[0]:
                best = (bw, kp, ki)
    return best


for name in ("stage_x_synth.toml", "stage_y_synth.toml"):
    spec = load_spec(ROOT / "specs" / name)
    t0 = time.perf_counter()
    res = synthesise_pi(spec)
    wall = time.perf_counter() - t0
    ccp = synthesise_pi(spec, method="ccp")
    t0 = time.perf_counter()
    bw, kp, ki = brute_force(spec, np.geomspace(10, 1e4, 60), np.geomspace(10, 1e6, 60))
    for _ in range(2):   # refine around the best
        bw, kp, ki = brute_force(spec, np.geomspace(kp / 1.25, kp * 1.25, 25), np.geomspace(ki / 1.6, ki * 1.6, 25))
    brute_s = time.perf_counter() - t0
    exact_bw = evaluate(spec, kp, ki).worst_bandwidth_hz
    d = res.to_dict()
    print(f"== {name}")
    print(f"  synthesis (ccp+exact): status {res.status}, verified {d['verified']}, kp {d['gains']['kp']:.2f}, "
          f"ki {d['gains']['ki']:.1f}, worst-case bandwidth {d['worst_case']['bandwidth_hz']:.3f} Hz, "
          f"solve time {res.seconds:.2f} s (wall incl. verification {wall:.2f} s)")
    print(f"  ccp alone (cvxpy+Clarabel): worst-case bandwidth {ccp.evaluation.worst_bandwidth_hz:.3f} Hz, "
          f"solve time {ccp.seconds:.2f} s")
    print(f"  brute force ({brute_s:.0f} s): kp {kp:.2f}, ki {ki:.1f}, worst-case bandwidth {exact_bw:.3f} Hz")
    print(f"  ratio synthesis / brute force: {d['worst_case']['bandwidth_hz'] / exact_bw:.4f}")
    for b in d["baselines"]:
        if b["meets_requirements"]:
            print(f"  baseline {b['name']}: {b['worst_bandwidth_hz']:.2f} Hz (meets the requirements); "
                  f"synthesis gains x{d['worst_case']['bandwidth_hz'] / b['worst_bandwidth_hz']:.2f}")
        else:
            print(f"  baseline {b['name']}: FAILS the requirements over the payload range (worst PM "
                  f"{b['worst_phase_margin_deg']:.1f} deg, worst GM {b['worst_gain_margin_db']:.1f} dB)")
