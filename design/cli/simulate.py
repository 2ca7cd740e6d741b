"""``gantry simulate``: a stepped-sine recording (CSV + JSON sidecar) from a plant model with effects."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Annotated, Optional

import typer

from design.cli.common import console, parse_effects, parse_f_hz, parse_set_items
from plant.errors import ParameterError

DEFAULT_NOISE_FRACTION = 0.01


def _check(option: str, value: float | None, *, allow_zero: bool = False) -> None:
    if value is None:
        return
    if not math.isfinite(value) or value < 0 or (value == 0 and not allow_zero):
        word = "non-negative" if allow_zero else "positive"
        raise ParameterError(f"{option} must be a finite {word} number, got {value:g}")


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
    amplitude_a: Annotated[Optional[float], typer.Option("--amplitude-a", help="Current amplitude (A); default "
                                                         "the thesis's 0.5 A (X) or 1.75 A (Y).")] = None,
    duration_s: Annotated[float, typer.Option("--duration-s", help="Length of each block (s).")] = 5.0,
    sample_rate_hz: Annotated[float, typer.Option("--sample-rate-hz", help="Recording sample rate (Hz).")] = 2000.0,
    noise_fraction: Annotated[Optional[float], typer.Option(
        "--noise-fraction", help=f"Noise std as a fraction of each block's amplitude (default "
        f"{DEFAULT_NOISE_FRACTION:g} unless absolute noise is given; 0 for none).")] = None,
    current_noise_a: Annotated[float, typer.Option("--current-noise-a", help="Current noise std (A).")] = 0.0,
    velocity_noise: Annotated[float, typer.Option("--velocity-noise-m-per-s", help="Velocity noise std (m/s).")]
    = 0.0,
    current_quantum_a: Annotated[Optional[float], typer.Option("--current-quantum-a",
                                                               help="Current resolution (A).")] = None,
    velocity_quantum: Annotated[Optional[float], typer.Option("--velocity-quantum-m-per-s",
                                                              help="Velocity resolution (m/s).")] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the noise (recorded in the sidecar).")] = 0,
    as_json: Annotated[bool, typer.Option("--json", help="Print a JSON summary instead of one line.")] = False,
) -> None:
    """Simulate a stepped-sine experiment (thesis section 4.1) and write it as a recording."""
    from design.views.json import print_json
    from design.workflows import simulation_plant
    from plant import __version__
    from plant.recording import atomic_write_text, write_recording_csv
    from plant.simulate import simulate_stepped_sine

    if out.suffix.lower() != ".csv":
        raise ParameterError(f"--out {out}: the recording is written as CSV; give a FILE.csv")
    if not out.parent.is_dir():
        raise ParameterError(f"--out {out}: directory {out.parent} does not exist")
    sidecar = out.with_suffix(".json")
    plant, amplitude_a = simulation_plant(spec=spec, stage=stage, values=parse_set_items(set_items or []),
                                          effects_added=parse_effects(effects or []), amplitude_a=amplitude_a)
    f = parse_f_hz(f_hz, f_spacing)
    _check("--duration-s", duration_s)
    _check("--sample-rate-hz", sample_rate_hz)
    for option, value in [("--noise-fraction", noise_fraction), ("--current-noise-a", current_noise_a),
                          ("--velocity-noise-m-per-s", velocity_noise)]:
        _check(option, value, allow_zero=True)
    _check("--current-quantum-a", current_quantum_a)
    _check("--velocity-quantum-m-per-s", velocity_quantum)
    if seed < 0:
        raise ParameterError(f"--seed must be a non-negative integer, got {seed}")
    if f[-1] > sample_rate_hz / 4:
        raise ParameterError(f"--f-hz: {f[-1]:g} Hz has fewer than 4 samples per period at --sample-rate-hz "
                             f"{sample_rate_hz:g}")
    if round(duration_s * sample_rate_hz) < 2:
        raise ParameterError(f"--duration-s {duration_s:g} gives fewer than 2 samples at --sample-rate-hz "
                             f"{sample_rate_hz:g}")
    absolute = bool(current_noise_a or velocity_noise)
    if absolute and noise_fraction is not None:
        raise ParameterError("give either --noise-fraction or --current-noise-a/--velocity-noise-m-per-s, not both")
    if noise_fraction is None and not absolute:
        noise_fraction = DEFAULT_NOISE_FRACTION

    t0 = time.perf_counter()
    rec = simulate_stepped_sine(plant, f_hz=f, current_amplitude_a=amplitude_a, duration_s=duration_s,
                                sample_rate_hz=sample_rate_hz, current_noise_a=current_noise_a,
                                velocity_noise_m_per_s=velocity_noise, noise_fraction=noise_fraction,
                                velocity_quantum_m_per_s=velocity_quantum, current_quantum_a=current_quantum_a,
                                seed=seed)
    elapsed_s = time.perf_counter() - t0
    write_recording_csv(rec, out)
    side = {"recording": out.name, "gantry_version": __version__, "spec": None if spec is None else str(spec),
            "settings": rec.metadata}
    atomic_write_text(sidecar, json.dumps(side, indent=2, allow_nan=False) + "\n")
    md = rec.metadata
    if as_json:
        print_json({"out": str(out), "sidecar": str(sidecar), "stage": plant.stage, "effects": md["effects"],
                    "parameters": md["parameters"], "n_blocks": len(rec.blocks), "f_hz": md["f_hz"],
                    "current_amplitude_a": amplitude_a, "duration_s": duration_s, "sample_rate_hz": sample_rate_hz,
                    "noise_fraction": md["noise_fraction"], "seed": seed, "method": md["method"],
                    "simulation_s": elapsed_s})
        return
    noise = (f"noise {100 * noise_fraction:g} %" if noise_fraction is not None
             else f"noise {current_noise_a:g} A / {velocity_noise:g} m/s")
    console.print(f"wrote {out}: stage {plant.stage.upper()}, effects {', '.join(md['effects']) or 'none'}, "
                  f"{len(rec.blocks)} blocks {f[0]:g}-{f[-1]:g} Hz x {duration_s:g} s at {sample_rate_hz:g} Hz, "
                  f"{amplitude_a:g} A, {noise}, seed {seed} (settings in {sidecar.name})",
                  highlight=False, soft_wrap=True)
