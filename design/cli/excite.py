"""``gantry excite``: design a multisine excitation, write it as CSV and predict its FRF variance."""

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
    out: Annotated[Path, typer.Option("--out", help="CSV to write: time_s,current_a rows of every period.")],
    f_min_hz: Annotated[float, typer.Option(callback=finite_positive, help="Lowest frequency of the band (Hz).")] \
    = 1.0,
    f_max_hz: Annotated[float, typer.Option(callback=finite_positive, help="Highest frequency of the band (Hz).")] \
    = 75.0,
    amplitude_a: Annotated[float, typer.Option(callback=finite_positive,
        help="Peak current (A) of the multisine; the stepped sine compared with has the same peak "
             "(thesis Stage X: 0.5 A).")] = 0.5,
    duration_s: Annotated[Optional[float], typer.Option(callback=finite_positive,
        help="Total machine time (s), a whole number of periods; default the thesis stepped sine's: "
             "50 frequencies x 5 s = 250 s.")] = None,
    periods: Annotated[Optional[int], typer.Option(help="Number of periods (instead of --duration-s).")] = None,
    period_s: Annotated[float, typer.Option(callback=finite_positive,
        help="Period (s): the frequency resolution is 1/period, the lines its odd multiples.")] = 5.0,
    lines_per_decade: Annotated[float, typer.Option(callback=finite_positive,
        help="Log spacing of the excited odd lines (a large value keeps every odd harmonic).")] = 25.0,
    sample_rate_hz: Annotated[float, typer.Option(callback=finite_positive,
                                                  help="Sample rate of the played signal (Hz).")] = 2000.0,
    phases: Annotated[str, typer.Option(help="Phases: optimised (lowest crest factor), schroeder or random.")]
    = "optimised",
    seed: Annotated[int, typer.Option(help="Seed of the random phases and of the optimisation's random starts.")]
    = 0,
    noise_m_per_s: Annotated[float, typer.Option(callback=finite_positive,
        help="Velocity noise (m/s, standard deviation, white at the sample rate) for the predicted variance; "
             "default 1 mm/s, about a 1 um encoder differenced at 2 kHz.")] = DEFAULT_NOISE_M_PER_S,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Design an odd log-spaced multisine, write it, and compare its predicted FRF variance per second of
    machine time with the thesis stepped sine (one 5 s block per frequency, same band, same peak current)."""
    from design.views.console import excitation_text
    from design.views.json import excitation_to_dict, json_text
    from plant.experiment.excitation import design_multisine, periods_for, predicted_variance, write_excitation_csv

    if out.suffix.lower() != ".csv":
        raise ParameterError(f"--out {out}: the excitation is written as CSV; give a FILE.csv")
    if not out.parent.is_dir():
        raise ParameterError(f"--out {out}: directory {out.parent} does not exist")
    with options_named("duration_s", "periods", "period_s", "sample_rate_hz"):
        n = periods_for(period_s=period_s, sample_rate_hz=sample_rate_hz, duration_s=duration_s, periods=periods)
    ms = design_multisine(f_min_hz=f_min_hz, f_max_hz=f_max_hz, peak_a=amplitude_a, period_s=period_s,
                          sample_rate_hz=sample_rate_hz, periods=n, lines_per_decade=lines_per_decade,
                          phases=phases, seed=seed)
    pred = predicted_variance(ms, noise_m_per_s=noise_m_per_s)
    text = json_text({"out": str(out), **excitation_to_dict(ms, pred)}) if as_json else excitation_text(out, ms, pred)
    write_excitation_csv(ms, out)         # the file last, then only the text composed before it
    print(text)
