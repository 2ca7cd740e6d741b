"""Drive filters as design variables: on the two resonant Stage X specs (a compliant optics mount,
its mode at 60 Hz at the nominal payload; sensed at the motor, and at the payload), the worst-case
bandwidth of PI alone and of PI + notch + low-pass, each against a brute-force search over the
same structure, and the gain the filters bring.

Run:  python benchmarks/bench_filters.py [--quick]

* Synthesis: ``synthesise_pi`` on the spec (filters designed) and on the spec without its filters
  (PI alone); wall time of each.
* Brute force, PI alone: (Kp, Ki) on a 20 x 20 log grid, then three 11 x 11 grids each spanning +-2
  cells of the previous around its best, evaluated on the 50 dense payloads with the cubic-refined
  margins of ``design.loop.fast`` (closed loops stable by the Nyquist test).
* Brute force, PI + filters: every filter setting of a grid (notch left out, or its frequency on 8
  log points of its range x damping {0.05, 0.2, 0.5, 1, 2} x depth {0, 0.1, 0.25, 0.5}; low-pass left
  out, or at 4 log points of its range), each with the gains of a 10 x 10 grid and one 7 x 7 zoom on
  15 payloads; the 4 best settings (3 with ``--quick``) then get a local 3 x 3 x 3 filter grid around
  them and a (Kp, Ki) search (12 x 12, three 9 x 9 zooms) on the 50 dense payloads. ``--quick``
  halves the first grid.
Ratios are synthesis / brute force (>= 0.99 asked: the synthesis is not beaten by the search).
"""

from __future__ import annotations

import itertools
import sys
import time
import tomllib
from pathlib import Path

import as_commands  # noqa: F401  (BLAS on one thread, as the commands run it)
import numpy as np

from design.loop.controller import PI
from design.loop.fast import fast_analyse_loop
from design.problem import with_filter_values
from design.spec.schema import load_spec, parse_spec
from design.synth.pi import synthesise_pi

ROOT = Path(__file__).resolve().parents[1]
QUICK = "--quick" in sys.argv
SPECS = ("stage_x_resonant_motor.toml", "stage_x_resonant_payload.toml")


def best_gains(problem, payload_kg, kp_grid, ki_grid):
    """(worst-case bandwidth, kp, ki) of the best pair of the grid meeting PM and GM at every payload."""
    plant = problem.plant.plant().with_values({"mass_kg": np.asarray(payload_kg, float).reshape(1, -1, 1)})
    req = problem.requirements
    KP, KI = np.meshgrid(kp_grid, ki_grid, indexing="ij")
    n = fast_analyse_loop(plant, PI(KP.reshape(-1, 1), KI.reshape(-1, 1)))
    ok = np.all((n.phase_margin_deg >= req.phase_margin_deg) & (n.gain_margin_db >= req.gain_margin_db)
                & n.stable, axis=1)
    bw = np.where(ok, np.min(np.nan_to_num(n.closed_loop_bandwidth_hz, nan=0.0), axis=1), -np.inf)
    i = int(np.argmax(bw))
    return float(bw[i]), float(KP.ravel()[i]), float(KI.ravel()[i])


def gain_search(problem, payload_kg, n0, zooms, nz):
    kp_grid, ki_grid = np.geomspace(10, 1e4, n0), np.geomspace(10, 1e7, n0)
    best = (-np.inf, None, None)
    for _ in range(zooms + 1):
        found = best_gains(problem, payload_kg, kp_grid, ki_grid)
        best = max(best, found, key=lambda b: b[0])
        if best[1] is None:
            return best
        dk, di = (kp_grid[1] / kp_grid[0]) ** 2, (ki_grid[1] / ki_grid[0]) ** 2
        kp_grid = np.geomspace(best[1] / dk, best[1] * dk, nz)
        ki_grid = np.geomspace(best[2] / di, best[2] * di, nz)
    return best


def filter_grid(problem, points):
    """Every setting of the brute-force grid: a list per filter of None (left out) or parameter dicts."""
    per_filter = []
    for f in problem.controller.filters:
        opts = [None] if f.designed else []
        lo, hi = f.ranges.get("frequency_hz", (f.fixed.get("frequency_hz"),) * 2)
        freqs = np.geomspace(lo, hi, points["frequency"]) if hi > lo else [lo]
        damp = points["damping"] if "damping_ratio" in f.ranges else [f.fixed["damping_ratio"]]
        depth = (points["depth"] if "depth" in f.ranges else [f.fixed.get("depth")]) if f.kind == "notch" else [None]
        for fr, z, d in itertools.product(freqs, damp, depth):
            v = {"frequency_hz": float(fr), "damping_ratio": float(np.clip(z, *f.ranges.get("damping_ratio",
                                                                                             (z, z))))}
            if d is not None:
                v["depth"] = float(np.clip(d, *f.ranges.get("depth", (d, d))))
            opts.append(v)
        per_filter.append(opts)
    return list(itertools.product(*per_filter))


def local_grid(problem, values):
    """3 x 3 x 3 settings around ``values`` (frequency x/1.15, damping and depth +-30 %), inside the ranges."""
    per_filter = []
    for f, v in zip(problem.controller.filters, values):
        if v is None or not f.designed:
            per_filter.append([v])
            continue
        axes = {k: ([v[k] / 1.15, v[k], v[k] * 1.15] if k == "frequency_hz" else [v[k] * 0.7, v[k], v[k] * 1.3])
                for k in f.ranges}
        opts = []
        for combo in itertools.product(*axes.values()):
            w = dict(v)
            for k, x in zip(axes, combo):
                w[k] = float(np.clip(x, *f.ranges[k]))
            opts.append(w)
        per_filter.append(opts)
    return list(itertools.product(*per_filter))


def main():
    scale = 0.5 if QUICK else 1.0
    for name in SPECS:
        problem = load_spec(ROOT / "specs" / name).problem()
        data = tomllib.loads((ROOT / "specs" / name).read_text())
        data["controller"].pop("filters")
        pi_problem = parse_spec(data).problem()
        dense = problem.plant.payload_kg.check_points()
        coarse = np.linspace(dense[0], dense[-1], 15)
        t0 = time.perf_counter()
        pi = synthesise_pi(pi_problem)
        t_pi = time.perf_counter() - t0
        t0 = time.perf_counter()
        flt = synthesise_pi(problem)
        t_f = time.perf_counter() - t0
        bw_pi, bw_f = pi.evaluation.worst_bandwidth_hz, flt.evaluation.worst_bandwidth_hz

        t0 = time.perf_counter()
        brute_pi = gain_search(pi_problem, dense, 20, 3, 11)
        points = {"frequency": max(int(8 * scale), 4), "damping": [0.05, 0.2, 0.5, 1.0, 2.0],
                  "depth": [0.0, 0.1, 0.25, 0.5]}
        first = []
        for values in filter_grid(problem, points):
            p = with_filter_values(problem, list(values))
            first.append((gain_search(p, coarse, max(int(10 * scale), 6), 1, 7)[0], values))
        first.sort(key=lambda x: -x[0])
        brute_f = (-np.inf, None, None, None)
        for _, values in first[:4 if not QUICK else 3]:
            for local in local_grid(problem, values):
                p = with_filter_values(problem, list(local))
                bw, kp, ki = gain_search(p, dense, 12, 3, 9)
                if bw > brute_f[0]:
                    brute_f = (bw, kp, ki, local)
        t_brute = time.perf_counter() - t0
        print(f"== {name}")
        print(f"  PI alone:      synthesis {bw_pi:.3f} Hz ({t_pi:.1f} s; kp {pi.evaluation.controller.kp:.1f}, ki "
              f"{pi.evaluation.controller.ki:.0f}, binding {pi.evaluation.binding.constraint}); brute force "
              f"{brute_pi[0]:.3f} Hz; ratio {bw_pi / brute_pi[0]:.4f}")
        used = [f for f in flt.filters if f.used]
        print(f"  PI + filters:  synthesis {bw_f:.3f} Hz ({t_f:.1f} s; kp {flt.evaluation.controller.kp:.1f}, ki "
              f"{flt.evaluation.controller.ki:.0f}; " + "; ".join(
                  f"{f.kind} " + ", ".join(f"{k} {f.values[k]:.4g}" for k in ("frequency_hz", "damping_ratio",
                                                                               "depth") if k in f.values)
                  for f in used) + f"); brute force {brute_f[0]:.3f} Hz "
              f"({len(first)} filter settings, then local grids around the best; {t_brute:.0f} s in all); ratio "
              f"{bw_f / brute_f[0]:.4f}")
        print(f"  brute-force best filters: {brute_f[3]}")
        print(f"  gain of the filters: x{bw_f / bw_pi:.2f} (never worse than PI alone: {bw_f >= bw_pi * 0.999}); "
              f"verified: {flt.status == 'optimal'}")


if __name__ == "__main__":
    main()
