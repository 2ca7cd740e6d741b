"""Stage Y's two rails in a time recording: a hidden cause that makes the rails disagree, found from both rails.

Run:  python examples/two_rails_time.py [SEED] [--kind rail_scale|motor_imbalance|offset_load|none]

A seeded draw picks the hidden cause (``--kind`` chooses): encoder Y2 reading its rail 2-5 % long, the two motors'
force constants 5-15 % either side of their mean, or the 35 kg load 0.1-0.25 m off the beam's centre. A 20 s
chirp of 3 A, 0.3-12 Hz, is recorded (both rails' positions, 1 um of noise) by the independent simulator of the
tests (tests/reference/independent_two_rails.py: Lagrange's equations of the beam on its rails, sampled
exactly), which shares no code with the tool, and the time-domain diagnosis reads it as a user's recording would
be read. A force fit on the rails' mean sees none of it; the joint reading names it with its size.
"""

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from rich.console import Console

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "reference"))

import independent_dual_drive as dd  # noqa: E402
import independent_two_rails as tr  # noqa: E402

from design.views.console import print_story  # noqa: E402
from plant import stage_y  # noqa: E402
from plant.data.recordings import TimeRecording  # noqa: E402
from plant.diagnose.time_diagnosis import diagnose_time  # noqa: E402
from plant.identify.inverse_model import Preprocessing  # noqa: E402

KINDS = ["rail_scale", "motor_imbalance", "offset_load", "none"]
argv = sys.argv[1:]
kind = argv[argv.index("--kind") + 1] if "--kind" in argv else None
args = [a for i, a in enumerate(argv) if not a.startswith("--") and (i == 0 or not argv[i - 1].startswith("--"))]
seed = int(args[0]) if args else 7
rng = np.random.default_rng(seed)
kind = kind or str(rng.choice(KINDS))
if kind not in KINDS:
    sys.exit(f"--kind must be one of {', '.join(KINDS)}")
# the thesis's Stage Y as the tool has it: 35 kg, 440 N*s/m per rail, K_t = 20 N/A shared by the two motors
rig = dd.Rig(beam_mass_kg=0.0, beam_inertia_kg_m2=0.5, carriage_mass_kg=35.0, k1=10.0, k2=10.0)
y2_scale = 1.0
if kind == "rail_scale":
    y2_scale = 1 + rng.uniform(0.02, 0.05)
    words = f"encoder Y2 reads {100 * (y2_scale - 1):+.2f} % long"
elif kind == "motor_imbalance":
    d = rng.uniform(0.05, 0.15)
    rig = replace(rig, k1=10.0 * (1 - d), k2=10.0 * (1 + d))
    words = f"force constants {-100 * d:+.1f} % / {100 * d:+.1f} % on Y1 / Y2"
elif kind == "offset_load":
    offset = rng.uniform(0.1, 0.25)
    rig = replace(rig, carriage_position_m=0.4 + offset)
    words = f"load {offset:.2f} m off the beam's centre towards Y2"
else:
    words = "nothing"
t, current, y1, y2 = tr.chirp(rig, y2_scale=y2_scale, seed=seed)
rec = TimeRecording(t, current, np.vstack([y1, y2]), "position", ("position_y1_m", "position_y2_m"))
diag = diagnose_time(stage_y(), rec, prep=Preprocessing(input_hold=True))

print(f"(hidden from the diagnosis: seed {seed}, {words})\n")
print_story(Console(), diag.story())
print(f"\nverdict: {diag.verdict}; truth: {kind}")
if diag.rails.scale_claimed:
    print(f"rail_scale.y2_scale: {diag.rails.y2_scale:.5f} +/- {diag.rails.y2_scale_stderr:.2g} (true {y2_scale:.5f})")
if kind == "motor_imbalance":
    per, se = diag.rails.imbalance_per_stiffness
    true = (rig.k1 - rig.k2) / (rig.k1 + rig.k2)
    print(f"motor_imbalance.fraction: {per * rig.yaw_stiffness:+.4f} +/- {se * rig.yaw_stiffness:.2g} at the rig's yaw "
          f"stiffness {rig.yaw_stiffness:.0e} N*m/rad (true {true:+.4f})")
print(f"mass_kg: {diag.final.values['mass_kg']:.2f} (true 35.00), damping_n_s_per_m: "
      f"{diag.final.values['damping_n_s_per_m']:.1f} (true 440.0)")
