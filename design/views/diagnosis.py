"""Diagnosis for people: JSON (the contract of ``gantry diagnose --json``), figures and an HTML section."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from design.results import DiagnosisOutcome
from design.views.html import Report
from plant.bode import bode
from plant.data.frequency_response import MeasuredResponse
from plant.diagnose.diagnosis import Diagnosis

#: model curves of the comparison figure: this many points per decade over the measured band
MODEL_POINTS_PER_DECADE = 200


def model_curves(fit, data: MeasuredResponse) -> tuple[np.ndarray, np.ndarray]:
    """(w in rad/s, response per output) of a fitted model on a dense grid over the measured band, so that a
    resonance is drawn as the model has it; at the measured frequencies alone for a plant whose response
    depends on the excitation at each of them (friction, a current limit)."""
    from plant.identify.fitting import at_outputs, output_map

    w = data.w_rad_s
    if not fit.plant.linear:
        return w, fit.model_response
    dense = np.geomspace(w[0], w[-1], max(int(MODEL_POINTS_PER_DECADE * np.log10(w[-1] / w[0])), 50))
    return dense, at_outputs(fit.plant.frd_outputs(dense), output_map(fit.plant, data.output_names))


def output_title(name: str) -> str:
    """'velocity per current, (m/s)/A' for an output column such as velocity or velocity_m_per_s."""
    what = name.removesuffix("_m_per_s").replace("_", " ")
    return f"{what} per current, (m/s)/A"


def comparison_figure(diag: Diagnosis, data: MeasuredResponse):
    """Measured points (with their 2-sigma band, on magnitude and phase) against the base and the final model,
    drawn on a dense grid, per output."""
    n_out = len(data.output_names)
    fig, axes = plt.subplots(2, n_out, sharex=True, figsize=(6.5 * n_out, 5.5), layout="tight", squeeze=False)
    base, final = diag.steps[0].fit, diag.final
    (wb, gb), (wf, gf) = model_curves(base, data), model_curves(final, data)
    for k, name in enumerate(data.output_names):
        band = 2 * np.sqrt(np.asarray(data.variance[k]))
        bode(data.w_rad_s, [data.response[k]], ["measured (±2σ)"], axes=axes[:, k], bands=[band], styles=["o"],
             legend=False, unit="(m/s)/A")
        bode(wb, [gb[k]], [f"base model (χ²ᵣ {base.reduced_chi2:.3g})"], axes=axes[:, k], styles=["--"],
             legend=False, unit="(m/s)/A")
        bode(wf, [gf[k]], [f"+ {', '.join(diag.added) or 'no effect'} (χ²ᵣ {final.reduced_chi2:.3g})"],
             axes=axes[:, k], styles=["-"], title=output_title(name), unit="(m/s)/A")
    return fig


def residual_figure(diag: Diagnosis):
    """Normalised residual magnitude per frequency for every step (2 = the 2-sigma line)."""
    fig, ax = plt.subplots(figsize=(7, 3.4), layout="tight")
    for s in diag.steps:
        r = np.sqrt(np.mean(np.abs(s.fit.residuals) ** 2, axis=0) / 2)
        ax.loglog(s.fit.f_hz, np.maximum(r, 1e-3), "o-", ms=3, label=" + ".join(("base",) + s.effects) if s.effects
                  else "base")
    ax.axhline(2, color="k", ls=":", label="2σ")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("|residual| / σ")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def error_steps_figure(diag: Diagnosis):
    """The error falling step by step: reduced chi-square, RMS magnitude and phase error."""
    labels = ["base"] + [f"+ {s.effects[-1]}" for s in diag.steps[1:]]
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.2), layout="tight")
    x = np.arange(len(diag.steps))
    values = ([s.fit.reduced_chi2 for s in diag.steps], [s.rms_magnitude_error_db for s in diag.steps],
              [s.rms_phase_error_deg for s in diag.steps])
    for ax, v, title in zip(axes, values, ("reduced χ²", "RMS magnitude error (dB)", "RMS phase error (deg)")):
        ax.bar(x, v, color="#4477aa")
        ax.set_yscale("log")
        ax.set_xticks(x, labels, fontsize=8)
        ax.set_title(title, fontsize=10)
        ax.grid(True, axis="y", alpha=0.3)
    axes[0].axhline(1, color="k", ls=":")
    return fig


def add_diagnosis_section(report: Report, diag: Diagnosis, data: MeasuredResponse) -> None:
    """The diagnosis's story (``Diagnosis.story``: the verdict first) with its figures: measured against model,
    the falling error and the normalised residuals after the headline."""
    story = diag.story()
    report.headline(story)
    report.figure(comparison_figure(diag, data), "Measured response (points, shaded ±2σ) against the base model "
                                                 "and the final model.")
    report.figure(error_steps_figure(diag), "The error falling step by step (log scales; χ²ᵣ = 1 is noise).")
    report.figure(residual_figure(diag), "Residuals normalised by their uncertainty, per frequency and step.")
    report.sections(story)


def diagnosis_report(diag: Diagnosis, data: MeasuredResponse, *, title: str, provenance: str) -> Report:
    report = Report(title)
    add_diagnosis_section(report, diag, data)
    report.heading("Reproducibility", 3)
    report.pre(provenance)
    return report


def diagnosis_html(outcome: DiagnosisOutcome, *, title: str, provenance: str) -> Report:
    """The HTML report of a frequency-domain or a time-domain diagnosis."""
    if outcome.time_domain:
        from design.views.time_diagnosis import time_diagnosis_report

        return time_diagnosis_report(outcome.diagnosis, title=f"{title[:-1]}, time domain)", provenance=provenance)
    return diagnosis_report(outcome.diagnosis, outcome.measured, title=title, provenance=provenance)
