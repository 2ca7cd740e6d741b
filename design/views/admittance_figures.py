"""Figures of the admittance section, one panel each so that a narrow screen stacks them: units on every axis,
each requirement drawn as its limit line with whether it is met, legends below the axes, the binding scenario
of the summary marked where it is plotted."""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import numpy as np

from design.admittance.mouse import MouseModel
from design.loop.curves import scenario_label
from design.loop.requirement import Binding
from design.views.plots import fixed_margins
from plant.bode import bode

#: one panel: width and height of the axes' figure (in), before the legend's rows below it
PANEL_IN = (6.4, 3.2)
#: a requirement's limit line
LIMIT_STYLE = {"color": "tab:red", "ls": ":", "lw": 1.4}
#: the binding scenario: black, as in the loop figures of the PI report
BINDING_STYLE = {"color": "k", "marker": "o", "ms": 7, "mfc": "none", "mew": 1.6, "ls": "none"}
LEGEND_ROW_IN = 0.2


def num(x, fmt: str = ".1f") -> str:
    """A number for text; ∞ for an infinite one, — for none."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "—"
    return "∞" if not np.isfinite(x) else format(x, fmt)


def passive_up_to_hz(check) -> float:
    """Worst passive band over the check's scenarios (Hz; inf: passive on the whole grid)."""
    return float(np.min(check.passive_up_to_hz))


def rendered_bandwidth_hz(check) -> float:
    """Worst frequency (Hz) up to which the rendered admittance stays within 3 dB / 30° of the virtual one."""
    bw = check.rendered_bandwidth_hz
    return float(np.nanmin(bw)) if np.any(np.isfinite(bw)) else math.nan


def passive_text(check) -> str:
    return num(passive_up_to_hz(check), ".3g")


def bandwidth_text(check) -> str:
    return num(rendered_bandwidth_hz(check))


def _panel(legend_rows: int, *, left_in: float = 0.75):
    """A one-axes figure with room below for ``legend_rows`` rows of legend."""
    bottom = 0.55 + LEGEND_ROW_IN * legend_rows + 0.1
    fig, ax = plt.subplots(figsize=(PANEL_IN[0], PANEL_IN[1] + bottom - 0.55))
    fixed_margins(fig, left_in=left_in, bottom_in=bottom, top_in=0.35)
    ax.grid(True, which="both", alpha=0.3)
    return fig, ax


def _legend_below(fig, axes, ncol: int = 1) -> None:
    """One legend for the figure under its axes, where it covers no curve."""
    handles: dict = {}
    for ax in np.atleast_1d(axes):
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    fig.legend(list(handles.values()), list(handles), loc="lower center", ncol=ncol, fontsize=8, frameon=False)


def _rows(n: int, ncol: int = 1) -> int:
    return -(-n // ncol)


def force_limit_label(limit_n: float, peak_n: float) -> str:
    """'the mouse's peak force, 1.2 N: EXCEEDED (peak 1.93 N)' or '...: met (peak 0.8 N)'."""
    return f"the mouse's peak force, {limit_n:g} N: {'met' if peak_n <= limit_n else 'EXCEEDED'} (peak {peak_n:.3g} N)"


def force_felt_figure(feel, mouse_peak_force_n: float):
    """The neck force on the locomotion profile (N over s) at the worst case, the force the virtual dynamics
    ask, and the mouse's peak force with whether the felt peak stays under it."""
    fig, ax = _panel(3)
    t = feel.profile.time_s
    ax.plot(t, feel.force_n, label="felt: neck force with the real loop")
    ax.plot(t, feel.ideal_force_n, "--", label="asked by the virtual dynamics, m_v a + b_v v")
    ax.axhline(mouse_peak_force_n, **LIMIT_STYLE, label=force_limit_label(mouse_peak_force_n, feel.peak_force_n))
    ax.set(xlabel="time (s)", ylabel="force (N)")
    ax.set_title("Force felt on the locomotion profile", fontsize=10)
    _legend_below(fig, ax)
    return fig


def apparent_mass_figure(feel, m_v: float):
    """|Im(1/Y_r)/ω| (kg) over frequency (Hz) at each payload on a log axis, dotted where negative, with m_v."""
    fig, ax = _panel(2)
    f = feel.frequency_hz
    for m, y in zip(feel.payload_kg, feel.apparent_mass_kg):
        line, = ax.loglog(f, np.where(y > 0, y, np.nan), label=f"{m:g} kg payload")
        ax.loglog(f, np.where(y < 0, -y, np.nan), ":", color=line.get_color())
    ax.axhline(m_v, color="k", ls="--", lw=1, label=f"m_v = {m_v:.4g} kg")
    ax.plot([], [], "k:", label="dotted: negative (its magnitude)")
    ax.set(xlabel="frequency (Hz)", ylabel="|apparent mass| (kg)", xlim=(f[0], f[-1]),
           ylim=(m_v / 10, 2 * float(np.max(feel.payload_kg))))
    ax.set_title("Apparent mass Im(1/Y_r)/ω", fontsize=10)
    _legend_below(fig, ax, ncol=3)
    return fig


def rendered_figure(curves, check, passivity=None):
    """The rendered admittance v/F ((m/s)/N) at each payload against the virtual 1/(m_v s + b_v) with its
    3 dB / 30° tolerance shaded, the phase wrapped, and the summary's worst passive band and rendered
    bandwidth (over the check's scenarios) as labelled vertical lines; with ``passivity`` (the spec's
    requirement) its limit and whether it is met."""
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(6.8, 6.8))
    fixed_margins(fig, left_in=0.85, right_in=0.25, bottom_in=1.5, hspace=0.1)
    styles = ["k--", *["-"] * len(curves.payload_kg)]
    bode(curves.w_rad_s, [curves.virtual, *curves.rendered],
         ["virtual 1/(m_v s + b_v)", *[f"rendered, {m:g} kg payload" for m in curves.payload_kg]], axes=axes,
         styles=styles, unit="(m/s)/N", legend=False, wrap_phase=True)
    f = curves.w_rad_s / (2 * np.pi)
    mag_db = 20 * np.log10(np.abs(curves.virtual))
    phase = np.angle(curves.virtual, deg=True)
    axes[0].fill_between(f, mag_db - 3, mag_db + 3, color="0.5", alpha=0.2, lw=0, label="virtual ±3 dB / ±30°")
    axes[1].fill_between(f, phase - 30, phase + 30, color="0.5", alpha=0.2, lw=0)
    axes[0].set_title("Rendered admittance v/F against the virtual dynamics", fontsize=10)
    marks = [(passive_up_to_hz(check), passive_text(check), "passive up to {} Hz (worst scenario)",
              {"color": "tab:purple", "ls": "-.", "lw": 1.3}),
             (rendered_bandwidth_hz(check), bandwidth_text(check), "within 3 dB / 30° up to {} Hz (worst scenario)",
              {"color": "tab:red", "ls": "-", "lw": 1.3})]
    if passivity is not None:
        need = math.inf if passivity.up_to_hz is None else passivity.up_to_hz
        ok = passive_up_to_hz(check) >= need * (1 - 1e-6)
        marks.append((need, num(need, "g"), "required passive up to {} Hz: " + ("met" if ok else "FAILED"),
                      LIMIT_STYLE))
    for k, (x, text, label, style) in enumerate(sorted(marks, key=lambda m: m[0])):
        if np.isfinite(x) and f[0] <= x <= f[-1]:
            for ax in axes:
                ax.axvline(x, **style, label=label.format(text) if ax is axes[0] else None)
            axes[0].annotate(f"{text} Hz", (x, 0.04 + 0.1 * (k // 2)), xycoords=("data", "axes fraction"),
                             xytext=(-4 if k % 2 == 0 else 4, 0), textcoords="offset points",
                             ha="right" if k % 2 == 0 else "left", fontsize=8, color=style["color"])
    _legend_below(fig, axes[0], ncol=2)
    return fig


def _checked_value(check, values, binding: Binding[MouseModel]) -> float:
    """The check's margin at the binding's scenario and mouse when the check computed it, else the binding's."""
    sc, row = check.scenarios, binding.scenario
    j = np.flatnonzero(np.isclose(sc.payload_kg, row.payload_kg) & np.all(
        [np.isclose(v, row.parameter(n)) for n, v in sc.parameters.items()], axis=0))
    k = [i for i, m in enumerate(check.mice) if m == binding.mouse]
    if j.size and k and np.isfinite(values[k[0], j[0]]):
        return float(values[k[0], j[0]])
    return float(binding.value)


def margin_figures(check, adm, binding: Binding[MouseModel], between=None) -> list:
    """Worst interaction-loop phase margin (deg) and gain margin (dB) over the uncertainty at each payload (kg),
    floating and braced mice, with the requirement and whether each meets it; the summary's binding scenario
    marked on the margin it binds; ``between`` (``design.admittance.between.BetweenCheck``): the least point the
    search between the check's points found, marked, and in its kind of mouse's worst."""
    payloads = np.unique(check.payload_kg)
    figs = []
    for key, what, unit, limit in (("phase_margin", "phase margin", "deg", adm.phase_margin_deg),
                                   ("gain_margin", "gain margin", "dB", adm.gain_margin_db)):
        values = getattr(check, f"{key}_{unit.lower()}")
        fig, ax = _panel(5)
        for name, keep in (("floating", [not m.grounded for m in check.mice]),
                           ("braced", [m.grounded for m in check.mice])):
            k = np.asarray(keep)
            if not k.any():
                continue
            worst = np.nanmin(np.where(k[:, None], values, np.nan), axis=0)
            y = np.array([np.nanmin(worst[check.payload_kg == m]) for m in payloads])
            low = float(np.nanmin(y))
            if between is not None and (name == "braced") == between.mouse.grounded:
                found = getattr(between, f"{key}_{unit.lower()}")
                low = min(low, found)
                if np.isfinite(found):
                    ax.plot([between.scenario.payload_kg], [found], "x", color="k", ms=7,
                            label=f"between the check's points, {name} mouse: {found:.1f} {unit}")
            ax.plot(payloads, np.where(np.isfinite(y), y, np.nan), "o-", ms=3,
                    label=f"{name} mice: worst {num(low)} {unit}: {'meets' if low >= limit - 1e-6 else 'FAILS'}")
        ax.axhline(limit, **LIMIT_STYLE, label=f"required {limit:g} {unit}")
        if binding.constraint == key and binding.payload_kg is not None:
            mouse = "braced" if binding.mouse.grounded else "floating"
            value = _checked_value(check, values, binding)
            ax.plot([binding.payload_kg], [value], **BINDING_STYLE,
                    label=f"{scenario_label(binding.scenario)},\n{mouse} mouse: {value:.1f} {unit}")
        ax.set(xlabel="payload (kg)", ylabel=f"{what} ({unit})")
        ax.set_title(f"Interaction-loop {what}, worst over the uncertainty" + (" (gaps: ∞)" if unit == "dB" else ""),
                     fontsize=10)
        _legend_below(fig, ax)
        figs.append(fig)
    return figs


def run_figures(run) -> list:
    """A simulated run: the gantry's speed against the intended one (m/s over s), and the sensed force and the
    legs' push (N over s) with the mouse's peak force."""
    tr, s = run.trace, run.settings
    speed, ax = _panel(2)
    ax.plot(tr.time_s, tr.intended_v_m_per_s, "k--", label="intended")
    ax.plot(tr.time_s, tr.v_m_per_s, label=f"gantry (shortfall {run.speed_shortfall_m_per_s:.3g} m/s)")
    ax.set(xlabel="time (s)", ylabel="speed (m/s)")
    ax.set_title("Speed on the simulated run", fontsize=10)
    _legend_below(speed, ax)
    force, ax = _panel(3)
    ax.plot(tr.time_s, tr.sensed_force_n, label="sensed force")
    ax.plot(tr.time_s, tr.leg_force_n, alpha=0.7, label="the legs' push")
    ax.axhline(s.mouse_peak_force_n, **LIMIT_STYLE, label=force_limit_label(s.mouse_peak_force_n, run.peak_force_n))
    ax.set(xlabel="time (s)", ylabel="force (N)")
    ax.set_title("Force on the simulated run", fontsize=10)
    _legend_below(force, ax)
    return [speed, force]


def planar_run_figure(run):
    """A planar run (``design.admittance.planar_run.PlanarRun``) in one figure: the path on the floor, intended and
    the clamp's (mm), above the sensed force's magnitude and its part across the mouse's heading (N over s) with
    the mouse's peak force."""
    tr, p = run.trace, run.path
    fig, (floor, force) = plt.subplots(2, 1, figsize=(PANEL_IN[0], 2 * PANEL_IN[1] + 1.2), layout="constrained")
    floor.plot(1e3 * p.position_m[:, 0], 1e3 * p.position_m[:, 1], "k--", label="intended")
    floor.plot(1e3 * tr.clamp_m[:, 0], 1e3 * tr.clamp_m[:, 1],
               label=f"the clamp (lags {1e3 * run.max_lag_m:.3g} mm at most)")
    floor.set(xlabel="x along the beam (mm)", ylabel="y along the rails (mm)", aspect="equal")
    floor.set_title("The path on the floor", fontsize=10)
    speed = p.speed_m_per_s
    heading = p.velocity_m_per_s / np.maximum(speed, 1e-12)[:, None]
    lateral = np.where(speed > 1e-9, tr.sensed_force_n[:, 0] * heading[:, 1] - tr.sensed_force_n[:, 1] * heading[:, 0],
                       np.nan)
    force.plot(tr.time_s, np.hypot(*tr.sensed_force_n.T), label="sensed force, magnitude")
    force.plot(tr.time_s, lateral, alpha=0.8, label=f"across the heading (peak {run.peak_lateral_force_n:.3g} N)")
    limit = run.settings.mouse.peak_force_n
    force.axhline(limit, **LIMIT_STYLE, label=force_limit_label(limit, run.peak_force_n))
    force.set(xlabel="time (s)", ylabel="force (N)")
    force.set_title("Force on the planar run", fontsize=10)
    for ax in (floor, force):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="best", frameon=False)
    return fig


def tradeoff_figures(t, adm) -> list:
    """The least force the virtual dynamics ask on the profile (N) against each requirement, with the mouse's
    peak force and the spec's own requirement."""
    passive = None if adm.passivity is None else adm.passivity.up_to_hz
    figs = []
    for front, label, unit, spec in ((t.margin_front, "interaction phase margin required", "deg",
                                      adm.phase_margin_deg),
                                     (t.passivity_front, "passive up to", "Hz", passive)):
        fig, ax = _panel(2)
        ax.plot([p.requirement for p in front], [p.force_n if p.feasible else np.nan for p in front], "o-",
                label="least force asked (gaps: no design within the bounds)")
        ax.axhline(t.mouse_peak_force_n, **LIMIT_STYLE, label=f"the mouse's peak force, {t.mouse_peak_force_n:g} N")
        if spec is not None:
            ax.axvline(spec, color="k", ls="--", lw=1, label=f"this spec: {spec:g} {unit}")
        ax.set(xlabel=f"{label} ({unit})", ylabel="m_v a + b_v v (N)")
        _legend_below(fig, ax)
        figs.append(fig)
    return figs


def schedule_figure(points, mouse_peak_force_n: float):
    """The peak force the mouse feels against payload: each payload's own design and the one robust design."""
    fig, ax = _panel(2)
    m = [p.payload_kg for p in points]
    ax.plot(m, [p.force_felt_n for p in points], "o-", label="designed for that payload alone (Kp, Ki, m_v, b_v)")
    ax.plot(m, [p.robust_force_felt_n for p in points], "s--", label="the one robust design for the whole range")
    ax.axhline(mouse_peak_force_n, **LIMIT_STYLE, label=force_limit_label(mouse_peak_force_n,
                                                                          max(p.robust_force_felt_n for p in points)))
    ax.set(xlabel="payload (kg)", ylabel="peak force felt on the profile (N)")
    _legend_below(fig, ax)
    return fig
