"""``gantry simulate``: a stepped-sine recording (CSV + JSON sidecar) from a plant model with effects."""

from __future__ import annotations

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
    seed: Annotated[int, typer.Option("--seed", help="Seed of the noise (recorded in the sidecar).")] = 0,
    as_json: Annotated[bool, typer.Option("--json", help="Print a JSON summary instead of one line.")] = False,
) -> None:
    """Simulate a stepped-sine experiment (thesis section 4.1) and write it as a recording."""
    from design.views.console import print_simulation
    from design.views.json import print_json, simulation_to_dict
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
    if noise_fraction is None and not (current_noise_a or velocity_noise):
        noise_fraction = DEFAULT_NOISE_FRACTION
    t0 = time.perf_counter()
    with options_named("duration_s", "sample_rate_hz", "noise_fraction", "current_noise_a", "current_quantum_a",
                       "seed", "velocity_noise_m_per_s", "velocity_quantum_m_per_s", f_hz="--f-hz",
                       current_amplitude_a="--amplitude-a"):
        check_stepped_sine_plan(f, duration_s, sample_rate_hz)
        rec = simulate_stepped_sine(plant, f_hz=f, current_amplitude_a=amplitude_a,
                                    duration_s=duration_s, sample_rate_hz=sample_rate_hz,
                                    current_noise_a=current_noise_a, velocity_noise_m_per_s=velocity_noise,
                                    noise_fraction=noise_fraction, velocity_quantum_m_per_s=velocity_quantum,
                                    current_quantum_a=current_quantum_a, seed=seed)
    elapsed_s = time.perf_counter() - t0
    sidecar = write_simulation(rec, out, spec=spec)
    if as_json:
        print_json(simulation_to_dict(rec, out, sidecar, amplitude_a=amplitude_a, simulation_s=elapsed_s))
    else:
        print_simulation(console, rec, out, sidecar, amplitude_a=amplitude_a)
