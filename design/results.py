"""Typed results of the workflows (``design.workflows``) that views and the JSON writer read.

May import: ``design.admittance``, ``design.synth``, ``design.spec``, ``design.loop``, ``design.problem``, ``plant``."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from design.loop.control_models import loop_models
from design.loop.controller import PI
from plant.errors import ParameterError
from plant.physics.effect_base import PADE_ORDER

if TYPE_CHECKING:
    from design.admittance.curves import AdmittanceCurves
    from design.admittance.dual import DualAdmittanceResult, RenderedByPosition
    from design.admittance.monte_carlo import AdmittanceMonteCarlo
    from design.admittance.schedule import SchedulePoint as AdmittanceSchedulePoint
    from design.admittance.synthesis import AdmittanceResult
    from design.loop.control_models import LoopModels
    from design.loop.curves import LoopCurves
    from design.loop.fitted import FittedCheck
    from design.problem import LoopProblem
    from design.spec.schema import Spec
    from design.synth.dual_curves import StructureCurves
    from design.synth.dual_design import DualDesign
    from design.synth.evaluation import Evaluation
    from design.synth.measured import MeasuredDesign
    from design.synth.monte_carlo import MonteCarloCheck
    from design.synth.pi import SynthesisResult
    from design.synth.planar import PlanarCheck, RotationDesign
    from design.synth.schedule import SchedulePoint
    from plant.data.frequency_response import MeasuredResponse
    from plant.diagnose.diagnosis import Diagnosis
    from plant.diagnose.time_diagnosis import TimeDiagnosis
    from plant.diagnose.two_rails import RailReading
    from plant.identify.fitting import FitResult
    from plant.identify.rational_fit import RationalFit
    from plant.identify.time_fit import TimeFitResult


@dataclass(frozen=True)
class FittedParameters:
    """The plant's parameters a fit result holds, estimated and fixed alike, by name ("damping_n_s_per_m",
    "delay.seconds"; SI units), and where they were read (``design.views.json.fitted_parameters_from_json``)."""

    values: Mapping[str, float]
    file: str


@dataclass(frozen=True)
class PlantFromFit:
    """Where a design's plant came from: a fit result file, the fitted effects left out, and the fitted values
    carried elsewhere than ``[plant]`` ("tilt_coupling.stiffness_n_m_per_rad -> dual_drive.yaw_...")."""

    file: str
    left_out: tuple[str, ...]
    carried: tuple[str, ...] = ()


@dataclass(frozen=True)
class DesignProblem:
    """A validated spec, the problem it poses, its file (relative paths start from its folder), and the
    fit its plant came from."""

    spec: Spec
    loop: LoopProblem
    spec_path: Path
    plant_from: PlantFromFit | None = None

    @property
    def spec_dir(self) -> Path:
        return self.spec_path.parent


@dataclass(frozen=True)
class FitOutcome:
    """A fit of a recording: frequency-domain (``FitResult``, with an optional rational fit) or time-domain
    (``TimeFitResult``)."""

    result: FitResult | TimeFitResult
    rational: RationalFit | None = None
    #: the frequency response a frequency-domain fit was made on, with the estimator's data checks (``notes``)
    measured: MeasuredResponse | None = None
    #: a time recording of both of Stage Y's rails: their joint reading (``plant.diagnose.two_rails``; the fit read
    #: Y2 at Y1's scale where a scale is claimed)
    rails: RailReading | None = None


@dataclass(frozen=True)
class DiagnosisOutcome:
    """A diagnosis of a recording: on its frequency response (``Diagnosis``, with the response) or on the
    time-domain force balance (``TimeDiagnosis``)."""

    diagnosis: Diagnosis | TimeDiagnosis
    measured: MeasuredResponse | None = None

    @property
    def time_domain(self) -> bool:
        """A diagnosis of the time-domain force balance (no frequency response was measured); telling it so
        keeps the frequency-domain views from importing the time-domain modules."""
        return self.measured is None


@dataclass(frozen=True)
class DesignOutcome:
    """What ``design.workflows.design`` found: the PI synthesis on the plant family (or the design from
    measured responses, ``measured``), its gain schedule when asked, and the admittance stage when the
    spec has one (on the PI gains when the synthesis succeeded, else on the spec's)."""

    problem: DesignProblem
    synthesis: SynthesisResult | None = None
    #: the data-driven design's result (``design.synth.measured``)
    measured: MeasuredDesign | None = None
    schedule: tuple[SchedulePoint, ...] | None = None
    admittance: AdmittanceResult | None = None
    #: the spec asks for an admittance stage but there were no PI gains to design it on
    admittance_skipped: bool = False
    #: the two-motor Stage Y's structures (``[dual_drive]``), designed instead of the one loop
    dual: DualDesign | None = None
    #: the admittance on the recommended structure (``[dual_drive]`` with ``[admittance]``)
    dual_admittance: DualAdmittanceResult | None = None
    #: the admittance designed per payload beside the robust one (``gantry synth --schedule``)
    admittance_schedule: tuple[AdmittanceSchedulePoint, ...] | None = None

    @property
    def status(self) -> str:
        """"optimal", "unbounded", "infeasible" or "mouse_cannot_drive" (a verified admittance design the
        declared mouse cannot drive on the declared profile); a failed admittance stage makes the design
        infeasible."""
        if self.measured is not None:
            return self.measured.status
        if self.dual is not None:
            if self.dual.status == "optimal" and self.dual_admittance is not None:
                return self.dual_admittance.status
            return self.dual.status
        if self.synthesis.status != "optimal":
            return self.synthesis.status
        if self.admittance is not None and self.admittance.status != "optimal":
            return self.admittance.status
        return self.synthesis.status

    @property
    def message(self) -> str:
        if self.measured is not None:
            return self.measured.message
        if self.dual is not None:
            if self.dual_admittance is not None:
                return f"{self.dual.message}; admittance: {self.dual_admittance.message}"
            return self.dual.message
        if self.synthesis.status == "optimal" and self.admittance is not None and self.admittance.status != "optimal":
            return f"admittance: {self.admittance.message}"
        return self.synthesis.message

    @property
    def verified(self) -> bool:
        """Every stage's result confirmed by its independent check."""
        if self.measured is not None:
            return self.measured.verified
        if self.dual is not None:
            return self.dual.recommended is not None and (
                self.dual_admittance is None or self.dual_admittance.status in ("optimal", "mouse_cannot_drive"))
        s = self.synthesis
        pi = bool(s.status == "optimal" and s.verification is not None and s.verification.verified)
        return pi and (self.admittance is None or self.admittance.verified)

    @property
    def controller(self) -> PI | None:
        """The designed PI (``design.loop.controller.PI``) when the PI design succeeded."""
        if self.measured is not None:
            return self.measured.controller
        if self.dual is not None:
            return None
        e = self.synthesis.evaluation
        return e.controller if self.synthesis.status == "optimal" and e is not None else None

    def loop_models(self, payload_kg: float | None = None, *, pade_order: int = PADE_ORDER) -> LoopModels:
        """P, C, L, S, T as python-control models (``design.loop.control_models``) at the designed gains, on
        the spec's plant at ``payload_kg`` (default: its nominal payload)."""

        if self.controller is None:
            raise ParameterError(f"no designed gains to build the loop from (status {self.status})")
        family = self.problem.loop.plant
        m = family.payload_kg.nominal_kg if payload_kg is None else payload_kg
        return loop_models(family.plant(m), self.controller, pade_order=pade_order)


@dataclass(frozen=True)
class ComparedRecording:
    """A recording compared with the model in a report: its path, response and diagnosis."""

    path: Path
    measured: MeasuredResponse
    diagnosis: Diagnosis
    #: the fitted parameters against the spec and the gains on the fitted plant
    check: FittedCheck


@dataclass(frozen=True)
class DesignOnPlants:
    """One pair of gains on the nominal plants (payload range at the nominal parameters), on the check
    scenarios of the uncertainty, and on the Monte Carlo draws."""

    name: str
    nominal: Evaluation
    robust: Evaluation
    monte_carlo: MonteCarloCheck


@dataclass(frozen=True)
class AdmittanceComparison:
    """The admittance design for the nominal parameters alone (same PI gains), and how it fares on the
    Monte Carlo draws over the uncertainty the robust design holds on."""

    nominal: AdmittanceResult
    monte_carlo: AdmittanceMonteCarlo | None


@dataclass(frozen=True)
class ReportContent:
    """Everything a design report shows, computed before it is drawn: the gains on the dense payloads
    beside the thesis gains, the loop's curves, the one Monte Carlo check, the design and admittance curves,
    and the recordings with their diagnoses."""

    problem: DesignProblem
    controller: PI
    gains_source: str
    evaluation: Evaluation
    thesis: Evaluation
    curves: LoopCurves
    design: DesignOutcome | None = None
    admittance_curves: AdmittanceCurves | None = None
    recordings: tuple[ComparedRecording, ...] = ()
    command: str = ""
    #: the reported gains on the Monte Carlo draws over the uncertainty (problems with uncertainty)
    monte_carlo_check: MonteCarloCheck | None = None
    #: the robust design beside the design for the nominal parameters alone (synthesised, uncertain problems)
    comparison: tuple[DesignOnPlants, ...] = ()
    #: the same for the admittance design
    admittance_comparison: AdmittanceComparison | None = None


@dataclass(frozen=True)
class DualReportContent:
    """Everything ``design.views.dual_report.dual_report`` draws of a two-motor Stage Y design: the outcome, each
    structure's map and steps, and the rendered admittance by carriage position when there is an admittance."""

    outcome: DesignOutcome
    structures: tuple[StructureCurves, ...]
    rendered: RenderedByPosition | None
    command: str = ""


@dataclass(frozen=True)
class PlanarOutcome:
    """What ``design.workflows.planar_design`` found: Stage X's design, Stage Y's structures, the rotation PI
    designed with Stage Y's loops closed, and the whole loop's check (``design.synth.planar``)."""

    spec_path: Path
    x: DesignOutcome
    y: DesignOutcome
    rotation: RotationDesign | None
    check: PlanarCheck | None
    #: the rotation channel's worst (GM dB, PM deg, bandwidth Hz) on the design plants with Stage Y's loops open
    rotation_alone: tuple[float, float, float] | None
    seconds: float

    @property
    def status(self) -> str:
        """"optimal" when every loop holds its requirements and the whole loop is verified; else "infeasible"."""
        ok = (self.x.status == "optimal" and self.y.status == "optimal" and self.rotation is not None
              and self.rotation.pi is not None and self.check is not None and self.check.holds)
        return "optimal" if ok else "infeasible"

    @property
    def message(self) -> str:
        if self.x.status != "optimal":
            return f"Stage X: {self.x.synthesis.message if self.x.synthesis else self.x.status}"
        if self.y.status != "optimal":
            return f"Stage Y: {self.y.dual.message}"
        if self.rotation is None or self.rotation.pi is None:
            return ("no rotation gains within rotation.controller hold rotation.requirements on every design plant "
                    "with Stage Y's loops closed")
        c = self.check
        if not c.holds:
            bad = next(w for w in (c.design, c.between, c.monte_carlo) if w is not None and not w.holds)
            return (f"the whole loop fails its requirements on {bad.n_failing} of {bad.n_plants} plants (least "
                    f"slack {bad.least_slack:.3g} at {bad.worst_at})")
        return (f"every loop holds its requirements on the whole machine: {c.coverage()}; least slack "
                f"{min(c.design.least_slack, c.between.least_slack):.3g} at {c.between.worst_at}")
