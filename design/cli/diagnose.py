"""``gantry diagnose``: compare model and measurement, find the missing effect, add it, watch the error fall."""

from __future__ import annotations

import hashlib
import shlex
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from design.cli.common import (
    BandHzOption,
    DecimateBandHzOption,
    FilterHzOption,
    FrfOption,
    InputHoldOption,
    SetOption,
    console,
    parse_band,
    parse_set,
)
from design.views.console import print_diagnosis, print_time_diagnosis
from design.views.json import print_json
from plant import __version__
from plant.errors import ParameterError

BASE_FREE = ("mass_kg", "damping_n_s_per_m")


def _read(path: Path, columns: str | None, sample_rate_hz: float | None):
    from plant.recording_io import parse_column_map
    from plant.time_recording_io import read_measurement

    return read_measurement(path, columns=parse_column_map(columns) if columns else None,
                            sample_rate_hz=sample_rate_hz)


def _measure(path: Path, columns: str | None, sample_rate_hz: float | None):
    from plant.lockin import estimate_response
    from plant.time_recording import TimeRecording

    rec = _read(path, columns, sample_rate_hz)
    if isinstance(rec, TimeRecording):
        raise ParameterError(f"{path}: a time-domain recording; --amplitude-files takes stepped sines")
    return estimate_response(rec)


def diagnose(
    data: Annotated[Path, typer.Argument(
        help="Stepped-sine (.csv, .xlsx, .tdms) or time-domain recording (.csv without frequency_hz, .mat).")],
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
        help="Column map: spreadsheets/TDMS frequency=2,current=3,velocity=6,velocity=7; time-domain CSV/.mat "
             "time=t,current=vir,position=qm,reference=qg.")] = None,
    sample_rate_hz: Annotated[Optional[float], typer.Option(help="Sample rate when the file has no time column.")]
    = None,
    set_values: SetOption = None,
    filter_hz: FilterHzOption = 100.0,
    decimate_band_hz: DecimateBandHzOption = 40.0,
    frf: FrfOption = None,
    band_hz: BandHzOption = None,
    input_hold: InputHoldOption = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    report: Annotated[Optional[Path], typer.Option(help="Write an HTML diagnosis report here.")] = None,
) -> None:
    """Compare a recording with the thesis model, rank the missing effects and add the justified ones."""
    from design.views.diagnosis import diagnosis_report
    from design.views.json import diagnosis_to_dict
    from plant.diagnosis import diagnose as run_diagnosis
    from plant.effects import EFFECTS
    from plant.frf_estimation import estimate_frf
    from plant.inverse_model import Preprocessing
    from plant.lockin import amplitude_dependence, estimate_response
    from plant.models import Plant
    from plant.time_recording import TimeRecording

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
    base = Plant(stage, **geometry).with_values(parse_set(set_values))
    recording = _read(data, columns, sample_rate_hz)
    if isinstance(recording, TimeRecording) and frf is None:
        if amplitude_files or fit_force_constant:
            raise ParameterError("--amplitude-files and --fit-force-constant apply to stepped sines; a time-domain "
                                 "fit needs the force constant set (--set force_constant_n_per_a=...)")
        _diagnose_time(base, recording, candidates, Preprocessing(filter_hz, decimate_band_hz, input_hold), data,
                       stage, report, as_json)
        return
    if isinstance(recording, TimeRecording):
        measured = estimate_frf(recording, method=frf, **parse_band(band_hz))
    else:
        measured = estimate_response(recording)
    dependent = None
    if amplitude_files:
        others = [_measure(p, columns, sample_rate_hz) for p in amplitude_files]
        dependent = bool(amplitude_dependence([measured, *others]).significant)
    free = BASE_FREE + (("force_constant_n_per_a",) if fit_force_constant else ())
    diag = run_diagnosis(base, measured, candidates=candidates, free_base=free,
                         amplitude_dependent=dependent)
    if report is not None:
        diagnosis_report(diag, measured, title=f"Diagnosis of {data.name} (Stage {stage.upper()})",
                         provenance=_provenance(data)).write(report)
    if as_json:
        print_json(diagnosis_to_dict(diag))
        return
    print_diagnosis(console, diag)
    if report is not None:
        console.print(f"report written to {report}")




def _provenance(data: Path) -> str:
    digest = hashlib.sha256(data.read_bytes()).hexdigest()[:16]
    return f"gantry {__version__}\ncommand: gantry {shlex.join(sys.argv[1:])}\ndata: {data} (sha256 {digest}...)"


def _diagnose_time(base, recording, candidates, prep, data: Path, stage: str, report: Path | None,
                   as_json: bool) -> None:
    """The time-domain diagnosis (``plant.time_diagnosis``): text, JSON and HTML report."""
    from design.views.json import time_diagnosis_to_dict
    from design.views.time_diagnosis import time_diagnosis_report
    from plant.time_diagnosis import diagnose_time

    diag = diagnose_time(base, recording, candidates=candidates, prep=prep)
    if report is not None:
        time_diagnosis_report(diag, title=f"Diagnosis of {data.name} (Stage {stage.upper()}, time domain)",
                              provenance=_provenance(data)).write(report)
    if as_json:
        print_json(time_diagnosis_to_dict(diag))
        return
    print_time_diagnosis(console, diag)
    if report is not None:
        console.print(f"report written to {report}")
