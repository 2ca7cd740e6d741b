"""``gantry diagnose``: compare model and measurement, find the missing effect, add it, watch the error fall."""

from __future__ import annotations

import hashlib
import shlex
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.table import Table

from design.cli import app, console, print_json
from plant import __version__
from plant.errors import ParameterError

BASE_FREE = ("mass_kg", "damping_n_s_per_m")


def _measure(path: Path, columns: str | None, sample_rate_hz: float | None):
    from plant.lockin import estimate_response
    from plant.recording_io import parse_column_map, read_recording

    rec = read_recording(path, columns=parse_column_map(columns) if columns else None, sample_rate_hz=sample_rate_hz)
    return estimate_response(rec)


@app.command()
def diagnose(
    data: Annotated[Path, typer.Argument(help="Stepped-sine recording (.csv, .xlsx, .tdms).")],
    stage: Annotated[str, typer.Option(help="Stage of the recording: x or y.")],
    amplitude_files: Annotated[Optional[list[Path]], typer.Option(
        "--amplitude-files", help="Recordings of the same frequencies at other amplitudes (repeatable).")] = None,
    load_position_m: Annotated[Optional[float], typer.Option(
        help="Stage Y: load position along the beam from rail Y1 (m); default thesis 0.4 (centred).")] = None,
    motor_length_m: Annotated[Optional[float], typer.Option(help="Stage Y: beam/motor length L (m); default 0.8.")]
    = None,
    fit_force_constant: Annotated[bool, typer.Option(
        "--fit-force-constant", help="Also fit the force constant (it trades off against mass and damping).")]
    = False,
    effects: Annotated[Optional[str], typer.Option(
        help="Candidate effects to try (comma list); default: every effect of the library.")] = None,
    columns: Annotated[Optional[str], typer.Option(
        help="Column map for spreadsheets/TDMS, e.g. frequency=2,current=3,velocity=6,velocity=7.")] = None,
    sample_rate_hz: Annotated[Optional[float], typer.Option(help="Sample rate when the file has no time column.")]
    = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    report: Annotated[Optional[Path], typer.Option(help="Write an HTML diagnosis report here.")] = None,
) -> None:
    """Compare a recording with the thesis model, rank the missing effects and add the justified ones."""
    from design.diagnosis_view import diagnosis_report, diagnosis_to_dict
    from plant.diagnosis import diagnose as run_diagnosis
    from plant.effects import EFFECTS
    from plant.lockin import amplitude_dependence
    from plant.models import Plant

    if stage not in ("x", "y"):
        raise ParameterError(f"--stage must be x or y, got {stage!r}")
    candidates = None
    if effects:
        candidates = tuple(e.strip() for e in effects.split(",") if e.strip())
        unknown = [e for e in candidates if e not in EFFECTS]
        if unknown:
            raise ParameterError(f"--effects: unknown effect {unknown[0]!r}; known: {', '.join(EFFECTS)}")
    geometry = {k: v for k, v in (("load_position_m", load_position_m), ("motor_length_m", motor_length_m))
                if v is not None}
    measured = _measure(data, columns, sample_rate_hz)
    dependent = None
    if amplitude_files:
        others = [_measure(p, columns, sample_rate_hz) for p in amplitude_files]
        dependent = bool(amplitude_dependence([measured, *others]).significant)
    free = BASE_FREE + (("force_constant_n_per_a",) if fit_force_constant else ())
    diag = run_diagnosis(Plant(stage, **geometry), measured, candidates=candidates, free_base=free,
                         amplitude_dependent=dependent)
    if report is not None:
        digest = hashlib.sha256(data.read_bytes()).hexdigest()[:16]
        provenance = (f"gantry {__version__}\ncommand: gantry {shlex.join(sys.argv[1:])}\n"
                      f"data: {data} (sha256 {digest}...)")
        diagnosis_report(diag, measured, title=f"Diagnosis of {data.name} (Stage {stage.upper()})",
                         provenance=provenance).write(report)
    if as_json:
        print_json(diagnosis_to_dict(diag))
        return
    console.print(f"[bold]Verdict:[/] {diag.explanation}")
    console.print(f"[bold]Where the base model fails:[/] {diag.steps[0].residuals.description}")
    console.print(f"[bold]Nonlinearity:[/] {diag.nonlinearity.description}")
    t = Table(title="Candidates tried on the base model")
    for col in ("effect", "dBIC", "reduced chi2", "note"):
        t.add_column(col, justify="left" if col in ("effect", "note") else "right")
    for c in diag.steps[0].ranking:
        t.add_row(c.effect, "" if c.skipped else f"{c.delta_bic:+.1f}",
                  "" if c.skipped else f"{c.reduced_chi2:.3g}", c.skipped)
    console.print(t)
    t = Table(title="The error, step by step")
    for col in ("model", "reduced chi2", "RMS mag dB", "RMS phase deg", "BIC"):
        t.add_column(col, justify="left" if col == "model" else "right")
    for s in diag.steps:
        t.add_row(" + ".join(("base",) + s.effects), f"{s.fit.reduced_chi2:.3g}", f"{s.rms_magnitude_error_db:.3f}",
                  f"{s.rms_phase_error_deg:.2f}", f"{s.fit.bic:.1f}")
    console.print(t)
    for s in diag.steps:
        console.print(f"  -> {s.decision}")
    if diag.alternatives:
        t = Table(title="Models within dBIC 10 of the selected one")
        for col in ("model", "dBIC", "reduced chi2", "relation"):
            t.add_column(col, justify="right" if col in ("dBIC", "reduced chi2") else "left")
        for a in diag.alternatives:
            t.add_row(" + ".join(a.effects) or "base", f"{a.delta_bic:+.1f}", f"{a.reduced_chi2:.3g}", a.note)
        console.print(t)
    final = diag.final
    console.print(f"[bold]{'Final' if diag.verdict == 'explained' else 'Best (not explained)'} effects:[/] "
                  f"{', '.join(diag.final_effects) or 'none'}")
    modes = final.plant.modes_hz()
    if modes.size:
        console.print(f"  mechanical modes: {', '.join(f'{m:.4g} Hz' for m in modes)}")
    for name, value in final.values.items():
        err = final.stderr.get(name)
        console.print(f"  {name:32s} {value:.6g}" + (f" +/- {err:.2g}" if err is not None else " (fixed)"))
    for note in diag.notes:
        console.print(f"[yellow]Note:[/] {note}")
    if report is not None:
        console.print(f"report written to {report}")


