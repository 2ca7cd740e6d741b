"""The one vocabulary of a diagnosis, whatever the kind of data (a frequency response or a time record).

* Verdict: ``EXPLAINED`` when the selected model leaves only noise, else ``NOT_EXPLAINED``.
* ΔBIC of an effect tried as an addition: BIC of the model without it minus BIC with it, so a positive
  value is evidence for the effect; ΔBIC of an alternative model: its BIC minus the selected model's,
  so a positive value is evidence against the alternative.
* An effect is added, and an alternative ruled out, on ``ACCEPT_DELTA_BIC`` (Kass & Raftery 1995:
  "very strong" evidence); within ``TIE_DELTA_BIC`` two models are equally supported.
"""

from __future__ import annotations

import math

from plant.physics.effects import EFFECTS
from plant.story import Section, Table, unit_text

EXPLAINED = "explained"
NOT_EXPLAINED = "not_explained"
ACCEPT_DELTA_BIC = 10.0
TIE_DELTA_BIC = 2.0


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
