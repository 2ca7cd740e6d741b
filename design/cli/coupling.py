"""``gantry coupling``: where X and Y meet, from a stepped sine of the X motor with every encoder recorded."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from design.cli.common import ColumnsOption, SampleRateHzOption, console, parse_machine


def coupling(
    data: Annotated[Path, typer.Argument(
        metavar="REC", help="Stepped sine of the X motor (.csv, .xlsx, .tdms) whose outputs are velocity_y1_m_per_s, "
             "velocity_y2_m_per_s and velocity_x_m_per_s.")],
    carriage_m: Annotated[float, typer.Option(
        "--carriage-m", help="Where the carriage stood during the recording (m from rail Y1).")],
    machine: Annotated[Optional[str], typer.Option(
        help="The planar machine's values (plant.physics.planar.PlanarGantry), e.g. "
             "carriage_mass_kg=56,yaw_stiffness_n_m_per_rad=2e5; its defaults otherwise.")] = None,
    columns: ColumnsOption = None,
    sample_rate_hz: SampleRateHzOption = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Find which geometric error couples X and Y (the beam's skew, the carriage's offset) and its size."""
    from design.views.console import print_story
    from design.views.json import coupling_to_dict, print_json
    from design.workflows import coupling as diagnose

    d = diagnose(data, carriage_position_m=carriage_m, machine=parse_machine(machine), columns=columns,
                 sample_rate_hz=sample_rate_hz)
    if as_json:
        print_json(coupling_to_dict(d))
    else:
        print_story(console, d.story())
