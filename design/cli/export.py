"""``gantry export``: a design's gains, filters and discrete coefficients in a drive's own parameter names, units
and scaling (``design.views.drive_parameters``: each conversion's source and its inverse), to type into the drive.

Exit status: 0, or 2 for bad input (a missing or unreadable design file, a file that is not ``gantry synth --json``'s,
an unknown drive, a drive that needs what was not given: the spec's force constant, the encoder's resolution, an
admittance design)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from design.cli.common import console, finite_positive


def export(
    design_file: Annotated[Path, typer.Argument(metavar="DESIGN", help="The design: the JSON of gantry synth "
                                                "--json.")],
    drive: Annotated[str, typer.Option("--drive", help="beckhoff (AX5000 S-0-0100/S-0-0101, AX8000 3140:01/02; "
                                       "needs --spec), copley (gains in drive units; needs --encoder-resolution-m), "
                                       "generic (Kp, Ki, Tn and the discrete coefficients) or labview (the "
                                       "admittance law's coefficients).")],
    spec_file: Annotated[Optional[Path], typer.Option("--spec", help="The spec the design was made from: its "
                                                      "force constant (plant.force_constant_n_per_a) for beckhoff.")]
    = None,
    encoder_resolution_m: Annotated[Optional[float], typer.Option(
        "--encoder-resolution-m", callback=finite_positive,
        help="The velocity encoder's resolution in m per count (1e-6 for 1 um), for copley; no spec key holds "
             "it.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Print a design's gains in a drive's own parameter names, units and scaling."""
    import json

    from design.views import drive_parameters as dp
    from design.views.json import print_json, synthesis_from_json
    from plant.errors import ParameterError
    from plant.host.text_io import read_text

    if drive not in dp.DRIVES:
        raise ParameterError(f"--drive {drive!r}: unknown drive; drives are {', '.join(dp.DRIVES)}")
    text = read_text(design_file, what="design file")
    where = str(design_file)
    if drive == "labview":
        synthesis_from_json(text, where)
        admittance = json.loads(text).get("admittance")
        if not isinstance(admittance, dict):
            raise ParameterError(f"{where}: no admittance design (made from a spec without [admittance]); "
                                 "--drive labview exports the admittance law")
        synthesis_from_json(text, where, admittance=True)
        out = dp.labview(admittance, where)
    else:
        design = synthesis_from_json(text, where)
        kp, ki = float(design.controller.kp), float(design.controller.ki)
        if drive == "generic":
            out = dp.generic(kp, ki, discrete=json.loads(text).get("discrete"))
        elif drive == "copley":
            if encoder_resolution_m is None:
                raise ParameterError("--drive copley needs --encoder-resolution-m (m per count of the velocity "
                                     "encoder, e.g. 1e-6 for 1 um): no spec key holds it")
            out = dp.copley(kp, ki, encoder_resolution_m)
        else:
            if spec_file is None:
                raise ParameterError("--drive beckhoff needs --spec SPEC, the spec the design was made from: its "
                                     "plant.force_constant_n_per_a turns A/(m/s) into the drive's N/(m/s)")
            from design.workflows import load_problem

            out = dp.beckhoff(kp, ki, load_problem(spec_file).loop.plant.force_constant_n_per_a)
    if as_json:
        print_json(dp.export_to_dict(out, where))
    else:
        from design.views.console import print_story

        print_story(console, dp.export_story(out, where))
