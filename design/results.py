"""Typed results of the workflows (``design.workflows``) that views and the JSON writer read."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from design.admittance.synthesis import AdmittanceResult
from design.spec.schema import Spec
from design.synth.pi import SynthesisResult
from design.synth.schedule import SchedulePoint
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


@dataclass(frozen=True)
class DesignOutcome:
    """What ``design.workflows.design`` found: the PI synthesis on the plant family (or the design from
    measured responses, ``measured``), its gain schedule when asked, and the admittance stage when the
    spec has one (on the PI gains when the synthesis succeeded, else on the spec's)."""

    problem: DesignProblem
    synthesis: SynthesisResult | None = None
    #: the data-driven design's result (``design.synth.measured``)
    measured: dict | None = None
    schedule: tuple[SchedulePoint, ...] | None = None
    admittance: AdmittanceResult | None = None
    #: the spec asks for an admittance stage but there were no PI gains to design it on
    admittance_skipped: bool = False
