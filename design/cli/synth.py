"""``gantry synth``: robust PI gains by optimisation from a spec file, independently verified.

Exit status: 0 for a verified optimal design; 1 when there is no such design: the problem is
unbounded (nothing in the plant limits the bandwidth), infeasible (no gains meet the
requirements; the binding requirement and payload are named), or the design failed the
independent check (the output explains which); 2 for bad input (spec errors name the key).
"""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.table import Table

from design.cli.common import PlantFromOption, console
from design.views.json import print_json


def synth(
    spec_file: Annotated[Path, typer.Argument(metavar="SPEC", help="Spec file (TOML).")],
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    report: Annotated[Optional[Path], typer.Option(help="Also write the HTML design report here.")] = None,
    method: Annotated[str, typer.Option(help="ccp (cvxpy + Clarabel) or ccp+exact (then casadi + IPOPT).")]
    = "ccp+exact",
    schedule: Annotated[bool, typer.Option("--schedule", help="Also per-payload gains (a gain schedule) and the "
                                                              "bandwidth they gain.")] = False,
    plant_from: PlantFromOption = None,
) -> None:
    """Synthesise PI gains maximising worst-case bandwidth under margin constraints over the payload range."""
    from design.workflows import design, load_problem

    problem = load_problem(spec_file, plant_from=plant_from)
    out = design(problem, method=method, schedule=schedule)
    if report is not None and out["status"] == "optimal" and not problem.spec.plant.measured:
        from design.views.report import design_report

        design_report(problem.spec, spec_path=spec_file, kp=out["gains"]["kp"], ki=out["gains"]["ki"],
                      gains_source="synthesised", synthesis=out,
                      command="gantry " + shlex.join(sys.argv[1:])).write(report)
    if as_json:
        print_json(out)
    else:
        _print(out)
        if report is not None and out["status"] == "optimal":
            console.print(f"report written to {report}")
    if report is not None and out["status"] != "optimal":
        typer.echo(f"no report written to {report}: no verified design", err=True)
    if out["status"] != "optimal":
        if not as_json:
            console.print(f"[bold red]{out['status']}[/] (exit status 1)")
        raise typer.Exit(1)


def _print(out: dict) -> None:
    console.print(f"[bold]status[/]: {out['status']} ({out['message']}); verified: {out['verified']}")
    g = out["gains"]
    wc = out["worst_case"]
    if g["kp"] is not None and wc is not None:
        b = out["binding"]
        where = "" if b["payload_kg"] is None else f" at {b['payload_kg']:.1f} kg"
        console.print(f"[bold]gains[/]: Kp = {g['kp']:.4g} A/(m/s), Ki = {g['ki']:.4g} A/m; worst case: "
                      f"bandwidth {wc['bandwidth_hz']:.2f} Hz, PM {wc['phase_margin_deg']:.2f} deg, GM "
                      f"{_num(wc['gain_margin_db'])} dB; binding: {b['constraint']}{where}")
        rows = out["per_payload"]
        t = Table(title=f"Per payload (dense check, {len(rows)} payloads; every {max(len(rows) // 8, 1)}th shown)")
        for col in ("payload kg", "bandwidth Hz", "PM deg", "GM dB"):
            t.add_column(col, justify="right")
        for row in rows[::max(len(rows) // 8, 1)] + ([rows[-1]] if (len(rows) - 1) % max(len(rows) // 8, 1) else []):
            t.add_row(f"{row['payload_kg']:.1f}", f"{row['bandwidth_hz']:.2f}", f"{row['phase_margin_deg']:.2f}",
                      _num(row["gain_margin_db"]))
        console.print(t)
    v = out.get("verification")
    if v:
        console.print(f"[bold]independent check[/] ({v['tool']}) at {v['payloads']} payloads: max pole real part "
                      f"{_num(v['max_closed_loop_pole_real_part'], '.3g')} 1/s, "
                      f"min PM {_num(v['min_phase_margin_deg'])}"
                      f" deg, min GM {_num(v['min_gain_margin_db'])} dB, bandwidth agreement "
                      f"{_num(v['max_bandwidth_rel_error'], '.1e')}; failures: {len(v['failures'])}")
    sch = out.get("schedule")
    if sch:
        t = Table(title=f"Gain schedule (verified at its points: {sch['verified']})")
        for col in ("payload kg", "Kp", "Ki", "bandwidth Hz", "robust gains Hz", "gain", "PM deg", "GM dB"):
            t.add_column(col, justify="right")
        for p in sch["points"]:
            t.add_row(f"{p['payload_kg']:.1f}", f"{p['kp']:.4g}", f"{p['ki']:.4g}", _num(p["bandwidth_hz"]),
                      _num(p["robust_bandwidth_hz"]), f"x{_num(p['bandwidth_gain'])}", _num(p["phase_margin_deg"]),
                      _num(p["gain_margin_db"]))
        console.print(t)
    adm = out.get("admittance")
    if adm and adm.get("m_v") is not None:
        bw = adm["rendered_bandwidth_hz"]
        console.print(f"[bold]admittance[/]: m_v = {adm['m_v']:.4g} kg, b_v = {adm['b_v']:.4g} N*s/m; peak resistance "
                      f"{adm['peak_resistance_n']:.3g} N; rendered bandwidth {_num(bw, '.1f')} Hz; interaction PM "
                      f"{_num(adm['worst_phase_margin_deg'], '.1f')} deg, "
                      f"GM {_num(adm['worst_gain_margin_db'], '.1f')} "
                      f"dB; binding: {adm['binding']['detail']}")
        console.print(f"  {adm['message']}; solver: {adm['solver']['method']}, {adm['solver']['seconds']:.1f} s")
    t = Table(title="Baselines on the same spec")
    for col in ("baseline", "Kp", "Ki", "worst BW Hz", "worst PM deg", "worst GM dB", "meets"):
        t.add_column(col, justify="left" if col == "baseline" else "right")
    for b in out["baselines"]:
        t.add_row(b["name"].split(" (")[0], f"{b['kp']:.4g}", f"{b['ki']:.4g}",
                  _num(b["worst_bandwidth_hz"]) if b.get("stable", True) else "unstable",
                  _num(b["worst_phase_margin_deg"], ".1f"), _num(b["worst_gain_margin_db"], ".1f"),
                  "yes" if b["meets_requirements"] else "NO")
    console.print(t)
    s = out["solver"]
    console.print(f"solver: {s['method']}, {s['seconds']:.2f} s" + (f" ({s['cpu_seconds']:.2f} s CPU)"
                                                                    if "cpu_seconds" in s else ""))


def _num(x, fmt: str = ".2f") -> str:
    return "inf" if x is None else format(x, fmt)
