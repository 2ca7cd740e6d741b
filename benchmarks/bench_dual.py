"""Two-motor Stage Y benchmark on ``specs/stage_y_dual.toml``: what a user waits for, and each structure's
scan against brute force on the same plants, side by side in one run.

Run:  python benchmarks/bench_dual.py [--quick]

* The command: ``gantry synth specs/stage_y_dual.toml --json`` in a fresh process under ``/usr/bin/time``:
  wall seconds, CPU seconds (user + system) and peak memory (max RSS); the median of 3 runs (1 with --quick).
* Stage Y admittance: ``gantry synth specs/stage_y_admittance.toml --json`` timed the same way (1 run), its
  virtual dynamics, force felt and Monte Carlo, and a brute force over (m_v, b_v): a log grid of N_ADM x N_ADM
  points a decade either side of the design, each judged by the exact check on the design plants x mice
  (``AdmittanceEvaluator`` on the structure's loops) and scored by the force the mouse feels; the ratio of the
  design's force to the best passing point's (<= 1: the design is at least as light).
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
ADMITTANCE_SPEC = ROOT / "specs" / "stage_y_admittance.toml"
QUICK = "--quick" in sys.argv
RUNS = 1 if QUICK else 3
N = 41 if QUICK else 81
N_ADM = 8 if QUICK else 12


def timed(spec: Path = SPEC) -> tuple[float, float, float, dict]:
    """(wall s, CPU s, peak MB, JSON) of the command in a fresh process."""
    with tempfile.NamedTemporaryFile(suffix=".time") as f:
        start = time.perf_counter()
        r = subprocess.run(["/usr/bin/time", "-f", "%U %S %M", "-o", f.name, sys.executable, "-m", "design", "synth",
                            str(spec), "--json"], capture_output=True, text=True)
        if r.returncode not in (0, 3):
            raise SystemExit(f"gantry synth {spec.name} failed: {r.stderr}")
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
        d, mc = row["between"]["worst"], row["monte_carlo"]
        print(f"  {row['structure']:20s} bandwidth {d['bandwidth_hz']:6.2f} Hz, PM {d['phase_margin_deg']:.2f} deg, "
              f"GM {d['gain_margin_db']:.2f} dB, common {d['common_phase_margin_deg']:.2f} deg / "
              f"{d['common_gain_margin_db']:.2f} dB, disk margin {d['disk_margin']:.3f}, yaw coupling "
              f"{d['yaw_coupling']:.3f} (over the box, between the grid's points too; designed "
              f"{row['design_rounds']} times); Monte Carlo {mc['n_failing']} of {mc['n_plants']} fail")
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
    req = dual.DualRequirements.of(spec.requirements)
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
    admittance()


def lightest_on_grid(ev, felt, m0: float, b0: float, n: int) -> tuple[float, float, float]:
    """(force felt, m_v, b_v) of the lightest point of an n x n log grid a decade either side of (m0, b0) that the
    exact check passes (``AdmittanceEvaluator.evaluate(...).meets``); inf and NaNs when none does."""
    best = (np.inf, np.nan, np.nan)
    for m in np.geomspace(m0 / 10, m0 * 10, n):
        for b in np.geomspace(b0 / 10, b0 * 10, n):
            f = felt(m, b)
            if f < best[0] and ev.evaluate(m, b, bandwidth=False).meets:
                best = (f, m, b)
    return best


def admittance() -> None:
    from design.admittance.dual import DualLoops
    from design.admittance.feel import FeltForce
    from design.admittance.model import AdmittanceEvaluator, mice
    from design.admittance.rig import RigTiming
    from design.loop.dual import BY_NAME
    from design.synth import dual
    from design.workflows import load_problem

    wall, cpu, mem, out = timed(ADMITTANCE_SPEC)
    a = out["admittance"]
    mc = a["monte_carlo"]
    print(f"gantry synth {ADMITTANCE_SPEC.name} --json: wall {wall:.1f} s, CPU {cpu:.1f} s, peak {mem:.0f} MB; "
          f"status {a['status']}; on {a['structure']}: m_v {a['m_v']:.4g} kg, b_v {a['b_v']:.4g} N*s/m, force felt "
          f"{a['mouse']['force_felt_peak_n']:.3g} N; worst PM {a['worst_phase_margin_deg']:.2f} deg, GM "
          f"{a['worst_gain_margin_db']:.2f} dB at carriage {a['worst_carriage_position_m']:.3g} m; Monte Carlo "
          f"{mc['violations']} of {mc['samples']} fail")
    problem = load_problem(ADMITTANCE_SPEC)
    spec, loop = problem.spec, problem.loop
    d = spec.dual_drive
    travel = d.carriage_position_m
    loops = DualLoops(BY_NAME[a["structure"]](**a["gains"]))
    plants = dual.dual_scenarios(spec.dual_model(), np.linspace(travel.min, travel.max, travel.points),
                                 d.stage_x_mass_kg + spec.plant.payload_kg.design_points(),
                                 {k: (v.min, v.max) for k, v in d.uncertainty.items()}, d.stage_x_mass_kg)
    feel = dual.dual_scenarios(spec.dual_model(), [travel.min, 0.5 * (travel.min + travel.max), travel.max],
                               d.stage_x_mass_kg + np.array([spec.plant.payload_kg.min, spec.plant.payload_kg.max]),
                               {}, d.stage_x_mass_kg)
    timing = RigTiming.of(loop.admittance.rig)
    corners = mice(loop)
    ev = AdmittanceEvaluator(loop, plants, loops=loops, timing=timing, corners=corners)
    felt = FeltForce(loop, feel, corners, loops=loops, timing=timing)
    start = time.perf_counter()
    best = lightest_on_grid(ev, felt, a["m_v"], a["b_v"], N_ADM)
    design = felt(a["m_v"], a["b_v"])
    print(f"  (m_v, b_v) brute force {N_ADM} x {N_ADM} on {len(plants)} design plants x {len(corners)} mice "
          f"({time.perf_counter() - start:.0f} s): best passing m_v {best[1]:.4g} kg, b_v {best[2]:.4g} N*s/m, force "
          f"felt {best[0]:.4f} N; the design {design:.4f} N; design / brute force {design / best[0]:.4f}")


if __name__ == "__main__":
    main()
