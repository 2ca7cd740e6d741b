"""``gantry mouse-run``: a force-limited mouse walking the spec's profile (or a recorded path) through the
sampled, nonlinear admittance loop of a design; what it feels, how far it falls short, drift and limit cycles.

The run is one payload and one mouse; the setting is also checked at every payload, uncertainty corner and
mouse of the spec (Stage X: ``design.admittance.corners``), where its coupled loop may be unstable.

Exit status: 0 when the mouse keeps up (peak force within its budget: the run never holds it at its limit
for long) and the setting is stable at every corner, 3 when it cannot keep up (the profile asks more than the
mouse's peak force) or a corner is unstable, 2 for bad input."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from design.cli.common import console, finite_non_negative, finite_positive, keep_inputs, read_design
from plant.errors import ParameterError, SpecError

#: the lab's hand-tuned X-axis setting (bsbrl/exoskeleton, mousetrack tuning files "newsys_m0p04_c4")
LAB_M_V_KG, LAB_B_V_N_S_PER_M = 0.04, 4.0


def mouse_run(
    spec_file: Annotated[Path, typer.Argument(metavar="SPEC", help="Spec file (TOML) with an \\[admittance] section "
                                              "and admittance.rig.update_rate_hz.")],
    design_file: Annotated[Optional[Path], typer.Option("--design", help="The design: the JSON of gantry synth "
                                                        "--json (its gains kp, ki, m_v, b_v).")] = None,
    lab: Annotated[bool, typer.Option("--lab", help="The lab's hand-tuned setting m_v = 0.04 kg, b_v = 4 N*s/m "
                                      "with the spec's controller gains, instead of --design.")] = False,
    path: Annotated[Optional[Path], typer.Option("--path", help="A recorded path to walk (CSV: time_s,position_m); "
                                                 "default the spec's trapezoidal locomotion profile.")] = None,
    payload_kg: Annotated[Optional[float], typer.Option("--payload-kg", callback=finite_positive,
                                                        help="Payload (default the heaviest of the spec).")] = None,
    friction_n: Annotated[Optional[float], typer.Option("--friction-n", callback=finite_non_negative,
                                                        help="Coulomb friction of the rails (N; default the "
                                                        "plant's coulomb_friction, 0 without one).")] = None,
    legs: Annotated[Optional[float], typer.Option("--legs-n-per-m", callback=finite_non_negative,
                                                  help="The walking mouse's stance stiffness (default the least of "
                                                  "admittance.mouse.leg_stiffness_n_per_m).")] = None,
    out: Annotated[Optional[Path], typer.Option("--out", help="Write the run (one row per drive tick) to this "
                                                "CSV.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Simulate a force-limited mouse walking through the sampled admittance loop of a design."""
    from design.admittance.corners import corner_check
    from design.admittance.mouse_run import mouse_run as run
    from design.admittance.mouse_run import path_from_csv, run_settings, trapezoid_path
    from design.loop.controller import PI
    from design.views.json import mouse_run_csv, mouse_run_to_dict, print_json
    from design.views.progress import StageProgress
    from design.workflows import load_problem
    from plant.host.files import atomic_write_text, is_stdout

    keep_inputs({"--out": out}, [spec_file, design_file, path], json=as_json)
    if lab == (design_file is not None):
        raise ParameterError("give exactly one of --design FILE (the JSON of gantry synth --json) or --lab")
    problem = load_problem(spec_file).loop
    if lab:
        controller = PI.given(problem.controller)
        if controller is None:
            raise SpecError(f"{spec_file}: --lab uses controller.kp.value and controller.ki.value; set them")
        m_v, b_v, source = LAB_M_V_KG, LAB_B_V_N_S_PER_M, "the lab's hand-tuned setting (bsbrl/exoskeleton)"
    else:
        problem, controller, (m_v, b_v) = read_design(design_file, problem, admittance=True)
        source = str(design_file)
    try:
        settings = run_settings(problem, controller=controller, m_v=m_v, b_v=b_v, payload_kg=payload_kg,
                                friction_n=friction_n, leg_stiffness_n_per_m=legs)
    except ValueError as exc:
        raise SpecError(f"{spec_file}: {exc}") from None
    adm = problem.admittance
    intended = (path_from_csv(path, settings.drive_rate_hz) if path is not None
                else trapezoid_path(adm.locomotion, settings.drive_rate_hz))
    progress = StageProgress(enabled=not as_json and sys.stderr.isatty())
    try:
        progress("the mouse walking the path")
        result = run(settings, intended)
        corners = None
        if problem.plant.nominal.stage == "x":
            progress("the setting at every payload, uncertainty corner and mouse of the spec")
            corners = corner_check(problem, controller=controller, m_v=m_v, b_v=b_v)
    finally:
        progress.close()
    d = mouse_run_to_dict(result, source, corners)
    if out is not None:                           # the file last, after what is printed
        text = mouse_run_csv(result)
    if as_json:
        print_json(d)
    else:
        console.print(f"[bold]mouse run[/] ({intended.source}; {source}: m_v = {m_v:.4g} kg, b_v = {b_v:.4g} N*s/m, "
                      f"{controller}) at {settings.gantry_mass_kg:g} kg", soft_wrap=True)
        for line in d["summary"]:
            console.print(f"  {line}", soft_wrap=True)
        if out is not None and not is_stdout(out):
            console.print(f"run written to {out}")
    if out is not None:
        atomic_write_text(out, text)
    if not d["mouse_keeps_up"] or not d.get("stable_at_every_corner", True):
        raise typer.Exit(3)
