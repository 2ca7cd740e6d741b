"""Real measurements: fit and diagnose the EMPS benchmark (a motor-driven prismatic axis in closed
position loop, 1 kHz, 24.8 s; Janot, Gautier & Brunot 2019), bundled in ``examples/data/emps``.

    python examples/emps.py [--report emps.html]

Prints the inverse-model (IDIM-LS) and output-error fits of mass, viscous and Coulomb friction
and the constant force next to the published IDIM-LS values, then the diagnosis that starts from
the thesis's linear model (mass and damping) and adds what the data ask for, and how the damping
moves when the drive is assumed to hold each logged command for one sample.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from plant.data.read import parse_column_map, read_measurement
from plant.diagnose.time_diagnosis import diagnose_time
from plant.identify.inverse_model import Preprocessing
from plant.identify.time_fit import fit_inverse_model, fit_output_error
from plant.physics.effects import make_effect
from plant.physics.models import Plant

DATA = Path(__file__).resolve().parent / "data" / "emps" / "DATA_EMPS.mat"
#: the command is in V; its gain gtau (N/V) plays the force constant
FORCE_CONSTANT_N_PER_V = 35.15
#: Janot, Gautier & Brunot (2019), IDIM-LS on this file
PUBLISHED = {"mass_kg": 95.1089, "damping_n_s_per_m": 203.5034, "coulomb_friction.force_n": 20.3935,
             "offset.force_n": -3.1648}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--report", type=Path, help="write the diagnosis as an HTML report here")
    args = parser.parse_args()

    rec = read_measurement(DATA, columns=parse_column_map("time=t,current=vir,position=qm,reference=qg"))
    print(f"{DATA.name}: {rec.n_samples} samples at {rec.sample_rate_hz:.0f} Hz, {rec.duration_s:.1f} s, "
          f"closed loop (kp = {rec.metadata['mat_scalars']['kp']}, kv = {rec.metadata['mat_scalars']['kv']})")

    plant = Plant("x", force_constant_n_per_a=FORCE_CONSTANT_N_PER_V,
                  effects=(make_effect("coulomb_friction"), make_effect("offset")), excitation_current_a=1.0)
    idim = fit_inverse_model(plant, rec)
    oe = fit_output_error(plant, rec, start=idim)
    held = fit_inverse_model(plant, rec, prep=Preprocessing(input_hold=True))
    print(f"\n{'parameter':26s} {'published':>10s} {'IDIM-LS':>18s} {'deviation':>9s} {'output error':>13s} "
          f"{'IDIM, held input':>17s}")
    for name, ref in PUBLISHED.items():
        v, se = idim.values[name], idim.stderr[name]
        print(f"{name:26s} {ref:10.4g} {v:10.4g} +/- {se:<5.2g} {100 * (v - ref) / abs(ref):+8.2f}% "
              f"{oe.values[name]:13.4g} {held.values[name]:17.4g}")
    print(f"\nIDIM-LS residual {idim.rms_residual:.3g} N rms ({idim.relative_error_percent:.2f} % of the force); "
          f"output-error residual {oe.rms_residual:.3g} m/s rms")

    diag = diagnose_time(Plant("x", force_constant_n_per_a=FORCE_CONSTANT_N_PER_V), rec)
    print(f"\nDiagnosis from the thesis model: {diag.where_it_fails}\n  by direction: {diag.direction.description}")
    for step in diag.steps:
        print(f"  {' + '.join(('base',) + step.effects):40s} {step.fit.rms_residual:7.3g} N rms   {step.decision}")
    print(f"Verdict: {diag.explanation}")
    if args.report:
        from design.views.time_diagnosis import time_diagnosis_report

        time_diagnosis_report(diag, title="EMPS benchmark: time-domain diagnosis",
                              provenance=f"examples/emps.py on {DATA.name}").write(args.report)
        print(f"report written to {args.report}")


if __name__ == "__main__":
    main()
