"""Admittance section of the design report: first whether the mouse can drive the design, then what it
feels (force on the profile, apparent mass and damping, a simulated run), the interaction-loop margins for
floating and braced mice against payload, the passive band and the stiffest contact, the lab's setting
beside the design, and, for a design that is not optimal, the trade-off front and the hardware changes."""

from __future__ import annotations

import numpy as np

from design.admittance.between import worst_by_legs
from design.admittance.curves import AdmittanceCurves
from design.admittance.model import admittance_problem
from design.problem import LoopProblem
from design.results import AdmittanceComparison, DesignOutcome
from design.synth.scenarios import describe_row
from design.views.admittance_figures import (
    apparent_mass_figure,
    bandwidth_text,
    force_felt_figure,
    margin_figures,
    num,
    passive_text,
    rendered_figure,
    run_figures,
    schedule_figure,
    tradeoff_figures,
)
from design.views.html import Report, table
from plant.story import Story
from plant.story import unit_text as units


def add_admittance_section(report: Report, problem: LoopProblem, outcome: DesignOutcome,
                           curves: AdmittanceCurves | None, comparison: AdmittanceComparison | None = None) -> None:
    report.heading("Admittance (mouse following)")
    r = outcome.admittance
    if outcome.admittance_skipped:
        report.text("Admittance synthesis: skipped: no PI gains (PI synthesis failed and no controller values in "
                    "the spec)", cls="summary")
        return
    if r.status not in ("optimal", "mouse_cannot_drive") or curves is None:
        report.text(f"Admittance synthesis: {r.status}: {r.message}", cls="summary")
        if r.tradeoff is not None:
            _tradeoff(report, r.tradeoff, admittance_problem(problem))
        return
    a = admittance_problem(problem)
    loc, hw, c, feel = a.locomotion, a.hardware, r.check, r.feel
    report.headline(admittance_summary(r, a))
    report.raw(table(["what the mouse meets", "value", "requirement / budget"], [
        ["force felt: the neck force while the body runs the profile, worst over the payloads and mice, peak / RMS",
         f"{feel.peak_force_n:.3g} / {feel.rms_force_n:.3g} N", f"{a.mouse.peak_force_n:g} N"],
        ["what the virtual dynamics alone ask at the profile's corner, m_v a_pk + b_v v_pk (the what-ifs compare "
         "this figure, on the heaviest payload)", f"{feel.ideal_peak_force_n:.3g} N", "—"],
        ["speed / acceleration reached with its peak force", f"{feel.reachable_speed_m_per_s:.3g} m/s / "
         f"{feel.reachable_acceleration_m_per_s2:.3g} m/s²", f"{loc.peak_speed_m_per_s:g} m/s / "
         f"{loc.peak_acceleration_m_per_s2:g} m/s²"],
        ["push to start the gantry at rest (deadband + offset)", f"{1e3 * feel.breakaway_force_n:.3g} mN", "—"],
        ["velocity loop short of the law's reference at the end of the cruise (the PI's integral action not "
         "yet caught up: the mouse pushes that much harder)", f"{100 * feel.velocity_shortfall:.3g} %"
         + (f" (Ki = {r.controller.ki:.4g} A/m too slow for the cruise)" if feel.shortfall_reported else ""), "—"],
        ["drift at rest", f"{feel.drift_mm_per_s:.3g} mm/s",
         "—" if a.sensor.max_drift_mm_per_s is None else f"{a.sensor.max_drift_mm_per_s:g} mm/s"],
        ["motor force on the locomotion profile" if hw.motor_force_criterion == "locomotion" else
         "motor force for the peak mouse force at the worst frequency", f"{np.max(c.motor_force_n):.3g} N",
         f"{hw.motor_peak_force_n:g} N"],
        *_recorded_rows(c, a),
        ["current per force-sensor step", f"{1e3 * np.max(c.sensor_current_a):.3g} mA",
         "—" if hw.max_current_per_sensor_step_a is None else f"{1e3 * hw.max_current_per_sensor_step_a:g} mA"],
    ]))
    report.figures([force_felt_figure(feel, a.mouse.peak_force_n), apparent_mass_figure(feel, r.m_v)],
                   f"What the mouse feels: left, the neck force when its body follows the profile, at the worst case "
                   f"({units(feel.worst)}); right, the mass the gantry seems to have at each frequency, the virtual "
                   "mass where the loop renders it, the gantry's own above (magnitude on a log axis, dotted where "
                   "negative).")
    report.figure(rendered_figure(curves, c, a.passivity),
                  "Velocity per sensed force: what the mouse feels, against what was asked for"
                  + (" (the sampled law at the input frequency)" if r.timing.sampled else "")
                  + ", at nominal parameters; shaded, the 3 dB / 30° tolerance around the virtual dynamics; the "
                    "vertical lines are the summary's worst passive band and rendered bandwidth over the "
                    f"{len(c.scenarios)} scenarios.")
    report.figures(margin_figures(c, a, r.binding, None if r.between is None else r.between.search),
                   "Worst interaction-loop margins over the uncertainty corners at each payload, for the floating and "
                   "the braced (grounded) mice, with the requirement (dotted), the binding scenario of the summary "
                   "(circled) and the least point the search between the check's points found (cross).")
    if curves.run is not None:
        _run_figure(report, curves.run)
    elif curves.run_refused:
        report.text(f"No mouse run: {curves.run_refused}.")
    if curves.lab is not None:
        _lab_table(report, r, curves.lab, feel)
    if comparison is not None:
        _comparison_table(report, r, comparison)
    if r.tradeoff is not None:
        _tradeoff(report, r.tradeoff, admittance_problem(problem))
    if outcome.admittance_schedule:
        pts = outcome.admittance_schedule
        report.figure(schedule_figure(pts, a.mouse.peak_force_n),
                      "The admittance scheduled over payload: at each design payload the co-design made for it "
                      "alone (its uncertainty, mice and requirements kept), beside the one robust design, by the peak "
                      "force the mouse feels on the profile (nominal parameters).")
        report.raw(table(["payload (kg)", "status", "Kp (A/(m/s))", "Ki (A/m)", "m_v (kg)", "b_v (N·s/m)",
                          "force felt (N)", "robust design's (N)"],
                         [[f"{p.payload_kg:g}", p.status + (f" (the robust design kept: the payload's own asked "
                                                            f"{num(p.own_force_felt_n, '.3g')} N)"
                                                            if p.kept_robust else ""),
                           f"{p.controller.kp:.4g}", f"{p.controller.ki:.4g}", f"{p.m_v:.4g}", f"{p.b_v:.4g}",
                           num(p.force_felt_n, ".3g"), f"{p.robust_force_felt_n:.3g}"] for p in pts]))
    if r.discrete is not None:
        d = r.discrete
        report.text(f"The admittance law as the rig runs it at {d.update_rate_hz:g} Hz: v[k] = {d.alpha:.10g} "
                    f"v[k−1] + {d.beta_m_per_s_per_n:.10g} F[k]"
                    + (f" + {d.beta_prev_m_per_s_per_n:.10g} F[k−1]" if d.beta_prev_m_per_s_per_n else "")
                    + f" ({d.rule}; F in N, v in m/s), "
                    f"held until the next update, {_delays(r.timing)} sample(s) of computation delay"
                    + (" (the design holds at every one)." if len(r.timing.delays) > 1 else "."))


def _delays(timing) -> str:
    d = timing.delays
    return f"{d[0]}" if len(d) == 1 else f"{d[0]} to {d[-1]}"


def admittance_summary(r, a) -> Story:
    """The admittance section's summary: whether the mouse can drive the design and what it feels, then the gains,
    the interaction loop's worst margins and what binds, the passive band, and how it was checked."""
    loc, c, feel = a.locomotion, r.check, r.feel
    legs = worst_by_legs(c, r.between)
    margins = "; ".join(f"{k} mice: PM {num(v[0])}°, GM {num(v[1])} dB" for k, v in legs.items())
    rig = "continuous" if not r.timing.sampled else f"sampled at {1 / r.timing.period_s:g} Hz"
    head = [("Verdict", f"the mouse {'can' if r.status == 'optimal' else 'CANNOT'} drive this design: it feels "
                        f"{feel.peak_force_n:.3g} N peak ({feel.rms_force_n:.3g} N RMS) on the locomotion profile "
                        f"({loc.travel_m:g} m at {loc.peak_speed_m_per_s:g} m/s, {loc.peak_acceleration_m_per_s2:g} "
                        f"m/s²) and can push {a.mouse.peak_force_n:g} N."),
            ("Design", f"m_v = {r.m_v:.4g} kg, b_v = {r.b_v:.4g} N·s/m with {r.controller} (admittance law {rig})."),
            ("Interaction loop", f"broken at the force-sensor signal, worst over {len(c.scenarios)} scenarios"
                                 f"{' and between them' if r.between is not None else ''}: {margins}."),
            ("Binding", f"{units(r.binding.detail)}."),
            ("Passivity", f"Passive up to {passive_text(c)} Hz; stable on a grounded spring up to "
                          f"{num(r.contact.worst_n_per_m, '.4g')} N/m. Rendered admittance within 3 dB / 30° of "
                          f"1/(m_v s + b_v) up to {bandwidth_text(c)} Hz."),
            ("Verified", _verified(r))]
    if r.between is not None:
        head.append(("Between the check's points", _between(r)))
    if r.monte_carlo is not None:
        mc = r.monte_carlo
        head.append(("Monte Carlo", f"{mc.violations} of {mc.samples} independent draws over payload, uncertainty "
                                    f"and mouse violate (95 % upper bound {100 * mc.rate_upper_bound:.2g} %)."))
    if r.latency is not None:
        head.append(("Latency", _latency(r)))
    return Story(tuple(head))


def _verified(r) -> str:
    """What was checked independently, in words."""
    v = r.verification
    if v is None:
        return "Not verified."
    loop = "sampled by c2d" if v.sampled else "continuous"
    poles = "inside the unit circle" if v.sampled else "in the left half-plane"
    return (f"python-control checked the rational model ({loop}) at the {v.cases} tightest (scenario, mouse) pairs "
            f"of the dense check: closed-loop poles {poles}"
            f" and the margins at the worst of them (PM {num(v.min_phase_margin_deg)}°, GM "
            f"{num(v.min_gain_margin_db)} dB): {'passed' if v.verified else 'FAILED'}.")


def _latency(r) -> str:
    lat = r.latency
    samples = "" if lat.margin_samples is None else f", {lat.margin_samples:.2f} samples of the law"
    more = "" if lat.delay_samples is None else (
        f" With {lat.delay_samples + 1} sample(s) of computation delay it is "
        + (f"stable (PM {num(lat.one_more_phase_margin_deg)}°, GM {num(lat.one_more_gain_margin_db)} dB)."
           if lat.one_more_stable else "unstable: measure the rig's latency."))
    return f"it tolerates {1e3 * lat.margin_s:.3g} ms more{samples} ({units(lat.worst)}).{more}"


def _between(r) -> str:
    held = r.between
    s, f = held.search, held.failed
    cured = ("" if f is None else
             f" At the ray's design it found PM {num(f.phase_margin_deg)}°, GM {num(f.gain_margin_db)} dB at "
             f"{units(describe_row(f.scenario))} with mouse ({units(f.mouse.label())}); (m_v, b_v) went up the ray by "
             f"{100 * (held.scale - 1):.2f} %.")
    return (f"a search over payload, uncertainty and mouse ({s.evaluations} points from "
            f"{s.starts} starts) finds at least PM {num(s.phase_margin_deg)}°, GM {num(s.gain_margin_db)} dB: "
            f"{'holds' if s.holds else 'fails'}.{cured}")


def _recorded_rows(c, a) -> list[list[str]]:
    """The motor on the spec's force record, when it has one."""
    record, worst = a.locomotion.force_record, c.recorded_worst()
    if record is None or worst is None:
        return []
    peak, at_s, j = worst
    return [[f"motor force on the recorded force ({record.file}, {record.duration_s:g} s, taken as given; "
             f"worst {at_s:.4g} s into it at {c.scenarios.describe(j)}; over the {len(c.scenarios)} dense scenarios)",
             f"{peak:.3g} N", f"{a.hardware.motor_peak_force_n:g} N"]]


def _run_figure(report: Report, run) -> None:
    s = run.settings
    report.figures(run_figures(run), f"A simulated run through the sampled loop at {s.gantry_mass_kg:g} kg "
                   f"({units(run.path.source)}; drive {s.drive_rate_hz:g} Hz, admittance {s.admittance_rate_hz:g} "
                   f"Hz, force quantised, offset and deadband applied, motor force limited): force felt "
                   f"{run.peak_force_n:.3g} N peak, speed shortfall {run.speed_shortfall_m_per_s:.3g} m/s, largest "
                   f"lag {1e3 * run.max_lag_m:.3g} mm, drift at rest {run.drift_mm_per_s:.3g} mm/s, limit cycle "
                   f"{run.limit_cycle_um:.3g} µm.")


def _lab_table(report: Report, r, lab, feel) -> None:
    def row(name, m_v, b_v, legs, force, passive, stable):
        cells = [f"{legs[k][0]:.1f}° / {legs[k][1]:.1f} dB" if k in legs else "—" for k in ("floating", "grounded")]
        return [name, f"{m_v:.4g}", f"{b_v:.4g}", *cells, f"{force:.3g} N", f"{num(passive, '.3g')} Hz",
                "yes" if stable else "NO"]

    report.raw(table(["virtual dynamics (same plant, loop and rig)", "m_v (kg)", "b_v (N·s/m)",
                      "floating PM / GM", "braced PM / GM", "force felt", "passive up to", "stable"],
                     [row("this design", r.m_v, r.b_v, worst_by_legs(r.check, r.between), feel.peak_force_n,
                          float(np.min(r.check.passive_up_to_hz)), bool(np.all(r.check.stable))),
                      row("the lab's hand-tuned setting", lab.m_v, lab.b_v, lab.margins, lab.force_felt_n,
                          lab.passive_up_to_hz, lab.stable)]))
    if lab.unstable_at:
        report.text(f"The lab's setting with these loops is unstable at {len(lab.unstable_at)} of the dense check's "
                    f"(scenario, mouse) pairs, first at {units(lab.unstable_at[0])}.")
    report.text(f"The lab's setting is m = 0.04 kg, c = 4 N·s/m (bsbrl/exoskeleton, X-axis mousetrack tuning). Their "
                f"bandwidth model of their own robot (post-sensor mass 0.01 kg, 10 ms holds; reproduced from the "
                f"published live script, design.admittance.lab_model) puts the apparent admittance within 3 dB / 30° "
                f"of its virtual one up to {lab.lab_model_bandwidth_hz:.3g} Hz on axis 1.")


def _comparison_table(report: Report, robust, comparison: AdmittanceComparison) -> None:
    """The robust admittance design beside the design for the nominal parameters, on the same draws."""
    def row(name, res, mc):
        if res.status not in ("optimal", "mouse_cannot_drive"):
            return [name, "—", "—", "—", f"{res.status}: {res.message}"]
        rate = "—" if mc is None else f"{mc.violations} of {mc.samples} ({100 * mc.rate:.2g} %, bound " \
                                      f"{100 * mc.rate_upper_bound:.2g} %)"
        return [name, f"{res.m_v:.4g}", f"{res.b_v:.4g}", f"{res.feel.peak_force_n:.3g}", rate]

    n = comparison.nominal
    report.raw(table(["admittance design", "m_v (kg)", "b_v (N·s/m)", "force felt (N)",
                      "Monte Carlo draws over the uncertainty that violate"],
                     [row("robust (this design)", robust, robust.monte_carlo),
                      row("nominal parameters only", n, comparison.monte_carlo)]))


def _tradeoff(report: Report, t, adm) -> None:
    report.figures(tradeoff_figures(t, adm), "The trade-off: the least force the virtual dynamics ask on the profile "
                   "for each requirement (every other requirement held), against the mouse's peak force (dotted) "
                   "and this spec's requirement (dashed). Gaps: no design within the bounds.")
    report.raw(table(["hardware change", "least force (N)", "now (N)"],
                     [[h.change, num(h.force_n, ".3g"), num(h.baseline_n, ".3g")] for h in t.changes]))
