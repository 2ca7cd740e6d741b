"""A design as a story (``plant.story``): what ``gantry synth``, ``planar-synth``, ``sweep`` and ``reproduce``
tell, the answer first (status, gains, the verdict) and then the evidence (tables by payload, the independent
check, the Monte Carlo, the search between the check's points, the admittance's figures). Built from the JSON
contract each command writes (``design.views.json``) or from the sweep's and the reproduction's results; a view
only lays it out (``design.views.console.print_story``)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from design.views.json import payload_sweep_rows
from plant.story import Section, Story, Table

if TYPE_CHECKING:
    from design.loop.analysis import PayloadSweep
    from design.loop.reproduce import TableRow

#: payload rows shown in the sweep's terminal table (all of them go to --csv / --json)
TABLE_ROWS = 15


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


def _status(out: dict) -> tuple[str, str]:
    return "status", f"{out['status']} ({out['message']}); verified: {out['verified']}"


def synthesis_story(out: dict) -> Story:
    """``gantry synth``'s story from its JSON: status and gains first, then the per-payload check, the independent
    check, the filters, the discrete gains, the Monte Carlo, the search between the points, the schedule, the
    admittance, the baselines, the coverage and the solver."""
    headline = [_status(out)]
    origin = out.get("plant_from")
    if origin:
        headline.append(("plant from", origin["file"]
                         + (f"; carried: {', '.join(origin['carried'])}" if origin["carried"] else "")
                         + (f"; left out (no linear response to design for): {', '.join(origin['left_out'])}"
                            if origin["left_out"] else "")))
    adm = out.get("admittance")
    if adm:
        headline.append(("admittance", _admittance_headline(adm)))
    if out.get("kind") == "dual_drive":
        sections = dual_design_sections(out)
        if adm and adm.get("m_v") is not None:
            sections.append(_admittance_section(adm))
            sections += _admittance_tables(adm)
            sections.append(Section("Admittance by carriage position", aside="(worst over payloads, uncertainty "
                                    "corners and mice)", table=Table(
                                        ("carriage m", "PM deg", "GM dB", "rendered BW Hz", "motor force N"),
                                        tuple((f"{r['carriage_position_m']:.3g}", _val(r["phase_margin_deg"]),
                                               _num(r["gain_margin_db"]), _num(r["rendered_bandwidth_hz"], ".2f"),
                                               f"{r['motor_force_n']:.4g}") for r in adm["by_carriage_position"]),
                                        frozenset())))
        return Story(tuple(headline), tuple(sections))
    sections = []
    g, wc = out["gains"], out["worst_case"]
    if g["kp"] is not None and wc is not None:
        b = out["binding"]
        where = "" if b["payload_kg"] is None else f" at {b['payload_kg']:.1f} kg"
        scenario = "".join(f", {k} = {v:.4g}" for k, v in (b.get("scenario") or {}).items())
        headline.insert(1 + bool(origin), ("gains", f"Kp = {g['kp']:.4g} A/(m/s), Ki = {g['ki']:.4g} A/m; worst case: "
                                                    f"bandwidth {_val(wc['bandwidth_hz'])} Hz, PM "
                                                    f"{_val(wc['phase_margin_deg'])} deg, GM "
                                                    f"{_num(wc['gain_margin_db'])} dB; binding: {b['constraint']}"
                                                    f"{where}{scenario}"))
        rows = out["per_payload"]
        step = max(len(rows) // 8, 1)
        shown = rows[::step] + ([rows[-1]] if (len(rows) - 1) % step else [])
        over = " worst over the uncertainty" if out.get("monte_carlo") else ""
        sections.append(Section("Per payload", aside=f"(dense check, {len(rows)} payloads{over}; every {step}th shown)",
                                table=Table(("payload kg", "bandwidth Hz", "PM deg", "GM dB"),
                                            tuple((f"{r['payload_kg']:.1f}", _val(r["bandwidth_hz"]),
                                                   _val(r["phase_margin_deg"]), _num(r["gain_margin_db"]))
                                                  for r in shown), frozenset())))
    v = out.get("verification")
    if v:
        if "max_closed_loop_pole_real_part" in v:
            pole = _num(v["max_closed_loop_pole_real_part"], ".3g")
            lines = (f"on {v['payloads']} plants: max pole real part {pole} 1/s, min PM "
                     f"{_num(v['min_phase_margin_deg'])} deg, min GM {_num(v['min_gain_margin_db'])} dB, bandwidth "
                     f"agreement {_num(v['max_bandwidth_rel_error'], '.1e')}; failures: {len(v['failures'])}",)
        else:       # a design on measured responses
            lines = (f"on {v['payloads']} recordings; failures: {len(v['failures'])}", *v["failures"])
        sections.append(Section("Independent check", lines, aside=f"({v['tool']})"))
    filters = []
    for f in out.get("filters") or []:
        if not f["used"]:
            filters.append(f"{f['kind']}: left out (the design is faster without it)")
            continue
        params = ", ".join(f"{k} = {f[k]:.4g}" for k in ("frequency_hz", "damping_ratio", "depth") if k in f)
        filters.append(f"{f['kind']}: {params} (chosen: {', '.join(f['designed']) or 'none, kept'})")
    if filters:
        sections.append(Section("Filters", tuple(filters)))
    dd = out.get("discrete")
    if dd:
        dv = dd["verification"]
        sections.append(Section(
            "Discrete", aside=f"at {dd['loop_rate_hz']:g} Hz",
            lines=(f"Kp = {dd['kp']:.6g}, integral gain per sample {dd['ki_per_sample']:.6g} ({dd['integrator']}); "
                   f"discrete loop on {dv['plants']} plants: min PM {_num(dv['min_phase_margin_deg'])} deg, min GM "
                   f"{_num(dv['min_gain_margin_db'])} dB, verified {dv['verified']}",
                   *(f"{f['name']} ({f['frequency_hz']:g} Hz, damping {f['damping_ratio']:.4g}): "
                     + ", ".join(f"{k} = {f[k]:.10g}" for k in ("b0", "b1", "b2", "a1", "a2"))
                     for f in dd["filters"]))))
    mc = out.get("monte_carlo")
    if mc:
        sections.append(Section(
            "Monte Carlo", aside=f"({mc['samples']} independent draws over payload x plant.uncertainty, seed "
                                 f"{mc['seed']})",
            lines=(f"{mc['violations']} violate ({100 * mc['rate']:.2g} %, 95 % upper bound "
                   f"{100 * mc['rate_upper_bound_95']:.2g} %); worst PM {_num(mc['worst_phase_margin_deg'])} deg, "
                   f"worst GM {_num(mc['worst_gain_margin_db'])} dB, lowest bandwidth "
                   f"{_num(mc['worst_bandwidth_hz'])} Hz",)))
    between = out.get("between_grid")
    if between:
        sections.append(Section(
            "Between the dense check's points",
            aside=f"(a search over {', '.join(between['coordinates'])} from {between['starts']} starts, "
                  f"{between['evaluations']} points)",
            lines=(f"least relative slack {between['slack']:.3g} (the grid's {between['grid_slack']:.3g}): "
                   f"{'holds' if between['holds'] else 'FAILS'}; least bandwidth "
                   f"{_num(between['least_bandwidth_hz'])} Hz (the check's {_num(between['grid_bandwidth_hz'])} Hz)",)))
    sch = out.get("schedule")
    if sch:
        sections.append(Section(
            "Gain schedule", aside=f"(verified at its points: {sch['verified']})",
            table=Table(("payload kg", "Kp", "Ki", "bandwidth Hz", "robust gains Hz", "gain", "PM deg", "GM dB"),
                        tuple((f"{p['payload_kg']:.1f}", f"{p['kp']:.4g}", f"{p['ki']:.4g}", _num(p["bandwidth_hz"]),
                               _num(p["robust_bandwidth_hz"]), f"x{_num(p['bandwidth_gain'])}",
                               _num(p["phase_margin_deg"]), _num(p["gain_margin_db"])) for p in sch["points"]),
                        frozenset())))
    if adm and adm.get("m_v") is not None:
        sections.append(_admittance_section(adm))
        sections += _admittance_tables(adm)
    if out["baselines"]:        # none for a co-designed admittance spec (its gains are not the PI loop's alone)
        sections.append(Section("Baselines on the same spec", table=Table(
            ("baseline", "Kp", "Ki", "worst BW Hz", "worst PM deg", "worst GM dB", "meets"),
            tuple((b["name"].split(" (")[0], f"{b['kp']:.4g}", f"{b['ki']:.4g}",
                   _num(b["worst_bandwidth_hz"]) if b.get("stable", True) else "unstable",
                   _num(b["worst_phase_margin_deg"], ".1f"), _num(b["worst_gain_margin_db"], ".1f"),
                   "yes" if b["meets_requirements"] else "NO") for b in out["baselines"]))))
    if "coverage" in out:
        sections.append(Section("Coverage", (out["coverage"]["text"],)))
    s = out["solver"]
    sections.append(Section("Solver", (f"{s['method']}, {s['seconds']:.2f} s"
                                       + (f" ({s['cpu_seconds']:.2f} s CPU)" if s.get("cpu_seconds") is not None
                                          else ""),)))
    return Story(tuple(headline), tuple(sections))


def dual_design_sections(out: dict) -> list[Section]:
    """The two-motor Stage Y's structures side by side: worst case over the whole box (the design plants and
    between them) and the Monte Carlo, then each one's gains, where it is worst and how the box was covered."""
    rows = []
    for row in out["structures"]:
        d, mc = (row["between"] or {}).get("worst", row["design_plants"]), row["monte_carlo"]
        mark = " *" if row["structure"] == out["recommended"] else ""
        if d is None:
            rows.append((row["structure"], "none", *[""] * 5))
            continue
        rows.append((row["structure"] + mark, _val(d["bandwidth_hz"]), _val(d["phase_margin_deg"]),
                     _num(d["gain_margin_db"]), _val(d["common_phase_margin_deg"]), _num(d["common_gain_margin_db"]),
                     "not run" if mc is None else f"{mc['n_failing']}"))
    lines = ["BW: worst-case translation bandwidth; PM, GM: each channel with the other closed; common: the same "
             "change on both motors at once; MC: Monte Carlo"
             + (f"; * recommended: {out['recommended']}" if out["recommended"] else "")]
    for row in out["structures"]:
        d = (row["between"] or {}).get("worst", row["design_plants"])
        if d is None:
            lines.append(f"{row['structure']}: no gains within the [controller] box hold the requirements")
            continue
        gains = ", ".join(f"{k} = {v:.4g}" + (" (at the [controller] bound)" if k in row["at_bound"] else "")
                          for k, v in row["gains"].items())
        between = row["between"]
        lines.append(
            f"{row['structure']}: {gains}; yaw coupling {d['yaw_coupling']:.3g} (peak rail disagreement per "
            f"translation command); disk margin {d['disk_margin']:.3g} (+-{_num(d['disk_gain_margin_db'])} dB, "
            f"+-{_val(d['disk_phase_margin_deg'])} deg); lowest bandwidth at {d['worst_bandwidth_at']}; smallest PM "
            f"at {d['worst_phase_margin_at']}; smallest common-mode PM at {d['worst_common_at']}; an extra "
            f"{1e3 * d['common_delay_margin_s']:.3g} ms of delay in both drives destabilises it"
            + (f"; binds: {', '.join(row['binding'])}" if row["binding"] else "")
            + (f"; between the grid's points: {between['coverage']}"
               + ("" if between["holds"] else ", FAILS at " + ", ".join(
                   f"{k} = {v:.4g}" for k, v in between["worst_point"].items()))
               + (f" (designed {row['design_rounds']} times, each failing point found there added)"
                  if row["design_rounds"] > 1 else "")
               if between else "")
            + (f"; a 1 mm/s offset on rail Y1's velocity sensor ramps the motors' differential current by "
               f"{abs(row['offset_ramp_a_per_s_per_mm_s']):.3g} A/s without end (a closed-loop pole at s = 0: "
               "integral action on both rails against the yaw spring; the common/differential pair with "
               "ki_differential = 0 has none)" if row["offset_ramp_a_per_s_per_mm_s"] else ""))
    return [Section("Structures", tuple(lines), aside=(
        f"worst over {out['design_plants']} design plants (carriage positions x payloads x uncertainty corners) and "
        f"between them; Monte Carlo: {out['monte_carlo_draws']} draws"),
        table=Table(("structure", "BW Hz", "PM deg", "GM dB", "common PM deg", "common GM dB", "MC fails"),
                    tuple(rows)))]


def _admittance_headline(adm: dict) -> str:
    """The admittance's answer: the virtual dynamics, the loops they sit on and what binds them (or why none)."""
    if adm.get("m_v") is None:
        return f"{adm['status']}: {adm['message']}"
    loops = (f"on the {adm['structure']} loops ({', '.join(f'{k} = {v:.4g}' for k, v in adm['gains'].items())})"
             if "structure" in adm else f"with Kp = {adm['kp']:.4g}, Ki = {adm['ki']:.4g}")
    return (f"m_v = {adm['m_v']:.4g} kg, b_v = {adm['b_v']:.4g} N*s/m {loops}; rendered bandwidth "
            f"{_num(adm['rendered_bandwidth_hz'], '.1f')} Hz; binding: {adm['binding']['detail']}")


def _admittance_section(adm: dict) -> Section:
    """The admittance's figures: the co-design, what the mouse feels, the motor, the margins by mouse, the rig."""
    m = adm.get("mouse") or {}
    lines = []
    cd = adm.get("codesign")
    if "structure" in adm and cd is not None:
        v = cd["velocity_loops"]
        w = v["between"]["worst"]
        lines.append(f"co-designed for the mouse from the structure's "
                     f"{', '.join(f'{k} = {x:.4g}' for k, x in cd['given_gains'].items())}: "
                     f"{cd['force_felt_n']:.3g} N felt on the reduced set for {cd['given_force_felt_n']:.3g} N "
                     f"({cd['candidates_meeting_velocity_requirements']} of {cd['candidates']} candidates met the "
                     f"velocity loops' requirements); its velocity loops: worst PM {_val(w['phase_margin_deg'])} deg, "
                     f"GM {_num(w['gain_margin_db'])} dB, common-mode {_val(w['common_phase_margin_deg'])} deg / "
                     f"{_num(w['common_gain_margin_db'])} dB, bandwidth {_val(w['bandwidth_hz'])} Hz over the design "
                     f"plants and between them; Monte Carlo {v['monte_carlo']['n_failing']} of "
                     f"{v['monte_carlo']['n_plants']} fail; " + ("verified" if cd["verified"] else "NOT verified"))
    limits = adm["limits"]
    if m:
        lines.append(f"the mouse feels {m['force_felt_peak_n']:.3g} N peak, {m['force_felt_rms_n']:.3g} N RMS on the "
                     f"profile (m_v a + b_v v = {m['virtual_dynamics_force_n']:.3g} N; it can push "
                     f"{limits['mouse_peak_force_n']:g} N: {'can' if m['can_drive'] else 'CANNOT'} drive it); with "
                     f"its peak force it reaches {m['reachable_speed_m_per_s']:.3g} m/s and "
                     f"{m['reachable_acceleration_m_per_s2']:.3g} m/s^2; it must push "
                     f"{1e3 * m['breakaway_force_n']:.3g} mN to start the gantry, which drifts "
                     f"{m['drift_mm_per_s']:.3g} mm/s at rest")
        if m.get("velocity_shortfall_reported"):
            short = m.get("velocity_shortfall_at_cruise_end", 0.0)
            lines.append(f"the velocity loop still leaves the gantry {100 * short:.3g} % short of the law's reference "
                         f"at the end of the cruise (Ki = {adm.get('ki', math.nan):.4g} A/m integrates too slowly for "
                         "it): the mouse pushes that much harder than m_v a + b_v v")
    rec = adm.get("recorded_force")
    motor = (f"motor: {adm['worst_motor_force_n']:.4g} N of {limits['motor_peak_force_n']:g} N "
             + ("on the locomotion profile" if limits.get("motor_force_criterion") == "locomotion" else
                "for the mouse's peak force at the worst frequency"))
    if rec and rec.get("motor_peak_force_n") is not None:
        motor += (f"; {rec['motor_peak_force_n']:.4g} N on the recorded force ({rec['file']}, {rec['duration_s']:g} "
                  f"s; worst {rec['at_s']:.4g} s into it, at {rec['where']}), {rec['checked']}")
    lines.append(motor)
    for name, v in adm["margins_by_mouse"].items():
        lines.append(f"interaction loop, {name} mice: worst PM {_num(v['phase_margin_deg'], '.1f')} deg, "
                     f"GM {_num(v['gain_margin_db'], '.1f')} dB")
    contact = ("" if "stiffest_contact_n_per_m" not in adm else
               f"; stable on a grounded spring up to {_num(adm['stiffest_contact_n_per_m'], '.4g')} N/m")
    lines.append(f"passive (Re Y_r >= 0) up to {_num(adm['passive_up_to_hz'], '.3g')} Hz{contact}")
    between = adm.get("between_grid")
    if between:
        failed = between["failed_at_ray_design"]
        cured = ("" if failed is None else
                 f"; at the ray's design it found PM {_num(failed['phase_margin_deg'], '.2f')} deg, GM "
                 f"{_num(failed['gain_margin_db'], '.2f')} dB there, and (m_v, b_v) went up the ray by "
                 f"{100 * (between['scale_up'] - 1):.2f} %")
        over = "carriage position, payload" if between["coordinates"][0] == "carriage_position_m" else "payload"
        lines.append(f"between the check's points ({between['evaluations']} points searched from {between['starts']} "
                     f"starts over {over}, uncertainty and mouse): least PM {_num(between['phase_margin_deg'], '.2f')} "
                     f"deg, GM {_num(between['gain_margin_db'], '.2f')} dB "
                     f"({'holds' if between['holds'] else 'FAILS'}){cured}")
    lat = adm.get("latency")
    if lat:
        more = lat["one_more_sample"]
        samples = "" if lat["margin_samples"] is None else f" ({lat['margin_samples']:.2f} samples)"
        extra = "" if more is None else (
            f"; with {more['computation_delay_samples']} sample(s) of computation delay: "
            + (f"PM {_num(more['phase_margin_deg'], '.1f')} deg, GM {_num(more['gain_margin_db'], '.1f')} dB"
               if more["stable"] else "UNSTABLE"))
        lines.append(f"latency: tolerates {_num(lat['margin_ms'], '.3g')} ms more{samples} (least at "
                     f"{lat['worst']}){extra}")
    rig = adm["rig"]
    if rig["discrete"]:
        d = rig["discrete"]
        lines.append(f"admittance law at {rig['update_rate_hz']:g} Hz: v[k] = {d['alpha']:.10g} v[k-1] + "
                     f"{d['beta_m_per_s_per_n']:.10g} F[k]"
                     + (f" + {d['beta_prev_m_per_s_per_n']:.10g} F[k-1]" if d.get("beta_prev_m_per_s_per_n") else ""))
        span = rig["computation_delay_samples"]
        if isinstance(span, dict):
            lines.append(f"computation delay {span['min']} to {span['max']} samples: the design holds at every one "
                         "(the latency figures at the largest)")
    lines.append(f"{adm['message']}; solver {adm['solver']['seconds']:.1f} s")
    t = adm.get("tradeoff")
    if t:
        front = ", ".join(f"{p['requirement']:g} deg: {_num(p['force_n'], '.3g')} N" for p in t["phase_margin_front"])
        lines.append(f"trade-off, interaction PM required -> force: {front}")
        lines += [f"with {h['change']}: {_num(h['force_n'], '.3g')} N (now {_num(h['baseline_n'], '.3g')} N)"
                  for h in t["hardware_changes"]]
    return Section("Admittance", tuple(lines))


def _admittance_tables(adm: dict) -> list[Section]:
    """The admittance designed per payload beside the robust design, when the spec asks for the schedule."""
    if not adm.get("schedule"):
        return []
    rows = tuple((f"{p['payload_kg']:g}", p["status"] + (f" (robust kept; own {_num(p['own_force_felt_n'], '.3g')} N)"
                                                         if p.get("kept_robust") else ""),
                  f"{p['kp']:.4g}", f"{p['ki']:.4g}", f"{p['m_v']:.4g}", f"{p['b_v']:.4g}",
                  _num(p["force_felt_n"], ".3g"), f"{p['robust_force_felt_n']:.3g}") for p in adm["schedule"])
    return [Section("Admittance scheduled over payload", aside="(each payload designed alone) beside the robust design",
                    table=Table(("payload kg", "status", "Kp", "Ki", "m_v kg", "b_v N*s/m", "force felt N",
                                 "robust design's N"), rows, frozenset({1})))]


def planar_design_story(out: dict) -> Story:
    """``gantry planar-synth``: the answer first (status, every loop's gains), then the whole loop's worst cases
    where they were found (Stage X's and Stage Y's own stories follow it on the terminal)."""
    x, y, rot, check = out["stage_x"], out["stage_y"], out["rotation"], out["check"]
    headline = [_status(out)]
    xg = x.get("gains") or {}
    if xg.get("kp") is not None:
        headline.append(("Stage X", f"kp = {xg['kp']:.4g} A/(m/s), ki = {xg['ki']:.4g} A/m ({x['status']})"))
    rec = y.get("recommended")
    if rec:
        row = next(r for r in y["structures"] if r["structure"] == rec)
        headline.append((f"Stage Y ({rec})", ", ".join(f"{k} = {v:.4g}" for k, v in row["gains"].items())
                         + " (A/(m/s), A/m)"))
    if rot is not None and rot["kp"] is not None:
        headline.append(("rotation", f"kp = {rot['kp']:.4g} A/(rad/s), ki = {rot['ki']:.4g} A/rad; worst rotation "
                                     f"bandwidth {rot['worst_bandwidth_hz']:.3g} Hz with Stage Y's loops closed"))
    if check is None:
        return Story(tuple(headline))
    sets = [(name, w) for name, w in (("design plants", check["design_plants"]), ("between", check["between"]),
                                      ("Monte Carlo", check["monte_carlo"])) if w is not None]
    rows = [("plants (failing)", *(f"{w['plants']} ({w['failing']})" for _, w in sets))]
    for label, part, key, fmt in (("Y PM deg", "stage_y", "phase_margin_deg", _val),
                                  ("Y GM dB", "stage_y", "gain_margin_db", _num),
                                  ("Y common PM deg", "stage_y", "common_phase_margin_deg", _val),
                                  ("Y common GM dB", "stage_y", "common_gain_margin_db", _num),
                                  ("Y translation BW Hz", "stage_y", "translation_bandwidth_hz", _val),
                                  ("rotation PM deg", "rotation", "phase_margin_deg", _val),
                                  ("rotation GM dB", "rotation", "gain_margin_db", _num),
                                  ("rotation BW Hz", "rotation", "bandwidth_hz", _val)):
        rows.append((label, *(fmt(w[part][key]) for _, w in sets)))
    lines = [f"covered: {check['coverage']}; least slack {check['between']['least_slack']:.3g} at "
             f"{check['between']['worst_at']}"]
    alone = rot.get("with_stage_y_open") if rot else None
    if alone:
        lines.append(f"the same rotation gains with Stage Y's loops open: PM {alone['phase_margin_deg']:.2f} deg, GM "
                     f"{alone['gain_margin_db']:.2f} dB, bandwidth {alone['bandwidth_hz']:.3g} Hz (the stages interact "
                     "through the beam's yaw); Stage X's carriage meets neither in the linear model, so its loop is "
                     "its own (below)")
    return Story(tuple(headline), (Section(
        "The whole loop", tuple(lines), aside="(Stage Y with the rotation loop closed, the rotation with Stage Y's "
                                              "loops closed)",
        table=Table(("worst", *(name for name, _ in sets)), tuple(rows))),))


def sweep_story(result, check=None, source: str | None = None) -> Story:
    """``gantry sweep``: the verdict against the requirements (``check``) and what it covers, the gains swept and
    where they come from, the table (at most ``TABLE_ROWS`` payloads), with samples the ranges and worst cases."""
    headline = []
    if check is not None:
        need = f"PM >= {check.phase_margin_deg:g} deg, GM >= {check.gain_margin_db:g} dB" + (
            f", bandwidth >= {check.min_bandwidth_hz:g} Hz" if check.min_bandwidth_hz is not None else "")
        covered = (f"at every payload swept and each of its {result.samples} Monte Carlo samples of the uncertainty"
                   if result.samples else "at every payload swept, at the nominal parameters only (--samples N "
                   "draws the uncertainty)")
        headline.append(("verdict", f"meets the requirements ({need}) {covered}" if check.meets else
                         f"VIOLATES the requirements ({need}) where Violations lists (checked {covered})"))
    if source is not None:
        headline.append(("gains", f"{result.controller} ({source})"))
    unstable = int(np.sum(result.unstable_samples))
    if unstable:
        headline.append(("UNSTABLE", f"{unstable} of {result.payload_kg.size * max(result.samples, 1)} closed loops: "
                                     "their margins are no guarantee (Nyquist on the analysis grid)"))
    sections = [_sweep_table(result)]
    if check is not None and not check.meets:
        sections.append(Section("Violations", tuple(check.violations)))
    if result.samples:
        ranges = ", ".join(f"{k} {lo:g}..{hi:g}" for k, (lo, hi) in result.uncertainty.items())
        worst = []
        for w in result.worst_case().values():
            params = ", ".join(f"{k} = {v:.4g}" for k, v in w.parameters.items())
            worst.append(f"{w.name} = {_fmt(w.value, 2)} at {w.payload_kg:.2f} kg ({params})")
        sections.append(Section("Worst case over all payloads and samples", tuple(worst),
                                aside=f"(sampling: {result.sampling}; ranges: {ranges})"))
    return Story(tuple(headline), tuple(sections))


def _sweep_table(result) -> Section:
    n = result.payload_kg.size
    show = np.unique(np.round(np.linspace(0, n - 1, min(n, TABLE_ROWS))).astype(int))
    note = "" if show.size == n else f"({show.size} of {n} payloads shown; --csv or --json for all)"
    if not result.samples:
        nom = result.nominal
        rows = []
        for i in show:
            ok = bool(nom.closed_loop_stable[i])
            rows.append((f"{result.payload_kg[i]:.2f}", _fmt(nom.open_loop_corner_hz[i], 2),
                         _fmt(nom.closed_loop_bandwidth_hz[i], 2) if ok else "unstable",
                         _fmt(nom.phase_margin_deg[i], 1) if ok else "unstable",
                         _fmt(nom.gain_margin_db[i], 1) if ok else "unstable"))
        return Section(f"Stage {result.stage.upper()} nominal payload sweep", aside=note, table=Table(
            ("payload kg", "plant corner Hz", "closed-loop BW Hz", "PM deg", "GM dB"), tuple(rows), frozenset()))
    lv = result.levels
    mid = len(lv) // 2
    columns = ["load kg"]
    for d in result.distributions:
        label = {"closed_loop_bandwidth_hz": "BW", "phase_margin_deg": "PM", "gain_margin_db": "GM"}[d.name]
        columns += [f"{label} {d.unit} p{lv[mid]:g}", f"p{lv[0]:g}\u2013p{lv[-1]:g}", f"{label} worst"]
    rows = []
    for i in show:
        cells = [f"{result.payload_kg[i]:.3g}"]
        for d in result.distributions:
            p = d.percentiles[:, i]
            cells += [_fmt(p[mid]), f"{_fmt(p[0])}\u2013{_fmt(p[-1])}", _fmt(d.worst[i])]
        rows.append(tuple(cells))
    return Section(f"Stage {result.stage.upper()} Monte Carlo sweep",
                   aside=f"({result.samples} samples, seed {result.seed}) {note}".rstrip(),
                   table=Table(tuple(columns), tuple(rows), frozenset()))


def reproduction_story(rows: list[TableRow], sweeps: list[PayloadSweep]) -> Story:
    """``gantry reproduce``: thesis Table 3.1 against the model, the definitions and explanations, the sweeps."""
    table = Table(("quantity", "stage", "unit", "thesis", "computed", "rel. diff."),
                  tuple((r.quantity, r.stage.upper(), r.unit, f"{r.thesis:g}", f"{r.computed:.2f}",
                         f"{100 * r.relative_difference:+.1f} %" + (" *" if r.explanation else "")) for r in rows),
                  frozenset({0, 1, 2}))
    definitions = [f"{q}: {next(r.definition for r in rows if r.quantity == q)}"
                   for q in dict.fromkeys(r.quantity for r in rows)]
    definitions += [f"* {r.stage.upper()} {r.quantity}: {r.explanation}" for r in rows if r.explanation]
    sections = [Section("Thesis Table 3.1", table=table, aside="(and section 3.1 phase margins) against this model"),
                Section("Definitions", tuple(definitions))]
    for s in sweeps:
        sweep_rows = tuple((f"{r['payload_kg']:.1f}", f"{r['open_loop_corner_hz']:.2f}",
                            f"{r['closed_loop_bandwidth_hz']:.2f}", f"{r['phase_margin_deg']:.1f}",
                            "inf" if r["gain_margin_db"] is None else f"{r['gain_margin_db']:.1f}")
                           for r in payload_sweep_rows(s))
        sections.append(Section(f"Stage {s.stage.upper()} payload sweep", aside="(thesis Figure 4.31)", table=Table(
            ("payload kg", "plant corner Hz", "closed-loop BW Hz", "PM deg", "GM dB"), sweep_rows, frozenset())))
    return Story(sections=tuple(sections))
