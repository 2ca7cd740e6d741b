"""``gantry reproduce``: thesis Table 3.1 and the payload sweep from spec files."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.table import Table

from design.cli.common import bundled_spec, console
from plant.errors import SpecError


def reproduce(
    spec: Annotated[Optional[list[Path]], typer.Option("--spec", help="Spec file (repeatable); default: the "
                                                       "thesis Stage X and Y specs in specs/.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of tables.")] = False,
    points: Annotated[int, typer.Option(help="Payload points in the sweep.", min=1, max=10000)] = 8,
) -> None:
    """Reproduce thesis Table 3.1 and the payload sweep (Figure 4.31) from spec files."""
    from dataclasses import asdict

    from design.loop.reproduce import sweeps, table_3_1
    from design.spec.schema import load_spec
    from design.views.json import payload_sweep_rows, print_json

    paths = spec or [bundled_spec("thesis_stage_x.toml"), bundled_spec("thesis_stage_y.toml")]
    specs = {}
    for path in paths:
        s = load_spec(path)
        if s.plant.stage in specs:
            raise SpecError(f"{path}: a spec for stage {s.plant.stage} was already given")
        if s.controller.kp.value is None or s.controller.ki.value is None:
            raise SpecError(f"{path}: controller.kp.value and controller.ki.value are needed to reproduce")
        specs[s.plant.stage] = s
    rows = table_3_1(specs)
    sw = sweeps(specs, points=points)
    if as_json:
        print_json({"table_3_1": [{k: v for k, v in asdict(r).items()} for r in rows],
                    "payload_sweep": [row for s in sw for row in payload_sweep_rows(s)]})
        return
    t = Table(title="Thesis Table 3.1 (and section 3.1 phase margins) against this model")
    for col in ("quantity", "stage", "unit", "thesis", "computed", "rel. diff."):
        t.add_column(col, justify="right" if col not in ("quantity", "stage") else "left")
    for r in rows:
        flag = "" if not r.explanation else " *"
        t.add_row(r.quantity, r.stage.upper(), r.unit, f"{r.thesis:g}", f"{r.computed:.2f}",
                  f"{100 * r.relative_difference:+.1f} %{flag}")
    console.print(t)
    console.print("Definitions:")
    for q in dict.fromkeys(r.quantity for r in rows):
        console.print(f"  [bold]{q}[/]: {next(r.definition for r in rows if r.quantity == q)}")
    for r in rows:
        if r.explanation:
            console.print(f"  * {r.stage.upper()} {r.quantity}: {r.explanation}")
    for s in sw:
        t = Table(title=f"Stage {s.stage.upper()} payload sweep (thesis Figure 4.31)")
        for col in ("payload kg", "plant corner Hz", "closed-loop BW Hz", "PM deg", "GM dB"):
            t.add_column(col, justify="right")
        for row in payload_sweep_rows(s):
            gm = row["gain_margin_db"]
            t.add_row(f"{row['payload_kg']:.1f}", f"{row['open_loop_corner_hz']:.2f}",
                      f"{row['closed_loop_bandwidth_hz']:.2f}", f"{row['phase_margin_deg']:.1f}",
                      "inf" if gm is None else f"{gm:.1f}")
        console.print(t)
