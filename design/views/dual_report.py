"""The HTML report of a two-motor Stage Y design (``[dual_drive]``): the structures side by side, each one's
bandwidth and margins over carriage position x payload (worst over the uncertainty corners), and the
yaw error a translation step leaves (python-control, the delays as Pade approximants); the numbers come
computed (``design.workflows.dual_report_content``), this module only draws them."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from design.results import DualReportContent
from design.synth.dual import DesignMap, DualRequirements
from design.synth.dual_curves import rail_gap_m
from design.views.html import Report, table
from design.views.plots import fixed_margins
from plant.bode import bode


def _map_figure(name: str, m: DesignMap, req: DualRequirements) -> Figure:
    fig = Figure(figsize=(10, 3.6))
    axes = fig.subplots(1, 2)
    fixed_margins(fig, wspace=0.35, right_in=0.9)
    for ax, values, title, unit, limit in ((axes[0], m.bandwidth_hz, "translation bandwidth", "Hz", None),
                                           (axes[1], m.phase_margin_deg, "phase margin (worst channel)", "deg",
                                            req.phase_margin_deg)):
        shown = np.where(np.isfinite(values), values, np.nan)
        mesh = ax.pcolormesh(m.payload_kg, m.carriage_position_m, shown, shading="nearest", cmap="viridis")
        fig.colorbar(mesh, ax=ax, label=unit)
        if limit is not None and np.nanmin(shown) < limit < np.nanmax(shown):
            ax.contour(m.payload_kg, m.carriage_position_m, shown, levels=[limit], colors="w", linewidths=1)
        i, j = np.unravel_index(int(np.nanargmin(shown)), shown.shape)
        ax.plot(m.payload_kg[j], m.carriage_position_m[i], "rx", ms=10, mew=2)
        ax.set_xlabel("payload (kg)")
        ax.set_ylabel("carriage position from rail Y1 (m)")
        ax.set_title(f"{name}: {title} (x: worst, {shown[i, j]:.3g} {unit})", fontsize=10)
    return fig


def _step_figure(name: str, steps: list[tuple[float, np.ndarray]], t: np.ndarray) -> Figure:
    fig = Figure(figsize=(10, 3.6))
    axes = fig.subplots(1, 2)
    fixed_margins(fig, wspace=0.3)
    for position, y in steps:
        line, = axes[0].plot(t * 1e3, y[0], label=f"Y1, carriage at {position:.2f} m")
        axes[0].plot(t * 1e3, y[1], "--", color=line.get_color(), label=f"Y2, carriage at {position:.2f} m")
        axes[1].plot(t * 1e3, rail_gap_m(y, t) * 1e3, color=line.get_color(), label=f"carriage at {position:.2f} m")
    axes[0].set_ylabel("rail velocity per command (m/s per m/s)")
    axes[1].set_ylabel("y2 - y1 per command (mm per m/s)")
    for ax in axes:
        ax.set_xlabel("time (ms)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    axes[0].set_title(f"{name}: translation step", fontsize=10)
    axes[1].set_title("yaw error: the rails' position difference", fontsize=10)
    return fig


def _admittance_section(rep: Report, r, curves) -> None:
    """The virtual dynamics on the recommended structure: the design, its margins and rendered bandwidth by
    carriage position, and the rendered admittance against the virtual one at the travel's ends and middle
    (``curves``: ``design.admittance.dual.RenderedByPosition``)."""
    rep.heading("Admittance for the mouse")
    rep.text(f"{r.status}: {r.message}", cls="summary")
    if curves is None:
        return
    rep.text(f"On the {r.structure} loops: m_v = {r.m_v:.4g} kg, b_v = {r.b_v:.4g} N*s/m (m_v a + b_v v = "
             f"{r.peak_resistance_n:.3g} N on the locomotion profile). Binding: {r.binding.detail}.")
    rep.raw(table(["carriage position m", "PM deg", "GM dB", "rendered bandwidth Hz", "motor force N"],
                  [[f"{p.carriage_position_m:.3g}", f"{p.phase_margin_deg:.2f}", f"{p.gain_margin_db:.2f}",
                    f"{p.rendered_bandwidth_hz:.2f}", f"{p.motor_force_n:.4g}"] for p in r.by_position]))
    fig = Figure(figsize=(6.8, 6.0))
    axes = fig.subplots(2, 1, sharex=True)
    fixed_margins(fig, left_in=0.85, right_in=0.25, hspace=0.1)
    bode(2 * np.pi * curves.frequency_hz, [curves.virtual, *curves.rendered],
         ["virtual 1/(m_v s + b_v)", *[f"rendered, carriage at {p:.2f} m" for p in curves.carriage_position_m]],
         axes=axes, styles=["k--", *["-"] * len(curves.rendered)], unit="(m/s)/N",
         title="admittance the mouse meets, heaviest payload")
    rep.figure(fig, f"the rendered admittance (its fundamental under the {1 / r.timing.period_s:g} Hz law) against "
                    f"the virtual one at {curves.payload_kg:g} kg and nominal parameters"
               if r.timing.sampled else "the rendered admittance against the virtual one at the heaviest payload")


def dual_report(content: DualReportContent) -> Report:
    """The report of a ``[dual_drive]`` design from its computed ``content``."""
    outcome = content.outcome
    problem, dual = outcome.problem, outcome.dual
    spec = problem.spec
    rep = Report(f"{spec.name}: two-motor Stage Y design")
    rep.text(f"{dual.status}: {dual.message}", cls="summary")
    rows = []
    for c in dual.checked:
        s = c.design
        if s.controller is None:
            rows.append([s.structure, "no gains within the box hold the requirements", *[""] * 8])
            continue
        w, mc = c.between.worst, s.monte_carlo
        rows.append([s.structure + (" (recommended)" if s.structure == dual.recommended else ""),
                     ", ".join(f"{k} {v:.4g}" for k, v in s.controller.gains().items()),
                     f"{w.bandwidth_hz:.2f}", f"{w.phase_margin_deg:.2f}", f"{w.gain_margin_db:.2f}",
                     f"{w.common_phase_margin_deg:.1f} deg, {w.common_gain_margin_db:.2f} dB",
                     f"{w.disk_margin:.3f} (±{w.disk_gain_margin_db:.2f} dB, ±{w.disk_phase_margin_deg:.1f} deg)",
                     f"{w.yaw_coupling:.3g}", w.worst_bandwidth_at,
                     "not run" if mc is None else f"{mc.n_failing} of {mc.n_plants} fail"])
    rep.heading("Structures on the same plants")
    between = next((c.between for c in dual.checked if c.between is not None), None)
    rep.text(f"Worst case over {dual.n_design_plants} design plants (carriage positions x payloads x corners of "
             f"the uncertainty box) and between them"
             + (f" ({between.coverage()})" if between is not None else "")
             + f"; Monte Carlo: {dual.n_monte_carlo} draws (seed {spec.verification.seed}). "
             f"Requirements: every channel PM >= {dual.requirements.phase_margin_deg:g} deg and GM >= "
             f"{dual.requirements.gain_margin_db:g} dB with the other channel closed"
             + (f"; against the same change on both motors at once PM >= "
                f"{dual.requirements.common_phase_margin_deg:g} deg and GM >= "
                f"{dual.requirements.common_gain_margin_db:g} dB (requirements.common_phase_margin_deg, "
                "common_gain_margin_db: the loop-at-a-time values unless the spec says otherwise; two motors on one "
                "beam share one drive model and one batch of magnets)"
                if dual.requirements.common else "; the common-mode margins are reported, not required")
             + (f", simultaneous disk margin >= {dual.requirements.disk_margin:g}" if dual.requirements.disk_margin
                else "; the simultaneous disk margin at both motors is reported, not required") + ".")
    rep.raw(table(["structure", "gains (A/(m/s), A/m)", "bandwidth Hz", "PM deg", "GM dB", "common-mode margins",
                   "disk margin",
                   "yaw coupling", "lowest bandwidth at", "Monte Carlo"], rows, left=2))
    rep.heading("Over the carriage travel")
    for c in content.structures:
        m = c.design_map
        i, j = np.unravel_index(int(np.argmin(m.bandwidth_hz)), m.bandwidth_hz.shape)
        rep.figure(_map_figure(c.structure, m, dual.requirements),
                   f"{c.structure}: each point the worst over the uncertainty corners; lowest bandwidth "
                   f"{m.bandwidth_hz[i, j]:.3g} Hz with the carriage at {m.carriage_position_m[i]:.3g} m and "
                   f"{m.payload_kg[j]:.3g} kg"
                   + ("" if m.holds.all() else f"; requirements missed at {int((~m.holds).sum())} of {m.holds.size} "
                      "map points (between the design points)"))
        rep.figure(_step_figure(c.structure, list(c.steps), c.time_s),
                   f"{c.structure}: a 1 m/s step of the translation command at {c.payload_kg:g} kg and nominal "
                   f"parameters (python-control, delays as Pade approximants of order 6); largest rail position "
                   f"difference {c.largest_rail_gap_m * 1e3:.3g} mm per m/s")
    if outcome.dual_admittance is not None:
        _admittance_section(rep, outcome.dual_admittance, content.rendered)
    rep.heading("Reproduce")
    if content.command:
        rep.pre(content.command)
    rep.pre(problem.spec_path.read_text(encoding="utf-8"))
    return rep
