"""``gantry reproduce``: thesis Table 3.1 and the payload sweep from spec files."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from design.cli.common import console
from design.spec.bundled import bundled_spec
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
    from design.views.console import print_story
    from design.views.design_story import reproduction_story
    from design.views.json import payload_sweep_rows, print_json
    from design.workflows import load_problem

    paths = spec or [bundled_spec("thesis_stage_x.toml"), bundled_spec("thesis_stage_y.toml")]
    specs = {}
    for path in paths:
        s = load_problem(path).loop
        stage = s.plant.nominal.stage
        if stage in specs:
            raise SpecError(f"{path}: a spec for stage {stage} was already given")
        if s.controller.kp.value is None or s.controller.ki.value is None:
            raise SpecError(f"{path}: controller.kp.value and controller.ki.value are needed to reproduce")
        specs[stage] = s
    rows = table_3_1(specs)
    sw = sweeps(specs, points=points)
    if as_json:
        print_json({"table_3_1": [{k: v for k, v in asdict(r).items()} for r in rows],
                    "payload_sweep": [row for s in sw for row in payload_sweep_rows(s)]})
        return
    print_story(console, reproduction_story(rows, sw))
