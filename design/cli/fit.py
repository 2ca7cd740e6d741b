"""``gantry fit``: physical parameters of a plant with effects from a recording: a stepped sine in the
frequency domain, a time-domain recording (any excitation) by the inverse model or output error."""

from __future__ import annotations

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
from design.views.json import fit_to_dict, print_json, time_fit_to_dict
from plant.errors import ParameterError


def fit(
    data: Annotated[Path, typer.Argument(
        help="Stepped-sine (.csv, .xlsx, .tdms) or time-domain recording (.csv without frequency_hz, .mat).")],
    stage: Annotated[str, typer.Option(help="Stage of the recording: x or y.")],
    effects: Annotated[Optional[str], typer.Option(help="Effects to include, e.g. delay,current_loop.")] = None,
    free: Annotated[Optional[str], typer.Option(
        help="Parameters to fit (comma list); default mass, damping and every effect parameter.")] = None,
    load_position_m: Annotated[Optional[float], typer.Option(help="Stage Y: load position from rail Y1 (m).")]
    = None,
    columns: Annotated[Optional[str], typer.Option(
        help="Column map: spreadsheets/TDMS frequency=2,current=3,velocity=6,velocity=7; time-domain CSV/.mat "
             "time=t,current=vir,position=qm,reference=qg.")] = None,
    sample_rate_hz: Annotated[Optional[float], typer.Option(help="Sample rate when the file has no time column.")]
    = None,
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
    from plant.effects import make_effect
    from plant.fitting import fit_plant
    from plant.frf_estimation import estimate_frf
    from plant.inverse_model import Preprocessing
    from plant.lockin import estimate_response
    from plant.models import Plant
    from plant.recording_io import parse_column_map
    from plant.time_recording import TimeRecording
    from plant.time_recording_io import read_measurement

    if stage not in ("x", "y"):
        raise ParameterError(f"--stage must be x or y, got {stage!r}")
    names = [e.strip() for e in (effects or "").split(",") if e.strip()]
    fx = tuple(make_effect(n) for n in names)
    geometry = {"load_position_m": load_position_m} if load_position_m is not None else {}
    settings = parse_set(set_values)
    free_names = tuple(p.strip() for p in free.split(",") if p.strip()) if free else None
    recording = read_measurement(data, columns=parse_column_map(columns) if columns else None,
                                 sample_rate_hz=sample_rate_hz)
    if isinstance(recording, TimeRecording) and frf is not None:
        measured = estimate_frf(recording, method=frf, **parse_band(band_hz))
    elif isinstance(recording, TimeRecording):
        plant = Plant(stage, effects=fx, excitation_current_a=1.0, **geometry).with_values(settings)
        _fit_time(plant, recording, free_names, method, Preprocessing(filter_hz, decimate_band_hz, input_hold), as_json)
        return
    else:
        measured = estimate_response(recording)
    plant = Plant(stage, effects=fx, excitation_current_a=float(measured.current_amplitude_a.mean()),
                  **geometry).with_values(settings)
    result = fit_plant(plant, measured, free=free_names)
    rat = None
    if rational:
        from plant.rational_fit import WEIGHTINGS, fit_rational

        try:
            n_poles, n_zeros = (int(v) for v in rational.split(","))
        except ValueError:
            raise ParameterError(f"--rational {rational!r}: expected POLES,ZEROS, e.g. 1,0") from None
        if rational_weighting not in WEIGHTINGS:
            raise ParameterError(f"--rational-weighting must be one of {', '.join(WEIGHTINGS)}, "
                                 f"got {rational_weighting!r}")
        # mean over outputs; its variance is the mean variance / number of outputs (independent noise)
        rat = fit_rational(measured.w_rad_s, measured.response.mean(axis=0), n_poles=n_poles, n_zeros=n_zeros,
                           weights=rational_weighting,
                           variance=measured.variance.mean(axis=0) / measured.response.shape[0])
    if as_json:
        print_json(fit_to_dict(result, rat))
        return
    console.print(result.report(), markup=False, highlight=False, soft_wrap=True)
    if rat is not None:
        console.print(f"\nRational fit ({rat.n_poles} poles, {rat.n_zeros} zeros, {rat.weighting} weighting): "
                      f"fit {rat.fit_percent:.1f} %, chi-square {rat.chi2:.4g} for {rat.dof} degrees of freedom"
                      f"\n{rat.tf}", markup=False, highlight=False)
        if rat.flags:
            console.print("Flags:\n" + "\n".join(f"    {f}" for f in rat.flags), markup=False, highlight=False)


def _fit_time(plant, recording, free, method, prep, as_json) -> None:
    from plant.time_fit import fit_inverse_model, fit_output_error

    if method not in ("inverse-model", "output-error"):
        raise ParameterError(f"--method must be inverse-model or output-error, got {method!r}")
    result = fit_inverse_model(plant, recording, free=free, prep=prep)
    if method == "output-error":
        result = fit_output_error(plant, recording, start=result, prep=prep)
    if as_json:
        print_json(time_fit_to_dict(result))
        return
    console.print(result.report(), markup=False, highlight=False, soft_wrap=True)
