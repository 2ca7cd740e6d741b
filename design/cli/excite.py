"""``gantry excite``: design a multisine excitation, write it as CSV and predict its FRF variance."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Optional

import typer

from design.cli.common import console
from plant.errors import ParameterError

#: velocity noise (m/s, standard deviation) of the prediction when none is given: a velocity
#: differenced from a 1 um encoder at 2 kHz steps by 2 mm/s, whose quantisation noise is
#: 2 / sqrt(12) = 0.6 mm/s; 1 mm/s leaves room for the drive's and the stage's own noise
DEFAULT_NOISE_M_PER_S = 1e-3


def _positive(option: str, value: float) -> float:
    if not (math.isfinite(value) and value > 0):
        raise ParameterError(f"{option} must be finite and > 0, got {value:g}")
    return value


def excite(
    out: Annotated[Path, typer.Option("--out", help="CSV to write: time_s,current_a rows of every period.")],
    f_min_hz: Annotated[float, typer.Option(help="Lowest frequency of the band (Hz).")] = 1.0,
    f_max_hz: Annotated[float, typer.Option(help="Highest frequency of the band (Hz).")] = 75.0,
    amplitude_a: Annotated[float, typer.Option(
        help="Peak current (A) of the multisine; the stepped sine compared with has the same peak "
             "(thesis Stage X: 0.5 A).")] = 0.5,
    duration_s: Annotated[Optional[float], typer.Option(
        help="Total machine time (s), a whole number of periods; default the thesis stepped sine's: "
             "50 frequencies x 5 s = 250 s.")] = None,
    periods: Annotated[Optional[int], typer.Option(help="Number of periods (instead of --duration-s).")] = None,
    period_s: Annotated[float, typer.Option(
        help="Period (s): the frequency resolution is 1/period, the lines its odd multiples.")] = 5.0,
    lines_per_decade: Annotated[float, typer.Option(
        help="Log spacing of the excited odd lines (a large value keeps every odd harmonic).")] = 25.0,
    sample_rate_hz: Annotated[float, typer.Option(help="Sample rate of the played signal (Hz).")] = 2000.0,
    phases: Annotated[str, typer.Option(help="Phases: optimised (lowest crest factor), schroeder or random.")]
    = "optimised",
    seed: Annotated[int, typer.Option(help="Seed of the random phases and of the optimisation's random starts.")]
    = 0,
    noise_m_per_s: Annotated[float, typer.Option(
        help="Velocity noise (m/s, standard deviation, white at the sample rate) for the predicted variance; "
             "default 1 mm/s, about a 1 um encoder differenced at 2 kHz.")] = DEFAULT_NOISE_M_PER_S,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Design an odd log-spaced multisine, write it, and compare its predicted FRF variance per second of
    machine time with the thesis stepped sine (one 5 s block per frequency, same band, same peak current)."""
    from design.views.json import print_json
    from plant.excitation import (
        MAX_SAMPLES,
        THESIS_BLOCK_S,
        THESIS_FREQUENCIES,
        design_multisine,
        predicted_variance,
        samples_per_period,
        write_excitation_csv,
    )

    _positive("--amplitude-a", amplitude_a)
    _positive("--period-s", period_s)
    _positive("--sample-rate-hz", sample_rate_hz)
    _positive("--noise-m-per-s", noise_m_per_s)
    if out.suffix.lower() != ".csv":
        raise ParameterError(f"--out {out}: the excitation is written as CSV; give a FILE.csv")
    if not out.parent.is_dir():
        raise ParameterError(f"--out {out}: directory {out.parent} does not exist")
    if duration_s is not None and periods is not None:
        raise ParameterError("give --duration-s or --periods, not both")
    n_period = samples_per_period(period_s, sample_rate_hz)
    if periods is None:
        duration = THESIS_FREQUENCIES * THESIS_BLOCK_S if duration_s is None else _positive("--duration-s", duration_s)
        if duration * sample_rate_hz > MAX_SAMPLES:
            raise ParameterError(f"--duration-s {duration:g} s at {sample_rate_hz:g} Hz is "
                                 f"{duration * sample_rate_hz:.3g} samples, more than {MAX_SAMPLES:.3g}")
        periods = round(duration / period_s)
        if abs(periods * period_s - duration) > 1e-9 * duration:
            raise ParameterError(f"--duration-s {duration:g} s is not a whole number of periods of --period-s "
                                 f"{period_s:g} s")
    elif periods * n_period > MAX_SAMPLES:
        raise ParameterError(f"--periods {periods} x {n_period} samples is {periods * n_period:.3g} samples, "
                             f"more than {MAX_SAMPLES:.3g}")
    if periods < 2:
        raise ParameterError(f"{periods} period(s): at least 2 are needed (the first is dropped as the transient); "
                             "raise --duration-s or --periods")
    ms = design_multisine(f_min_hz=f_min_hz, f_max_hz=f_max_hz, peak_a=amplitude_a, period_s=period_s,
                          sample_rate_hz=sample_rate_hz, periods=periods, lines_per_decade=lines_per_decade,
                          phases=phases, seed=seed)
    pred = predicted_variance(ms, noise_m_per_s=noise_m_per_s)
    write_excitation_csv(ms, out)
    if as_json:
        print_json({"out": str(out), "f_hz": ms.f_hz, "harmonics": ms.harmonics, "amplitudes_a": ms.amplitudes,
                    "phases_rad": ms.phases, "phase_method": ms.phase_method, "period_s": ms.period_s,
                    "periods": ms.periods, "machine_time_s": ms.duration_s, "sample_rate_hz": ms.sample_rate_hz,
                    "samples": int(ms.current_a.size), "peak_a": ms.peak_a, "rms_a": ms.rms_a,
                    "crest_factor": ms.crest_factor, "noise_m_per_s": noise_m_per_s,
                    "multisine_variance": pred.multisine_variance,
                    "multisine_variance_s": pred.multisine_variance_s,
                    "stepped": {"f_hz": pred.stepped_f_hz, "block_s": THESIS_BLOCK_S, "amplitude_a": ms.peak_a,
                                "machine_time_s": pred.stepped_time_s, "variance": pred.stepped_variance,
                                "variance_s": pred.stepped_variance_s},
                    "ratio": pred.ratio})
        return
    lines = [
        f"wrote {out}: {ms.current_a.size} samples at {ms.sample_rate_hz:g} Hz, {ms.periods} periods of "
        f"{ms.period_s:g} s = {ms.duration_s:g} s of machine time",
        f"lines: {ms.f_hz.size} odd harmonics of {1 / ms.period_s:g} Hz, {ms.f_hz[0]:g} to {ms.f_hz[-1]:g} Hz, "
        f"{ms.amplitudes[0]:.4g} A each",
        f"peak {ms.peak_a:.4g} A, RMS {ms.rms_a:.4g} A, crest factor {ms.crest_factor:.3f} ({ms.phase_method} phases)",
        f"predicted FRF variance for {noise_m_per_s:g} m/s velocity noise, mean per line x machine time:",
        f"  multisine    {pred.multisine_variance_s:.4g} (m/s per A)^2 s  ({ms.f_hz.size} lines in "
        f"{pred.multisine_time_s:g} s, first period dropped)",
        f"  stepped sine {pred.stepped_variance_s:.4g} (m/s per A)^2 s  ({pred.stepped_f_hz.size} log-spaced "
        f"frequencies, {THESIS_BLOCK_S:g} s blocks at {ms.peak_a:g} A, {pred.stepped_time_s:g} s)",
        f"  ratio stepped / multisine: {pred.ratio:.3g} (> 1: the multisine is better per second)",
    ]
    console.print("\n".join(lines), markup=False, highlight=False, soft_wrap=True)
