"""Reproduce the thesis model through the Python API and save its figures.

Run:  python examples/reproduce_thesis.py [OUT_DIR]
Writes bode_stage_x.png, bode_stage_y.png and payload_sweep.png (thesis Figures 3.13,
3.14 and 4.31) and prints Table 3.1 beside the computed values.
"""

import sys
from pathlib import Path

import numpy as np

from design.loop.analysis import payload_sweep
from design.loop.controller import PI
from design.loop.loops import closed_loop_frd, open_loop_frd
from design.loop.reproduce import table_3_1
from design.spec.schema import load_spec
from design.views.plots import payload_sweep_figure
from plant.bode import bode
from plant.grid import log_grid_rad_s

ROOT = Path(__file__).resolve().parents[1]
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("out")
out.mkdir(parents=True, exist_ok=True)

specs = {stage: load_spec(ROOT / "specs" / f"thesis_stage_{stage}.toml").problem() for stage in ("x", "y")}
for row in table_3_1(specs):
    print(f"{row.stage.upper()} {row.quantity:24s} thesis {row.thesis:7.2f}  computed {row.computed:7.2f} "
          f"{row.unit:4s} ({100 * row.relative_difference:+.1f} %)")

w = log_grid_rad_s(0.1, 1000.0, 800)
sweeps = []
for stage, spec in specs.items():
    plant = spec.plant.plant()
    kp, ki = spec.controller.kp.value, spec.controller.ki.value
    payloads = np.array([5.0, 20.0, 35.0])
    L = open_loop_frd(plant.with_payload(payloads), w, PI(kp, ki))
    fig = bode(w, [*L, *closed_loop_frd(L)],
               [f"loop, {m:g} kg" for m in payloads] + [f"closed loop, {m:g} kg" for m in payloads],
               styles=["-"] * 3 + ["--"] * 3, title=f"Stage {stage.upper()}: PI loop (thesis gains)")
    fig.savefig(out / f"bode_stage_{stage}.png", dpi=110)
    sweeps.append(payload_sweep(plant, PI(kp, ki), np.linspace(5, 40, 36)))
payload_sweep_figure(sweeps).savefig(out / "payload_sweep.png", dpi=110)
print(f"figures written to {out}/")
