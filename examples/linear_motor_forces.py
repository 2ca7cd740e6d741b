"""Find a linear motor's position-dependent forces, add them, watch the error fall, and compensate them.

Run:  python examples/linear_motor_forces.py [OUT_DIR]

A linear-motor axis of the independent simulator of the tests (tests/reference/independent_linear_motor.py,
which shares no code with the tool) has a force constant that falls off towards the ends of its magnet track
(-30 % at the ends of a 0.3 m track) and a 3 N force ripple at a 20 mm pitch; nobody tells the tool. A slow
sweep over 0.17 m of travel, current command and position recorded (OUT_DIR/sweep.csv), goes to the
time-domain diagnosis (``gantry diagnose OUT_DIR/sweep.csv --stage x --compensation OUT_DIR/table.csv`` does
the same), which names both, adds them one at a time while the error falls, and exports the drive's
compensation table. The simulated drive then applies the table and the diagnosis of a new sweep finds nothing
missing.
"""

import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "reference"))

import independent_linear_motor as lm  # noqa: E402

from plant import stage_x  # noqa: E402
from plant.data.read import read_measurement  # noqa: E402
from plant.diagnose.time_diagnosis import diagnose_time  # noqa: E402

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp())
out.mkdir(parents=True, exist_ok=True)
axis = lm.LinearMotorAxis(kt_droop=0.3, travel_m=0.3, ripple_n=(3.0,), ripple_phase_rad=(0.4,), ripple_pitch_m=0.02)


def sweep(path: Path, seed: int, drive=None):
    t, current, position = lm.slow_sweep(axis, seed=seed, drive=drive)
    np.savetxt(path, np.column_stack([t, current, position]), delimiter=",", header="time_s,current_a,position_m",
               comments="", fmt="%.9g")
    return diagnose_time(stage_x(), read_measurement(path))


diag = sweep(out / "sweep.csv", seed=1)
print(f"Verdict: {diag.explanation}\n")
print("The error, step by step:")
for step in diag.steps:
    model = " + ".join(("base",) + step.effects)
    print(f"  {model:46s} rms residual {step.fit.rms_residual:6.3f} N  ({step.decision})")
print("\nFitted:")
for name, value in diag.final.values.items():
    print(f"  {name:36s} {value:.5g}")
table = diag.compensation()
table.write(out / "table.csv")
print(f"\nCompensation table: {out / 'table.csv'} ({table.position_m.size} points over "
      f"{table.position_m[0]:.3f}..{table.position_m[-1]:.3f} m): removes {table.removed_rms_n:.3g} N rms, leaves "
      f"{table.residual_rms_n:.3g} N rms")

x, scale, offset = np.loadtxt(out / "table.csv", delimiter=",", comments="#", skiprows=2).T
after = sweep(out / "compensated.csv", seed=2,
              drive=lambda command, position: np.interp(position, x, scale) * command + np.interp(position, x, offset))
print(f"\nWith the table in the drive: {after.explanation}")
print(f"rms residual of the base model: {diag.steps[0].fit.rms_residual:.3g} N without the table, "
      f"{after.steps[0].fit.rms_residual:.3g} N with it")
