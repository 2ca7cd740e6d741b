"""Planar mouse run benchmark: the tool's run (``design.admittance.planar_run``, classical Runge-Kutta per drive
tick) against the independent reference (``tests/reference/independent_planar_run.py``, Newton's planar equations
integrated by scipy's DOP853 tick to tick), side by side in one process, on the bundled specs' machine with the
bundled designs' gains (40 kg on the carriage, mid-beam, both axes' laws at 100 Hz, 4 kHz drives).

Run:  python benchmarks/bench_planar_run.py [--quick]

Prints, for a diagonal run and a run with a quarter turn (the spec's trapezoid; ``--quick``: a 0.1 m travel):
each simulator's wall and CPU seconds (``time.process_time``), their ratio, and the largest difference of the
sensed force between them against its peak. And the command as a user runs it (``gantry planar-run``, a fresh
process under ``/usr/bin/time``: wall, CPU, peak memory).
"""

import json
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "reference"))
sys.path.insert(0, str(ROOT / "tests" / "design" / "admittance"))
QUICK = "--quick" in sys.argv
X_SPEC, Y_SPEC = ROOT / "specs" / "stage_x_admittance.toml", ROOT / "specs" / "stage_y_admittance.toml"
#: the bundled designs' gains (gantry synth --json on the two specs)
X_GAINS = {"kp": 199.94, "ki": 18.54, "m_v": 0.04193, "b_v": 5.019}
Y_DESIGN = {"structure": "common_differential", "m_v": 1.2052, "b_v": 13.312,
            "gains": {"kp_common": 219.77, "ki_common": 18957.0, "kp_differential": 191.20, "ki_differential": 1.0}}


def timed(fn):
    wall, cpu = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - wall, time.process_time() - cpu


def main() -> None:
    from test_planar_run import _reference

    from design.admittance.planar_path import diagonal_path, turn_path
    from design.admittance.planar_run import planar_settings, simulate_planar_run
    from design.loop.controller import PI
    from design.loop.dual import CommonDifferential
    from design.workflows import load_problem

    x, y = load_problem(X_SPEC).loop, load_problem(Y_SPEC)
    s = planar_settings(x, y, x_controller=PI(X_GAINS["kp"], X_GAINS["ki"]),
                        x_virtual=(X_GAINS["m_v"], X_GAINS["b_v"]),
                        y_controller=CommonDifferential(**Y_DESIGN["gains"]),
                        y_virtual=(Y_DESIGN["m_v"], Y_DESIGN["b_v"]))
    loc = x.admittance.locomotion
    if QUICK:
        loc = replace(loc, travel_m=0.1)
    for name, path in (("diagonal 45 deg", diagonal_path(loc, s.drive_rate_hz, rest_s=0.2)),
                       ("quarter turn", turn_path(loc, s.drive_rate_hz, radius_m=0.02 if QUICK else 0.05, rest_s=0.2))):
        tool, tw, tc = timed(lambda: simulate_planar_run(s, path))
        (_, fs, _), rw, rc = timed(lambda: _reference(s, path))
        peak = float(np.max(np.abs(fs)))
        diff = float(np.max(np.abs(tool.sensed_force_n - fs)))
        print(f"{name}: {path.time_s.size} drive ticks; tool {tw:.2f} s wall {tc:.2f} s CPU, reference {rw:.2f} s "
              f"wall {rc:.2f} s CPU (tool / reference CPU {tc / rc:.3f}); sensed force differs by {diff:.2e} N at "
              f"most, {diff / peak:.1e} of its peak {peak:.3f} N")
    with tempfile.TemporaryDirectory() as tmp:
        xd, yd, times = Path(tmp) / "x.json", Path(tmp) / "y.json", Path(tmp) / "time.txt"
        xd.write_text(json.dumps({"gains": X_GAINS}))
        yd.write_text(json.dumps({"admittance": Y_DESIGN}))
        wall = time.perf_counter()
        r = subprocess.run(["/usr/bin/time", "-f", "%U %S %M", "-o", str(times), sys.executable, "-m", "design",
                            "planar-run", str(X_SPEC), str(Y_SPEC), "--x-design", str(xd), "--y-design", str(yd),
                            "--json"], capture_output=True, text=True)
        wall = time.perf_counter() - wall
        user, system, rss = times.read_text().split()[-3:]
        d = json.loads(r.stdout)
        print(f"gantry planar-run (the spec's diagonal, exit {r.returncode}): {wall:.2f} s wall, "
              f"{float(user) + float(system):.2f} s CPU, {int(rss) / 1024:.0f} MB; force felt "
              f"{d['peak_force_n']:.3f} N, {d['peak_lateral_force_n']:.3f} N sideways")


if __name__ == "__main__":
    main()
