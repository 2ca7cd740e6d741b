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
    ColumnsOption,
    DecimateBandHzOption,
    FilterHzOption,
    FrfOption,
    InputHoldOption,
    SampleRateHzOption,
    SetOption,
    console,
    keep_inputs,
    parse_band,
    parse_set,
)
from plant import __version__

BASE_FREE = ("mass_kg", "damping_n_s_per_m")


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
    columns: ColumnsOption = None,
    sample_rate_hz: SampleRateHzOption = None,
    set_values: SetOption = None,
    filter_hz: FilterHzOption = 100.0,
    decimate_band_hz: DecimateBandHzOption = 40.0,
    frf: FrfOption = None,
    band_hz: BandHzOption = None,
    input_hold: InputHoldOption = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    report: Annotated[Optional[Path], typer.Option(help="Write an HTML diagnosis report here.")] = None,
    compensation: Annotated[Optional[Path], typer.Option(
        help="Time-domain recording with position: write the drive's compensation table of the selected "
             "force_ripple / force_constant_profile here (CSV: position_m, current_scale, current_offset_a).")]
    = None,
) -> None:
    """Compare a recording with the thesis model, rank the missing effects and add the justified ones."""
    from design.views.console import print_diagnosis_outcome
    from design.views.json import diagnosis_outcome_to_dict, print_json
    from design.views.progress import LazyProgress
    from design.workflows import diagnose_recording
    from plant.identify.inverse_model import Preprocessing

    keep_inputs({"--report": report, "--compensation": compensation}, [data, *(amplitude_files or [])], json=as_json)
    candidates = tuple(e.strip() for e in effects.split(",") if e.strip()) if effects else None
    progress = LazyProgress(enabled=not as_json and sys.stderr.isatty(), label="diagnose", unit="models")
    try:
        outcome = diagnose_recording(
            data, stage=stage, candidates=candidates,
            values=parse_set(set_values), load_position_m=load_position_m, motor_length_m=motor_length_m,
            columns=columns, sample_rate_hz=sample_rate_hz, amplitude_files=tuple(amplitude_files or ()),
            fit_force_constant=fit_force_constant, frf=frf, band=parse_band(band_hz),
            prep=Preprocessing(filter_hz, decimate_band_hz, input_hold), progress=progress)
    finally:
        progress.close()
    files: dict[Path, str] = {}
    if compensation is not None:
        files[compensation] = _compensation_text(outcome)
    if report is not None:
        from design.views.diagnosis import diagnosis_html

        files[report] = diagnosis_html(outcome, title=f"Diagnosis of {data.name} (Stage {stage.upper()})",
                                       provenance=_provenance(data)).render()
    if as_json:
        print_json(diagnosis_outcome_to_dict(outcome))
    else:
        print_diagnosis_outcome(console, outcome)
    if files:       # the files last: a stop while the text prints leaves none behind
        from plant.host.files import atomic_write_texts, is_stdout

        done = "; ".join(f"{what} written to {path}" for what, path in (("compensation table", compensation),
                                                                         ("report", report))
                         if path is not None and not is_stdout(path))
        atomic_write_texts(files)
        if done and not as_json:
            print(done)


def _compensation_text(outcome) -> str:
    """The selected time-domain model's compensation table (CSV), or a ``ParameterError`` saying why there is
    none."""
    from plant.errors import ParameterError

    if not outcome.time_domain:
        raise ParameterError("--compensation: a compensation table comes from a time-domain recording with the "
                             "position (the frequency-domain diagnosis has no position-dependent force)")
    return outcome.diagnosis.compensation().csv_text()


def _provenance(data: Path) -> str:
    digest = hashlib.sha256(data.read_bytes()).hexdigest()[:16]
    return f"gantry {__version__}\ncommand: gantry {shlex.join(sys.argv[1:])}\ndata: {data} (sha256 {digest}...)"
