"""``gantry fit``: physical parameters of a plant with effects from a recording: a stepped sine in the
frequency domain, a time-domain recording (any excitation) by the inverse model or output error."""

from __future__ import annotations

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
    parse_band,
    parse_set,
)


def fit(
    data: Annotated[Path, typer.Argument(
        help="Stepped-sine (.csv, .xlsx, .tdms) or time-domain recording (.csv without frequency_hz, .mat).")],
    stage: Annotated[str, typer.Option(help="Stage of the recording: x or y.")],
    effects: Annotated[Optional[str], typer.Option(help="Effects to include, e.g. delay,current_loop.")] = None,
    free: Annotated[Optional[str], typer.Option(
        help="Parameters to fit (comma list); default mass, damping and every effect parameter.")] = None,
    load_position_m: Annotated[Optional[float], typer.Option(help="Stage Y: load position from rail Y1 (m).")]
    = None,
    columns: ColumnsOption = None,
    sample_rate_hz: SampleRateHzOption = None,
    rational: Annotated[Optional[str], typer.Option(
        help="Also fit a rational transfer function like MATLAB tfest: POLES,ZEROS (e.g. 1,0).")]
    = None,
    rational_weighting: Annotated[str, typer.Option(
        help="Weighting of the rational fit: inverse_sigma (the measured variance), thesis (Appendix B) "
             "or uniform.")] = "inverse_sigma",
    set_values: SetOption = None,
    method: Annotated[str, typer.Option(
        help="Time-domain recordings: inverse-model (IDIM-LS) or output-error (simulated velocity).")]
    = "inverse-model",
    filter_hz: FilterHzOption = 100.0,
    decimate_band_hz: DecimateBandHzOption = 40.0,
    frf: FrfOption = None,
    band_hz: BandHzOption = None,
    input_hold: InputHoldOption = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Fit bounded physical parameters to a recording: maximum likelihood with inverse-variance weights on a
    stepped sine's frequency response, IDIM-LS or output error on a time-domain recording."""
    from design.views.console import print_fit
    from design.views.json import fit_outcome_to_dict, print_json
    from design.views.progress import StageProgress
    from design.workflows import fit_recording
    from plant.errors import DataError
    from plant.identify.inverse_model import Preprocessing

    progress = StageProgress(enabled=not as_json and sys.stderr.isatty())
    try:
        outcome = fit_recording(
            data, stage=stage, effects=tuple(e.strip() for e in (effects or "").split(",") if e.strip()),
            free=tuple(p.strip() for p in free.split(",") if p.strip()) if free else None,
            values=parse_set(set_values), load_position_m=load_position_m, columns=columns,
            sample_rate_hz=sample_rate_hz, frf=frf, band=parse_band(band_hz), method=method,
            prep=Preprocessing(filter_hz, decimate_band_hz, input_hold), rational=rational,
            rational_weighting=rational_weighting, progress=progress)
    except DataError as exc:        # the data's own failings, named with the file
        raise DataError(str(exc) if str(exc).startswith(str(data)) else f"{data}: {exc}") from None
    finally:
        progress.close()
    if as_json:
        print_json(fit_outcome_to_dict(outcome))
    else:
        print_fit(console, outcome)
