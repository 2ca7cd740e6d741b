"""What the commands share: the ``typer`` app, the console, shared options and their parsers, JSON output."""

from __future__ import annotations

import math
import re
import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Optional

import numpy as np
import typer
from rich.console import Console

from plant import __version__
from plant.errors import GantryError, ParameterError
from plant.host.files import is_stdout

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Model, identify and tune the controllers of the exoskeleton H-gantry.")


def _flags_without_a_type() -> None:
    """Help that reads as flags: typer (0.29) shows a flag such as ``--json`` with the type ``<bool>``, as if it
    took a value; a flag is shown bare, every other option keeps its type."""
    from typer.core import TyperOption

    shown = TyperOption.display_type_rich

    def display_type_rich(self, ctx):
        return None if self.is_flag else shown(self, ctx)

    TyperOption.display_type_rich = display_type_rich


_flags_without_a_type()

class _Console(Console):
    """rich's console, ending as the other outputs do when the reader of standard output goes away
    (``design.cli.main``: status 141, as SIGPIPE would) instead of rich's exit status 1."""

    def on_broken_pipe(self) -> None:
        self.quiet = True
        raise BrokenPipeError


console = _Console()


def _version(value: bool) -> None:
    if value:
        print(f"gantry {__version__}")
        raise typer.Exit()


@app.callback()
def _main(version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True,
                                                help="Print the version and exit.")] = False) -> None:
    """Model, identify and tune the controllers of the exoskeleton H-gantry."""


def finite_positive(param: typer.CallbackParam, value: float | None) -> float | None:
    """Option callback: a finite number > 0 (the error names the option)."""
    if value is not None and not (math.isfinite(value) and value > 0):
        raise ParameterError(f"{param.opts[0]} must be finite and > 0, got {value:g}")
    return value


def finite_non_negative(param: typer.CallbackParam, value: float | None) -> float | None:
    """Option callback: a finite number >= 0 (the error names the option)."""
    if value is not None and not (math.isfinite(value) and value >= 0):
        raise ParameterError(f"{param.opts[0]} must be a finite non-negative number, got {value:g}")
    return value


@contextmanager
def options_named(*names: str, **renamed: str):
    """Library errors name parameters (``duration_s``); re-raise them naming the options (``--duration-s``,
    or the option given for a parameter in ``renamed``)."""
    try:
        yield
    except ParameterError as exc:
        msg = str(exc)
        for n, option in {**{n: "--" + n.replace("_", "-") for n in names}, **renamed}.items():
            msg = re.sub(rf"(?<![-\w]){n}\b", option, msg)
        raise ParameterError(msg) from None


def keep_inputs(outputs: dict[str, Path | None], inputs: list[Path | None], *, json: bool = False) -> None:
    """Refuse an output option that names one of the command's inputs (it would replace it), and more than
    one output to standard output (``-``; ``json``: ``--json`` prints there); with one there, what the command
    prints for reading goes to standard error."""
    given = {Path(p).resolve() for p in inputs if p is not None}
    to_stdout = [option for option, path in outputs.items() if path is not None and is_stdout(path)]
    if len(to_stdout) + json > 1:
        raise ParameterError(f"{' and '.join(to_stdout + ['--json'] * json)}: only one output can go to standard "
                             "output (-); write the others to files")
    if to_stdout:       # the file owns standard output: the tables and notes go to standard error
        console.file = sys.stderr
    for option, path in outputs.items():
        if path is not None and not is_stdout(path) and Path(path).resolve() in given:
            raise ParameterError(f"{option} {path}: is an input of this command; write the output to another file")


def read_design(path: Path, problem, *, admittance: bool = False):
    """A design as ``gantry synth --json`` writes it (``design.views.json.synthesis_from_json``): (the problem with
    the design's drive filters, its PI controller, and with ``admittance`` its virtual dynamics (m_v kg, b_v
    N*s/m), else None); ParameterError naming the file and what is missing."""
    from design.synth.pi import with_chosen_filters
    from design.views.json import synthesis_from_json
    from plant.host.text_io import read_text

    design = synthesis_from_json(read_text(path, what="design file"), str(path), admittance=admittance)
    kinds = [f.kind for f in design.filters]
    if design.filters and kinds != [f.kind for f in problem.controller.filters]:
        raise ParameterError(f"{path}: its drive filters ({', '.join(kinds)}) are not the spec's "
                             f"controller.filters ({', '.join(f.kind for f in problem.controller.filters)})")
    return with_chosen_filters(problem, design.filters), design.controller, design.admittance


#: options shared by the commands that read recordings (``fit``, ``diagnose``; ``report`` the first two)
ColumnsOption = Annotated[Optional[str], typer.Option(
    help="Column map: spreadsheets/TDMS frequency=2,current=3,velocity=6,velocity=7; time-domain CSV/.mat "
         "time=t,current=vir,position=qm,reference=qg.")]
SampleRateHzOption = Annotated[Optional[float], typer.Option(help="Sample rate when the file has no time column.")]
SetOption = Annotated[Optional[str], typer.Option(
    "--set", help="Parameter values (held fixed unless fitted), e.g. force_constant_n_per_a=35.15 for a drive "
                  "command in V with its gain in N/V.")]
FilterHzOption = Annotated[float, typer.Option(
    help="Time-domain recordings: zero-phase Butterworth corner before differentiating (5 x the band of the "
         "dynamics).")]
DecimateBandHzOption = Annotated[float, typer.Option(
    help="Time-domain recordings: band kept by the decimation (2 x the band of the dynamics).")]
FrfOption = Annotated[Optional[str], typer.Option(
    help="Time-domain recordings: estimate the frequency response first (auto, periodic, lpm or closed-loop) and "
         "fit in the frequency domain, where delays, filters and modes live.")]
BandHzOption = Annotated[Optional[str], typer.Option(
    help="With --frf: the band LOW:HIGH (Hz) of the frequency response, e.g. 1:200.")]
PlantFromOption = Annotated[Optional[Path], typer.Option(
    help="Take the plant's damping, force constant and effects from a fit result (gantry fit --json); the "
         "spec keeps its payload range, uncertainty and requirements.")]
InputHoldOption = Annotated[bool, typer.Option(
    "--input-hold", help="Time-domain recordings: the drive held each logged command until the next sample "
                         "(align the force by half a sample).")]


def parse_set(text: str | None) -> dict[str, float]:
    """``"force_constant_n_per_a=35.15,mass_kg=90"`` -> values of plant parameters (``--set`` as one comma list)."""
    return parse_set_items([p for p in (text or "").split(",") if p.strip()])


def parse_band(text: str | None) -> dict[str, tuple[float, float]]:
    """``"1:200"`` -> ``{"f_range_hz": (1.0, 200.0)}`` (``--band-hz``); nothing when not given."""
    if text is None:
        return {}
    low, sep, high = text.partition(":")
    try:
        band = (float(low), float(high))
    except ValueError:
        band = (math.nan, math.nan)
    if not sep or not all(math.isfinite(b) for b in band) or not 0 <= band[0] < band[1]:
        raise ParameterError(f"--band-hz {text!r}: expected LOW:HIGH in Hz with 0 <= LOW < HIGH, e.g. 1:200")
    return {"f_range_hz": band}


#: plant keys ``--set KEY=VALUE`` may change besides effect parameters (``effect.parameter``)
PLANT_KEYS = ("mass_kg", "damping_n_s_per_m", "force_constant_n_per_a", "motor_length_m", "load_position_m")


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

    An effect named without parameters gets its defaults (``plant.physics.effects.make_effect``)."""
    from plant.physics.effects import make_effect

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


def parse_machine(text: str | None) -> dict[str, float]:
    """``"carriage_mass_kg=56,beam_skew_rad=0"`` -> the planar machine's values by field name (``--machine``); the
    names are checked where the machine is made."""
    values: dict[str, float] = {}
    for item in (p for p in (text or "").split(",") if p.strip()):
        key, eq, number = item.partition("=")
        if not eq or not key.strip():
            raise ParameterError(f"--machine {item!r}: expected KEY=VALUE, e.g. carriage_mass_kg=56")
        values[key.strip()] = _number("--machine", item, number)
    return values


def parse_set_items(items: list[str]) -> dict[str, float]:
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


#: most blocks of a stepped sine (``--f-hz``)
MAX_FREQUENCIES = 2000


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
        if count > MAX_FREQUENCIES:
            raise ParameterError(f"--f-hz {text!r}: {count:g} frequencies is more than the {MAX_FREQUENCIES} a stepped "
                                 "sine can have (one block each)")
        if not 0 < start < stop:
            raise ParameterError(f"--f-hz {text!r}: need 0 < START < STOP")
        return (np.geomspace if spacing == "log" else np.linspace)(start, stop, int(count))
    f = np.array([_number("--f-hz", text, p) for p in text.split(",")])
    if np.any(f <= 0):
        raise ParameterError(f"--f-hz {text!r}: frequencies must be positive")
    if len(np.unique(f)) != len(f):
        raise ParameterError(f"--f-hz {text!r}: a frequency is listed twice (duplicate block)")
    return np.sort(f)


#: most payload points of ``--payload``
MAX_PAYLOAD_POINTS = 10000


def parse_payload(text: str) -> np.ndarray:
    """``MIN:MAX:POINTS`` (kg, kg, count) or a single mass ``M`` -> payloads in kg."""
    parts = text.split(":")
    usage = f"--payload {text!r}: expected MIN:MAX:POINTS in kg (e.g. 5:40:71) or one mass"
    if len(parts) not in (1, 3):
        raise ParameterError(usage)
    try:
        lo, hi = float(parts[0]), float(parts[-1 if len(parts) == 1 else 1])
        points = 1 if len(parts) == 1 else int(parts[2])
    except ValueError:
        raise ParameterError(usage) from None
    from design.problem import PAYLOAD_MAX_KG, PAYLOAD_MIN_KG

    for mass in (lo, hi):
        if not PAYLOAD_MIN_KG <= mass <= PAYLOAD_MAX_KG:
            raise ParameterError(f"--payload {text!r}: {mass:g} kg is outside [{PAYLOAD_MIN_KG:g}, {PAYLOAD_MAX_KG:g}] "
                                 "kg, the payloads every command accepts (as plant.payload_kg of a spec)")
    if hi < lo:
        raise ParameterError(f"--payload {text!r}: MAX ({hi:g}) must be >= MIN ({lo:g})")
    if not 1 <= points <= MAX_PAYLOAD_POINTS or (points == 1 and hi != lo):
        raise ParameterError(f"--payload {text!r}: POINTS must be 2..{MAX_PAYLOAD_POINTS} for a range (1 for one mass)")
    return np.linspace(lo, hi, points)
