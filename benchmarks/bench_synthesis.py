"""Synthesis benchmark: solve time per spec, worst-case bandwidth against a dense brute-force
search over (Kp, Ki) on the same spec, and the bandwidth gained over the baselines.

Run:  python benchmarks/bench_synthesis.py [--quick]   (admittance: benchmarks/bench_admittance.py)

* Solve time: ``synthesise_pi`` (scan, ccp, exact multi-start, dense robustness check),
  wall and CPU, warm (imports and first-call set-up done by a previous run) and cold
  (first call in the process, imports excluded as reported by the tool); the python-control
  verification is timed apart.
* Brute force: a 60 x 60 log grid of (Kp, Ki) over Kp 10..1e4, Ki 10..1e7, evaluated on the
  synthesis' check scenarios (the 50 dense payloads; times the corners and 24 seeded draws of the
  spec's uncertainty when it has some) with the cubic-refined margins of ``design.loop.fast``
  (batched per Kp), closed loops stable by the Nyquist test,
  keeping the best pair meeting PM and GM everywhere; then two 25 x 25 refinements, each spanning
  +-2 cells of the previous grid around its best. With uncertainty (1600 check scenarios) the
  grids are 20 x 20 and three 11 x 11 refinements. The best is re-evaluated exactly like the
  synthesis' designs. ``--quick`` uses 30 x 30 (12 x 12) and smaller refinements.
* Robustness (specs with ``plant.uncertainty``): the Monte Carlo check of the design (10,000
  independent draws over payload x uncertainty, violations with their 95 % upper bound) beside the
  design for the nominal parameters alone on the same draws.
"""

import sys
import time
from pathlib import Path

import as_commands  # noqa: F401  (BLAS on one thread, as the commands run it)
import numpy as np

from design.loop.controller import PI
from design.loop.fast import fast_analyse_loop
from design.spec.schema import load_spec
from design.synth.evaluation import evaluate
from design.synth.pi import synthesise_pi
from design.synth.scenarios import check_scenarios
from design.views.json import synthesis_to_dict

ROOT = Path(__file__).resolve().parents[1]
QUICK = "--quick" in sys.argv


def brute_force(spec, kp_grid, ki_grid):
    """Best (worst-case bandwidth, kp, ki) on the grid over the synthesis' check scenarios (the dense
    payloads, times the corners and seeded draws of the uncertainty when the spec has some)."""
    s = check_scenarios(spec)
    plant = spec.plant.plant().with_values({k: v.reshape(1, -1, 1) for k, v in s.values().items()})
    req = spec.requirements
    best = (-np.inf, None, None)
    for kp in kp_grid:
        n = fast_analyse_loop(plant, PI(np.full((ki_grid.size, 1), kp), ki_grid[:, None]))
        ok = np.all((n.phase_margin_deg >= req.phase_margin_deg) & (n.gain_margin_db >= req.gain_margin_db)
                    & n.stable, axis=1)
        bw = np.where(ok, np.min(np.nan_to_num(n.closed_loop_bandwidth_hz, nan=0.0), axis=1), -np.inf)
        i = int(np.argmax(bw))
        if bw[i] > best[0]:
            best = (float(bw[i]), float(kp), float(ki_grid[i]))
    return best


def main():
    for name in ("stage_x_synth.toml", "stage_y_synth.toml"):
        spec = load_spec(ROOT / "specs" / name).problem()
        cold = synthesise_pi(spec)
        runs = [synthesise_pi(spec) for _ in range(3)]
        res = runs[-1]
        d = synthesis_to_dict(res)
        wall = np.median([r.seconds for r in runs])
        cpu = np.median([r.record.cpu_seconds for r in runs])
        ccp = synthesise_pi(spec, method="ccp")
        t0 = time.perf_counter()
        big = len(check_scenarios(spec)) > 100        # uncertainty: 1600 plants per gain pair
        n0, zooms, nz = (12 if QUICK else 20, 3, 9 if QUICK else 11) if big else (30 if QUICK else 60, 2, 25)
        kp_grid, ki_grid = np.geomspace(10, 1e4, n0), np.geomspace(10, 1e7, n0)
        for _ in range(zooms + 1):
            bw, kp, ki = brute_force(spec, kp_grid, ki_grid)
            # the next grid spans +-2 cells of this one around its best point
            dk, di = (kp_grid[1] / kp_grid[0]) ** 2, (ki_grid[1] / ki_grid[0]) ** 2
            kp_grid, ki_grid = np.geomspace(kp / dk, kp * dk, nz), np.geomspace(ki / di, ki * di, nz)
        brute_s = time.perf_counter() - t0
        brute_bw = evaluate(spec, PI(kp, ki)).worst_bandwidth_hz
        ours = d["worst_case"]["bandwidth_hz"]
        print(f"== {name} ({len(check_scenarios(spec))} check scenarios)")
        print(f"  synthesis (ccp+exact): {d['status']}, verified {d['verified']}, kp {d['gains']['kp']:.2f}, "
              f"ki {d['gains']['ki']:.1f}, worst-case bandwidth {ours:.3f} Hz, chosen: {d['solver']['chosen']}")
        print(f"  solve time warm: {wall:.2f} s wall, {cpu:.2f} s CPU (median of 3); cold: {cold.seconds:.2f} s wall, "
              f"{cold.record.cpu_seconds:.2f} s CPU (+{cold.record.import_seconds:.2f} s imports); "
              f"python-control verification {res.record.verification_seconds:.2f} s")
        print(f"  LP solves {d['solver']['lp_solves']}, IPOPT starts {len(d['solver']['exact_starts'])}, "
              f"rounds {d['solver']['rounds']}")
        print("  ccp alone (the circle design, cvxpy + Clarabel): worst-case bandwidth "
              f"{ccp.evaluation.worst_bandwidth_hz:.3f} Hz "
              f"({ccp.record.chosen})")
        print(f"  brute force ({brute_s:.0f} s): kp {kp:.2f}, ki {ki:.1f}, worst-case bandwidth {brute_bw:.3f} Hz")
        print(f"  ratio synthesis / brute force: {ours / brute_bw:.4f}")
        mc = d.get("monte_carlo")
        if mc:
            nominal = synthesise_pi(spec, nominal=True)
            from design.synth.monte_carlo import monte_carlo_check

            nmc = monte_carlo_check(spec, nominal.evaluation.controller)
            print(f"  Monte Carlo ({mc['samples']} draws over payload x plant.uncertainty, seed {mc['seed']}): robust "
                  f"design {mc['violations']} violations (95 % upper bound {100 * mc['rate_upper_bound_95']:.3f} %), "
                  f"worst PM {mc['worst_phase_margin_deg']:.2f} deg, GM {mc['worst_gain_margin_db']:.2f} dB")
            print(f"  nominal design (uncertainty ignored): kp {nominal.evaluation.controller.kp:.2f}, ki "
                  f"{nominal.evaluation.controller.ki:.1f}, bandwidth {nominal.evaluation.worst_bandwidth_hz:.3f} Hz "
                  "on the "
                  f"nominal plant; on the same draws {nmc.violations} violations ({100 * nmc.rate:.1f} %), worst PM "
                  f"{nmc.worst_phase_margin_deg:.1f} deg, GM {nmc.worst_gain_margin_db:.1f} dB")
        for b in d["baselines"]:
            if b["meets_requirements"]:
                print(f"  baseline {b['name']}: {b['worst_bandwidth_hz']:.2f} Hz (meets the requirements); "
                      f"synthesis x{ours / b['worst_bandwidth_hz']:.2f}")
            else:
                print(f"  baseline {b['name']}: FAILS the requirements (stable: {b['stable']}, worst PM "
                      f"{b['worst_phase_margin_deg']:.1f} deg, worst GM {b['worst_gain_margin_db']:.1f} dB)")


if __name__ == "__main__":
    main()
