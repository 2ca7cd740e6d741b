"""Typed results of the workflows (``design.workflows``) that views and the JSON writer read."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from design.spec.schema import Spec
from plant.diagnosis import Diagnosis
from plant.fitting import FitResult
from plant.frequency_response import MeasuredResponse
from plant.rational_fit import RationalFit
from plant.time_diagnosis import TimeDiagnosis
from plant.time_fit import TimeFitResult


@dataclass(frozen=True)
class PlantFromFit:
    """Where a design's plant came from: a fit result file, and the fitted effects left out."""

    file: str
    left_out: tuple[str, ...]


@dataclass(frozen=True)
class DesignProblem:
    """A validated spec, the folder its relative paths start from, and the fit its plant came from."""

    spec: Spec
    spec_dir: Path
    plant_from: PlantFromFit | None = None


@dataclass(frozen=True)
class FitOutcome:
    """A fit of a recording: frequency-domain (``FitResult``, with an optional rational fit) or time-domain
    (``TimeFitResult``)."""

    result: FitResult | TimeFitResult
    rational: RationalFit | None = None


@dataclass(frozen=True)
class DiagnosisOutcome:
    """A diagnosis of a recording: on its frequency response (``Diagnosis``, with the response) or on the
    time-domain force balance (``TimeDiagnosis``)."""

    diagnosis: Diagnosis | TimeDiagnosis
    measured: MeasuredResponse | None = None
