"""Results as text on the console: the output of the commands without ``--json``."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
from rich import box
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from design.views.json import payload_sweep_rows
from plant.experiment.simulate_time import travel_notes
from plant.story import Section, Story

if TYPE_CHECKING:
    from design.loop.analysis import PayloadSweep
    from design.loop.reproduce import TableRow
    from design.results import DiagnosisOutcome, FitOutcome
    from plant.data.recordings import Recording
    from plant.experiment.excitation import Multisine, SteppedSine, VariancePrediction

#: payload rows shown in the sweep's terminal table (all of them go to --csv / --json)
TABLE_ROWS = 15


def print_story(console: Console, story: Story) -> None:
    """A story (``plant.story``) on the terminal, laid out as ``Story.text`` lays it out: the headline's labels in
    bold, each section as ``[[Title]]`` with its table (a rich table) and its lines; notes as notes."""
    for label, sentence in story.headline:
        console.print(f"[bold]{escape(label)}:[/] {escape(sentence)}", soft_wrap=True)
    for s in story.sections:
        if s.kind == "notes" and s.table is None:
            for line in s.lines:
                console.print(f"[yellow]{escape(s.title.rstrip('s'))}:[/] {escape(line)}", soft_wrap=True)
            continue
        console.print(f"[bold]\\[[{escape(s.title)}]][/]" + (f" {escape(s.aside)}" if s.aside else ""), soft_wrap=True)
        if s.table is not None:
            t = Table(box=box.SIMPLE_HEAD, pad_edge=False)
            for k, column in enumerate(s.table.columns):
                t.add_column(escape(column), justify="left" if k in s.table.text_columns else "right")
            for row in s.table.rows:
                t.add_row(*(escape(c) for c in row))
            console.print(t)
        for line in s.numbered():
            console.print(f"    {escape(line)}", soft_wrap=True, highlight=False)


def print_fit(console: Console, outcome: FitOutcome) -> None:
    """The text of ``gantry fit``: the fit's story, the estimator's data checks, and the rational fit when
    there is one."""
    story = outcome.result.story()
    if outcome.measured is not None and outcome.measured.notes:
        story = replace(story, sections=(*story.sections, Section("Data", tuple(outcome.measured.notes))))
    print_story(console, story)
    if outcome.rational is not None:
        console.print()
        print_story(console, outcome.rational.story())


def print_diagnosis_outcome(console: Console, outcome: DiagnosisOutcome) -> None:
    """The text of ``gantry diagnose``: the diagnosis's story, frequency or time domain."""
    print_story(console, outcome.diagnosis.story())


def print_dual_design(console: Console, out: dict) -> None:
    """The two-motor Stage Y's structures side by side: worst case over the whole box (the design plants and
    between them) and the Monte Carlo, then each one's gains, where it is worst and how the box was covered."""
    t = Table(title=f"Structures: worst over {out['design_plants']} design plants (carriage positions x payloads x "
                    f"uncertainty corners) and between them; Monte Carlo: {out['monte_carlo_draws']} draws")
    for col in ("structure", "BW Hz", "PM deg", "GM dB", "common PM deg", "common GM dB", "MC fails"):
        t.add_column(col, justify="left" if col == "structure" else "right", no_wrap=col == "structure")
    for row in out["structures"]:
        d, mc = (row["between"] or {}).get("worst", row["design_plants"]), row["monte_carlo"]
        mark = " *" if row["structure"] == out["recommended"] else ""
        if d is None:
            t.add_row(row["structure"], "none", *[""] * 5)
            continue
        t.add_row(row["structure"] + mark, _val(d["bandwidth_hz"]), _val(d["phase_margin_deg"]),
                  _num(d["gain_margin_db"]), _val(d["common_phase_margin_deg"]), _num(d["common_gain_margin_db"]),
                  "not run" if mc is None else f"{mc['n_failing']}")
    console.print(t)
    console.print("BW: worst-case translation bandwidth; PM, GM: each channel with the other closed; common: the "
                  "same change on both motors at once; MC: Monte Carlo"
                  + (f"; * recommended: {out['recommended']}" if out["recommended"] else ""),
                  soft_wrap=True)
    for row in out["structures"]:
        d = (row["between"] or {}).get("worst", row["design_plants"])
        if d is None:
            console.print(f"[bold]{row['structure']}[/]: no gains within the \\[controller] box hold the requirements",
                          soft_wrap=True)
            continue
        gains = ", ".join(f"{k} = {v:.4g}" + (" (at the \\[controller] bound)" if k in row["at_bound"] else "")
                          for k, v in row["gains"].items())
        console.print(f"[bold]{row['structure']}[/]: {gains}; yaw coupling {d['yaw_coupling']:.3g} (peak rail "
                      f"disagreement per translation command); disk margin {d['disk_margin']:.3g} (+-"
                      f"{_num(d['disk_gain_margin_db'])} dB, +-{_val(d['disk_phase_margin_deg'])} deg); lowest "
                      f"bandwidth at {d['worst_bandwidth_at']}; smallest PM at {d['worst_phase_margin_at']}; "
                      f"smallest common-mode PM at {d['worst_common_at']}; an extra "
                      f"{1e3 * d['common_delay_margin_s']:.3g} ms of delay in both drives destabilises it"
                      + (f"; binds: {', '.join(row['binding'])}" if row["binding"] else "")
                      + (f"; between the grid's points: {row['between']['coverage']}"
                         + ("" if row["between"]["holds"] else ", FAILS at " + ", ".join(
                             f"{k} = {v:.4g}" for k, v in row["between"]["worst_point"].items()))
                         + (f" (designed {row['design_rounds']} times, each failing point found there added)"
                            if row["design_rounds"] > 1 else "")
                         if row["between"] else "")
                      + (f"; a 1 mm/s offset on rail Y1's velocity sensor ramps the motors' differential current by "
                         f"{abs(row['offset_ramp_a_per_s_per_mm_s']):.3g} A/s without end (a closed-loop pole at "
                         "s = 0: integral action on both rails against the yaw spring; the common/differential pair "
                         "with ki_differential = 0 has none)" if row["offset_ramp_a_per_s_per_mm_s"] else ""),
                      soft_wrap=True)


def print_synthesis(console: Console, out: dict) -> None:
    """The text of ``gantry synth``: status, gains, per-payload table, check, schedule, admittance, baselines."""
    console.print(f"[bold]status[/]: {out['status']} ({out['message']}); verified: {out['verified']}", soft_wrap=True)
    origin = out.get("plant_from")
    if origin:
        console.print(f"plant from {origin['file']}"
                      + (f"; carried: {', '.join(origin['carried'])}" if origin["carried"] else "")
                      + (f"; left out (no linear response to design for): {', '.join(origin['left_out'])}"
                         if origin["left_out"] else ""), soft_wrap=True, markup=False)
    if out.get("kind") == "dual_drive":
        print_dual_design(console, out)
        adm = out.get("admittance")
        if adm and adm.get("m_v") is not None:
            _print_admittance(console, adm)
            t = Table(title="Admittance by carriage position (worst over payloads, uncertainty corners and mice)")
            for col in ("carriage m", "PM deg", "GM dB", "rendered BW Hz", "motor force N"):
                t.add_column(col, justify="right")
            for r in adm["by_carriage_position"]:
                t.add_row(f"{r['carriage_position_m']:.3g}", _val(r["phase_margin_deg"]), _num(r["gain_margin_db"]),
                          _num(r["rendered_bandwidth_hz"], ".2f"), f"{r['motor_force_n']:.4g}")
            console.print(t)
        elif adm:
            console.print(f"[bold]admittance[/]: {adm['status']}: {adm['message']}", soft_wrap=True)
        return
    g = out["gains"]
    wc = out["worst_case"]
    if g["kp"] is not None and wc is not None:
        b = out["binding"]
        where = "" if b["payload_kg"] is None else f" at {b['payload_kg']:.1f} kg"
        scenario = "".join(f", {k} = {v:.4g}" for k, v in (b.get("scenario") or {}).items())
        console.print(f"[bold]gains[/]: Kp = {g['kp']:.4g} A/(m/s), Ki = {g['ki']:.4g} A/m; worst case: "
                      f"bandwidth {_val(wc['bandwidth_hz'])} Hz, PM {_val(wc['phase_margin_deg'])} deg, GM "
                      f"{_num(wc['gain_margin_db'])} dB; binding: {b['constraint']}{where}{scenario}")
        rows = out["per_payload"]
        over = " worst over the uncertainty" if out.get("monte_carlo") else ""
        t = Table(title=f"Per payload (dense check, {len(rows)} payloads{over}; every {max(len(rows) // 8, 1)}th "
                        "shown)")
        for col in ("payload kg", "bandwidth Hz", "PM deg", "GM dB"):
            t.add_column(col, justify="right")
        for row in rows[::max(len(rows) // 8, 1)] + ([rows[-1]] if (len(rows) - 1) % max(len(rows) // 8, 1) else []):
            t.add_row(f"{row['payload_kg']:.1f}", _val(row["bandwidth_hz"]), _val(row["phase_margin_deg"]),
                      _num(row["gain_margin_db"]))
        console.print(t)
    v = out.get("verification")
    if v:
        if "max_closed_loop_pole_real_part" in v:
            console.print(f"[bold]independent check[/] ({v['tool']}) on {v['payloads']} plants: max pole real part "
                          f"{_num(v['max_closed_loop_pole_real_part'], '.3g')} 1/s, "
                          f"min PM {_num(v['min_phase_margin_deg'])}"
                          f" deg, min GM {_num(v['min_gain_margin_db'])} dB, bandwidth agreement "
                          f"{_num(v['max_bandwidth_rel_error'], '.1e')}; failures: {len(v['failures'])}")
        else:       # a design on measured responses
            console.print(f"[bold]independent check[/] ({v['tool']}) on {v['payloads']} recordings; failures: "
                          f"{len(v['failures'])}" + "".join(f"\n  {f}" for f in v["failures"]))
    for f in out.get("filters") or []:
        if not f["used"]:
            console.print(f"[bold]{f['kind']} filter[/]: left out (the design is faster without it)")
            continue
        params = ", ".join(f"{k} = {f[k]:.4g}" for k in ("frequency_hz", "damping_ratio", "depth") if k in f)
        console.print(f"[bold]{f['kind']} filter[/]: {params} (chosen: {', '.join(f['designed']) or 'none, kept'})")
    dd = out.get("discrete")
    if dd:
        v = dd["verification"]
        console.print(f"[bold]discrete[/] at {dd['loop_rate_hz']:g} Hz: Kp = {dd['kp']:.6g}, integral gain per sample "
                      f"{dd['ki_per_sample']:.6g} ({escape(dd['integrator'])}); discrete loop on {v['plants']} plants: "
                      f"min PM "
                      f"{_num(v['min_phase_margin_deg'])} deg, min GM {_num(v['min_gain_margin_db'])} dB, verified "
                      f"{v['verified']}")
        for f in dd["filters"]:
            console.print(f"  {f['name']} ({f['frequency_hz']:g} Hz, damping {f['damping_ratio']:.4g}): "
                          + ", ".join(f"{k} = {f[k]:.10g}" for k in ("b0", "b1", "b2", "a1", "a2")))
    mc = out.get("monte_carlo")
    if mc:
        console.print(f"[bold]Monte Carlo[/] ({mc['samples']} independent draws over payload x plant.uncertainty, seed "
                      f"{mc['seed']}): {mc['violations']} violate ({100 * mc['rate']:.2g} %, 95 % upper bound "
                      f"{100 * mc['rate_upper_bound_95']:.2g} %); worst PM {_num(mc['worst_phase_margin_deg'])} deg, "
                      f"worst GM {_num(mc['worst_gain_margin_db'])} dB, lowest bandwidth "
                      f"{_num(mc['worst_bandwidth_hz'])} Hz")
    between = out.get("between_grid")
    if between:
        console.print(f"[bold]between the dense check's points[/] (a search over {', '.join(between['coordinates'])} "
                      f"from {between['starts']} starts, {between['evaluations']} points): least relative slack "
                      f"{between['slack']:.3g} (the grid's {between['grid_slack']:.3g}): "
                      f"{'holds' if between['holds'] else 'FAILS'}; least bandwidth "
                      f"{_num(between['least_bandwidth_hz'])} Hz (the check's {_num(between['grid_bandwidth_hz'])} Hz)",
                      soft_wrap=True)
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
        _print_admittance(console, adm)
    elif adm:
        console.print(f"[bold]admittance[/]: {adm['status']}: {adm['message']}", soft_wrap=True)
    if out["baselines"]:        # none for a co-designed admittance spec (its gains are not the PI loop's alone)
        t = Table(title="Baselines on the same spec")
        for col in ("baseline", "Kp", "Ki", "worst BW Hz", "worst PM deg", "worst GM dB", "meets"):
            t.add_column(col, justify="left" if col == "baseline" else "right")
        for b in out["baselines"]:
            t.add_row(b["name"].split(" (")[0], f"{b['kp']:.4g}", f"{b['ki']:.4g}",
                      _num(b["worst_bandwidth_hz"]) if b.get("stable", True) else "unstable",
                      _num(b["worst_phase_margin_deg"], ".1f"), _num(b["worst_gain_margin_db"], ".1f"),
                      "yes" if b["meets_requirements"] else "NO")
        console.print(t)
    if "coverage" in out:
        console.print(f"coverage: {out['coverage']['text']}", soft_wrap=True)
    s = out["solver"]
    console.print(f"solver: {s['method']}, {s['seconds']:.2f} s" + (f" ({s['cpu_seconds']:.2f} s CPU)"
                                                                    if s.get("cpu_seconds") is not None else ""))


def _print_admittance(console: Console, adm: dict) -> None:
    """The admittance stage: the virtual dynamics, what the mouse feels, the margins by mouse, the rig."""
    bw, m = adm["rendered_bandwidth_hz"], adm.get("mouse") or {}
    loops = (f"on the {adm['structure']} loops ({', '.join(f'{k} = {v:.4g}' for k, v in adm['gains'].items())})"
             if "structure" in adm else f"with Kp = {adm['kp']:.4g}, Ki = {adm['ki']:.4g}")
    console.print(f"[bold]admittance[/]: m_v = {adm['m_v']:.4g} kg, b_v = {adm['b_v']:.4g} N*s/m {loops}; rendered "
                  f"bandwidth {_num(bw, '.1f')} Hz; binding: {adm['binding']['detail']}", soft_wrap=True)
    cd = adm.get("codesign")
    if "structure" in adm and cd is not None:
        v = cd["velocity_loops"]
        w = v["between"]["worst"]
        console.print(f"  co-designed for the mouse from the structure's "
                      f"{', '.join(f'{k} = {x:.4g}' for k, x in cd['given_gains'].items())}: "
                      f"{cd['force_felt_n']:.3g} N felt on the reduced set for {cd['given_force_felt_n']:.3g} N "
                      f"({cd['candidates_meeting_velocity_requirements']} of {cd['candidates']} candidates met the "
                      f"velocity loops' requirements); its velocity loops: worst PM {_val(w['phase_margin_deg'])} deg, "
                      f"GM {_num(w['gain_margin_db'])} dB, common-mode {_val(w['common_phase_margin_deg'])} deg / "
                      f"{_num(w['common_gain_margin_db'])} dB, bandwidth {_val(w['bandwidth_hz'])} Hz over the design "
                      f"plants and between them; Monte Carlo {v['monte_carlo']['n_failing']} of "
                      f"{v['monte_carlo']['n_plants']} fail; "
                      + ("verified" if cd["verified"] else "NOT verified"), soft_wrap=True)
    if m:
        console.print(f"  the mouse feels {m['force_felt_peak_n']:.3g} N peak, {m['force_felt_rms_n']:.3g} N RMS on "
                      f"the profile (m_v a + b_v v = {m['virtual_dynamics_force_n']:.3g} N; it can push "
                      f"{adm['limits']['mouse_peak_force_n']:g} N: {'can' if m['can_drive'] else 'CANNOT'} drive it); "
                      f"with its peak force it reaches {m['reachable_speed_m_per_s']:.3g} m/s and "
                      f"{m['reachable_acceleration_m_per_s2']:.3g} m/s^2; it must push "
                      f"{1e3 * m['breakaway_force_n']:.3g} mN to start the gantry, which drifts "
                      f"{m['drift_mm_per_s']:.3g} mm/s at rest", soft_wrap=True)
        short = m.get("velocity_shortfall_at_cruise_end", 0.0)
        if m.get("velocity_shortfall_reported"):
            console.print(f"  the velocity loop still leaves the gantry {100 * short:.3g} % short of the law's "
                          f"reference at the end of the cruise (Ki = {adm.get('ki', math.nan):.4g} A/m integrates "
                          "too slowly for it): the mouse pushes that much harder than m_v a + b_v v", soft_wrap=True)
    rec = adm.get("recorded_force")
    limits = adm["limits"]
    motor = (f"  motor: {adm['worst_motor_force_n']:.4g} N of {limits['motor_peak_force_n']:g} N "
             + ("on the locomotion profile" if limits.get("motor_force_criterion") == "locomotion" else
                "for the mouse's peak force at the worst frequency"))
    if rec and rec.get("motor_peak_force_n") is not None:
        motor += (f"; {rec['motor_peak_force_n']:.4g} N on the recorded force ({rec['file']}, {rec['duration_s']:g} "
                  f"s; worst {rec['at_s']:.4g} s into it, at {rec['where']}), {rec['checked']}")
    console.print(motor, soft_wrap=True)
    for name, v in adm["margins_by_mouse"].items():
        console.print(f"  interaction loop, {name} mice: worst PM {_num(v['phase_margin_deg'], '.1f')} deg, "
                      f"GM {_num(v['gain_margin_db'], '.1f')} dB")
    contact = ("" if "stiffest_contact_n_per_m" not in adm else
               f"; stable on a grounded spring up to {_num(adm['stiffest_contact_n_per_m'], '.4g')} N/m")
    console.print(f"  passive (Re Y_r >= 0) up to {_num(adm['passive_up_to_hz'], '.3g')} Hz{contact}")
    between = adm.get("between_grid")
    if between:
        failed = between["failed_at_ray_design"]
        cured = ("" if failed is None else
                 f"; at the ray's design it found PM {_num(failed['phase_margin_deg'], '.2f')} deg, GM "
                 f"{_num(failed['gain_margin_db'], '.2f')} dB there, and (m_v, b_v) went up the ray by "
                 f"{100 * (between['scale_up'] - 1):.2f} %")
        over = ("carriage position, payload" if between["coordinates"][0] == "carriage_position_m" else "payload")
        console.print(f"  between the check's points ({between['evaluations']} points searched from "
                      f"{between['starts']} starts over {over}, uncertainty and mouse): least PM "
                      f"{_num(between['phase_margin_deg'], '.2f')} deg, GM {_num(between['gain_margin_db'], '.2f')} dB "
                      f"({'holds' if between['holds'] else 'FAILS'}){cured}", soft_wrap=True)
    lat = adm.get("latency")
    if lat:
        more = lat["one_more_sample"]
        samples = "" if lat["margin_samples"] is None else f" ({lat['margin_samples']:.2f} samples)"
        extra = "" if more is None else (
            f"; with {more['computation_delay_samples']} sample(s) of computation delay: "
            + (f"PM {_num(more['phase_margin_deg'], '.1f')} deg, GM {_num(more['gain_margin_db'], '.1f')} dB"
               if more["stable"] else "UNSTABLE"))
        console.print(f"  latency: tolerates {_num(lat['margin_ms'], '.3g')} ms more{samples} (least at "
                      f"{lat['worst']}){extra}", soft_wrap=True)
    rig = adm["rig"]
    if rig["discrete"]:
        d = rig["discrete"]
        console.print(escape(f"  admittance law at {rig['update_rate_hz']:g} Hz: v[k] = {d['alpha']:.10g} v[k-1] + "
                             f"{d['beta_m_per_s_per_n']:.10g} F[k]"
                             + (f" + {d['beta_prev_m_per_s_per_n']:.10g} F[k-1]" if d.get("beta_prev_m_per_s_per_n")
                                else "")))
        span = rig["computation_delay_samples"]
        if isinstance(span, dict):
            console.print(f"  computation delay {span['min']} to {span['max']} samples: the design holds at every one "
                          "(the latency figures at the largest)", soft_wrap=True)
    console.print(f"  {adm['message']}; solver {adm['solver']['seconds']:.1f} s", soft_wrap=True)
    if adm.get("schedule"):
        rows = [[f"{p['payload_kg']:g}", p["status"] + (f" (robust kept; own {_num(p['own_force_felt_n'], '.3g')} N)"
                                                        if p.get("kept_robust") else ""),
                 f"{p['kp']:.4g}", f"{p['ki']:.4g}", f"{p['m_v']:.4g}", f"{p['b_v']:.4g}",
                 _num(p["force_felt_n"], ".3g"), f"{p['robust_force_felt_n']:.3g}"]
                for p in adm["schedule"]]
        t = Table(title="Admittance scheduled over payload (each payload designed alone) beside the robust design")
        for col in ("payload kg", "status", "Kp", "Ki", "m_v kg", "b_v N*s/m", "force felt N", "robust design's N"):
            t.add_column(col, justify="left" if col == "status" else "right")
        for row in rows:
            t.add_row(*row)
        console.print(t)
    t = adm.get("tradeoff")
    if t:
        front = ", ".join(f"{p['requirement']:g} deg: {_num(p['force_n'], '.3g')} N" for p in t["phase_margin_front"])
        console.print(f"  trade-off, interaction PM required -> force: {front}", soft_wrap=True)
        for h in t["hardware_changes"]:
            console.print(f"  with {h['change']}: {_num(h['force_n'], '.3g')} N (now {_num(h['baseline_n'], '.3g')} N)",
                          soft_wrap=True)


def _num(x, fmt: str = ".2f") -> str:
    """A margin: None in the JSON is an infinite one."""
    return "inf" if x is None else format(x, fmt)


def _val(x, fmt: str = ".2f") -> str:
    """A bandwidth or phase margin: None in the JSON is one outside the measured band, unknown."""
    return "n/a" if x is None else format(x, fmt)


def _fmt(x: float, digits: int | None = None) -> str:
    """A number for the table: ``digits`` decimals, or 3 significant figures by default."""
    if not math.isfinite(x):
        return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")
    return f"{x:.{digits}f}" if digits is not None else f"{x:.3g}"


def sweep_table(result) -> Table:
    """The sweep as a table of at most ``TABLE_ROWS`` payloads (nominal, or Monte Carlo percentiles)."""
    n = result.payload_kg.size
    show = np.unique(np.round(np.linspace(0, n - 1, min(n, TABLE_ROWS))).astype(int))
    note = "" if show.size == n else f" ({show.size} of {n} payloads shown; --csv or --json for all)"
    if not result.samples:
        t = Table(title=f"Stage {result.stage.upper()} nominal payload sweep{note}")
        for col in ("payload kg", "plant corner Hz", "closed-loop BW Hz", "PM deg", "GM dB"):
            t.add_column(col, justify="right")
        for i in show:
            nom = result.nominal
            ok = bool(nom.closed_loop_stable[i])
            t.add_row(f"{result.payload_kg[i]:.2f}", _fmt(nom.open_loop_corner_hz[i], 2),
                      _fmt(nom.closed_loop_bandwidth_hz[i], 2) if ok else "unstable",
                      _fmt(nom.phase_margin_deg[i], 1) if ok else "unstable",
                      _fmt(nom.gain_margin_db[i], 1) if ok else "unstable")
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


def print_sweep(console: Console, result, check=None, source: str | None = None) -> None:
    """The text of ``gantry sweep``: the gains swept and where they come from, the table, with samples the
    ranges and the worst cases, and the verdict against the requirements (``check``)."""
    if source is not None:
        console.print(f"Gains: {result.controller} ({source})", soft_wrap=True)
    console.print(sweep_table(result))
    unstable = int(np.sum(result.unstable_samples))
    if unstable:
        console.print(f"[bold red]{unstable} of {result.payload_kg.size * max(result.samples, 1)} closed loops are "
                      "UNSTABLE[/]: their margins are no guarantee (Nyquist on the analysis grid)")
    if result.samples:
        ranges = ", ".join(f"{k} {lo:g}..{hi:g}" for k, (lo, hi) in result.uncertainty.items())
        console.print(f"Sampling: {result.sampling}; ranges: {ranges}.")
        console.print("Worst case over all payloads and samples:")
        for w in result.worst_case().values():
            params = ", ".join(f"{k} = {v:.4g}" for k, v in w.parameters.items())
            console.print(f"  {w.name} = {_fmt(w.value, 2)} at {w.payload_kg:.2f} kg ({params})")
    if check is not None:
        need = f"PM >= {check.phase_margin_deg:g} deg, GM >= {check.gain_margin_db:g} dB" + (
            f", bandwidth >= {check.min_bandwidth_hz:g} Hz" if check.min_bandwidth_hz is not None else "")
        covered = (f"at every payload swept and each of its {result.samples} Monte Carlo samples of the uncertainty"
                   if result.samples else "at every payload swept, at the nominal parameters only (--samples N "
                   "draws the uncertainty)")
        if check.meets:
            console.print(f"[bold green]meets the requirements[/] ({need}) {covered}", soft_wrap=True)
        else:
            console.print(f"[bold red]VIOLATES the requirements[/] ({need}) {covered}:", soft_wrap=True)
            for line in check.violations:
                console.print(f"  {line}", soft_wrap=True)


def print_reproduction(console: Console, rows: list[TableRow], sweeps: list[PayloadSweep]) -> None:
    """``gantry reproduce``: thesis Table 3.1 against the model, definitions, explanations, payload sweeps."""

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
    for s in sweeps:
        t = Table(title=f"Stage {s.stage.upper()} payload sweep (thesis Figure 4.31)")
        for col in ("payload kg", "plant corner Hz", "closed-loop BW Hz", "PM deg", "GM dB"):
            t.add_column(col, justify="right")
        for row in payload_sweep_rows(s):
            gm = row["gain_margin_db"]
            t.add_row(f"{row['payload_kg']:.1f}", f"{row['open_loop_corner_hz']:.2f}",
                      f"{row['closed_loop_bandwidth_hz']:.2f}", f"{row['phase_margin_deg']:.1f}",
                      "inf" if gm is None else f"{gm:.1f}")
        console.print(t)


def print_time_simulation(console: Console, rec, out, sidecar) -> None:
    """``gantry simulate --form continuous|chirp``: what was written, how far the carriage went, and what that
    travel cannot show."""

    md = rec.metadata
    ex = md["excitation"]
    if "f_hz" in ex:
        what = f"{len(ex['f_hz'])} sines {ex['f_hz'][0]:g}-{ex['f_hz'][-1]:g} Hz x {ex['block_s']:g} s in one run"
    else:
        what = f"a chirp {ex['f0_hz']:g}-{ex['f1_hz']:g} Hz"
    lines = [f"wrote {out}: stage {md['stage'].upper()}, effects {', '.join(md['effects']) or 'none'}, {what} "
             f"({md['duration_s']:g} s at {md['sample_rate_hz']:g} Hz), {ex['amplitude_a']:g} A; the carriage "
             f"covered {1e3 * float(np.ptp(rec.output[0])):.4g} mm; noise {md['current_noise_std_a']:g} A / "
             f"{md['noise_std']:g} m, seed {md['seed']} (settings in {sidecar.name})"]
    lines += [f"note: {n}" for n in travel_notes(rec)]
    console.print("\n".join(lines), markup=False, highlight=False, soft_wrap=True)


def excitation_text(out, written: str, ms: Multisine, pred: VariancePrediction, stepped: SteppedSine, *,
                    chosen: bool) -> str:
    """``gantry excite``: what was written and why, both designs, their predicted variance per second and the
    verdict (composed before the file is written)."""
    if written == "stepped_sine":
        what = (f"wrote {out}: the stepped sine, {stepped.f_hz.size} log-spaced frequencies {stepped.f_hz[0]:g} to "
                f"{stepped.f_hz[-1]:g} Hz, {stepped.block_s:g} s each at {stepped.amplitude_a:g} A, "
                f"{stepped.samples_per_block} samples per block at {stepped.sample_rate_hz:g} Hz = "
                f"{stepped.duration_s:g} s of machine time")
    else:
        what = (f"wrote {out}: the multisine, {ms.current_a.size} samples at {ms.sample_rate_hz:g} Hz, {ms.periods} "
                f"periods of {ms.period_s:g} s = {ms.duration_s:g} s of machine time")
    why = ("(--form auto: the lower predicted variance per second of machine time)" if chosen
           else "(asked for by --form)")
    lines = [
        f"{what} {why}",
        f"multisine: {ms.f_hz.size} odd harmonics of {1 / ms.period_s:g} Hz, {ms.f_hz[0]:g} to {ms.f_hz[-1]:g} Hz, "
        f"{ms.amplitudes[0]:.4g} A each; peak {ms.peak_a:.4g} A, RMS {ms.rms_a:.4g} A, crest factor "
        f"{ms.crest_factor:.3f} ({ms.phase_method} phases)",
        f"predicted FRF variance for {pred.noise_m_per_s:g} m/s velocity noise, mean per line x machine time:",
        f"  multisine    {pred.multisine_variance_s:.4g} (m/s per A)^2 s  ({ms.f_hz.size} lines in "
        f"{pred.multisine_time_s:g} s, first period dropped)",
        f"  stepped sine {pred.stepped_variance_s:.4g} (m/s per A)^2 s  ({pred.stepped_f_hz.size} log-spaced "
        f"frequencies, {stepped.block_s:g} s blocks at {stepped.amplitude_a:g} A, {pred.stepped_time_s:g} s)",
        f"  ratio stepped / multisine: {pred.ratio:.3g} (> 1: the multisine is better per second)",
        pred.verdict(ms.crest_factor),
    ]
    return "\n".join(lines)


def print_simulation(console: Console, rec: Recording, out, sidecar, *, amplitude_a: float) -> None:
    """``gantry simulate``: one line saying what was written."""
    md = rec.metadata
    noise = (f"noise {100 * md['noise_fraction']:g} %" if md["noise_fraction"] is not None
             else f"noise {np.max(md['current_noise_std_a']):g} A / {np.max(md['velocity_noise_std_m_per_s']):g} m/s")
    f = md["f_hz"]
    console.print(f"wrote {out}: stage {md['stage'].upper()}, effects {', '.join(md['effects']) or 'none'}, "
                  f"{len(rec.blocks)} blocks {f[0]:g}-{f[-1]:g} Hz x {md['duration_s']:g} s at "
                  f"{md['sample_rate_hz']:g} Hz, {amplitude_a:g} A, {noise}, seed {md['seed']} (settings in "
                  f"{sidecar.name})", highlight=False, soft_wrap=True)


def print_planar_design(console: Console, out: dict) -> None:
    """``gantry planar-synth``: the answer first (status, every loop's gains), then the whole loop's worst cases
    where they were found, then Stage X's and Stage Y's own figures."""
    x, y, rot, check = out["stage_x"], out["stage_y"], out["rotation"], out["check"]
    console.print(f"[bold]status[/]: {out['status']} ({out['message']}); verified: {out['verified']}", soft_wrap=True)
    xg = x.get("gains") or {}
    if xg.get("kp") is not None:
        console.print(f"  Stage X: kp = {xg['kp']:.4g} A/(m/s), ki = {xg['ki']:.4g} A/m ({x['status']})",
                      soft_wrap=True)
    rec = y.get("recommended")
    if rec:
        row = next(r for r in y["structures"] if r["structure"] == rec)
        gains = ", ".join(f"{k} = {v:.4g}" for k, v in row["gains"].items())
        console.print(f"  Stage Y ({rec}): {gains} (A/(m/s), A/m)", soft_wrap=True)
    if rot is not None and rot["kp"] is not None:
        console.print(f"  rotation: kp = {rot['kp']:.4g} A/(rad/s), ki = {rot['ki']:.4g} A/rad; worst rotation "
                      f"bandwidth {rot['worst_bandwidth_hz']:.3g} Hz with Stage Y's loops closed", soft_wrap=True)
    if check is None:
        return
    sets = [(name, w) for name, w in (("design plants", check["design_plants"]), ("between", check["between"]),
                                      ("Monte Carlo", check["monte_carlo"])) if w is not None]
    t = Table(title="The whole loop: Stage Y with the rotation loop closed, the rotation with Stage Y's loops closed")
    t.add_column("worst")
    for name, _ in sets:
        t.add_column(name, justify="right")
    t.add_row("plants (failing)", *(f"{w['plants']} ({w['failing']})" for _, w in sets))
    for label, part, key, fmt in (("Y PM deg", "stage_y", "phase_margin_deg", _val),
                                  ("Y GM dB", "stage_y", "gain_margin_db", _num),
                                  ("Y common PM deg", "stage_y", "common_phase_margin_deg", _val),
                                  ("Y common GM dB", "stage_y", "common_gain_margin_db", _num),
                                  ("Y translation BW Hz", "stage_y", "translation_bandwidth_hz", _val),
                                  ("rotation PM deg", "rotation", "phase_margin_deg", _val),
                                  ("rotation GM dB", "rotation", "gain_margin_db", _num),
                                  ("rotation BW Hz", "rotation", "bandwidth_hz", _val)):
        t.add_row(label, *(fmt(w[part][key]) for _, w in sets))
    console.print(t)
    console.print(f"covered: {check['coverage']}; least slack {check['between']['least_slack']:.3g} at "
                  f"{check['between']['worst_at']}", soft_wrap=True)
    alone = rot.get("with_stage_y_open") if rot else None
    if alone:
        console.print(f"the same rotation gains with Stage Y's loops open: PM {alone['phase_margin_deg']:.2f} deg, GM "
                      f"{alone['gain_margin_db']:.2f} dB, bandwidth {alone['bandwidth_hz']:.3g} Hz (the stages "
                      "interact through the beam's yaw); Stage X's carriage meets neither in the linear model, so its "
                      "loop is its own (below)", soft_wrap=True)
