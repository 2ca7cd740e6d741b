"""``gantry report``: a self-contained HTML design report (and optionally a PDF)."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from design.cli.common import ColumnsOption, PlantFromOption, SampleRateHzOption, keep_inputs
from plant.host.files import is_stdout


def report(
    spec_file: Annotated[Path, typer.Argument(metavar="SPEC", help="Spec file (TOML).")],
    out: Annotated[Path, typer.Option(help="Output HTML file (- for standard output).")],
    data: Annotated[Optional[list[Path]], typer.Option(
        "--data", help="Recording(s) to compare with the model and diagnose (repeatable).")] = None,
    columns: ColumnsOption = None,
    sample_rate_hz: SampleRateHzOption = None,
    samples: Annotated[Optional[int], typer.Option(
        help="Monte Carlo draws over payload x the spec's plant.uncertainty, the report's one Monte Carlo (0: "
             "none; default the spec's verification.monte_carlo_samples, the synthesis' own check).",
        min=0, max=100000)] = None,
    seed: Annotated[Optional[int], typer.Option(
        help="Seed of the Monte Carlo draws (default the spec's verification.seed).", min=0)] = None,
    pdf: Annotated[bool, typer.Option("--pdf", help="Also write a PDF next to the HTML (needs Chromium).")] = False,
    synthesise: Annotated[bool, typer.Option(
        "--synth/--no-synth", help="Synthesise the gains (default when the plant has a delay, lag, sampling or "
                                   "resonance); otherwise report the spec's controller values.")] = True,
    schedule: Annotated[bool, typer.Option("--schedule", help="Also the gains per payload (the PI schedule, and "
                                                              "the admittance designed per payload).")] = False,
    plant_from: PlantFromOption = None,
) -> None:
    """Write a design report: summary, plant, Bode/Nyquist/step, margins vs payload, data, reproducibility."""
    from design.views.progress import StageProgress
    from design.views.report import design_report
    from design.workflows import load_problem, report_content

    if pdf and is_stdout(out):
        from plant.errors import ParameterError

        raise ParameterError("--pdf: the PDF is written beside the HTML file; give --out FILE.html")
    keep_inputs({"--out": out, "--pdf": out.with_suffix(".pdf") if pdf else None},
                [spec_file, plant_from, *(data or [])])
    problem = load_problem(spec_file, plant_from=plant_from)
    progress = StageProgress(enabled=sys.stderr.isatty())
    try:
        if problem.spec.dual_drive is not None:
            from design.views.dual_report import dual_report
            from design.workflows import design, dual_report_content

            if data:
                from plant.errors import ParameterError

                raise ParameterError("--data: a [dual_drive] report compares no recordings yet")
            outcome = design(problem, progress=progress)
            content = dual_report_content(outcome, command="gantry " + shlex.join(sys.argv[1:]), progress=progress)
            progress("drawing the report")
            report = dual_report(content)
        else:
            content = report_content(problem, synthesise=synthesise, data=data or (), columns=columns,
                                     sample_rate_hz=sample_rate_hz, samples=samples, seed=seed,
                                     command="gantry " + shlex.join(sys.argv[1:]), progress=progress,
                                     schedule=schedule)
            progress("drawing the figures")
            report = design_report(content)
    finally:
        progress.close()
    _write(report, out, pdf)


def _write(report, out: Path, pdf: bool) -> None:
    """The HTML report, and with ``pdf`` its PDF beside it: both written or neither."""
    from plant.host.files import atomic_write_texts

    html = report.render()
    files: dict[Path, str | bytes] = {out: html}
    if pdf:
        from design.views.browser import html_to_pdf

        files[out.with_suffix(".pdf")] = html_to_pdf(html)
    done = f"report written to {out}" + (f" and {out.with_suffix('.pdf')}" if pdf else "")
    atomic_write_texts(files)
    if not is_stdout(out):
        print(done)         # plain: after the files, as few calls as possible
