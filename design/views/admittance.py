"""Admittance section of the design report: what the mouse feels, the interaction-loop margins
against payload, the hardware limits and the resistance over the locomotion profile."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from design.admittance.curves import AdmittanceCurves
from design.admittance.model import admittance_problem
from design.problem import LoopProblem
from design.results import AdmittanceComparison, DesignOutcome
from design.views.html import Report, table
from design.views.plots import bode


def add_admittance_section(report: Report, problem: LoopProblem, outcome: DesignOutcome,
                           curves: AdmittanceCurves | None, comparison: AdmittanceComparison | None = None) -> None:
    report.heading("Admittance (mouse following)")
    r = outcome.admittance
    if outcome.admittance_skipped:
        report.text("Admittance synthesis: skipped: no PI gains (PI synthesis failed and no controller values in "
                    "the spec)", cls="summary")
        return
    if r.status != "optimal" or curves is None:
        report.text(f"Admittance synthesis: {r.status}: {r.message}", cls="summary")
        return
    a = admittance_problem(problem)
    loc, hw, c = a.locomotion, a.hardware, r.check
    bw = np.nanmin(c.rendered_bandwidth_hz) if np.any(np.isfinite(c.rendered_bandwidth_hz)) else None
    payloads, worst = c.per_payload()
    worst_pm, worst_gm = worst["phase_margin_deg"], worst["gain_margin_db"]
    scenarios = (f"{len(c.scenarios)} scenarios (payload × corners of plant.uncertainty)" if c.scenarios.parameters
                 else f"{c.payload_kg.size} payloads")
    mc = r.monte_carlo
    mc_text = "" if mc is None else (
        f" Monte Carlo: {mc.violations} of {mc.samples} independent draws over payload, uncertainty and mouse "
        f"violate (95 % upper bound {100 * mc.rate_upper_bound:.2g} %).")
    report.text(f"m_v = {r.m_v:.4g} kg, b_v = {r.b_v:.4g} N·s/m with the PI gains Kp = {r.kp:.4g} A/(m/s), "
                f"Ki = {r.ki:.4g} A/m. Peak resistance on the locomotion profile ({loc.peak_acceleration_m_per_s2:g} "
                f"m/s², {loc.peak_speed_m_per_s:g} m/s): {r.peak_resistance_n:.3g} N (the mouse's peak force: "
                f"{a.mouse.peak_force_n:g} N). The rendered admittance follows 1/(m_v s + b_v) within 3 dB / 30° up "
                f"to {'—' if bw is None else f'{bw:.1f}'} Hz. Interaction loop (broken at the force-sensor signal): "
                f"worst PM {_num(np.min(worst_pm))}°, worst GM {_num(np.min(worst_gm))} dB over "
                f"{scenarios} × {len(r.corners)} mouse corners. Binding: "
                f"{r.binding['detail']}. Verified: {r.verified}.{mc_text}", cls="summary")
    fig = bode(curves.w_rad_s, [curves.virtual, *curves.rendered],
               ["virtual 1/(m_v s + b_v)"] + [f"rendered, {m:g} kg" for m in curves.payload_kg],
               styles=["k--", "-", "-", "-"], title="Rendered admittance v/F against the virtual dynamics")
    report.figure(fig, "Velocity per sensed force: what the mouse feels, against what was asked for.")
    report.figure(_per_payload_figure(payloads, worst_pm, worst["sensor_current_a"], worst["motor_force_n"], a),
                  "Worst case over the mouse corners" + (" and the uncertainty corners" if c.scenarios.parameters
                                                         else "") + " at each dense payload, with the limits (dashed).")
    if comparison is not None:
        _comparison_table(report, r, comparison, a)
    report.raw(table(["quantity (worst over the check scenarios)", "value", "limit"], [
        ["motor force for the peak mouse force", f"{np.max(c.motor_force_n):.3g} N", f"{hw.motor_peak_force_n:g} N"],
        ["current per force-sensor step", f"{1e3 * np.max(c.sensor_current_a):.3g} mA",
         f"{1e3 * hw.max_current_per_sensor_step_a:g} mA"],
        ["interaction phase margin", f"{_num(np.min(worst_pm), '.2f')} deg", f"{a.phase_margin_deg:g} deg"],
        ["interaction gain margin", f"{_num(np.min(worst_gm), '.2f')} dB", f"{a.gain_margin_db:g} dB"],
    ]))
    fig, ax = plt.subplots(figsize=(7, 3.2), layout="tight")
    ax.plot(curves.profile_time_s, curves.resistance_n, label="m_v a + b_v v")
    ax.plot(curves.profile_time_s, curves.damping_part_n, "--", label="b_v v")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("resistance (N)")
    ax.set_title("Resistance felt over the locomotion profile", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    report.figure(fig, "Resistance m_v·a + b_v·v over the trapezoidal locomotion profile of the spec.")


def _comparison_table(report: Report, robust, comparison: AdmittanceComparison, a) -> None:
    """The robust admittance design beside the design for the nominal parameters, on the same draws."""
    def row(name, res, mc):
        if res.status != "optimal":
            return [name, "—", "—", "—", f"{res.status}: {res.message}"]
        rate = "—" if mc is None else f"{mc.violations} of {mc.samples} ({100 * mc.rate:.2g} %, bound " \
                                      f"{100 * mc.rate_upper_bound:.2g} %)"
        return [name, f"{res.m_v:.4g}", f"{res.b_v:.4g}", f"{res.peak_resistance_n:.3g}", rate]

    n = comparison.nominal
    report.raw(table(["admittance design", "m_v (kg)", "b_v (N·s/m)", "peak resistance (N)",
                      "Monte Carlo draws over the uncertainty that violate"],
                     [row("robust (this design)", robust, robust.monte_carlo),
                      row("nominal parameters only", n, comparison.monte_carlo)]))
    if n.status == "optimal" and comparison.monte_carlo is not None:
        report.text(f"Robustness costs {100 * (robust.peak_resistance_n / n.peak_resistance_n - 1):.0f} % more peak "
                    f"resistance; with the design for the nominal plant alone, "
                    f"{100 * comparison.monte_carlo.rate:.2g} % of the plants the spec declares plausible would "
                    f"miss a requirement (worst current per sensor step "
                    f"{1e3 * comparison.monte_carlo.worst_sensor_current_a:.3g} mA, limit "
                    f"{1e3 * a.hardware.max_current_per_sensor_step_a:g} mA; worst motor force "
                    f"{comparison.monte_carlo.worst_motor_force_n:.3g} N, limit {a.hardware.motor_peak_force_n:g} N).")


def _num(x, fmt: str = ".1f") -> str:
    """A margin for text; ∞ for an infinite one."""
    return "∞" if not np.isfinite(x) else format(x, fmt)


def _per_payload_figure(payload_kg, pm_deg, current_a, force_n, a):
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.4), layout="tight")
    series = ((pm_deg, "interaction PM (deg)", a.phase_margin_deg),
              (current_a, "current per sensor step (A)", a.hardware.max_current_per_sensor_step_a),
              (force_n, "motor force for peak mouse force (N)", a.hardware.motor_peak_force_n))
    for ax, (values, label, limit) in zip(axes, series):
        values = np.where(np.isfinite(values), values, np.nan)
        ax.plot(payload_kg, values, "o-", ms=3)
        ax.axhline(limit, color="k", ls="--", lw=1)
        ax.set_ylim(bottom=0.0, top=1.1 * max(limit, np.nanmax(values) if np.any(np.isfinite(values)) else limit))
        ax.set_xlabel("payload (kg)")
        ax.set_title(label + ("; gaps: ∞" if np.any(np.isnan(values)) else ""), fontsize=10)
        ax.grid(True, alpha=0.3)
    return fig
