"""The one vocabulary of a diagnosis, whatever the kind of data (a frequency response or a time record).

* Verdict: ``EXPLAINED`` when the selected model leaves only noise, else ``NOT_EXPLAINED``.
* ΔBIC of an effect tried as an addition: BIC of the model without it minus BIC with it, so a positive
  value is evidence for the effect; ΔBIC of an alternative model: its BIC minus the selected model's,
  so a positive value is evidence against the alternative.
* An effect is added, and an alternative ruled out, on ``ACCEPT_DELTA_BIC`` (Kass & Raftery 1995:
  "very strong" evidence); within ``TIE_DELTA_BIC`` two models are equally supported.

A ranking that survives misfit (``rank_models``). BIC's likelihood assumes the noise model: on frequency data each
residual's variance is estimated from the recording, so its likelihood has the F distribution's heavy tail
(``plant.identify.fitting.minus_two_log_likelihood``), which grows only as the log of a large residual. That is
right when a few variances happen to be underestimated; it is wrong when every model of the search is rejected by
the noise test, because then the residual is model error everywhere, and a log-compressed likelihood ranks a model
that concentrates a huge error in a few lines above one with a 6x smaller chi^2 spread over many. When no model is
consistent with the noise the search therefore ranks by the quasi-likelihood BIC, QBIC = chi^2 / (c e) + k ln n: the
Gaussian chi^2 (each residual divided by its expectation e, the mean of nu / (nu - 2)) scaled by the
over-dispersion c, the least reduced chi^2 / e of the search's models (the best model's misfit taken as inflated
noise, as QAIC takes the global model's; Lebreton et al. 1992, Burnham & Anderson 2002 section 2.5), and the same
k ln n penalty; differences keep BIC's scale, so ``ACCEPT_DELTA_BIC`` reads the same. With c = 1 (a model
consistent with the noise exists) the ranking is BIC.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from plant.physics.effects import EFFECTS
from plant.story import Section, Table, unit_text

EXPLAINED = "explained"
NOT_EXPLAINED = "not_explained"
ACCEPT_DELTA_BIC = 10.0
TIE_DELTA_BIC = 2.0


@dataclass(frozen=True)
class Ranking:
    """The criterion a search ranks its models by (module doc): ``BIC``, or ``QBIC`` with the over-dispersion
    ``overdispersion`` when no model is consistent with the noise; ``score`` by model."""

    criterion: str
    overdispersion: float
    score: dict

    @property
    def delta_label(self) -> str:
        """'ΔBIC' or 'ΔQBIC'."""
        return f"Δ{self.criterion}"


def rank_models(fits: Mapping, adequate: Mapping) -> Ranking:
    """BIC of each fit (``PlantFit``) when one of them is ``adequate`` (consistent with the noise), else QBIC with the
    over-dispersion of the best (module doc)."""
    if any(adequate.values()):
        return Ranking("BIC", 1.0, {k: f.bic for k, f in fits.items()})
    fitted = [f for f in fits.values() if f.dof > 0]
    c = max(1.0, min((f.chi2 / (f.dof * f.expected_reduced_chi2) for f in fitted), default=1.0))
    return Ranking("QBIC", c, {k: f.chi2 / (c * f.expected_reduced_chi2) + f.n_params * math.log(f.n_data)
                               for k, f in fits.items()})


def verdict(explained: bool) -> str:
    """``EXPLAINED`` or ``NOT_EXPLAINED``."""
    return EXPLAINED if explained else NOT_EXPLAINED


def addition_delta_bic(bic_without: float, bic_with: float) -> float:
    """ΔBIC of an added effect: positive when the data favour adding it."""
    return bic_without - bic_with


def model_label(effects, base=()) -> str:
    """'base + delay + resonance': the base model and the effects added to it (those of ``base`` are its own)."""
    return " + ".join(("base", *(e for e in effects if e not in base)))


def model_section(verdict_: str, lines) -> Section:
    """The model a diagnosis reports: "Selected model" when it explains the data, else "Best model (not
    explained)", with ``lines`` (its effects, its modes)."""
    return Section("Selected model" if verdict_ == EXPLAINED else "Best model (not explained)", tuple(lines))


def fitted_sentence(fit) -> str:
    """The headline's fitted values of ``fit`` (a ``PlantFit``): every free base parameter and each effect's main
    parameter, with ±1σ and units ("mass_kg = 27.15 ± 0.0046 kg, ..., rail_scale.y2_scale = 1.03 ± 0.00023")."""
    params = fit.plant.parameters()
    names = [n for n in fit.free if "." not in n] + [f"{e.name}.{e.main_parameter}" for e in fit.plant.effects
                                                    if f"{e.name}.{e.main_parameter}" in fit.free]
    parts = []
    for n in names:
        unit = unit_text(params[n].unit)
        err = fit.stderr.get(n, math.nan)
        parts.append(f"{n} = {fit.values[n]:.4g}" + (f" ± {err:.2g}" if math.isfinite(err) else "")
                     + (f" {unit}" if unit and unit != "1" else ""))
    return ", ".join(parts)


def delta_bic_text(value: float) -> str:
    """A ΔBIC cell: signed to one decimal, empty where the model was not fitted (NaN)."""
    return "" if math.isnan(value) else f"{value:+.1f}"


def parameter_section(fit, *, ols: bool = False) -> Section:
    """The fitted parameters of ``fit`` (a ``PlantFit``): value, ±1σ and unit; a parameter without an error is
    "fixed", or "set from the recording" when it shapes a time-domain effect's signal (a ripple's pitch, a
    profile's span: ``search_fixed``). ``ols``: a column of the ordinary least-squares errors beside the
    Newey-West ones (time-domain fits)."""
    params = fit.plant.parameters()
    rows = []
    for name, value in fit.values.items():
        effect, _, field = name.partition(".")
        cls = EFFECTS.get(effect) if field else None
        held = "set from the recording" if cls and cls.time_domain and field in cls.search_fixed else "fixed"
        err = f"{fit.stderr[name]:.3g}" if name in fit.stderr else held
        extra = ((f"{fit.stderr_ols[name]:.3g}" if name in fit.stderr_ols else "",) if ols else ())
        rows.append((name, f"{value:.6g}", err, *extra, unit_text(params[name].unit)))
    columns = ("parameter", "value", "±1σ (Newey-West)" if ols else "±1σ", *(("±1σ (OLS)",) if ols else ()), "unit")
    return Section("Fitted parameters", table=Table(columns, tuple(rows), frozenset({0, len(columns) - 1})))
