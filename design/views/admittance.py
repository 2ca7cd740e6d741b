"""Admittance section of the design report: what the mouse feels, the interaction-loop margins
against payload, the hardware limits and the resistance over the locomotion profile."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from design.admittance.model import (
    gantry_loop,
    rendered_admittance,
    virtual_impedance_frd,
)
from design.spec.schema import Spec
from design.views.html import Report, table
from design.views.plots import bode
from plant.grid import log_grid_rad_s


def add_admittance_section(report: Report, spec: Spec, synthesis: dict) -> None:
    adm = synthesis["admittance"]
    report.heading("Admittance (mouse following)")
    if adm.get("m_v") is None:
        report.text(f"Admittance synthesis: {adm.get('status')}: {adm.get('message')}", cls="summary")
        return
    m_v, b_v, kp, ki = adm["m_v"], adm["b_v"], adm["kp"], adm["ki"]
    a = spec.admittance
    loc, hw = a.locomotion, a.hardware
    bw = adm["rendered_bandwidth_hz"]
    report.text(f"m_v = {m_v:.4g} kg, b_v = {b_v:.4g} N·s/m with the PI gains Kp = {kp:.4g} A/(m/s), Ki = {ki:.4g} "
                f"A/m. Peak resistance on the locomotion profile ({loc.peak_acceleration_m_per_s2:g} m/s², "
                f"{loc.peak_speed_m_per_s:g} m/s): {adm['peak_resistance_n']:.3g} N (the mouse's peak force: "
                f"{a.mouse.peak_force_n:g} N). The rendered admittance follows 1/(m_v s + b_v) within 3 dB / 30° up "
                f"to {'—' if bw is None else f'{bw:.1f}'} Hz. Interaction loop (broken at the force-sensor signal): "
                f"worst PM {_num(adm['worst_phase_margin_deg'])}°, "
                f"worst GM {_num(adm['worst_gain_margin_db'])} dB over "
                f"{len(adm['per_payload'])} payloads × {len(adm['mouse_corners'])} mouse corners. Binding: "
                f"{adm['binding']['detail']}. Verified: {adm['verified']}.", cls="summary")
    rng = spec.plant.payload_kg
    w = log_grid_rad_s(0.1, 1000.0, 800)
    loop = gantry_loop(spec, w, sorted({rng.min, rng.nominal_kg, rng.max}), kp=kp, ki=ki)
    rendered = rendered_admittance(loop, m_v, b_v)
    fig = bode(w, [1.0 / virtual_impedance_frd(w, m_v, b_v), *rendered],
               ["virtual 1/(m_v s + b_v)"] + [f"rendered, {m:g} kg" for m in loop.payload_kg],
               styles=["k--", "-", "-", "-"], title="Rendered admittance v/F against the virtual dynamics")
    report.figure(fig, "Velocity per sensed force: what the mouse feels, against what was asked for.")
    report.figure(_per_payload_figure(adm), "Worst case over the mouse corners at each dense payload, with the "
                                            "limits (dashed).")
    report.raw(table(["quantity (worst over payloads)", "value", "limit"], [
        ["motor force for the peak mouse force", f"{adm['worst_motor_force_n']:.3g} N", f"{hw.motor_peak_force_n:g} N"],
        ["current per force-sensor step", f"{1e3 * adm['worst_sensor_current_a']:.3g} mA",
         f"{1e3 * hw.max_current_per_sensor_step_a:g} mA"],
        ["interaction phase margin", f"{_num(adm['worst_phase_margin_deg'], '.2f')} deg",
         f"{a.phase_margin_deg:g} deg"],
        ["interaction gain margin", f"{_num(adm['worst_gain_margin_db'], '.2f')} dB", f"{a.gain_margin_db:g} dB"],
    ]))
    report.figure(_profile_figure(m_v, b_v, loc.peak_speed_m_per_s, loc.peak_acceleration_m_per_s2),
                  "Resistance m_v·a + b_v·v over the trapezoidal locomotion profile of the spec.")


def _num(x, fmt: str = ".1f") -> str:
    """A margin for text: infinite margins are None in the JSON."""
    return "∞" if x is None else format(x, fmt)


def _per_payload_figure(adm: dict):
    rows = adm["per_payload"]
    lim = adm["limits"]
    m = [r["payload_kg"] for r in rows]
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.4), layout="tight")
    series = (("phase_margin_deg", "interaction PM (deg)", lim["phase_margin_deg"]),
              ("sensor_current_a", "current per sensor step (A)", lim["max_current_per_sensor_step_a"]),
              ("motor_force_n", "motor force for peak mouse force (N)", lim["motor_peak_force_n"]))
    for ax, (key, label, limit) in zip(axes, series):
        ax.plot(m, [np.nan if r[key] is None else r[key] for r in rows], "o-", ms=3)
        ax.axhline(limit, color="k", ls="--", lw=1)
        if key == "phase_margin_deg" and any(r[key] is None for r in rows):
            ax.set_title(label + "; gaps: ∞", fontsize=10)
        values = [np.nan if r[key] is None else r[key] for r in rows]
        ax.set_ylim(bottom=0.0, top=1.1 * max(limit, np.nanmax(values) if np.any(np.isfinite(values)) else limit))
        ax.set_xlabel("payload (kg)")
        ax.set_title(label, fontsize=10)
        ax.grid(True, alpha=0.3)
    return fig


def _profile_figure(m_v: float, b_v: float, v_pk: float, a_pk: float):
    """Accelerate at a_pk to v_pk, run, decelerate (times scaled to the profile)."""
    t_acc = v_pk / a_pk
    t = np.linspace(0.0, 4 * t_acc, 800)
    acc = np.where(t < t_acc, a_pk, np.where(t < 3 * t_acc, 0.0, -a_pk))
    v = np.clip(np.where(t < 3 * t_acc, a_pk * t, v_pk - a_pk * (t - 3 * t_acc)), 0.0, v_pk)
    fig, ax = plt.subplots(figsize=(7, 3.2), layout="tight")
    ax.plot(t, m_v * acc + b_v * v, label="m_v a + b_v v")
    ax.plot(t, b_v * v, "--", label="b_v v")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("resistance (N)")
    ax.set_title("Resistance felt over the locomotion profile", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return fig
