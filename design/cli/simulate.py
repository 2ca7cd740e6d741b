"""``gantry simulate``: a recording (CSV + JSON sidecar) from a plant model with effects: stepped-sine blocks, or
one continuous run with the position (a stepped sine or a chirp) for the forces that depend on where the carriage
is."""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Annotated, Optional

import typer

from design.cli.common import (
    console,
    finite_non_negative,
    finite_positive,
    keep_inputs,
    options_named,
    parse_effects,
    parse_f_hz,
    parse_set_items,
)
from plant.errors import ParameterError

#: the noise of a simulated recording when none is given: this fraction of each block's fundamental
DEFAULT_NOISE_FRACTION = 0.01
#: position noise of a continuous run when none is given (m): an optical encoder's resolution
DEFAULT_POSITION_NOISE_M = 1e-6
FORMS = ("blocks", "continuous", "chirp")


def simulate(
    out: Annotated[Path, typer.Option("--out", help="Recording to write (CSV, long format); the settings and "
                                      "seed go to a sidecar FILE.json next to it.")],
    spec: Annotated[Optional[Path], typer.Option("--spec", help="Spec file: its plant at the nominal payload.")] = None,
    stage: Annotated[Optional[str], typer.Option("--stage", help="x or y: the thesis plant (instead of --spec).")] \
    = None,
    set_items: Annotated[Optional[list[str]], typer.Option("--set", help="KEY=VALUE plant or effect parameter, "
                                                           "e.g. mass_kg=40 (repeatable).")] = None,
    effects: Annotated[Optional[list[str]], typer.Option("--effects", help="Effects to add, comma-separated: "
                                                         "a name (defaults) or effect.parameter=value, e.g. "
                                                         "delay.seconds=0.001,current_loop.bandwidth_hz=200.")] = None,
    f_hz: Annotated[str, typer.Option("--f-hz", help="Frequencies: START:STOP:COUNT or a list 1,2,5 (Hz).")]
    = "1:75:50",
    f_spacing: Annotated[str, typer.Option("--f-spacing", help="Spacing of START:STOP:COUNT: log or linear.")]
    = "log",
    amplitude_a: Annotated[Optional[float], typer.Option(
        "--amplitude-a", callback=finite_positive,
        help="Current amplitude (A); default the thesis's 0.5 A (X) or 1.75 A (Y).")] = None,
    form: Annotated[str, typer.Option(
        "--form", help="blocks: one stepped-sine block per frequency, each from rest (velocity; thesis 4.1). "
        "continuous: the same sines one after another in one run, the motion carried over; chirp: a logarithmic "
        "chirp from the lowest to the highest frequency over the same total time. The last two record time, "
        "current and position (the forces that depend on the position need it).")] = "blocks",
    duration_s: Annotated[float, typer.Option(
        "--duration-s", callback=finite_positive, help="Length of each block (s).")] = 5.0,
    sample_rate_hz: Annotated[float, typer.Option(
        "--sample-rate-hz", callback=finite_positive, help="Recording sample rate (Hz).")] = 2000.0,
    noise_fraction: Annotated[Optional[float], typer.Option(
        "--noise-fraction", callback=finite_non_negative, help="Noise std as a fraction of each block's amplitude "
        f"(default {DEFAULT_NOISE_FRACTION:g} unless absolute noise is given; 0 for none).")] = None,
    current_noise_a: Annotated[float, typer.Option(
        "--current-noise-a", callback=finite_non_negative, help="Current noise std (A).")] = 0.0,
    velocity_noise: Annotated[float, typer.Option(
        "--velocity-noise-m-per-s", callback=finite_non_negative, help="Velocity noise std (m/s).")] = 0.0,
    current_quantum_a: Annotated[Optional[float], typer.Option(
        "--current-quantum-a", callback=finite_positive, help="Current resolution (A).")] = None,
    velocity_quantum: Annotated[Optional[float], typer.Option(
        "--velocity-quantum-m-per-s", callback=finite_positive, help="Velocity resolution (m/s).")] = None,
    position_noise_m: Annotated[float, typer.Option(
        "--position-noise-m", callback=finite_non_negative,
        help="Position noise std (m) of --form continuous or chirp.")] = DEFAULT_POSITION_NOISE_M,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the noise (recorded in the sidecar).")] = 0,
    as_json: Annotated[bool, typer.Option("--json", help="Print a JSON summary instead of one line.")] = False,
) -> None:
    """Simulate an experiment (a stepped sine as in thesis section 4.1, or one continuous run) and write it as a
    recording."""
    from design.views.console import print_simulation
    from design.views.json import print_json, simulation_to_dict
    from design.views.progress import LazyProgress
    from design.workflows import simulation_plant
    from plant.data.writers import write_simulation
    from plant.experiment.simulate import check_stepped_sine_plan, simulate_stepped_sine

    if out.suffix.lower() != ".csv":
        raise ParameterError(f"--out {out}: the recording is written as CSV; give a FILE.csv")
    if not out.parent.is_dir():
        raise ParameterError(f"--out {out}: directory {out.parent} does not exist")
    keep_inputs({"--out": out, "--out (sidecar)": out.with_suffix(".json")}, [spec])
    plant, amplitude_a = simulation_plant(spec=spec, stage=stage, values=parse_set_items(set_items or []),
                                          effects_added=parse_effects(effects or []), amplitude_a=amplitude_a)
    f = parse_f_hz(f_hz, f_spacing)
    if form not in FORMS:
        raise ParameterError(f"--form must be one of {', '.join(FORMS)}, got {form!r}")
    if form != "blocks":
        _continuous(plant, out, spec=spec, form=form, f=f, amplitude_a=amplitude_a, duration_s=duration_s,
                    sample_rate_hz=sample_rate_hz, noise_fraction=noise_fraction, current_noise_a=current_noise_a,
                    position_noise_m=position_noise_m, seed=seed, as_json=as_json,
                    velocity_only={"--velocity-noise-m-per-s": velocity_noise,
                                   "--velocity-quantum-m-per-s": velocity_quantum,
                                   "--current-quantum-a": current_quantum_a})
        return
    if noise_fraction is None and not (current_noise_a or velocity_noise):
        noise_fraction = DEFAULT_NOISE_FRACTION
    progress = LazyProgress(enabled=not as_json and sys.stderr.isatty(), label="simulate", unit="steps")
    t0 = time.perf_counter()
    try:
        with options_named("duration_s", "sample_rate_hz", "noise_fraction", "current_noise_a", "current_quantum_a",
                           "seed", "velocity_noise_m_per_s", "velocity_quantum_m_per_s", f_hz="--f-hz",
                           current_amplitude_a="--amplitude-a"):
            check_stepped_sine_plan(f, duration_s, sample_rate_hz)
            rec = simulate_stepped_sine(plant, f_hz=f, current_amplitude_a=amplitude_a,
                                        duration_s=duration_s, sample_rate_hz=sample_rate_hz,
                                        current_noise_a=current_noise_a, velocity_noise_m_per_s=velocity_noise,
                                        noise_fraction=noise_fraction, velocity_quantum_m_per_s=velocity_quantum,
                                        current_quantum_a=current_quantum_a, seed=seed, progress=progress)
    finally:
        progress.close()
    elapsed_s = time.perf_counter() - t0
    sidecar = write_simulation(rec, out, spec=spec)
    if as_json:
        print_json(simulation_to_dict(rec, out, sidecar, amplitude_a=amplitude_a, simulation_s=elapsed_s))
    else:
        print_simulation(console, rec, out, sidecar, amplitude_a=amplitude_a)


def _continuous(plant, out: Path, *, spec, form: str, f, amplitude_a: float, duration_s: float, sample_rate_hz: float,
                noise_fraction, current_noise_a: float, position_noise_m: float, seed: int, as_json: bool,
                velocity_only: dict) -> None:
    """``--form continuous`` or ``chirp``: one run from rest, recorded as time, current and position."""
    from design.views.console import print_time_simulation
    from design.views.json import print_json, time_simulation_to_dict
    from design.views.progress import LazyProgress
    from plant.data.writers import write_simulation
    from plant.experiment.simulate_time import chirp, simulate_time_domain, stepped_sine

    for option, value in velocity_only.items():
        if value:
            raise ParameterError(f"{option}: --form {form} records positions (give --position-noise-m)")
    if f[-1] > sample_rate_hz / 4:
        raise ParameterError(f"--f-hz {f[-1]:g} Hz has fewer than 4 samples per period at --sample-rate-hz "
                             f"{sample_rate_hz:g}; raise it to at least {4 * f[-1]:g}")
    if noise_fraction is not None and current_noise_a:
        raise ParameterError("give either --noise-fraction or --current-noise-a, not both")
    if not current_noise_a:
        current_noise_a = (DEFAULT_NOISE_FRACTION if noise_fraction is None else noise_fraction) * amplitude_a
    if form == "continuous":
        excitation = stepped_sine(f, amplitude_a=amplitude_a, block_s=duration_s)
    else:
        if f.size < 2:
            raise ParameterError("--f-hz: a chirp needs its lowest and highest frequency (give two or more)")
        excitation = chirp(f0_hz=float(f[0]), f1_hz=float(f[-1]), amplitude_a=amplitude_a,
                           duration_s=duration_s * f.size)
    progress = LazyProgress(enabled=not as_json and sys.stderr.isatty(), label="simulate", unit="samples")
    t0 = time.perf_counter()
    try:
        with options_named("seed", sample_rate_hz="--sample-rate-hz", current_noise_a="--current-noise-a",
                           noise="--position-noise-m"):
            rec = simulate_time_domain(plant, excitation, sample_rate_hz=sample_rate_hz,
                                       current_noise_a=current_noise_a, noise=position_noise_m, seed=seed,
                                       progress=progress)
    finally:
        progress.close()
    elapsed_s = time.perf_counter() - t0
    sidecar = write_simulation(rec, out, spec=spec)
    if as_json:
        print_json(time_simulation_to_dict(rec, out, sidecar, simulation_s=elapsed_s))
    else:
        print_time_simulation(console, rec, out, sidecar)
