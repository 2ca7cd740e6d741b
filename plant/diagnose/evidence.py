"""The one vocabulary of a diagnosis, whatever the kind of data (a frequency response or a time record).

* Verdict: ``EXPLAINED`` when the selected model leaves only noise, else ``NOT_EXPLAINED``.
* ΔBIC of an effect tried as an addition: BIC of the model without it minus BIC with it, so a positive
  value is evidence for the effect; ΔBIC of an alternative model: its BIC minus the selected model's,
  so a positive value is evidence against the alternative.
* An effect is added, and an alternative ruled out, on ``ACCEPT_DELTA_BIC`` (Kass & Raftery 1995:
  "very strong" evidence); within ``TIE_DELTA_BIC`` two models are equally supported.
"""

from __future__ import annotations

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
