"""Admittance section of the design report: rendered vs virtual admittance, resistance, margins."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from design.admittance import _Loops
from design.html import Report, table
from design.plots import bode
from design.spec import Spec
from plant.grid import log_grid_rad_s


def add_admittance_section(report: Report, spec: Spec, synthesis: dict) -> None:
    adm = synthesis["admittance"]
    report.heading("Admittance (mouse following)")
    if adm.get("m_v") is None:
        report.text(f"Admittance synthesis: {adm.get('status')}: {adm.get('message')}", cls="summary")
        return
    m_v, b_v, kp, ki = adm["m_v"], adm["b_v"], adm["kp"], adm["ki"]
    a = spec.admittance
    report.text(f"m_v = {m_v:.4g} kg, b_v = {b_v:.4g} N·s/m (PI Kp = {kp:.4g}, Ki = {ki:.4g}). The mouse feels at "
                f"most {adm['peak_resistance_n']:.3g} N at {a.locomotion.peak_acceleration_m_per_s2:g} m/s² and "
                f"{a.locomotion.peak_speed_m_per_s:g} m/s. Rendered admittance follows 1/(m_v s + b_v) within 3 dB / "
                f"30° up to {adm['rendered_bandwidth_hz'] or float('nan'):.1f} Hz. Interaction loop (broken at the "
                f"force sensor): worst PM {adm['worst_phase_margin_deg']:.1f}°, worst GM "
                f"{adm['worst_gain_margin_db']:.1f} dB over payloads × mouse corners; binding: {adm['binding']}; "
                f"verified: {adm['verified']}.", cls="summary")
    rng = spec.plant.payload_kg
    w = log_grid_rad_s(0.1, 1000.0, 800)
    loops = _Loops(spec, kp, ki, sorted({rng.min, rng.nominal_kg, rng.max}), w)
    yv, H = loops.responses(m_v, b_v)
    fig = bode(w, [yv, *H], ["virtual 1/(m_v s + b_v)"] + [f"rendered, {m:g} kg" for m in loops.payload_kg],
               styles=["k--", "-", "-", "-"], title="Rendered admittance v/F against the virtual dynamics")
    report.figure(fig, "Velocity per sensed force: what the mouse feels, against what was asked for.")
    report.raw(table(["quantity", "value", "limit"], [
        ["peak motor force for the peak mouse force", f"{adm['peak_motor_force_n']:.3g} N",
         f"{a.motor_peak_force_n:g} N"],
        ["current per force-sensor step", f"{1e3 * adm['current_per_sensor_step_a']:.3g} mA",
         f"{1e3 * a.current_per_sensor_step_max_a:g} mA"],
        ["interaction phase margin (worst)", f"{adm['worst_phase_margin_deg']:.2f} deg", f"{a.phase_margin_deg:g} deg"],
        ["interaction gain margin (worst)", f"{adm['worst_gain_margin_db']:.2f} dB", f"{a.gain_margin_db:g} dB"],
    ]))
    fig, ax = plt.subplots(figsize=(7, 3.2))
    t = np.linspace(0, 1, 500)
    v = a.locomotion.peak_speed_m_per_s * np.sin(np.pi * t) ** 2
    acc = np.gradient(v, t)
    ax.plot(t, m_v * acc + b_v * v, label="m_v a + b_v v")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("resistance (N)")
    ax.set_title("Resistance felt over a 1 s run to peak speed and back", fontsize=10)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    report.figure(fig, "Resistance m_v·a + b_v·v for a smooth run (peak speed from the spec).")
