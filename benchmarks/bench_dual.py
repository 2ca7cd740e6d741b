"""Two-motor Stage Y benchmark on ``specs/stage_y_dual.toml``: what a user waits for, and each structure's
scan against brute force on the same plants, side by side in one run.

Run:  python benchmarks/bench_dual.py [--quick]

* The command: ``gantry synth specs/stage_y_dual.toml --json`` in a fresh process under ``/usr/bin/time``:
  wall seconds, CPU seconds (user + system) and peak memory (max RSS); the median of 3 runs (1 with --quick).
* Brute force: for the per-motor and master-slave structures (two gains each), a log grid of N x N gains
  over the spec's box (N = 81, 41 with --quick), the grid's best point found exactly on the design plants
  (lazy cutting planes, which find the exhaustive scan's best: tests/design/synth/test_dual_synthesis.py), its
  worst-case bandwidth beside the design's: the ratio design / brute force (>= 1: the scan is
  at least as good as the grid).
"""

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "specs" / "stage_y_dual.toml"
QUICK = "--quick" in sys.argv
RUNS = 1 if QUICK else 3
N = 41 if QUICK else 81


def timed() -> tuple[float, float, float, dict]:
    """(wall s, CPU s, peak MB, JSON) of the command in a fresh process."""
    with tempfile.NamedTemporaryFile(suffix=".time") as f:
        start = time.perf_counter()
        r = subprocess.run(["/usr/bin/time", "-f", "%U %S %M", "-o", f.name, sys.executable, "-m", "design", "synth",
                            str(SPEC), "--json"], capture_output=True, text=True, check=True)
        wall = time.perf_counter() - start
        user, system, rss = Path(f.name).read_text().split()[-3:]
    return wall, float(user) + float(system), int(rss) / 1024, json.loads(r.stdout)


def main() -> None:
    runs = [timed() for _ in range(RUNS)]
    wall, cpu, mem = (float(np.median([r[i] for r in runs])) for i in range(3))
    out = runs[0][3]
    print(f"gantry synth {SPEC.name} --json: wall {wall:.1f} s, CPU {cpu:.1f} s, peak {mem:.0f} MB "
          f"(median of {RUNS}); {out['design_plants']} design plants, {out['monte_carlo_draws']} Monte Carlo draws")
    for row in out["structures"]:
        d, mc = row["design_plants"], row["monte_carlo"]
        print(f"  {row['structure']:20s} bandwidth {d['bandwidth_hz']:6.2f} Hz, PM {d['phase_margin_deg']:.2f} deg, "
              f"GM {d['gain_margin_db']:.2f} dB, disk margin {d['disk_margin']:.3f}, yaw coupling "
              f"{d['yaw_coupling']:.3f}; Monte Carlo {mc['n_failing']} of {mc['n_plants']} fail")
    print(f"  recommended: {out['recommended']}")

    from design.loop.dual import MasterSlave, PerMotor
    from design.synth import dual
    from design.workflows import load_problem

    spec = load_problem(SPEC).spec
    d = spec.dual_drive
    travel = d.carriage_position_m
    scenarios = dual.dual_scenarios(spec.dual_model(), np.linspace(travel.min, travel.max, travel.points),
                                    d.stage_x_mass_kg + spec.plant.payload_kg.design_points(),
                                    {k: (v.min, v.max) for k, v in d.uncertainty.items()})
    req = dual.DualRequirements(spec.requirements.phase_margin_deg, spec.requirements.gain_margin_db)
    lk = np.log10([max(spec.controller.kp.min, spec.controller.kp.max * 1e-6), spec.controller.kp.max])
    li = np.log10([max(spec.controller.ki.min, spec.controller.ki.max * 1e-6), spec.controller.ki.max])
    for name, make in (("per_motor", PerMotor), ("master_slave", MasterSlave)):
        start = time.perf_counter()
        s, kp, ki = dual._grid(make, scenarios, req, dual._Objective(), set(), -np.inf,
                               np.linspace(*lk, N), np.linspace(*li, N))
        k = int(np.argmax(s))
        mine = next(r for r in out["structures"] if r["structure"] == name)["design_plants"]["bandwidth_hz"]
        print(f"  {name:20s} brute force {N} x {N}: best {s[k]:.2f} Hz at kp {kp[k]:.4g}, ki {ki[k]:.4g} "
              f"({time.perf_counter() - start:.0f} s, the grid scored by lazy cutting planes); "
              f"design / brute force {mine / s[k]:.4f}")


if __name__ == "__main__":
    main()
