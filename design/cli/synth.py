"""``gantry synth``: robust PI gains by optimisation from a spec file, independently verified.

Exit status: 0 for a verified optimal design; 1 when there is no such design: the problem is
unbounded (nothing in the plant limits the bandwidth), infeasible (no gains meet the
requirements; the binding requirement and payload are named), or the design failed the
independent check (the output explains which); 2 for bad input (spec errors name the key); 3 for a
verified admittance design that the spec's mouse cannot drive on its locomotion profile
(``mouse_cannot_drive``: the force felt, the binding requirement and the trade-off are printed).
"""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from design.cli.common import PlantFromOption, console, keep_inputs
from plant.host.files import is_stdout


def synth(
    spec_file: Annotated[Path, typer.Argument(metavar="SPEC", help="Spec file (TOML).")],
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    report: Annotated[Optional[Path], typer.Option(help="Also write the HTML design report here.")] = None,
    method: Annotated[str, typer.Option(help="ccp (cvxpy + Clarabel) or ccp+exact (then casadi + IPOPT).")]
    = "ccp+exact",
    schedule: Annotated[bool, typer.Option("--schedule", help="Also per-payload gains (a gain schedule) and the "
                                                              "bandwidth they gain; with \\[admittance], the "
                                                              "admittance designed per payload and the force the "
                                                              "mouse feels with it.")] = False,
    plant_from: PlantFromOption = None,
) -> None:
    """Synthesise PI gains maximising worst-case bandwidth under margin constraints over the payload range."""
    from design.views.json import design_to_dict, print_json
    from design.views.progress import StageProgress
    from design.workflows import design, load_problem

    keep_inputs({"--report": report}, [spec_file, plant_from], json=as_json)
    problem = load_problem(spec_file, plant_from=plant_from)
    if problem.spec.dual_drive is not None and schedule:
        from plant.errors import ParameterError

        raise ParameterError(f"{spec_file}: a [dual_drive] design has no --schedule (one set of gains per "
                             "structure over the carriage travel)")
    progress = StageProgress(enabled=not as_json and sys.stderr.isatty())
    try:
        outcome = design(problem, method=method, schedule=schedule, progress=progress)
        out = design_to_dict(outcome)
        reportable = out["status"] in ("optimal", "mouse_cannot_drive")
        if report is not None and reportable and outcome.dual is not None:
            from design.views.dual_report import dual_report
            from design.workflows import dual_report_content

            content = dual_report_content(outcome, command="gantry " + shlex.join(sys.argv[1:]), progress=progress)
            progress("drawing the report")
            dual_report(content).write(report)
        elif report is not None and reportable and not problem.spec.plant.measured:
            from design.views.report import design_report
            from design.workflows import report_content

            content = report_content(problem, outcome=outcome, command="gantry " + shlex.join(sys.argv[1:]),
                                     progress=progress)
            progress("drawing the figures")
            design_report(content).write(report)
    finally:
        progress.close()
    from design.views.console import print_story
    from design.views.design_story import synthesis_story

    if as_json:
        print_json(out)
    else:
        print_story(console, synthesis_story(out))
        if report is not None and reportable and not is_stdout(report):
            console.print(f"report written to {report}")
    if report is not None and not reportable:
        typer.echo(f"no report written to {report}: no verified design", err=True)
    if out["status"] != "optimal":
        code = 3 if out["status"] == "mouse_cannot_drive" else 1
        if not as_json:
            console.print(f"[bold red]{out['status']}[/] (exit status {code})")
        raise typer.Exit(code)
