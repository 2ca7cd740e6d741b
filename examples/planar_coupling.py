"""Where X and Y meet: simulate a stepped sine of the X motor on a planar gantry whose beam is skewed (or whose
carriage's centre of mass sits off the X motor's line), with every encoder recorded, then find the error.

Run:  python examples/planar_coupling.py [--skew-mrad 2] [--offset-mm 0] [--out coupling_x.csv]

The recording (``plant.experiment.planar_recording``: 2-120 Hz, 1 A, the carriage 0.28 m from Y1) is written as a
CSV that ``gantry coupling REC --carriage-m 0.28`` reads as it would a measured one; the diagnosis
(``plant.diagnose.coupling``) is told the machine's mechanics but not the error.
"""

import argparse

import numpy as np
from rich.console import Console

from design.views.console import print_story
from plant.data.writers import write_recording_csv
from plant.diagnose.coupling import diagnose_coupling
from plant.estimate.lockin import estimate_response
from plant.experiment.planar_recording import x_motor_recording
from plant.physics.planar import PlanarGantry

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--skew-mrad", type=float, default=2.0)
parser.add_argument("--offset-mm", type=float, default=0.0)
parser.add_argument("--out", default=None, help="also write the recording here (CSV)")
args = parser.parse_args()

POSITION = 0.28
truth = PlanarGantry(beam_skew_rad=args.skew_mrad * 1e-3, carriage_offset_m=args.offset_mm * 1e-3)
recording = x_motor_recording(truth, POSITION, np.geomspace(2.0, 120.0, 10), seed=1)
if args.out:
    write_recording_csv(recording, args.out)
print_story(Console(), diagnose_coupling(estimate_response(recording), PlanarGantry(), POSITION).story())
