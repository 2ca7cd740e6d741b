"""``gantry report``: a self-contained HTML design report (and optionally a PDF)."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from design.cli.common import PlantFromOption, console


def report(
    spec_file: Annotated[Path, typer.Argument(metavar="SPEC", help="Spec file (TOML).")],
    out: Annotated[Path, typer.Option(help="Output HTML file.")],
    data: Annotated[Optional[list[Path]], typer.Option(
        "--data", help="Recording(s) to compare with the model and diagnose (repeatable).")] = None,
    samples: Annotated[Optional[int], typer.Option(
        help="Monte Carlo samples over the spec's plant.uncertainty (0: none; default 200 when the spec has "
             "uncertainty ranges, else 0).", min=0, max=100000)] = None,
    seed: Annotated[int, typer.Option(help="Seed of the Monte Carlo samples.")] = 0,
    pdf: Annotated[bool, typer.Option("--pdf", help="Also write a PDF next to the HTML (needs Chromium).")] = False,
    synthesise: Annotated[bool, typer.Option(
        "--synth/--no-synth", help="Synthesise the gains (default when the plant has a delay, lag, sampling or "
                                   "resonance); otherwise report the spec's controller values.")] = True,
    plant_from: PlantFromOption = None,
) -> None:
    """Write a design report: summary, plant, Bode/Nyquist/step, margins vs payload, data, reproducibility."""
    from design.synth.pi import PHASE_LIMITING
    from design.views.json import design_to_dict
    from design.views.report import design_report
    from design.workflows import design, load_problem, measure
    from plant.errors import SpecError

    problem = load_problem(spec_file, plant_from=plant_from)
    spec = problem.spec
    if samples is None:
        samples = 200 if spec.plant.uncertainty else 0
    elif samples and not spec.plant.uncertainty:     # before any long computation
        raise SpecError(f"{spec_file}: plant.uncertainty: no parameter ranges to sample; add some or drop --samples")
    synthesis = None
    kp, ki, source = spec.controller.kp.value, spec.controller.ki.value, "from the spec's controller values"
    if synthesise and any(e in PHASE_LIMITING for e in spec.plant.effects):
        synthesis = design_to_dict(design(problem))
        if synthesis["status"] == "optimal":
            kp, ki = synthesis["gains"]["kp"], synthesis["gains"]["ki"]
            source = "synthesised" + (", independently verified" if synthesis["verified"] else ", NOT verified")
        else:
            source += f" (synthesis {synthesis['status']}: {synthesis['message']})"
    if kp is None or ki is None:
        raise SpecError(f"{spec_file}: no gains to report: synthesis did not succeed and controller.kp.value / "
                        "controller.ki.value are not set")
    recordings = []
    for path in data or []:
        from plant.diagnosis import diagnose

        measured = measure(path)
        recordings.append((path, measured, diagnose(spec.plant.plant(), measured)))
    rep = design_report(spec, spec_path=spec_file, kp=kp, ki=ki, gains_source=source, synthesis=synthesis,
                        recordings=recordings, command="gantry " + shlex.join(sys.argv[1:]), samples=samples,
                        seed=seed)
    rep.write(out)
    console.print(f"report written to {out}")
    if pdf:
        from design.views.browser import html_to_pdf

        html_to_pdf(out, out.with_suffix(".pdf"))
        console.print(f"PDF written to {out.with_suffix('.pdf')}")
