"""What the commands share: the ``typer`` app, the console, shared options and their parsers, JSON output."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console

from plant import __version__
from plant.errors import ParameterError, SpecError

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Model, identify and tune the controllers of the exoskeleton H-gantry.")
console = Console()


def _version(value: bool) -> None:
    if value:
        print(f"gantry {__version__}")
        raise typer.Exit()


@app.callback()
def _main(version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True,
                                                help="Print the version and exit.")] = False) -> None:
    """Model, identify and tune the controllers of the exoskeleton H-gantry."""


def bundled_spec(name: str) -> Path:
    """A spec of ``specs/`` next to the package (source checkout) or in the working directory."""
    for root in (Path(__file__).resolve().parents[1], Path.cwd()):
        path = root / "specs" / name
        if path.is_file():
            return path
    raise SpecError(f"bundled spec specs/{name} not found; run from the project checkout or pass --spec FILE")


#: options shared by the commands that read recordings (``fit``, ``diagnose``)
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
    """``"force_constant_n_per_a=35.15,mass_kg=90"`` -> values of plant parameters (``--set``)."""
    out: dict[str, float] = {}
    for item in (p.strip() for p in (text or "").split(",") if p.strip()):
        name, eq, value = item.partition("=")
        try:
            number = float(value)
        except ValueError:
            number = math.nan
        if not eq or not name.strip() or not math.isfinite(number):
            raise ParameterError(f"--set item {item!r}: expected NAME=NUMBER with a finite number, e.g. "
                            "force_constant_n_per_a=35.15")
        out[name.strip()] = number
    return out


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
