"""The tool from Python, as a notebook uses it: a recording -> its frequency response -> the missing effect
-> a fit -> a robust design -> python-control models, MATLAB files, a figure and the report.

Run:  python examples/notebook_api.py [OUT_DIR]      (about 20 s; OUT_DIR defaults to a new temporary folder)

Every step is one call into ``design.workflows`` or a typed result's method (``docs/api.md``).
"""

import sys
import tempfile
from pathlib import Path

import numpy as np

from design.views.mat import write_design_mat, write_response_mat
from design.views.report import design_report
from design.workflows import design, diagnose_recording, fit_recording, load_problem, measure, report_content
from plant import Delay, stage_x
from plant.data.writers import write_recording_csv
from plant.experiment.simulate import simulate_stepped_sine

ROOT = Path(__file__).resolve().parents[1]
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="gantry_"))
out.mkdir(parents=True, exist_ok=True)

# 1. A stepped-sine recording. Here a simulated one: Stage X at 30 kg with a 1 ms drive delay that the
#    steps below are not told about (a real one is read the same way: CSV, xlsx, TDMS, .mat).
truth = stage_x(mass_kg=30.0) * Delay(0.001)
recording = simulate_stepped_sine(truth, f_hz=np.geomspace(2.0, 120.0, 12), current_amplitude_a=0.5,
                                  duration_s=1.5, noise_fraction=0.01, seed=4)
write_recording_csv(recording, out / "rec.csv")

# 2. Its frequency response (lock-in per block, with variances), also as a MATLAB file.
response = measure(out / "rec.csv")
write_response_mat(response, out / "response.mat")
print(f"frequency response: {response.f_hz.size} lines, {response.f_hz[0]:.3g}-{response.f_hz[-1]:.3g} Hz")

# 3. What the thesis model misses.
found = diagnose_recording(out / "rec.csv", stage="x").diagnosis
print(f"diagnosis: {found.verdict}; effects added: {', '.join(found.added) or 'none'}")

# 4. The plant with those effects, fitted.
fit = fit_recording(out / "rec.csv", stage="x", effects=tuple(found.final_effects)).result
print("fit: " + ", ".join(f"{n} = {fit.values[n]:.4g} +/- {fit.stderr[n]:.2g}" for n in fit.free))

# 5. Robust PI gains for the bundled Stage X spec (5-40 kg, its uncertainty), verified.
problem = load_problem(ROOT / "specs" / "stage_x_synth.toml")
outcome = design(problem)
controller = outcome.controller          # a design.loop.controller.PI: .kp, .ki, .frd(w), .tf(), .discrete(T)
print(f"design: {outcome.status}, {controller}, verified: {outcome.verified}")

# 6. The loop as python-control models (P, C, L, S, T; balanced state space, the delay a Pade of order 6).
loops = outcome.loop_models()
gm_db, pm_deg = loops.margins()
print(f"python-control at {loops.payload_kg:g} kg: PM {pm_deg:.2f} deg, GM {gm_db:.2f} dB; "
      f"P has {loops.P.nstates} states")
loops.plot().savefig(out / "loop.png")
write_design_mat(outcome, out / "design.mat")

# 7. The design report (self-contained HTML).
design_report(report_content(problem, outcome=outcome)).write(out / "design.html")
print(f"written to {out}: rec.csv, response.mat, loop.png, design.mat, design.html")
