"""``gantry planar-run``: a mouse walking on the floor in two dimensions (a straight run at any heading, a run
with a turn, or a recorded x-y path) through both axes' admittance at once on the planar gantry
(``design.admittance.planar_run``): the force it feels, how much of it sideways, how far the clamp lags, what
each motor does and how the beam yaws.

Exit status: 0 when the mouse keeps up (the force felt within its budget, the clamp's peak speed within 5 %
of the mouse's, as ``gantry mouse-run`` judges it), 3 when it cannot, 2 for bad input."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from design.cli.common import console, finite_non_negative, finite_positive, keep_inputs, read_design
from plant.errors import ParameterError


def planar_run(
    x_spec: Annotated[Path, typer.Argument(metavar="X_SPEC", help="Stage X's spec (TOML) with an \\[admittance] "
                                           "section: the carriage, X's drive and law, the mouse.")],
    y_spec: Annotated[Path, typer.Argument(metavar="Y_SPEC", help="Stage Y's two-motor spec (TOML) with "
                                           "\\[dual_drive] and \\[admittance]: the beam, both Y drives, Y's law.")],
    x_design: Annotated[Path, typer.Option("--x-design", help="Stage X's design: the JSON of gantry synth X_SPEC "
                                           "--json (kp, ki, m_v, b_v).")],
    y_design: Annotated[Path, typer.Option("--y-design", help="Stage Y's design: the JSON of gantry synth Y_SPEC "
                                           "--json (the structure, its gains, m_v, b_v).")],
    path: Annotated[str, typer.Option("--path", help="diagonal (the spec's trapezoid at --heading-deg), turn (along "
                                      "X, a quarter turn of --radius-m, along Y) or a CSV file time_s,x_m,y_m.")]
    = "diagonal",
    heading_deg: Annotated[float, typer.Option("--heading-deg", help="The diagonal run's heading from X toward Y "
                                               "(deg).")] = 45.0,
    radius_m: Annotated[float, typer.Option("--radius-m", callback=finite_positive,
                                            help="The turn's radius (m).")] = 0.05,
    payload_kg: Annotated[Optional[float], typer.Option("--payload-kg", callback=finite_positive,
                                                        help="Payload (default the heaviest of X_SPEC).")] = None,
    carriage_m: Annotated[Optional[float], typer.Option("--carriage-m", callback=finite_positive,
                                                        help="Where the carriage starts, from rail Y1 (m; default "
                                                        "mid-travel of Y_SPEC).")] = None,
    legs: Annotated[Optional[float], typer.Option("--legs-n-per-m", callback=finite_non_negative,
                                                  help="The walking mouse's stance stiffness (default the least of "
                                                  "X_SPEC's admittance.mouse.leg_stiffness_n_per_m).")] = None,
    out: Annotated[Optional[Path], typer.Option("--out", help="Write the run (one row per drive tick) to this "
                                                "CSV.")] = None,
    plot: Annotated[Optional[Path], typer.Option("--plot", help="Draw the path on the floor and the force felt "
                                                 "(and across the heading) to this SVG file.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Simulate a mouse walking in two dimensions through both axes' admittance on the planar gantry."""
    from design.admittance.planar_path import diagonal_path, planar_path_from_csv, turn_path
    from design.admittance.planar_run import planar_run as run
    from design.admittance.planar_run import planar_settings
    from design.views.json import dual_admittance_from_json, planar_run_csv, planar_run_to_dict, print_json
    from design.views.progress import StageProgress
    from design.workflows import load_problem
    from plant.host.files import atomic_write_texts, is_stdout
    from plant.host.text_io import read_text

    csv_path = None if path in ("diagonal", "turn") else Path(path)
    keep_inputs({"--out": out, "--plot": plot}, [x_spec, y_spec, x_design, y_design, csv_path], json=as_json)
    x_problem = load_problem(x_spec).loop
    y_problem = load_problem(y_spec)
    x_problem, x_controller, x_virtual = read_design(x_design, x_problem, admittance=True)
    y_controller, y_virtual = dual_admittance_from_json(read_text(y_design, what="design file"), str(y_design))
    settings = planar_settings(x_problem, y_problem, x_controller=x_controller, x_virtual=x_virtual,
                               y_controller=y_controller, y_virtual=y_virtual, payload_kg=payload_kg,
                               carriage_position_m=carriage_m, leg_stiffness_n_per_m=legs)
    loc = x_problem.admittance.locomotion
    if csv_path is not None:
        intended = planar_path_from_csv(csv_path, settings.drive_rate_hz)
    elif path == "turn":
        intended = turn_path(loc, settings.drive_rate_hz, radius_m=radius_m)
    else:
        intended = diagonal_path(loc, settings.drive_rate_hz, heading_deg=heading_deg)
    reach = settings.carriage_position_m + intended.position_m[:, 0]
    if reach.min() <= 0 or reach.max() >= settings.machine.rail_separation_m:
        raise ParameterError(f"--path: the carriage would leave the beam (from {settings.carriage_position_m:g} m it "
                             f"reaches {reach.min():.3g} .. {reach.max():.3g} m of 0 .. "
                             f"{settings.machine.rail_separation_m:g} m); start it elsewhere with --carriage-m")
    progress = StageProgress(enabled=not as_json and sys.stderr.isatty())
    try:
        progress("the mouse walking the path on the planar gantry")
        result = run(settings, intended)
    finally:
        progress.close()
    d = planar_run_to_dict(result, {"x": str(x_design), "y": str(y_design)})
    files = {}
    if out is not None:
        files[out] = planar_run_csv(result)
    if plot is not None:
        import matplotlib

        matplotlib.use("Agg")
        from design.views.admittance_figures import planar_run_figure
        from design.views.html import svg

        files[plot] = svg(planar_run_figure(result))
    if as_json:
        print_json(d)
    else:
        console.print(f"[bold]planar run[/] ({intended.source}) with {settings.machine.carriage_mass_kg:g} kg on the "
                      f"carriage from {settings.carriage_position_m:g} m; X: m_v = {settings.x_law.m_v:.4g} kg, b_v = "
                      f"{settings.x_law.b_v:.4g} N*s/m; Y ({y_controller.name}): m_v = {settings.y_law.m_v:.4g} kg, "
                      f"b_v = {settings.y_law.b_v:.4g} N*s/m", soft_wrap=True)
        for line in d["summary"]:
            console.print(f"  {line}", soft_wrap=True)
        for path, what in ((out, "run"), (plot, "figure")):
            if path is not None and not is_stdout(path):
                console.print(f"{what} written to {path}")
    if files:
        atomic_write_texts(files)
    if not result.mouse_keeps_up:
        raise typer.Exit(3)
