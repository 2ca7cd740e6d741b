"""Views of a time-domain diagnosis: the ``--json`` contract and the HTML report with plots."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from design.views.html import Report
from plant.diagnose.time_diagnosis import TimeDiagnosis


def force_figure(diag: TimeDiagnosis):
    """Measured force against the base and the final model, and both residuals, over time."""
    base, final = diag.steps[0].fit, diag.final
    fig, (ax, ax2) = plt.subplots(2, 1, sharex=True, figsize=(9, 5.5), layout="tight")
    ax.plot(base.time_s, base.measured, color="k", lw=1, label="measured K_f u")
    ax.plot(base.time_s, base.model, "--", lw=1, label=f"base model ({base.rms_residual:.3g} N rms)")
    ax.plot(final.time_s, final.model, lw=1, label=f"+ {', '.join(diag.selected) or 'no effect'} "
                                                   f"({final.rms_residual:.3g} N rms)")
    ax.set_ylabel("force (N)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax2.plot(base.time_s, base.residual, lw=0.8, label="base")
    ax2.plot(final.time_s, final.residual, lw=0.8, label="final")
    ax2.axhspan(-2 * final.noise_rms, 2 * final.noise_rms, color="0.8", label="±2σ noise")
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("residual (N)")
    ax2.legend(fontsize=8)
    ax2.grid(alpha=0.3)
    return fig


def friction_figure(diag: TimeDiagnosis):
    """Residual force against velocity for the base and the final model: the friction curve."""
    fig, ax = plt.subplots(figsize=(7, 3.8), layout="tight")
    for s in (diag.steps[0], diag.steps[-1]):
        ax.plot(s.fit.velocity_m_per_s, s.fit.residual, ".", ms=2, alpha=0.5,
                label=" + ".join(("base",) + s.effects))
    ax.set_xlabel("velocity (m/s)")
    ax.set_ylabel("residual force (N)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, markerscale=4)
    return fig


def steps_figure(diag: TimeDiagnosis):
    """RMS residual per regime of motion, step by step, against the noise level."""
    fig, ax = plt.subplots(figsize=(7, 3.4), layout="tight")
    names = [r.name for r in diag.steps[0].fit.regimes]
    x = np.arange(len(names))
    width = 0.8 / len(diag.steps)
    for k, s in enumerate(diag.steps):
        by = {r.name: r.rms_residual for r in s.fit.regimes}
        ax.bar(x + k * width, [by.get(n, np.nan) for n in names], width,
               label=" + ".join(("base",) + s.effects))
    ax.axhline(diag.final.noise_rms, color="k", ls=":", label="noise")
    ax.set_yscale("log")
    ax.set_xticks(x + width * (len(diag.steps) - 1) / 2, names)
    ax.set_ylabel("rms residual (N)")
    ax.legend(fontsize=8)
    ax.grid(True, axis="y", alpha=0.3)
    return fig


def time_diagnosis_report(diag: TimeDiagnosis, *, title: str, provenance: str) -> Report:
    """The HTML report of a time-domain diagnosis: its story (``TimeDiagnosis.story``) with the force, friction
    and residual-by-regime figures after the headline."""
    report = Report(title)
    story = diag.story()
    report.headline(story)
    report.figure(force_figure(diag), "Measured force (drive input × force constant, filtered and decimated as "
                                      "IDIM-LS does) against the base and the final model.")
    report.figure(friction_figure(diag), "Residual force against velocity: a step at v = 0 is Coulomb friction, "
                                         "a constant shift an offset.")
    report.figure(steps_figure(diag), "The residual by regime of motion, step by step (log scale).")
    report.sections(story)
    report.heading("Reproducibility", 3)
    report.pre(provenance)
    return report
