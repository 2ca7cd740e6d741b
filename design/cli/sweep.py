"""``gantry sweep``: margins and bandwidth across payloads, Monte Carlo over the spec's uncertainty."""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path
from typing import Annotated, Optional

import numpy as np
import typer
from rich import box
from rich.console import Console
from rich.table import Table

from design.cli.common import console
from plant.errors import ParameterError, SpecError

#: payload points when --payload is not given and the spec's range is not a single mass
DEFAULT_POINTS = 71
#: payload rows shown in the terminal table (all of them go to --csv / --json)
TABLE_ROWS = 15
MAX_POINTS = 10000


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
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo <= 0 or hi <= 0:
        raise ParameterError(f"--payload {text!r}: masses must be finite and positive (kg)")
    if hi < lo:
        raise ParameterError(f"--payload {text!r}: MAX ({hi:g}) must be >= MIN ({lo:g})")
    if not 1 <= points <= MAX_POINTS or (points == 1 and hi != lo):
        raise ParameterError(f"--payload {text!r}: POINTS must be 2..{MAX_POINTS} for a range (1 for one mass)")
    return np.linspace(lo, hi, points)


class _LazyProgress:
    """Progress callback that shows a rich progress bar on stderr once the work has taken a second."""

    def __init__(self, enabled: bool):
        self.enabled = enabled
        self.t0 = time.perf_counter()
        self.bar = None
        self.task = None

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        if self.bar is None and time.perf_counter() - self.t0 > 1.0 and done < total:
            from rich.progress import BarColumn, Progress, TimeRemainingColumn

            self.bar = Progress("sweep", BarColumn(), "{task.completed}/{task.total} plants", TimeRemainingColumn(),
                                console=Console(stderr=True), transient=True)
            self.bar.start()
            self.task = self.bar.add_task("sweep", total=total)
        if self.bar is not None:
            self.bar.update(self.task, completed=done)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.stop()


def _fmt(x: float, digits: int | None = None) -> str:
    """A number for the table: ``digits`` decimals, or 3 significant figures by default."""
    if not math.isfinite(x):
        return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")
    return f"{x:.{digits}f}" if digits is not None else f"{x:.3g}"


def _table(result) -> Table:
    n = result.payload_kg.size
    show = np.unique(np.round(np.linspace(0, n - 1, min(n, TABLE_ROWS))).astype(int))
    note = "" if show.size == n else f" ({show.size} of {n} payloads shown; --csv or --json for all)"
    if not result.samples:
        t = Table(title=f"Stage {result.stage.upper()} nominal payload sweep{note}")
        for col in ("payload kg", "plant corner Hz", "closed-loop BW Hz", "PM deg", "GM dB"):
            t.add_column(col, justify="right")
        for i in show:
            nom = result.nominal
            t.add_row(f"{result.payload_kg[i]:.2f}", _fmt(nom.open_loop_corner_hz[i], 2),
                      _fmt(nom.closed_loop_bandwidth_hz[i], 2), _fmt(nom.phase_margin_deg[i], 1),
                      _fmt(nom.gain_margin_db[i], 1))
        return t
    lv = result.levels
    mid = len(lv) // 2
    t = Table(title=f"Stage {result.stage.upper()} Monte Carlo sweep, {result.samples} samples, "
                    f"seed {result.seed}{note}",
              box=box.SIMPLE_HEAD, padding=(0, 1), collapse_padding=True, pad_edge=False, show_edge=False)
    t.add_column("load\nkg", justify="right")
    for d in result.distributions:
        label = {"closed_loop_bandwidth_hz": "BW", "phase_margin_deg": "PM", "gain_margin_db": "GM"}[d.name]
        t.add_column(f"{label} {d.unit}\np{lv[mid]:g}", justify="right")
        t.add_column(f"\np{lv[0]:g}\u2013p{lv[-1]:g}", justify="right")
        t.add_column("\nworst", justify="right")
    for i in show:
        cells = [f"{result.payload_kg[i]:.3g}"]
        for d in result.distributions:
            p = d.percentiles[:, i]
            cells += [_fmt(p[mid]), f"{_fmt(p[0])}\u2013{_fmt(p[-1])}", _fmt(d.worst[i])]
        t.add_row(*cells)
    return t


def sweep(
    spec: Annotated[Path, typer.Argument(help="Spec file (TOML); plant.uncertainty gives the Monte Carlo ranges.")],
    payload: Annotated[Optional[str], typer.Option(help="Payloads MIN:MAX:POINTS in kg, e.g. 5:40:71 (default: the "
                                                   f"spec's payload min:max with {DEFAULT_POINTS} points).")] = None,
    samples: Annotated[int, typer.Option(help="Monte Carlo samples per payload (uniform over plant.uncertainty); "
                                         "0: nominal sweep only.", min=0, max=1_000_000)] = 0,
    seed: Annotated[int, typer.Option(help="Seed of the random draws (recorded in the outputs).", min=0)] = 0,
    csv: Annotated[Optional[Path], typer.Option("--csv", help="Write one row per payload (percentiles, worst "
                                                "case; units in the column names) to this CSV file.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of tables.")] = False,
) -> None:
    """Margins and bandwidth across payloads, with Monte Carlo over the spec's uncertainty ranges."""
    from design.loop.sweep import monte_carlo_sweep
    from design.spec.schema import load_spec
    from design.views.json import print_json
    from plant.recording import atomic_write_text

    s = load_spec(spec)
    if payload is not None:
        masses = parse_payload(payload)
    else:
        rng = s.plant.payload_kg
        masses = rng.grid(DEFAULT_POINTS if rng.max > rng.min else 1)
    progress = _LazyProgress(enabled=not as_json and sys.stderr.isatty())
    try:
        result = monte_carlo_sweep(s, payload_kg=masses, samples=samples, seed=seed, progress=progress)
    except SpecError as exc:
        raise SpecError(f"{spec}: {exc}") from None
    finally:
        progress.close()
    if csv is not None:
        atomic_write_text(csv, result.to_csv())
    if as_json:
        print_json(result.to_json())
        return
    console.print(_table(result))
    if result.samples:
        ranges = ", ".join(f"{k} {lo:g}..{hi:g}" for k, (lo, hi) in result.uncertainty.items())
        console.print(f"Sampling: {result.sampling}; ranges: {ranges}.")
        console.print("Worst case over all payloads and samples:")
        for w in result.worst_case().values():
            params = ", ".join(f"{k} = {v:.4g}" for k, v in w.parameters.items())
            console.print(f"  {w.name} = {_fmt(w.value, 2)} at {w.payload_kg:.2f} kg ({params})")
    if csv is not None:
        console.print(f"Wrote {csv}")
