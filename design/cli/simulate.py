"""``gantry simulate``: a stepped-sine recording (CSV + JSON sidecar) from a plant model with effects."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Annotated, Optional

import numpy as np
import typer

from design.cli.common import console
from design.views.json import print_json
from plant.errors import GantryError, ParameterError

#: thesis section 4.1: 0.5 A sine for Stage X, 1.75 A for Stage Y
THESIS_AMPLITUDE_A = {"x": 0.5, "y": 1.75}
#: plant keys ``--set`` may change besides effect parameters (``effect.parameter``)
PLANT_KEYS = ("mass_kg", "damping_n_s_per_m", "force_constant_n_per_a", "motor_length_m", "load_position_m")
DEFAULT_NOISE_FRACTION = 0.01


def _number(option: str, item: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ParameterError(f"{option} {item!r}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise ParameterError(f"{option} {item!r}: value must be finite")
    return value


def parse_effects(items: list[str]) -> dict[str, dict[str, float]]:
    """``["delay.seconds=0.001,current_loop", ...]`` -> ``{"delay": {"seconds": 0.001}, "current_loop": {}}``.

    An effect named without parameters gets its defaults (``plant.effects.make_effect``)."""
    from plant.effects import make_effect

    effects: dict[str, dict[str, float]] = {}
    for item in (part.strip() for chunk in items for part in chunk.split(",")):
        if not item:
            continue
        key, eq, text = item.partition("=")
        name, dot, param = key.strip().partition(".")
        if bool(eq) != bool(dot) or (dot and not param):
            raise ParameterError(f"--effects {item!r}: write an effect name (delay) or effect.parameter=value "
                                 "(delay.seconds=0.001)")
        params = effects.setdefault(name, {})
        if eq:
            params[param] = _number("--effects", item, text)
        try:
            make_effect(name, **params)
        except GantryError as exc:
            raise type(exc)(f"--effects {item!r}: {exc}") from None
    return effects


def parse_set(items: list[str]) -> dict[str, float]:
    """``["mass_kg=40", "delay.seconds=0.002"]`` -> ``{"mass_kg": 40.0, "delay.seconds": 0.002}``."""
    values: dict[str, float] = {}
    for item in items:
        key, eq, text = item.partition("=")
        key = key.strip()
        if not eq or not key:
            raise ParameterError(f"--set {item!r}: expected KEY=VALUE, e.g. mass_kg=40")
        if "." not in key and key not in PLANT_KEYS:
            raise ParameterError(f"--set {item!r}: unknown parameter {key!r}; plant parameters are "
                                 f"{', '.join(PLANT_KEYS)}, effect parameters are written effect.parameter")
        values[key] = _number("--set", item, text)
    return values


def parse_f_hz(text: str, spacing: str) -> np.ndarray:
    """``"1:75:50"`` (``spacing`` log or linear) or an explicit list ``"1,2,5,10"``, in Hz."""
    if spacing not in ("log", "linear"):
        raise ParameterError(f"--f-spacing must be log or linear, got {spacing!r}")
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise ParameterError(f"--f-hz {text!r}: write START:STOP:COUNT (e.g. 1:75:50) or a list 1,2,5")
        start, stop = (_number("--f-hz", text, p) for p in parts[:2])
        count = _number("--f-hz", text, parts[2])
        if count != int(count) or count < 2:
            raise ParameterError(f"--f-hz {text!r}: COUNT must be a whole number >= 2")
        if not 0 < start < stop:
            raise ParameterError(f"--f-hz {text!r}: need 0 < START < STOP")
        return (np.geomspace if spacing == "log" else np.linspace)(start, stop, int(count))
    f = np.array([_number("--f-hz", text, p) for p in text.split(",")])
    if np.any(f <= 0):
        raise ParameterError(f"--f-hz {text!r}: frequencies must be positive")
    if len(np.unique(f)) != len(f):
        raise ParameterError(f"--f-hz {text!r}: a frequency is listed twice (duplicate block)")
    return np.sort(f)


def build_simulation_plant(*, spec: Path | None, stage: str | None, set_items: list[str], effect_items: list[str],
                           amplitude_a: float | None):
    """The plant (spec's nominal payload or thesis defaults, then ``--set``/``--effects``) and the amplitude."""
    from design.spec.schema import load_spec
    from plant.models import Plant, build_plant

    if (spec is None) == (stage is None):
        raise ParameterError("give exactly one of --spec FILE or --stage x|y")
    effects: dict[str, dict[str, float]] = {}
    base: dict[str, float] = {}
    if spec is not None:
        p = load_spec(spec).plant
        stage = p.stage
        effects = {name: dict(params) for name, params in p.effects.items()}
        base = {"mass_kg": p.payload_kg.nominal_kg, "damping_n_s_per_m": p.damping_n_s_per_m,
                "force_constant_n_per_a": p.force_constant_n_per_a, "motor_length_m": p.motor_length_m,
                "load_position_m": p.load_position_m}
    elif stage not in ("x", "y"):
        raise ParameterError(f"--stage must be x or y, got {stage!r}")
    for name, params in parse_effects(effect_items).items():
        effects.setdefault(name, {}).update(params)
    for key, value in parse_set(set_items).items():
        if "." in key:
            name, param = key.split(".", 1)
            if name not in effects:
                raise ParameterError(f"--set {key}: the plant has no effect {name}; add it with --effects {name}")
            effects[name][param] = value
        else:
            base[key] = value
    if amplitude_a is None:
        amplitude_a = THESIS_AMPLITUDE_A[stage]
    if not (math.isfinite(amplitude_a) and amplitude_a > 0):
        raise ParameterError(f"--amplitude-a must be a positive number of amperes, got {amplitude_a:g}")
    excitation = amplitude_a if "coulomb_friction" in effects else None
    try:
        plant: Plant = build_plant(stage, effects=effects, excitation_current_a=excitation, **base)
    except GantryError as exc:
        raise type(exc)(f"plant from --spec/--stage, --set and --effects: {exc}") from None
    return plant, amplitude_a


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
    from plant import __version__
    from plant.recording import atomic_write_text, write_recording_csv
    from plant.simulate import simulate_stepped_sine

    if out.suffix.lower() != ".csv":
        raise ParameterError(f"--out {out}: the recording is written as CSV; give a FILE.csv")
    if not out.parent.is_dir():
        raise ParameterError(f"--out {out}: directory {out.parent} does not exist")
    sidecar = out.with_suffix(".json")
    plant, amplitude_a = build_simulation_plant(spec=spec, stage=stage, set_items=set_items or [],
                                                effect_items=effects or [], amplitude_a=amplitude_a)
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
