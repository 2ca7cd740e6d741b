"""How much the designs with drive filters depend on rounding: the joint step (IPOPT on the gains and the
filter parameters together, ``design.synth.exact.exact_design(..., design_filters=True)``) is started from
gains moved by a relative ``eps`` (1e-12 is a few units in the last place) and the whole synthesis is run
to its verified result, for each bundled spec that designs filters.

Run:  python benchmarks/bench_joint_sensitivity.py [--eps 0,1e-12,-1e-12,1e-9,-1e-9] [--spec PATH ...]

A robust design step gives the same worst-case bandwidth for every ``eps``; the spread printed at the end
(largest over smallest) is 1 then. Each synthesis takes 20-40 s on a 2-core machine.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from unittest import mock

import design.synth.pi as pi
from design.workflows import load_problem

ROOT = Path(__file__).resolve().parents[1]
SPECS = ("specs/stage_x_resonant_payload.toml", "specs/stage_x_resonant_motor.toml")


def _synthesise(spec: str, eps: float):
    """The synthesis of ``spec`` with the joint step's starting kp and ki times (1 + eps)."""
    exact = pi.exact_design

    def moved(problem, scenarios, kp0, ki0, **options):
        if options.get("design_filters"):
            kp0, ki0 = kp0 * (1 + eps), ki0 * (1 + eps)
        return exact(problem, scenarios, kp0, ki0, **options)

    with mock.patch.object(pi, "exact_design", moved):
        return pi.synthesise_pi(load_problem(ROOT / spec).loop)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--eps", type=lambda text: [float(v) for v in text.split(",")],
                        default=[0.0, 1e-12, -1e-12, 1e-9, -1e-9], help="relative moves, comma-separated")
    parser.add_argument("--spec", nargs="+", default=list(SPECS))
    args = parser.parse_args()
    for spec in args.spec:
        print(f"{spec}\n  {'eps':>8}  {'status':8} {'bandwidth Hz':>12}  {'s':>5}  joint IPOPT solves", flush=True)
        found = []
        for eps in args.eps:
            t0 = time.perf_counter()
            r = _synthesise(spec, eps)
            bw = r.evaluation.worst_bandwidth_hz if r.status == "optimal" else float("nan")
            found.append(bw)
            joint = ", ".join(j.ipopt for j in r.record.joint_exact or ())
            print(f"  {eps:>8.0e}  {r.status:8} {bw:12.4f}  {time.perf_counter() - t0:5.1f}  {joint}", flush=True)
        print(f"  spread (largest / smallest worst-case bandwidth): {max(found) / min(found):.3f}\n", flush=True)


if __name__ == "__main__":
    main()
