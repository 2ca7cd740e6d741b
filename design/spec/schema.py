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
from dataclasses import replace
from pathlib import Path
from typing import Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from design.problem import (
    AdmittanceProblem,
    ControllerBounds,
    DriveFilter,
    GainBounds,
    LoopProblem,
    Mouse,
    PayloadRange,
    PlantFamily,
    Range,
    Requirements,
    Uncertainty,
    Verification,
    with_filters,
)
from plant.effects import EFFECTS, make_effect
from plant.errors import GantryError, SpecError
from plant.models import Plant
from plant.parameters import THESIS
from plant.text_io import read_text

RANGE_KEYS_OF_MOUSE = tuple(k for k, f in Mouse.__dataclass_fields__.items() if f.type in (Range, "Range"))


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


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
            return PayloadRange.fixed(v)
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

    def family(self) -> PlantFamily:
        """The plant model at the nominal payload, with the payload range and the uncertainty."""
        nonlinear = [n for n in self.effects if not EFFECTS[n].linear]
        if nonlinear:
            raise SpecError(f"plant.effects.{nonlinear[0]}: designs and loop analyses need a linear plant, and "
                            f"{nonlinear[0]} is nonlinear; design on the linear model and check the effect with "
                            "gantry simulate")
        effects = tuple(make_effect(name, **params) for name, params in self.effects.items())
        nominal = Plant(self.stage, mass_kg=self.payload_kg.nominal_kg, damping_n_s_per_m=self.damping_n_s_per_m,
                        force_constant_n_per_a=self.force_constant_n_per_a, motor_length_m=self.motor_length_m,
                        load_position_m=self.load_position_m, effects=effects)
        return PlantFamily(nominal, self.payload_kg, dict(self.uncertainty))


class FilterRange(_Strict):
    """A filter parameter the synthesis chooses, between ``min`` and ``max``."""

    min: float = Field(ge=0)
    max: float = Field(ge=0)

    @model_validator(mode="after")
    def _ordered(self):
        if self.max < self.min:
            raise ValueError(f"max ({self.max}) must be >= min ({self.min})")
        return self


class FilterSpec(_Strict):
    """A biquad after the PI controller: every parameter a number (the drive's filter, kept) or a range
    (the synthesis chooses it). Defaults: low-pass Butterworth damping 1/sqrt 2; notch damping 0.3,
    depth 0.1."""

    kind: Literal["low_pass", "notch"]
    frequency_hz: float | FilterRange
    damping_ratio: float | FilterRange | None = None
    depth: float | FilterRange | None = None

    @model_validator(mode="after")
    def _valid(self):
        from design.loop.filters import KINDS

        if self.kind == "low_pass" and self.depth is not None:
            raise ValueError("depth is a notch parameter; a low-pass filter has none")
        cls = KINDS[self.kind]
        for end in ("min", "max"):
            values = {k: (getattr(v, end) if isinstance(v, FilterRange) else v)
                      for k, v in self.parameters().items()}
            try:
                cls(**values)
            except (GantryError, ValueError) as exc:
                raise ValueError(str(exc).replace(f"{cls.name}.", "")) from None
        return self

    def parameters(self) -> dict[str, float | FilterRange]:
        defaults = {"damping_ratio": 0.7071067811865476} if self.kind == "low_pass" else \
            {"damping_ratio": 0.3, "depth": 0.1}
        given = {"frequency_hz": self.frequency_hz, "damping_ratio": self.damping_ratio, "depth": self.depth}
        return {k: (given[k] if given.get(k) is not None else defaults[k]) for k in ("frequency_hz", *defaults)}

    def drive_filter(self) -> DriveFilter:
        p = self.parameters()
        return DriveFilter(self.kind, {k: float(v) for k, v in p.items() if not isinstance(v, FilterRange)},
                           {k: (v.min, v.max) for k, v in p.items() if isinstance(v, FilterRange)})


class ControllerSpec(_Strict):
    kp: GainBounds = GainBounds(value=THESIS["kp"].value, max=1.0e4)
    ki: GainBounds = GainBounds(value=THESIS["ki"].value)
    #: the drive's velocity-loop rate (Hz): designs are verified with its hold and computation delay and
    #: exported as discrete gains and filter coefficients
    loop_rate_hz: float | None = Field(None, gt=0, le=1e6)
    #: biquads after the PI controller (``[[controller.filters]]``)
    filters: list[FilterSpec] = Field(default_factory=list, max_length=2)

    @field_validator("kp", "ki", mode="before")
    @classmethod
    def _number(cls, v):
        if isinstance(v, (int, float)):
            return {"value": v, "min": 0.0, "max": max(1.0e7, float(v))}
        return v


class ObjectiveSpec(_Strict):
    maximise: Literal["worst_case_bandwidth"] = "worst_case_bandwidth"


class Spec(_Strict):
    name: str = "unnamed design"
    plant: PlantSpec
    controller: ControllerSpec = ControllerSpec()
    requirements: Requirements = Requirements()
    objective: ObjectiveSpec = ObjectiveSpec()
    admittance: AdmittanceProblem | None = None
    verification: Verification = Verification()

    @field_validator("admittance", mode="before")
    @classmethod
    def _one_number_ranges(cls, v):
        """``m_v = 2.0`` means the range [2, 2]; likewise the mouse's ranges."""
        def expand(section: dict, keys) -> dict:
            return {k: ({"min": x, "max": x} if k in keys and isinstance(x, (int, float)) and not isinstance(x, bool)
                        else x) for k, x in section.items()}
        if not isinstance(v, dict):
            return v
        v = expand(v, ("m_v", "b_v"))
        if isinstance(v.get("mouse"), dict):
            v["mouse"] = expand(v["mouse"], RANGE_KEYS_OF_MOUSE)
        return v

    @model_validator(mode="after")
    def _admittance_needs_a_model(self):
        if self.admittance is not None and self.plant.measured:
            raise ValueError("admittance: needs the plant model (the mechanical mobility and responses at every "
                             "frequency), not plant.measured; design the PI gains from the data in a spec of their "
                             "own, then give them as controller.kp.value / controller.ki.value here")
        return self

    def problem(self) -> LoopProblem:
        """The design problem the numerics solve (``design.problem``), free of the file format. With
        ``controller.loop_rate_hz`` the plant carries the ``sampling`` effect at that rate."""
        family = self.plant.family()
        rate = self.controller.loop_rate_hz
        if rate is not None:
            given = self.plant.effects.get("sampling")
            if given is not None and given.get("rate_hz") != rate:
                raise SpecError(f"controller.loop_rate_hz = {rate:g} and plant.effects.sampling disagree; give the "
                                "loop rate once (controller.loop_rate_hz adds the sampling effect)")
            for name, params in self.plant.effects.items():
                f = params.get("frequency_hz")
                if name == "sensor_filter" and f is not None and f >= rate / 2:
                    raise SpecError(f"plant.effects.{name}.frequency_hz = {f:g} Hz is at or above the Nyquist "
                                    f"frequency of controller.loop_rate_hz = {rate:g} Hz ({rate / 2:g} Hz): the "
                                    "drive cannot run that filter")
            if given is None:
                nominal = family.nominal
                family = replace(family, nominal=replace(nominal, effects=(*nominal.effects,
                                                                           make_effect("sampling", rate_hz=rate))))
        filters = tuple(f.drive_filter() for f in self.controller.filters)
        if len({f.kind for f in filters}) < len(filters):
            raise SpecError("controller.filters: at most one low_pass and one notch")
        for k, f in enumerate(filters):
            top = max(f.fixed.get("frequency_hz", 0.0), f.ranges.get("frequency_hz", (0.0, 0.0))[1])
            if rate is not None and top >= rate / 2:
                raise SpecError(f"controller.filters.{k}.frequency_hz reaches {top:g} Hz, at or above the Nyquist "
                                f"frequency of controller.loop_rate_hz = {rate:g} Hz ({rate / 2:g} Hz)")
        return LoopProblem(with_filters(family, filters), ControllerBounds(self.controller.kp, self.controller.ki,
                                                                            rate, filters),
                           self.requirements, self.admittance, self.verification)


def _key_path(loc) -> str:
    return ".".join(str(p) for p in loc if not (isinstance(p, str) and p in ("float", "PayloadRange")))


def _no_booleans(data, path: str = "") -> None:
    """No spec key takes true/false: a boolean where a number belongs is an error, not 1 or 0."""
    if isinstance(data, bool):
        raise SpecError(f"{path}: {str(data).lower()} is not a number")
    if isinstance(data, dict):
        for k, v in data.items():
            _no_booleans(v, f"{path}.{k}" if path else str(k))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            _no_booleans(v, f"{path}.{i}")


def parse_spec(data: dict, *, source: str = "spec") -> Spec:
    """Validate a spec mapping; ``SpecError`` names the first failing key path."""
    try:
        _no_booleans(data)
    except SpecError as exc:
        raise SpecError(f"{source}: {exc}") from None
    try:
        return Spec.model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        msg = err["msg"].removeprefix("Value error, ")
        if err["type"] in ("extra_forbidden", "unexpected_keyword_argument"):
            msg = "unknown key (check the spelling; see specs/ for the allowed keys)"
        path = _key_path(err["loc"])
        raise SpecError(f"{source}: {path}: {msg}" if path else f"{source}: {msg}") from None


def load_spec(path: str | Path) -> Spec:
    """Read and validate a TOML spec file."""
    path = Path(path)
    text = read_text(path, what="spec file")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{path}: not valid TOML: {exc}") from None
    return parse_spec(data, source=str(path))
