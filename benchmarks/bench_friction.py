"""Friction benchmark: ``diagnose`` on stepped-sine recordings of a stage with Coulomb friction, simulated by
the independent stick-slip simulator (tests/reference/independent_stick_slip.py: SciPy event-located integration from
rest, no code of the tool).

Run:  python benchmarks/bench_friction.py [--n 16] [--seed 5]

Each recording draws mass 25-50 kg, rail damping 200-800 N*s/m, Coulomb friction 5-95 % of the drive force
(K_t I = 20 N/A x 0.5 A = 10 N: from sliding throughout to sticking most of each half period) and 0.5-3 %
noise; 12 blocks of 3 s at 2-60 Hz, 2 kHz. A hit: the diagnosis adds exactly ``coulomb_friction``, says
"explained", and finds F_c and the mass within 5 %.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import as_commands  # noqa: F401  (BLAS on one thread, as the commands run it)
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "reference"))

from independent_stick_slip import write_recording  # noqa: E402

from plant import stage_x  # noqa: E402
from plant.data.read_stepped_sine import read_recording  # noqa: E402
from plant.diagnose.diagnosis import diagnose  # noqa: E402
from plant.estimate.lockin import estimate_response  # noqa: E402

FORCE_N = 10.0
TOLERANCE = 0.05


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=16)
    parser.add_argument("--seed", type=int, default=5)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    rows, hits, times = [], 0, []
    print(f"{'#':>3} {'F_c/F':>6} {'mass':>6} {'damping':>8} {'noise':>6}  {'found':24} {'verdict':14} "
          f"{'F_c err':>8} {'mass err':>8} {'chi2':>6} {'s':>5}")
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.n):
            share, mass, damping = rng.uniform(0.05, 0.95), rng.uniform(25, 50), rng.uniform(200, 800)
            noise = rng.uniform(0.005, 0.03)
            path = write_recording(Path(tmp) / f"rec{i}.csv", f_hz=np.geomspace(2.0, 60.0, 12), mass_kg=mass,
                                   damping_n_s_per_m=damping, friction_n=share * FORCE_N, duration_s=3.0,
                                   noise_fraction=noise, seed=i)
            t0 = time.perf_counter()
            diag = diagnose(stage_x(), estimate_response(read_recording(path)))
            elapsed = time.perf_counter() - t0
            values = diag.final.values
            fc_err = values.get("coulomb_friction.force_n", 0.0) / (share * FORCE_N) - 1
            mass_err = values["mass_kg"] / mass - 1
            hit = (diag.added == ("coulomb_friction",) and diag.verdict == "explained"
                   and abs(fc_err) < TOLERANCE and abs(mass_err) < TOLERANCE)
            hits += hit
            times.append(elapsed)
            rows.append((fc_err, mass_err, diag.final.reduced_chi2))
            print(f"{i:3d} {share:6.2f} {mass:6.1f} {damping:8.0f} {noise:6.3f}  {'+'.join(diag.added) or 'none':24} "
                  f"{diag.verdict:14} {fc_err:+8.2%} {mass_err:+8.2%} {diag.final.reduced_chi2:6.2f} {elapsed:5.1f}"
                  f"{'' if hit else '  MISS'}")
    fc, ms, chi = (np.abs(np.array(c)) for c in zip(*rows))
    print(f"\nhit rate            {hits}/{args.n} = {hits / args.n:.0%}")
    print(f"|F_c error|         median {np.median(fc):.2%}, max {np.max(fc):.2%}")
    print(f"|mass error|        median {np.median(ms):.2%}, max {np.max(ms):.2%}")
    print(f"reduced chi-square  median {np.median(chi):.2f}, max {np.max(chi):.2f}")
    print(f"diagnose seconds    mean {np.mean(times):.1f}, max {np.max(times):.1f}")


if __name__ == "__main__":
    main()
