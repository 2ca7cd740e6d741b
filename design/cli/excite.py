"""``gantry excite``: design the thesis stepped sine and a multisine over one band, predict the FRF variance of
each per second of machine time, and write the better one (or the one asked for) as CSV."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from design.cli.common import finite_positive, options_named
from plant.errors import ParameterError

#: velocity noise (m/s, standard deviation) of the prediction when none is given: a velocity
#: differenced from a 1 um encoder at 2 kHz steps by 2 mm/s, whose quantisation noise is
#: 2 / sqrt(12) = 0.6 mm/s; 1 mm/s leaves room for the drive's and the stage's own noise
DEFAULT_NOISE_M_PER_S = 1e-3


def excite(
    out: Annotated[Path, typer.Option("--out", help="CSV to write: frequency_hz,time_s,current_a rows of every "
                                      "block (stepped sine) or time_s,current_a rows of every period (multisine).")],
    form: Annotated[str, typer.Option("--form", help="auto (the better per second of machine time), stepped or "
                                      "multisine.")] = "auto",
    f_min_hz: Annotated[float, typer.Option(callback=finite_positive, help="Lowest frequency of the band (Hz).")] \
    = 1.0,
    f_max_hz: Annotated[float, typer.Option(callback=finite_positive, help="Highest frequency of the band (Hz).")] \
    = 75.0,
    amplitude_a: Annotated[float, typer.Option(callback=finite_positive,
        help="Peak current (A) of both excitations (thesis Stage X: 0.5 A).")] = 0.5,
    frequencies: Annotated[int, typer.Option(help="Stepped sine: number of log-spaced frequencies (thesis: 50).")]
    = 50,
    block_s: Annotated[float, typer.Option(callback=finite_positive,
        help="Stepped sine: seconds per frequency (thesis: 5 s).")] = 5.0,
    duration_s: Annotated[Optional[float], typer.Option(callback=finite_positive,
        help="Multisine: total machine time (s), a whole number of periods; default the stepped sine's "
             "(frequencies x block, 250 s).")] = None,
    periods: Annotated[Optional[int], typer.Option(help="Multisine: number of periods (instead of --duration-s).")] \
    = None,
    period_s: Annotated[float, typer.Option(callback=finite_positive,
        help="Multisine period (s): the frequency resolution is 1/period, the lines its odd multiples.")] = 5.0,
    lines_per_decade: Annotated[float, typer.Option(callback=finite_positive,
        help="Multisine: log spacing of the excited odd lines (a large value keeps every odd harmonic).")] = 25.0,
    sample_rate_hz: Annotated[float, typer.Option(callback=finite_positive,
                                                  help="Sample rate of the played signal (Hz).")] = 2000.0,
    phases: Annotated[str, typer.Option(help="Multisine phases: optimised (lowest crest factor), schroeder or random.")]
    = "optimised",
    seed: Annotated[int, typer.Option(help="Seed of the random phases and of the optimisation's random starts.")]
    = 0,
    noise_m_per_s: Annotated[float, typer.Option(callback=finite_positive,
        help="Velocity noise (m/s, standard deviation, white at the sample rate) for the predicted variance; "
             "default 1 mm/s, about a 1 um encoder differenced at 2 kHz.")] = DEFAULT_NOISE_M_PER_S,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Design the thesis stepped sine and an odd log-spaced multisine over one band at one peak current, predict
    the FRF variance each gives per second of machine time, and write the better one (--form auto) or the
    one named."""
    from design.views.console import excitation_text
    from design.views.json import excitation_to_dict, json_text
    from plant.experiment.excitation import (
        FORMS,
        design_multisine,
        design_stepped_sine,
        periods_for,
        predicted_variance,
        write_excitation_csv,
        write_stepped_sine_csv,
    )

    if form not in FORMS:
        raise ParameterError(f"--form {form!r}: one of {', '.join(FORMS)}")
    if out.suffix.lower() != ".csv":
        raise ParameterError(f"--out {out}: the excitation is written as CSV; give a FILE.csv")
    if not out.parent.is_dir():
        raise ParameterError(f"--out {out}: directory {out.parent} does not exist")
    with options_named("f_min_hz", "f_max_hz", "amplitude_a", "frequencies", "block_s", "sample_rate_hz"):
        stepped = design_stepped_sine(f_min_hz=f_min_hz, f_max_hz=f_max_hz, amplitude_a=amplitude_a,
                                      frequencies=frequencies, block_s=block_s, sample_rate_hz=sample_rate_hz)
    if duration_s is None and periods is None:
        duration_s = stepped.duration_s
    with options_named("duration_s", "periods", "period_s", "sample_rate_hz"):
        n = periods_for(period_s=period_s, sample_rate_hz=sample_rate_hz, duration_s=duration_s, periods=periods)
    ms = design_multisine(f_min_hz=f_min_hz, f_max_hz=f_max_hz, peak_a=amplitude_a, period_s=period_s,
                          sample_rate_hz=sample_rate_hz, periods=n, lines_per_decade=lines_per_decade,
                          phases=phases, seed=seed)
    pred = predicted_variance(ms, noise_m_per_s=noise_m_per_s, stepped_f_hz=stepped.f_hz, block_s=block_s)
    written = {"auto": pred.better, "stepped": "stepped_sine", "multisine": "multisine"}[form]
    text = (json_text({"out": str(out), "form": written, **excitation_to_dict(ms, pred, stepped)}) if as_json
            else excitation_text(out, written, ms, pred, stepped, chosen=form == "auto"))
    if written == "stepped_sine":                 # the file last, then only the text composed before it
        write_stepped_sine_csv(stepped, out)
    else:
        write_excitation_csv(ms, out)
    print(text)
