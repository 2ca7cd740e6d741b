"""Views of a time-domain diagnosis: the ``--json`` contract and the HTML report with plots."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from design.views.html import Report, table
from plant.time_diagnosis import DELTA_BIC_STRONG, TimeDiagnosis
from plant.time_fit import bic


def time_diagnosis_to_dict(diag: TimeDiagnosis) -> dict:
    """Strict-JSON-ready dict with the keys of the stepped-sine diagnosis where they mean the same."""
    final = diag.final
    best_bic = min(s.bic for s in diag.steps)
    alternatives = [{"effects": list(c), "delta_bic": _bic(diag, c) - _bic(diag, diag.selected),
                     "rms_residual_n": f.rms_residual, "consistent_with_noise": f.explained}
                    for c, f in diag.models.items() if c != diag.selected
                    and _bic(diag, c) - _bic(diag, diag.selected) < DELTA_BIC_STRONG]
    return {
        "domain": "time",
        "steps": [{"effects": list(s.effects), "rms_residual_n": s.fit.rms_residual, "noise_ratio": s.fit.noise_ratio,
                   "relative_error_percent": s.fit.relative_error_percent, "bic": s.bic, "decision": s.decision,
                   "regimes": _regimes(s.fit)} for s in diag.steps],
        "ranking": [{"effect": c.effect, "delta_bic": c.delta_bic, "rms_residual_n": c.rms_residual_n}
                    for c in diag.ranking],
        "final_effects": list(diag.final_effects),
        "added_effects": list(diag.added),
        "parameters": {n: {"value": v, "stderr": final.stderr.get(n), "stderr_ols": final.stderr_ols.get(n),
                           "fixed": n not in final.stderr} for n, v in final.values.items()},
        "where_it_fails": diag.where_it_fails,
        "direction": {"forward_n": diag.direction.forward_n, "backward_n": diag.direction.backward_n,
                      "description": diag.direction.description},
        "notes": list(diag.notes),
        "flags": list(final.flags),
        "verdict": diag.verdict,
        "explanation": diag.explanation,
        "final_rms_residual_n": final.rms_residual,
        "final_noise_ratio": final.noise_ratio,
        "noise_rms_n": final.noise_rms,
        "n_effective": diag.n_effective,
        "best_bic": best_bic,
        "residual_peak_hz": diag.residual_peak_hz,
        "residual_peak_share": diag.residual_peak_share,
        "models_evaluated": len(diag.models),
        "alternatives": alternatives,
        "main_parameters": {e.name: {"name": f"{e.name}.{e.main_parameter}",
                                     "value": final.values[f"{e.name}.{e.main_parameter}"]}
                            for e in final.plant.effects},
    }


def _bic(diag: TimeDiagnosis, combo) -> float:
    return bic(diag.models[combo], diag.n_effective)


def _regimes(fit) -> list[dict]:
    return [{"name": r.name, "share": r.share, "rms_residual_n": r.rms_residual, "noise_ratio": r.noise_ratio,
             "significant": r.significant} for r in fit.regimes]


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
    """The HTML report of a time-domain diagnosis."""
    report = Report(title)
    base, final = diag.steps[0].fit, diag.final
    verdict = diag.explanation if diag.verdict == "explained" else f"Not explained. {diag.explanation}"
    report.text(f"{verdict} RMS residual {base.rms_residual:.3g} N → {final.rms_residual:.3g} N "
                f"(noise alone {final.noise_rms:.3g} N). Where the base model fails: {diag.where_it_fails}. "
                f"By direction: {diag.direction.description}.", cls="summary")
    report.figure(force_figure(diag), "Measured force (drive input × force constant, filtered and decimated as "
                                      "IDIM-LS does) against the base and the final model.")
    report.figure(friction_figure(diag), "Residual force against velocity: a step at v = 0 is Coulomb friction, "
                                         "a constant shift an offset.")
    report.figure(steps_figure(diag), "The residual by regime of motion, step by step (log scale).")
    report.heading("Steps", 3)
    report.raw(table(["model", "rms residual (N)", "× noise", "BIC", "decision"],
                     [[" + ".join(("base",) + s.effects), f"{s.fit.rms_residual:.4g}", f"{s.fit.noise_ratio:.3g}",
                       f"{s.bic:.1f}", s.decision] for s in diag.steps]))
    report.heading("Candidates tried on the base model", 3)
    report.raw(table(["effect", "ΔBIC", "rms residual (N)"],
                     [[c.effect, f"{c.delta_bic:+.1f}", f"{c.rms_residual_n:.4g}"] for c in diag.ranking]))
    report.heading("Fitted parameters", 3)
    params = final.plant.parameters()
    report.raw(table(["parameter", "value", "±1σ (Newey-West)", "±1σ (OLS)", "unit"],
                     [[n, f"{v:.6g}", f"{final.stderr[n]:.3g}" if n in final.stderr else "fixed",
                       f"{final.stderr_ols[n]:.3g}" if n in final.stderr_ols else "", params[n].unit]
                      for n, v in final.values.items()]))
    for note in diag.notes:
        report.text(f"Note: {note}")
    report.heading("Reproducibility", 3)
    report.pre(provenance)
    return report
