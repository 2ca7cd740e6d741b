"""Spec files (TOML) validated with pydantic; errors name the key path and the allowed range.

Shape (see ``specs/``)::

    name = "Stage X velocity loop"
    [plant]
    stage = "x"
    force_constant_n_per_a = 20.0
    damping_n_s_per_m = 440.0
    payload_kg = { min = 5.0, max = 40.0, points = 8, nominal = 35.0 }
    [plant.effects]
    delay = { seconds = 0.0005 }
    [controller]
    kp = { value = 236.0, min = 0.0, max = 10000.0 }   # A per (m/s)
    ki = { value = 47.0, min = 0.0, max = 1.0e7 }      # A per m
    [requirements]
    phase_margin_deg = 45.0
    gain_margin_db = 6.0
    [objective]
    maximise = "worst_case_bandwidth"
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from design.spec.admittance import AdmittanceSpec
from plant.effects import EFFECTS, make_effect
from plant.errors import GantryError, SpecError
from plant.models import Plant
from plant.parameters import THESIS


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


#: payloads of the range every design is checked at, beyond the points it was computed at
DENSE_PAYLOADS = 50


class PayloadRange(_Strict):
    """Payload (moving mass M of Eq. 3.15/3.16) range in kg."""

    min: float = Field(5.0, gt=0, le=1000)
    max: float = Field(40.0, gt=0, le=1000)
    points: int = Field(8, ge=1, le=10000)
    nominal: float | None = Field(None, gt=0, le=1000)

    @model_validator(mode="after")
    def _ordered(self):
        if self.max < self.min:
            raise ValueError(f"max ({self.max}) must be >= min ({self.min})")
        return self

    @property
    def nominal_kg(self) -> float:
        return self.nominal if self.nominal is not None else 0.5 * (self.min + self.max)

    def grid(self, points: int | None = None) -> np.ndarray:
        return np.linspace(self.min, self.max, points or self.points)

    def design_points(self) -> np.ndarray:
        """The payloads a design is computed at: the grid, or the one payload of a fixed one."""
        return self.grid() if self.max > self.min else np.array([self.min])

    def check_points(self) -> np.ndarray:
        """The ``DENSE_PAYLOADS`` payloads every design is checked at (one for a fixed payload)."""
        return np.linspace(self.min, self.max, DENSE_PAYLOADS) if self.max > self.min else np.array([self.min])


class Uncertainty(_Strict):
    """A parameter's range for Monte Carlo sweeps (uniform between min and max)."""

    min: float
    max: float

    @model_validator(mode="after")
    def _ordered(self):
        if self.max < self.min:
            raise ValueError(f"max ({self.max}) must be >= min ({self.min})")
        return self


class MeasuredPlant(_Strict):
    """A measured recording of the plant at one payload (data-driven design): a stepped sine, or a
    time-domain recording whose frequency response is estimated from its excitation."""

    payload_kg: float = Field(gt=0, le=1000)
    file: str
    #: column map for spreadsheets/TDMS ("frequency=2,current=3,velocity=6") or .mat files
    #: ("time=t,current=i,velocity=v")
    columns: str | None = None


class PlantSpec(_Strict):
    stage: Literal["x", "y"]
    force_constant_n_per_a: float = Field(THESIS["force_constant_n_per_a"].value, gt=0, le=1000)
    damping_n_s_per_m: float = Field(THESIS["damping_n_s_per_m"].value, gt=0, le=1e5)
    motor_length_m: float = Field(THESIS["motor_length_m"].value, gt=0, le=100)
    load_position_m: float = Field(THESIS["load_position_m"].value, gt=0, le=100)
    payload_kg: PayloadRange | float = PayloadRange()
    effects: dict[str, dict[str, float]] = Field(default_factory=dict)
    #: parameter ranges for Monte Carlo, keyed by parameter name (``damping_n_s_per_m``, ``delay.seconds``)
    uncertainty: dict[str, Uncertainty] = Field(default_factory=dict)
    #: measured responses, one recording per payload: synthesis then uses the data, not the model
    measured: list[MeasuredPlant] = Field(default_factory=list)

    @field_validator("payload_kg", mode="before")
    @classmethod
    def _payload(cls, v):
        if isinstance(v, (int, float)):
            return PayloadRange(min=v, max=v, points=1, nominal=v)
        return v

    @field_validator("effects")
    @classmethod
    def _effects(cls, v):
        for name, params in v.items():
            if name not in EFFECTS:
                raise ValueError(f"unknown effect {name!r}; known effects: {', '.join(EFFECTS)}")
            try:
                make_effect(name, **params)
            except GantryError as exc:
                raise ValueError(str(exc)) from None
        return v

    @model_validator(mode="after")
    def _geometry(self):
        if self.load_position_m >= self.motor_length_m:
            raise ValueError(f"load_position_m ({self.load_position_m}) must be < motor_length_m "
                             f"({self.motor_length_m})")
        return self

    def plant(self, payload_kg=None) -> Plant:
        """The plant at ``payload_kg`` (default: nominal); an array gives a batch."""
        effects = tuple(make_effect(name, **params) for name, params in self.effects.items())
        p = Plant(self.stage, mass_kg=self.payload_kg.nominal_kg, damping_n_s_per_m=self.damping_n_s_per_m,
                  force_constant_n_per_a=self.force_constant_n_per_a, motor_length_m=self.motor_length_m,
                  load_position_m=self.load_position_m, effects=effects)
        return p if payload_kg is None else p.with_payload(payload_kg)


class GainSpec(_Strict):
    """A controller gain: ``value`` (used for analysis), and bounds for synthesis."""

    value: float | None = Field(None, ge=0)
    min: float = Field(0.0, ge=0)
    max: float = Field(1.0e7, gt=0)

    @model_validator(mode="after")
    def _ordered(self):
        if self.max < self.min:
            raise ValueError(f"max ({self.max}) must be >= min ({self.min})")
        if self.value is not None and not self.min <= self.value <= self.max:
            raise ValueError(f"value ({self.value}) must lie within [min, max] = [{self.min}, {self.max}]")
        return self


class ControllerSpec(_Strict):
    kp: GainSpec = GainSpec(value=THESIS["kp"].value, max=1.0e4)
    ki: GainSpec = GainSpec(value=THESIS["ki"].value)

    @field_validator("kp", "ki", mode="before")
    @classmethod
    def _number(cls, v):
        if isinstance(v, (int, float)):
            return {"value": v, "min": 0.0, "max": max(1.0e7, float(v))}
        return v


class RequirementsSpec(_Strict):
    phase_margin_deg: float = Field(45.0, ge=0, lt=90)
    gain_margin_db: float = Field(6.0, ge=0, le=60)
    disk_margin: float | None = Field(None, gt=0, lt=2)
    peak_sensitivity: float | None = Field(None, gt=1)
    #: optional: synthesis is infeasible when the worst-case bandwidth cannot reach this
    min_bandwidth_hz: float | None = Field(None, gt=0, le=1e5)


class ObjectiveSpec(_Strict):
    maximise: Literal["worst_case_bandwidth"] = "worst_case_bandwidth"


class Spec(_Strict):
    name: str = "unnamed design"
    plant: PlantSpec
    controller: ControllerSpec = ControllerSpec()
    requirements: RequirementsSpec = RequirementsSpec()
    objective: ObjectiveSpec = ObjectiveSpec()
    admittance: AdmittanceSpec | None = None

    @model_validator(mode="after")
    def _admittance_needs_a_model(self):
        if self.admittance is not None and self.plant.measured:
            raise ValueError("admittance: needs the plant model (the mechanical mobility and responses at every "
                             "frequency), not plant.measured; design the PI gains from the data in a spec of their "
                             "own, then give them as controller.kp.value / controller.ki.value here")
        return self


def _key_path(loc) -> str:
    return ".".join(str(p) for p in loc if not (isinstance(p, str) and p in ("float", "PayloadRange")))


def parse_spec(data: dict, *, source: str = "spec") -> Spec:
    """Validate a spec mapping; ``SpecError`` names the first failing key path."""
    try:
        return Spec.model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        msg = err["msg"].removeprefix("Value error, ")
        if err["type"] == "extra_forbidden":
            msg = "unknown key (check the spelling; see specs/ for the allowed keys)"
        path = _key_path(err["loc"])
        raise SpecError(f"{source}: {path}: {msg}" if path else f"{source}: {msg}") from None


def load_spec(path: str | Path) -> Spec:
    """Read and validate a TOML spec file."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise SpecError(f"{path}: cannot read spec file ({exc.strerror})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{path}: not valid TOML: {exc}") from None
    return parse_spec(data, source=str(path))
