"""``gantry planar-synth``: the gantry's loops designed and verified as one planar machine (``design.synth.planar``):
Stage X's PI and Stage Y's two-motor structure on their own specs, the rotation stage's PI with Stage Y's loops
closed, then the whole loop checked on the design plants, between them and on Monte Carlo draws.

Exit status: 0 when every loop holds its requirements and the whole loop is verified; 1 when not (the output
names what fails and where); 2 for bad input (spec errors name the file and the key)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from design.cli.common import console, keep_inputs


def planar_synth(
    spec_file: Annotated[Path, typer.Argument(metavar="PLANAR_SPEC", help="Planar spec (TOML) with \\[planar] "
                                              "(stage_x, stage_y: their spec files) and \\[rotation].")],
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Design X, Y and rotation loops together on the planar gantry and verify the whole loop."""
    from design.views.console import print_story
    from design.views.design_story import planar_design_story, synthesis_story
    from design.views.json import planar_design_to_dict, print_json
    from design.views.progress import StageProgress
    from design.workflows import planar_design

    keep_inputs({}, [spec_file], json=as_json)
    progress = StageProgress(enabled=not as_json and sys.stderr.isatty())
    try:
        outcome = planar_design(spec_file, progress=progress)
    finally:
        progress.close()
    out = planar_design_to_dict(outcome)
    if as_json:
        print_json(out)
    else:
        print_story(console, planar_design_story(out))
        console.rule("Stage X")
        print_story(console, synthesis_story(out["stage_x"]))
        console.rule("Stage Y")
        print_story(console, synthesis_story(out["stage_y"]))
        console.print(f"planar design: {outcome.seconds:.1f} s")
    if out["status"] != "optimal":
        raise typer.Exit(1)
