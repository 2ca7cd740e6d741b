"""Design report: one self-contained HTML file a controls engineer reads top to bottom.

Summary first (gains, worst-case bandwidth and margins, verified or not, what limits the
design), then the plant, Bode / Nyquist / step plots over the payload range, margins and
bandwidth against payload (thesis Figure 4.31 extended), admittance, measured data with the
diagnosis, and reproducibility. Every number in the summary comes from the gains evaluated on the
dense payload grid (``design.synth.evaluation.evaluate``), never from an optimiser's claim; the view only
draws what ``design.workflows.report_content`` computed.
"""

from __future__ import annotations

import hashlib

import matplotlib.pyplot as plt
import numpy as np

from design.loop.curves import LoopCurves
from design.results import ReportContent
from design.synth.evaluation import Evaluation
from design.synth.scenarios import describe_row
from design.views.html import Report, table
from design.views.plots import fixed_margins
from plant import __version__
from plant.arguments import check_instance
from plant.bode import bode
from plant.host.text_io import read_text
from plant.story import Story
from plant.story import unit_text as units


def limiting_text(ev: Evaluation, requirements) -> str:
    """The requirement with the least slack and where: e.g. "phase margin 45.00 deg (required 45) at 40.0 kg"."""
    b = ev.binding
    if b.payload_kg is None:
        return f"the gain bound {b.constraint}"
    i = int(np.argmin(np.abs(ev.payload_kg - b.payload_kg)))
    where = f"{ev.payload_kg[i]:.1f} kg" + "".join(f", {k} = {v:.4g}" for k, v in b.scenario.parameters)
    if b.constraint == "gain_margin":
        return f"gain margin {ev.gain_margin_db[i]:.2f} dB (required {requirements.gain_margin_db:g}) at {where}"
    if b.constraint == "phase_margin":
        return f"phase margin {ev.phase_margin_deg[i]:.2f} deg (required {requirements.phase_margin_deg:g}) at {where}"
    return f"{b.constraint.replace('_', ' ')} (slack {b.slack:.3g}) at {where}"


#: the binding scenario's curves: black and dashed, drawn over the payloads'
BINDING_STYLE = {"color": "k", "ls": "--", "lw": 1.6}


def _styles(c: LoopCurves) -> list[dict]:
    return [BINDING_STYLE if k == c.binding_row else {} for k in range(len(c.labels))]


def _legend_below(fig, ax, ncol: int) -> None:
    """One legend for the figure, under the axes, where it covers no curve."""
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=ncol, fontsize=8, frameon=False)


def loop_bode_figure(c: LoopCurves):
    """Plant and loop Bode plots at the report payloads and the binding scenario, with each loop's gain
    crossover (phase margin) and phase crossover (gain margin) marked."""
    fig, axes = plt.subplots(2, 2, sharex=True, figsize=(12, 6.4))
    fixed_margins(fig, hspace=0.12, bottom_in=1.15)
    styles = ["k--" if k == c.binding_row else "-" for k in range(len(c.labels))]
    bode(c.bode_w_rad_s, list(c.plant), list(c.labels), axes=axes[:, 0], title="Plant P(jω)", styles=styles,
         unit="(m/s)/A", legend=False)
    bode(c.bode_w_rad_s, list(c.loop), list(c.labels), axes=axes[:, 1], title="Loop L = P (Kp + Ki/s)",
         styles=styles, unit="(dimensionless)", legend=False)
    mag, phase = axes[:, 1]
    mag.axhline(0.0, color="0.4", lw=0.8)
    phase.axhline(-180.0, color="0.4", lw=0.8)
    f = c.bode_w_rad_s / (2 * np.pi)
    for k, line in enumerate(mag.get_lines()[:len(c.labels)]):
        color, fc, pm = line.get_color(), c.gain_crossover_hz[k], c.phase_margin_deg[k]
        if np.isfinite(fc) and np.isfinite(pm):
            mag.plot([fc], [0.0], "o", color=color, ms=4)
            phase.plot([fc, fc], [-180.0, -180.0 + pm], color=color, lw=2.2, solid_capstyle="butt")
            if k in (c.binding_row, _worst(c.phase_margin_deg)):
                phase.annotate(f"PM {pm:.1f}°", (fc, -180.0 + pm / 2), xytext=(6, 0), textcoords="offset points",
                               fontsize=8, color=color, va="center")
        fp, gm = c.phase_crossover_hz[k], c.gain_margin_db[k]
        if np.isfinite(fp) and np.isfinite(gm) and f[0] <= fp <= f[-1]:
            mag.plot([fp, fp], [0.0, -gm], color=color, lw=2.2, solid_capstyle="butt")
            if k in (c.binding_row, _worst(c.gain_margin_db)):
                mag.annotate(f"GM {gm:.1f} dB", (fp, -gm / 2), xytext=(6, 0), textcoords="offset points",
                             fontsize=8, color=color, va="center")
    _legend_below(fig, axes[0, 0], min(len(c.labels), 4))
    return fig


def _worst(values: np.ndarray) -> int | None:
    """The row of the least finite value (None: none finite)."""
    v = np.where(np.isfinite(values), values, np.inf)
    return int(np.argmin(v)) if np.isfinite(v).any() else None


def closed_loop_figure(c: LoopCurves, requirements):
    """|S| and |T| of the closed velocity loop per row: the bandwidth marked where |T| falls to the requirements'
    level (a dot and its frequency, each row; labelled on the least), the peaks of |S| (1 / the distance of L from
    -1) and |T| marked, the requirements' M_s limit drawn when one is declared."""
    fig, axes = plt.subplots(1, 2, sharex=True, figsize=(12, 4.2))
    fixed_margins(fig, wspace=0.22, bottom_in=1.15)
    f = c.bode_w_rad_s / (2 * np.pi)
    level_db = 10 * np.log10(requirements.level2)
    with np.errstate(divide="ignore"):
        S_db, T_db = (20 * np.log10(np.abs(x)) for x in (c.sensitivity, c.complementary))
    styles = _styles(c)
    for k, label in enumerate(c.labels):
        s_line, = axes[0].semilogx(f, S_db[k], label=label, **styles[k])
        t_line, = axes[1].semilogx(f, T_db[k], **{"color": s_line.get_color(), **styles[k]})
        j = int(np.argmax(S_db[k]))
        axes[0].plot([f[j]], [S_db[k][j]], "v", color=s_line.get_color(), ms=5)
        bw = c.bandwidth_hz[k]
        if np.isfinite(bw):
            axes[1].plot([bw], [level_db], "o", color=t_line.get_color(), ms=4)
    least = _worst(c.bandwidth_hz)
    if least is not None:
        axes[1].annotate(f"bandwidth {c.bandwidth_hz[least]:.3g} Hz", (c.bandwidth_hz[least], level_db),
                         xytext=(10, -16), textcoords="offset points", fontsize=8)
    worst_s = int(np.argmax(c.peak_sensitivity))
    axes[0].annotate(f"Ms {20 * np.log10(c.peak_sensitivity[worst_s]):.2f} dB", (f[int(np.argmax(S_db[worst_s]))],
                     float(np.max(S_db[worst_s]))), xytext=(8, 4), textcoords="offset points", fontsize=8)
    if requirements.peak_sensitivity is not None:
        axes[0].axhline(20 * np.log10(requirements.peak_sensitivity), color="tab:red", lw=0.8, ls="--",
                        label=f"Ms limit {requirements.peak_sensitivity:g}")
    axes[1].axhline(level_db, color="0.4", lw=0.8)
    for ax, title in zip(axes, ("Sensitivity |S| = |1 / (1 + L)|", "Complementary sensitivity |T| = |L / (1 + L)|")):
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("frequency (Hz)")
        ax.grid(True, alpha=0.3)
        ax.set_ylim(-40, 15)
    axes[0].set_ylabel("magnitude (dB, dimensionless)")
    _legend_below(fig, axes[0], min(len(c.labels), 4))
    return fig


def nyquist_figure(c: LoopCurves, requirements):
    """Nyquist curves with the margin regions: unit circle, PM cone and the GM point."""
    req = requirements
    fig, ax = plt.subplots(figsize=(8.6, 6))
    fixed_margins(fig, right_in=2.6)
    th = np.linspace(0, 2 * np.pi, 400)
    ax.plot(np.cos(th), np.sin(th), color="0.6", lw=0.8, label="|L| = 1")
    pm = np.radians(req.phase_margin_deg)
    for sgn in (1, -1):
        ax.plot([0, -np.cos(pm) * 1.6], [0, sgn * np.sin(pm) * 1.6], color="tab:red", lw=0.8, ls="--",
                label=f"PM {req.phase_margin_deg:g}° cone" if sgn > 0 else None)
    gm = 10 ** (-req.gain_margin_db / 20)
    ax.plot([-gm], [0], "x", color="tab:red", ms=9, label=f"-1/GM ({req.gain_margin_db:g} dB)")
    ax.plot([-1], [0], "k+", ms=12, mew=2, label="-1")
    for label, L, style in zip(c.labels, c.nyquist_loop, _styles(c)):
        ax.plot(L.real, L.imag, label=label, **style)
    ax.set_xlim(-3, 1.5)
    ax.set_ylim(-2.5, 2)
    ax.set_aspect("equal")
    ax.set_xlabel("Re L (dimensionless)")
    ax.set_ylabel("Im L (dimensionless)")
    ax.grid(True, alpha=0.3)
    ax.set_title("Nyquist: each curve must pass right of the cone on |L| = 1 and of the GM mark", fontsize=10)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.03, 1.0), frameon=False)
    return fig


#: step responses beyond this are drawn clipped and labelled as diverging
STEP_PLOT_LIMIT = 5.0


def step_figure(c: LoopCurves):
    """Closed velocity-loop step response (rational model, Pade for delays)."""
    fig, ax = plt.subplots(figsize=(9.5, 3.8))
    fixed_margins(fig, right_in=2.6)
    for label, y, style in zip(c.labels, c.step_response, _styles(c)):
        finite = np.all(np.isfinite(y)) and np.max(np.abs(y)) < STEP_PLOT_LIMIT
        ax.plot(c.step_time_s * 1e3, np.clip(np.where(np.isfinite(y), y, np.nan), -STEP_PLOT_LIMIT, STEP_PLOT_LIMIT),
                label=label + ("" if finite else " (diverges: unstable closed loop)"), **style)
    ax.axhline(1.0, color="0.4", lw=0.8)
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("velocity / reference (m/s per m/s)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False)
    ax.set_title("Closed velocity loop: unit step of the velocity reference", fontsize=10)
    return fig


#: payload bins of the Monte Carlo band in the margins-against-payload figure
MC_BINS = 14


def _monte_carlo_band(check, key: str):
    """Bin centres (kg), 5 % and 95 % percentiles and minimum per payload bin of the check's draws."""
    m, v = check.draws.payload_kg, np.asarray(getattr(check.draws, key), float)
    edges = np.linspace(np.min(m), np.max(m), MC_BINS + 1)
    idx = np.clip(np.digitize(m, edges) - 1, 0, MC_BINS - 1)
    centres, lo, hi, low = [], [], [], []
    for b in range(MC_BINS):
        x = v[idx == b]
        x = x[~np.isnan(x)]
        if x.size:
            centres.append(0.5 * (edges[b] + edges[b + 1]))
            with np.errstate(invalid="ignore"):      # an infinite gain margin: its percentiles stay inf
                lo.append(np.percentile(x, 5))
                hi.append(np.percentile(x, 95))
            low.append(np.min(x))
    return np.array(centres), np.array(lo), np.array(hi), np.array(low)


def thesis_verdict(ev: Evaluation) -> str:
    """The thesis gains' verdict: pass or fail and the worst margins."""
    gm = float(np.min(ev.gain_margin_db))
    mark = "meet the requirements" if ev.meets else "FAIL the requirements"
    return (f"{mark} (worst phase margin {np.min(ev.phase_margin_deg):.1f} deg, gain margin "
            + ("infinite" if not np.isfinite(gm) else f"{gm:.1f} dB") + ")")


def verdict_label(name: str, ev: Evaluation, requirements) -> str:
    """'thesis gains (Kp 236, Ki 47): FAILS (worst PM 40.0 deg, GM 5.0 dB)' or '...: meets ...'."""
    gm = float(np.min(ev.gain_margin_db))
    c = ev.controller
    return (f"{name} (Kp {c.kp:.4g}, Ki {c.ki:.4g}): {'meets' if ev.meets else 'FAILS'} (worst PM "
            f"{np.min(ev.phase_margin_deg):.1f}°, GM " + ("∞" if not np.isfinite(gm) else f"{gm:.1f} dB") + ")")


def payload_figure(designed: Evaluation, thesis: Evaluation, requirements, check=None):
    """Thesis Figure 4.31 extended: bandwidth and margins against payload, each the worst over the uncertainty
    scenarios at that payload, for the designed and the thesis gains; shaded, the report's Monte Carlo check."""
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.6))
    fixed_margins(fig, left_in=0.6, bottom_in=1.35)
    req = requirements
    keys = ("bandwidth_hz", "phase_margin_deg", "gain_margin_db")
    for s, name, style in ((designed, "designed gains", "-"), (thesis, "thesis gains", "--")):
        label = verdict_label(name, s, req)
        for ax, key in zip(axes, keys):
            y = getattr(s, key)
            ax.plot(s.payload_kg, np.where(np.isfinite(y), y, np.nan), style, label=label,
                    color="tab:blue" if name == "designed gains" else ("tab:green" if s.meets else "tab:red"))
    if check is not None and check.draws is not None:
        for ax, key in zip(axes, keys):
            x, lo, hi, low = _monte_carlo_band(check, key)
            ax.fill_between(x, lo, hi, color="tab:blue", alpha=0.18, lw=0,
                            label=f"designed gains, Monte Carlo check: 5-95 % of its {check.samples} draws "
                                  f"(seed {check.seed}) per payload bin")
            ax.plot(x, low, ":", color="tab:blue", lw=1, label="... and their worst draw per bin")
    axes[1].axhline(req.phase_margin_deg, color="tab:red", ls=":", label="required")
    axes[2].axhline(req.gain_margin_db, color="tab:red", ls=":")
    for ax, title, unit in zip(axes, ("closed-loop bandwidth", "phase margin", "gain margin (gaps: ∞)"),
                               ("Hz", "deg", "dB")):
        ax.set_title(title + ", worst over the uncertainty", fontsize=10)
        ax.set_xlabel("payload (kg)")
        ax.set_ylabel(unit)
        ax.grid(True, alpha=0.3)
    handles = {}
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    fig.legend(list(handles.values()), list(handles), loc="lower center", ncol=2, fontsize=8, frameon=False)
    return fig


def _between_line(b) -> str:
    """The synthesis's search between the dense check's points, in one sentence."""
    return (f"a search over {', '.join(b.coordinates)} ({b.evaluations} points from {b.starts} starts) finds the least "
            f"relative slack {b.slack:.3g} (the check's {b.grid_slack:.3g}) at {units(describe_row(b.scenario))}: "
            + ("holds" if b.holds else "fails") + f"; the least bandwidth it finds is {b.least_bandwidth_hz:.2f} Hz "
            f"(the check's {b.grid_bandwidth_hz:.2f} Hz).")


def _measured_line(check, req) -> str:
    """The gains on a fitted plant, and what of the fit lies outside the spec or is not identified."""
    gm = "infinite" if not np.isfinite(check.gain_margin_db) else f"{check.gain_margin_db:.1f} dB"
    lo, hi = check.payload_kg
    text = (f"on the stage fitted from the recording (at its {check.fitted_mass_kg:.3g} kg and carrying {lo:g}-{hi:g} "
            f"kg): least phase margin {check.phase_margin_deg:.1f} deg, gain margin {gm}, bandwidth "
            f"{check.bandwidth_hz:.3g} Hz: " + ("meets the requirements" if check.meets else
                                               "does NOT meet the requirements"))
    if check.outside:
        text += ("; outside the spec's ranges, so the verification above does not cover this stage: "
                 + ", ".join(f"{p.name} {p.value:.4g} ± {p.stderr:.2g} (spec {p.low:g} – {p.high:g})"
                             for p in check.outside))
    if check.unidentified:
        text += ("; not identified by the data (held at the spec's nominal values): "
                 + ", ".join(p.name for p in check.unidentified))
    return text + "."


def summary_story(content: ReportContent) -> Story:
    """The report's summary: the answer first (the mouse on the admittance, the gains, the worst case recomputed
    over the payload range and whether it meets the requirements, what limits it), then how it was checked."""
    c, loop = content, content.problem.loop
    ev, thesis, req, d = c.evaluation, c.thesis, loop.requirements, c.design
    mc = c.monte_carlo_check
    meets = ev.meets and (mc is None or mc.violations == 0)
    worst_gm = float(np.min(ev.gain_margin_db))
    rng = loop.plant.payload_kg
    over = (f"{ev.payload_kg.size} payloads x {len(ev.row_bandwidth_hz) // ev.payload_kg.size} sets of the "
            "uncertain parameters" if loop.plant.uncertainty else f"{ev.payload_kg.size} payloads")
    head: list[tuple[str, str]] = []
    a = None if d is None else d.admittance
    if a is not None and a.status in ("optimal", "mouse_cannot_drive"):
        pm = float(np.nanmin(a.check.phase_margin_deg))
        budget = d.problem.loop.admittance.mouse.peak_force_n
        head.append(("Admittance", f"the mouse {'can' if a.status == 'optimal' else 'CANNOT'} drive it: it feels "
                                   f"{a.feel.peak_force_n:.3g} N of its {budget:g} N on the locomotion profile; "
                                   f"m_v = {a.m_v:.4g} kg, b_v = {a.b_v:.4g} N·s/m; interaction PM "
                                   f"{'∞' if not np.isfinite(pm) else f'{pm:.1f}'} deg (see below)."))
    elif a is not None:
        head.append(("Admittance", f"{a.status}: {a.message}"))
    head += [("Gains", f"{c.controller} ({c.gains_source})."),
             (f"Worst case over {rng.min:g}-{rng.max:g} kg",
              f"bandwidth {ev.worst_bandwidth_hz:.2f} Hz, phase margin {np.min(ev.phase_margin_deg):.1f} deg, gain "
              "margin " + ("infinite" if not np.isfinite(worst_gm) else f"{worst_gm:.1f} dB")
              + f" over {over}, recomputed here: "
              + ("meets the requirements." if meets else "does NOT meet the requirements.")),
             ("Limiting", f"{limiting_text(ev, req)}.")]
    if mc is not None:
        head.append(("Monte Carlo", f"over payload x plant.uncertainty ({mc.samples} independent draws, seed "
                                    f"{mc.seed}): {mc.violations} violate the requirements ({100 * mc.rate:.2g} %, "
                                    f"one-sided 95 % upper bound {100 * mc.rate_upper_bound:.2g} %); worst PM "
                                    f"{mc.worst_phase_margin_deg:.1f} deg, worst GM {mc.worst_gain_margin_db:.1f} dB."))
    for r in c.recordings:
        head.append((f"Measured ({r.path.name})", _measured_line(r.check, req)))
    if d is not None and d.synthesis is not None and d.synthesis.between is not None:
        head.append(("Between the check's points", _between_line(d.synthesis.between)))
    head.append(("Thesis gains on the same plant", f"{thesis_verdict(thesis)}; worst-case bandwidth "
                                                   f"{thesis.worst_bandwidth_hz:.2f} Hz."))
    for f in (d.synthesis.filters if d is not None and d.synthesis is not None else ()):
        params = ", ".join(f"{k} {f.values[k]:.4g}" for k in ("frequency_hz", "damping_ratio", "depth")
                           if k in f.values)
        head.append((f"Drive filter {f.kind}", f"{params} (designed: {', '.join(f.designed)})." if f.used else
                     "left out: the design is faster without it."))
    if d is not None:
        head.append(("Synthesis", f"status {d.status}, independently verified: {'yes' if d.verified else 'no'}."))
    return Story(tuple(head))


def design_report(content: ReportContent) -> Report:
    """The report of ``content`` (built by ``design.workflows.report_content``)."""
    check_instance("content", content, ReportContent, "design.workflows.report_content(problem) makes one")
    c, problem = content, content.problem
    spec, loop = problem.spec, problem.loop
    ev, thesis, req, d = c.evaluation, c.thesis, loop.requirements, c.design
    report = Report(f"Design report: {spec.name}")
    report.headline(summary_story(c))
    rng = loop.plant.payload_kg

    report.heading("Plant")
    p = spec.plant
    report.text(f"Stage {p.stage.upper()} (thesis Eq. {'3.15' if p.stage == 'x' else '3.16'}), effects: "
                f"{', '.join(p.effects) or 'none'}; payload {rng.min:g}-{rng.max:g} kg "
                f"(nominal {rng.nominal_kg:g} kg).")
    rows = [[k, f"{getattr(p, k):g}"] for k in ("force_constant_n_per_a", "damping_n_s_per_m")]
    if p.stage == "y":
        rows += [[k, f"{getattr(p, k):g}"] for k in ("motor_length_m", "load_position_m")]
    rows += [[f"{e}.{k}", f"{v:g}"] for e, ps in p.effects.items() for k, v in ps.items()]
    rows += [[f"uncertainty {k}", f"{u.min:g} – {u.max:g}"] for k, u in p.uncertainty.items()]
    report.raw(table(["parameter", "value"], rows))
    for r in c.recordings:
        report.text(f"Fitted from {r.path.name}, against the spec's ranges (outside: beyond the range by more than "
                    "two standard errors; not identified: an error that is not finite or exceeds the value):")
        report.raw(table(["parameter", "fitted", "±", "spec range", "status"], [
            [p.name, f"{p.value:.4g}", "—" if not np.isfinite(p.stderr) else f"{p.stderr:.2g}",
             "none declared" if p.low is None else f"{p.low:g} – {p.high:g}", p.status] for p in r.check.parameters]))

    report.heading("Loop over the payload range")
    report.figure(loop_bode_figure(c.curves), "Bode plots of plant and loop at light, nominal and heavy payload "
                  "(nominal parameters)" + (" and, dashed, the binding scenario, where the requirement with the least "
                                            "slack binds" if c.curves.binding_row is not None else "")
                  + "; on the loop, each gain crossover's phase margin and phase crossover's gain margin.")
    report.figure(closed_loop_figure(c.curves, req),
                  f"Closed velocity loop: sensitivity |S| (its peak Ms marked ▼) and |T|, the bandwidth marked where "
                  f"|T| falls to {10 * np.log10(req.level2):.2f} dB (the requirements' definition) at each payload "
                  "(nominal parameters)" + (" and the binding scenario" if c.curves.binding_row is not None else "")
                  + ".")
    report.figure(nyquist_figure(c.curves, req), "Nyquist curves; the curve must stay right of the dashed PM cone "
                                                 "where it crosses the unit circle and cross the real axis right "
                                                 "of the GM mark.")
    report.figure(step_figure(c.curves), "Closed-loop step response of the velocity loop.")

    report.heading("Margins and bandwidth against payload")
    report.figure(payload_figure(ev, thesis, req, c.monte_carlo_check),
                  "Thesis Figure 4.31 extended: designed against thesis gains, each the worst over the uncertainty "
                  "scenarios at each payload (the figures of the summary)"
                  + (f"; shaded: the summary's Monte Carlo check ({c.monte_carlo_check.samples} draws, seed "
                     f"{c.monte_carlo_check.seed})" if c.monte_carlo_check is not None else "") + ".")
    report.raw(table(["payload kg", "bandwidth Hz (worst)", "PM deg (worst)", "GM dB (worst)",
                      "thesis gains: bandwidth Hz (worst)"],
                     [[f"{m:.1f}", f"{b:.2f}", f"{pm:.1f}", "∞" if not np.isfinite(g) else f"{g:.1f}", f"{bt:.2f}"]
                      for m, b, pm, g, bt in list(zip(ev.payload_kg, ev.bandwidth_hz, ev.phase_margin_deg,
                                                      ev.gain_margin_db, thesis.bandwidth_hz))[::7]]))

    if c.comparison:
        report.heading("Robust and nominal designs")
        report.text("The design holds on every payload point x corner of the uncertainty box (and the violators its "
                    "checks added); the design for the nominal parameters alone is faster on the nominal plant and "
                    "misses the requirements on part of the plants the spec calls plausible. Bandwidths are worst "
                    "cases over the payload range.")
        report.raw(table(["design", "Kp A/(m/s)", "Ki A/m", "bandwidth, nominal parameters Hz",
                          "bandwidth over the uncertainty Hz", "Monte Carlo violations", "95 % bound",
                          "Monte Carlo: worst PM deg", "Monte Carlo: worst GM dB"],
                         [[r.name, f"{r.nominal.controller.kp:.4g}", f"{r.nominal.controller.ki:.4g}",
                           f"{r.nominal.worst_bandwidth_hz:.2f}",
                           f"{r.robust.worst_bandwidth_hz:.2f}",
                           f"{r.monte_carlo.violations} / {r.monte_carlo.samples}",
                           f"{100 * r.monte_carlo.rate_upper_bound:.2g} %",
                           f"{r.monte_carlo.worst_phase_margin_deg:.1f}",
                           f"{r.monte_carlo.worst_gain_margin_db:.1f}"] for r in c.comparison]))
        if len(c.comparison) == 2:
            cost = 1 - c.comparison[0].nominal.worst_bandwidth_hz / c.comparison[1].nominal.worst_bandwidth_hz
            report.text(f"Robustness costs {100 * cost:.0f} % of the nominal design's worst-case bandwidth on the "
                        "nominal plant.")

    if d is not None and (d.admittance is not None or d.admittance_skipped):
        from design.views.admittance import add_admittance_section

        add_admittance_section(report, loop, d, c.admittance_curves, c.admittance_comparison)

    if c.recordings:
        from design.views.diagnosis import add_diagnosis_section

        report.heading("Measurements against the model")
        for r in c.recordings:
            report.heading(r.path.name, 3)
            add_diagnosis_section(report, r.diagnosis, r.measured)

    report.heading("Reproducibility")
    spec_path = problem.spec_path
    text = read_text(spec_path)
    report.raw(table(["item", "value"], [
        ["tool", f"gantry {__version__}"], ["command", c.command or "(library call)"],
        ["spec", f"{spec_path} (sha256 {hashlib.sha256(text.encode()).hexdigest()})"],
        ["Monte Carlo", "none" if c.monte_carlo_check is None else
         f"{c.monte_carlo_check.samples} draws, seed {c.monte_carlo_check.seed}"],
        *[[f"data {k + 1}", f"{r.path} (sha256 {hashlib.sha256(r.path.read_bytes()).hexdigest()[:16]}…)"]
          for k, r in enumerate(c.recordings)]]))
    report.pre(text)
    if d is not None:
        import json

        from design.views.json import design_to_dict

        report.raw("<details><summary>Synthesis output (JSON, as printed by <code>--json</code>)</summary>")
        report.pre(json.dumps(design_to_dict(d), indent=2, allow_nan=False))
        report.raw("</details>")
    return report
