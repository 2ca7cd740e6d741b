"""Design report: one self-contained HTML file a controls engineer reads top to bottom.

Summary first (gains, worst-case bandwidth and margins, verified or not, what limits the
design), then the plant, Bode / Nyquist / step plots over the payload range, margins and
bandwidth against payload (thesis Figure 4.31 extended), admittance, measured data with the
diagnosis, and reproducibility. Every number in the summary is recomputed here on a dense
payload grid (50 payloads), never taken from an optimiser's claim.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from design.loop.analysis import PayloadSweep, payload_sweep
from design.loop.loops import closed_loop_tf, open_loop_frd
from design.spec.schema import DENSE_PAYLOADS, Spec
from design.views.html import Report, table
from design.views.plots import bode
from plant import __version__
from plant.grid import log_grid_rad_s
from plant.parameters import THESIS

#: plotted frequencies: 100 per decade resolve a mode of damping ratio 0.02 (half-power width 4 %)
W_PLOT = log_grid_rad_s(0.1, 2000.0, 430)


@dataclass(frozen=True)
class Check:
    """Worst case of the loop with the reported gains over a dense payload grid."""

    sweep: PayloadSweep
    worst_bandwidth_hz: float
    worst_phase_margin_deg: float
    worst_gain_margin_db: float
    meets_requirements: bool
    #: the requirement with the least slack and where: e.g. "phase margin 45.0 deg at 40.0 kg"
    limiting: str


def check_design(spec: Spec, kp: float, ki: float) -> Check:
    """Margins and bandwidth of (kp, ki) at ``DENSE_PAYLOADS`` payloads of the spec's range."""
    m = spec.plant.payload_kg.check_points()
    s = payload_sweep(spec.plant.plant(), kp, ki, m)
    req = spec.requirements
    pm_slack = s.phase_margin_deg - req.phase_margin_deg
    gm_slack = s.gain_margin_db - req.gain_margin_db
    i_pm, i_gm = int(np.nanargmin(pm_slack)), int(np.argmin(np.where(np.isfinite(gm_slack), gm_slack, np.inf)))
    if np.isfinite(gm_slack[i_gm]) and gm_slack[i_gm] < pm_slack[i_pm]:
        limiting = f"gain margin {s.gain_margin_db[i_gm]:.2f} dB (required {req.gain_margin_db:g}) at {m[i_gm]:.1f} kg"
    else:
        limiting = (f"phase margin {s.phase_margin_deg[i_pm]:.2f} deg (required {req.phase_margin_deg:g}) at "
                    f"{m[i_pm]:.1f} kg")
    ok = bool(np.all(pm_slack >= -1e-6) and np.all(np.where(np.isfinite(gm_slack), gm_slack, 1) >= -1e-6)
              and np.all(np.isfinite(s.closed_loop_bandwidth_hz)))
    return Check(s, float(np.nanmin(s.closed_loop_bandwidth_hz)), float(np.nanmin(s.phase_margin_deg)),
                 float(np.min(s.gain_margin_db)), ok, limiting)


def _payloads(spec: Spec) -> list[float]:
    rng = spec.plant.payload_kg
    return sorted({rng.min, rng.nominal_kg, rng.max})


def loop_bode_figure(spec: Spec, kp: float, ki: float):
    plant = spec.plant.plant()
    fig, axes = plt.subplots(2, 2, sharex=True, figsize=(12, 5.5), layout="tight")
    masses = _payloads(spec)
    P = plant.with_payload(masses).frd(W_PLOT)
    L = open_loop_frd(P, W_PLOT, kp, ki)
    bode(W_PLOT, list(P), [f"plant, {m:g} kg" for m in masses], axes=axes[:, 0], title="Plant P(jω)")
    bode(W_PLOT, list(L), [f"loop, {m:g} kg" for m in masses], axes=axes[:, 1], title="Loop L = P (Kp + Ki/s)")
    return fig


def nyquist_figure(spec: Spec, kp: float, ki: float):
    """Nyquist curves with the margin regions: unit circle, PM cone and the GM point."""
    plant = spec.plant.plant()
    req = spec.requirements
    fig, ax = plt.subplots(figsize=(6.2, 6), layout="tight")
    th = np.linspace(0, 2 * np.pi, 400)
    ax.plot(np.cos(th), np.sin(th), color="0.6", lw=0.8, label="|L| = 1")
    pm = np.radians(req.phase_margin_deg)
    for sgn in (1, -1):
        ax.plot([0, -np.cos(pm) * 1.6], [0, sgn * np.sin(pm) * 1.6], color="tab:red", lw=0.8, ls="--")
    gm = 10 ** (-req.gain_margin_db / 20)
    ax.plot([-gm], [0], "x", color="tab:red", ms=9, label=f"-1/GM ({req.gain_margin_db:g} dB)")
    ax.plot([-1], [0], "k+", ms=12, mew=2, label="-1")
    w = log_grid_rad_s(0.05, 5000.0, 500)
    for m in _payloads(spec):
        L = open_loop_frd(plant.with_payload(m), w, kp, ki)
        ax.plot(L.real, L.imag, label=f"{m:g} kg")
    ax.set_xlim(-3, 1.5)
    ax.set_ylim(-2.5, 2)
    ax.set_aspect("equal")
    ax.set_xlabel("Re L")
    ax.set_ylabel("Im L")
    ax.grid(True, alpha=0.3)
    ax.set_title(f"Nyquist; dashed: PM {req.phase_margin_deg:g}° cone", fontsize=10)
    ax.legend(fontsize=8, loc="lower right")
    return fig


def step_figure(spec: Spec, kp: float, ki: float):
    """Closed velocity-loop step response (rational model, Pade for delays)."""
    import control

    plant = spec.plant.plant()
    fig, ax = plt.subplots(figsize=(7, 3.6), layout="tight")
    for m in _payloads(spec):
        T = closed_loop_tf(plant.with_payload(m), kp, ki)
        t = np.linspace(0, 0.25, 2000)
        resp = control.step_response(T, t)
        ax.plot(resp.time * 1e3, np.squeeze(resp.outputs), label=f"{m:g} kg")
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("velocity / reference")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Closed velocity loop: unit step of the velocity reference", fontsize=10)
    return fig


def payload_figure(designed: PayloadSweep, thesis: PayloadSweep, spec: Spec, mc=None):
    """Thesis Figure 4.31 extended: bandwidth and margins against payload, designed vs thesis gains."""
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8), layout="tight")
    req = spec.requirements
    for s, label, style in ((designed, "designed gains", "-"), (thesis, "thesis gains (Kp 236, Ki 47)", "--")):
        axes[0].plot(s.payload_kg, s.closed_loop_bandwidth_hz, style, label=label)
        axes[1].plot(s.payload_kg, s.phase_margin_deg, style, label=label)
        axes[2].plot(s.payload_kg, np.where(np.isfinite(s.gain_margin_db), s.gain_margin_db, np.nan), style,
                     label=label)
    if mc is not None:
        for ax, dist in zip(axes, mc.distributions):
            lo, hi = dist.percentile(mc.levels[0]), dist.percentile(mc.levels[-1])
            ax.fill_between(mc.payload_kg, lo, hi, alpha=0.2, label=f"{mc.levels[0]:g}-{mc.levels[-1]:g} % "
                            f"({mc.samples} samples)")
    axes[1].axhline(req.phase_margin_deg, color="tab:red", ls=":", label="required")
    axes[2].axhline(req.gain_margin_db, color="tab:red", ls=":", label="required")
    for ax, title in zip(axes, ("closed-loop bandwidth (Hz)", "phase margin (deg)", "gain margin (dB; gaps: ∞)")):
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("payload (kg)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    return fig


def design_report(spec: Spec, *, spec_path: Path, kp: float, ki: float, gains_source: str,
                  synthesis: dict | None = None, recordings=(), command: str = "", samples: int = 0,
                  seed: int = 0) -> Report:
    """Build the report for gains (kp, ki); ``recordings`` are (path, MeasuredResponse, Diagnosis)."""
    check = check_design(spec, kp, ki)
    thesis = check_design(spec, THESIS["kp"].value, THESIS["ki"].value)
    report = Report(f"Design report: {spec.name}")
    verified = synthesis.get("verified") if synthesis else None
    status = ("<span class='ok'>meets the requirements</span>" if check.meets_requirements
              else "<span class='bad'>does NOT meet the requirements</span>")
    lines = [f"<b>Gains</b> ({gains_source}): Kp = {kp:.4g} A/(m/s), Ki = {ki:.4g} A/m.",
             f"<b>Worst case over {spec.plant.payload_kg.min:g}-{spec.plant.payload_kg.max:g} kg</b> "
             f"({DENSE_PAYLOADS} payloads, recomputed here): bandwidth {check.worst_bandwidth_hz:.2f} Hz, "
             f"phase margin {check.worst_phase_margin_deg:.1f} deg, gain margin "
             + ("infinite" if not np.isfinite(check.worst_gain_margin_db) else f"{check.worst_gain_margin_db:.1f} dB")
             + ": "
             f"{status}.",
             f"<b>Limiting:</b> {check.limiting}.",
             f"<b>Thesis gains on the same plant:</b> worst-case bandwidth {thesis.worst_bandwidth_hz:.2f} Hz, "
             f"phase margin {thesis.worst_phase_margin_deg:.1f} deg."]
    if synthesis is not None:
        lines.append(f"<b>Synthesis:</b> status {synthesis.get('status')}, independently verified: "
                     f"{'<span class=ok>yes</span>' if verified else '<span class=bad>no</span>'}.")
        adm = synthesis.get("admittance")
        if adm and adm.get("m_v") is not None:
            pm = adm["worst_phase_margin_deg"]
            lines.append(f"<b>Admittance:</b> m_v = {adm['m_v']:.4g} kg, b_v = {adm['b_v']:.4g} N·s/m; peak resistance "
                         f"{adm['peak_resistance_n']:.3g} N; interaction PM {'∞' if pm is None else f'{pm:.1f}'} deg "
                         f"(see below).")
    report.raw("<div class='summary'>" + "<br>".join(lines) + "</div>")

    report.heading("Plant")
    p = spec.plant
    report.text(f"Stage {p.stage.upper()} (thesis Eq. {'3.15' if p.stage == 'x' else '3.16'}), effects: "
                f"{', '.join(p.effects) or 'none'}; payload {p.payload_kg.min:g}-{p.payload_kg.max:g} kg "
                f"(nominal {p.payload_kg.nominal_kg:g} kg).")
    rows = [[k, f"{getattr(p, k):g}"] for k in ("force_constant_n_per_a", "damping_n_s_per_m")]
    if p.stage == "y":
        rows += [[k, f"{getattr(p, k):g}"] for k in ("motor_length_m", "load_position_m")]
    rows += [[f"{e}.{k}", f"{v:g}"] for e, ps in p.effects.items() for k, v in ps.items()]
    rows += [[f"uncertainty {k}", f"{u.min:g} – {u.max:g}"] for k, u in p.uncertainty.items()]
    report.raw(table(["parameter", "value"], rows))
    for path, measured, diag in recordings:
        fitted = diag.final
        report.text(f"Fitted from {Path(path).name}: " + ", ".join(
            f"{n} = {fitted.values[n]:.4g} ± {fitted.stderr[n]:.2g}" for n in fitted.free))

    report.heading("Loop over the payload range")
    report.figure(loop_bode_figure(spec, kp, ki), "Bode plots of plant and loop at light, nominal and heavy payload.")
    report.figure(nyquist_figure(spec, kp, ki), "Nyquist curves; the curve must stay right of the dashed PM cone "
                                                "where it crosses the unit circle and cross the real axis right "
                                                "of the GM mark.")
    report.figure(step_figure(spec, kp, ki), "Closed-loop step response of the velocity loop.")

    report.heading("Margins and bandwidth against payload")
    mc = None
    if samples:
        from design.loop.sweep import monte_carlo_sweep

        mc = monte_carlo_sweep(spec, payload_kg=check.sweep.payload_kg, samples=samples, seed=seed, kp=kp, ki=ki)
    report.figure(payload_figure(check.sweep, thesis.sweep, spec, mc),
                  "Thesis Figure 4.31 extended: designed against thesis gains" +
                  (f"; shaded: Monte Carlo over the spec's uncertainty (seed {seed})" if mc else "") + ".")
    report.raw(table(["payload kg", "bandwidth Hz", "PM deg", "GM dB", "thesis-gain bandwidth Hz"],
                     [[f"{m:.1f}", f"{b:.2f}", f"{pm:.1f}", "∞" if not np.isfinite(g) else f"{g:.1f}", f"{bt:.2f}"]
                      for m, b, pm, g, bt in list(zip(check.sweep.payload_kg, check.sweep.closed_loop_bandwidth_hz,
                                                      check.sweep.phase_margin_deg, check.sweep.gain_margin_db,
                                                      thesis.sweep.closed_loop_bandwidth_hz))[::7]]))

    if synthesis and synthesis.get("admittance"):
        from design.views.admittance import add_admittance_section

        add_admittance_section(report, spec, synthesis)

    if recordings:
        from design.views.diagnosis import add_diagnosis_section

        report.heading("Measurements against the model")
        for path, measured, diag in recordings:
            report.heading(Path(path).name, 3)
            add_diagnosis_section(report, diag, measured)

    report.heading("Reproducibility")
    text = spec_path.read_text()
    report.raw(table(["item", "value"], [
        ["tool", f"gantry {__version__}"], ["command", command or "(library call)"],
        ["spec", f"{spec_path} (sha256 {hashlib.sha256(text.encode()).hexdigest()})"],
        ["seed", str(seed)], *[[f"data {k + 1}", f"{Path(r[0])} (sha256 "
                                              f"{hashlib.sha256(Path(r[0]).read_bytes()).hexdigest()[:16]}…)"]
                               for k, r in enumerate(recordings)]]))
    report.pre(text)
    if synthesis is not None:
        import json

        report.raw("<details><summary>Synthesis output (JSON, as printed by <code>--json</code>)</summary>")
        report.pre(json.dumps(synthesis, indent=2, allow_nan=False))
        report.raw("</details>")
    return report


