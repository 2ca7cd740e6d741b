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

import dataclasses
import difflib
import tomllib
import types
import typing
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from design.problem import (
    PAYLOAD_MAX_KG,
    PAYLOAD_MIN_KG,
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
    StanceRange,
    Uncertainty,
    VerificationPlan,
    with_filters,
)
from design.spec.bundled import read_spec_text
from design.spec.dual_drive import DualDriveSpec, ParameterRange
from plant.data.table import CsvTable
from plant.errors import DataError, GantryError, SpecError
from plant.physics.drive_filters import KINDS
from plant.physics.effects import EFFECTS, make_effect
from plant.physics.models import BASE_BOUNDS, Plant
from plant.physics.parameters import THESIS

RANGE_KEYS_OF_MOUSE = tuple(k for k, f in Mouse.__dataclass_fields__.items()
                            if f.type in (Range, "Range", StanceRange, "StanceRange"))


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class MeasuredPlant(_Strict):
    """A measured recording of the plant at one payload (data-driven design): a stepped sine, or a
    time-domain recording whose frequency response is estimated from its excitation."""

    payload_kg: float = Field(ge=PAYLOAD_MIN_KG, le=PAYLOAD_MAX_KG)
    file: str
    #: column map for spreadsheets/TDMS ("frequency=2,current=3,velocity=6") or .mat files
    #: ("time=t,current=i,velocity=v")
    columns: str | None = None


def _limits(name: str):
    """``Field`` bounds of a base plant parameter: its ``BASE_BOUNDS``, the limits of every command."""
    lo, hi, _ = BASE_BOUNDS[name]
    return Field(THESIS[name].value, ge=lo, le=hi)


class PlantSpec(_Strict):
    stage: Literal["x", "y"]
    force_constant_n_per_a: float = _limits("force_constant_n_per_a")
    damping_n_s_per_m: float = _limits("damping_n_s_per_m")
    motor_length_m: float = Field(THESIS["motor_length_m"].value, gt=0, le=100)
    load_position_m: float = Field(THESIS["load_position_m"].value, gt=0, le=100)
    #: a range, or one payload (a range of one point)
    payload_kg: PayloadRange | Annotated[float, Field(ge=PAYLOAD_MIN_KG, le=PAYLOAD_MAX_KG)] = PayloadRange()
    effects: dict[str, dict[str, float]] = Field(default_factory=dict)
    #: parameter ranges for Monte Carlo, keyed by parameter name (``damping_n_s_per_m``, ``delay.seconds``)
    uncertainty: dict[str, Uncertainty] = Field(default_factory=dict)
    #: measured responses, one recording per payload: synthesis then uses the data, not the model
    measured: list[MeasuredPlant] = Field(default_factory=list)

    @field_validator("payload_kg")
    @classmethod
    def _payload(cls, v):
        return PayloadRange.fixed(v) if isinstance(v, (int, float)) else v

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

    @model_validator(mode="after")
    def _effects_fit_the_stage(self):
        """The effects together on this stage (one that needs another, or a Stage Y effect on Stage X, is refused
        here rather than by the first command that builds the plant)."""
        effects = tuple(make_effect(name, **params) for name, params in self.effects.items())
        nonlinear = any(not EFFECTS[n].linear for n in self.effects)
        try:
            Plant(self.stage, effects=effects, **self.base_values(), excitation_current_a=1.0 if nonlinear else None)
        except GantryError as exc:
            raise ValueError(f"effects: {exc}") from None
        return self

    def family(self) -> PlantFamily:
        """The plant model at the nominal payload, with the payload range and the uncertainty."""
        nonlinear = [n for n in self.effects if not EFFECTS[n].linear]
        if nonlinear:
            raise SpecError(f"plant.effects.{nonlinear[0]}: designs and loop analyses need a linear plant, and "
                            f"{nonlinear[0]} is nonlinear; design on the linear model and check the effect with "
                            "gantry simulate")
        effects = tuple(make_effect(name, **params) for name, params in self.effects.items())
        nominal = Plant(self.stage, effects=effects, **self.base_values())
        return PlantFamily(nominal, self.payload_kg, dict(self.uncertainty))

    def base_values(self) -> dict[str, float]:
        """The base parameters of the plant at the nominal payload, as ``Plant`` takes them (SI)."""
        return {"mass_kg": self.payload_kg.nominal_kg, "damping_n_s_per_m": self.damping_n_s_per_m,
                "force_constant_n_per_a": self.force_constant_n_per_a, "motor_length_m": self.motor_length_m,
                "load_position_m": self.load_position_m}


class FilterRange(ParameterRange):
    """A filter parameter the synthesis chooses, between ``min`` and ``max``."""

    min: float = Field(ge=0)
    max: float = Field(ge=0)


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
    #: "required": a synthesised design has ki > 0, so the loop tracks a constant velocity without error;
    #: "optional" admits a P-only design (ki = 0), whose steady-state velocity error 1 - |T(0)| is reported
    integral: Literal["required", "optional"] = "required"

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
    verification: VerificationPlan = VerificationPlan()
    #: Stage Y as two motors, and the loop structures to design (``design.spec.dual_drive``)
    dual_drive: DualDriveSpec | None = None

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
    def _dual_drive_is_stage_y(self):
        d = self.dual_drive
        if d is None:
            return self
        if self.plant.stage != "y":
            raise ValueError("dual_drive: the two-motor model is Stage Y's; set plant.stage = \"y\"")
        if self.plant.measured:
            raise ValueError("dual_drive: designs on the model, not plant.measured")
        try:
            model = self.dual_model()
        except (GantryError, ValueError) as exc:
            raise ValueError(f"dual_drive: {exc}") from None
        for name, r in d.uncertainty.items():
            effect, dot, param = name.partition(".")
            if dot and effect not in self.plant.effects:
                raise ValueError(f"dual_drive.uncertainty.{name}: the plant has no effect {effect} (plant.effects)")
            for value in (r.min, r.max):
                try:
                    if dot:
                        make_effect(effect, **{**self.plant.effects[effect], param: value})
                    else:
                        model.with_values(**{name: value})
                except (GantryError, TypeError, ValueError) as exc:
                    raise ValueError(f"dual_drive.uncertainty.{name}: {exc}") from None
        return self

    def dual_model(self):
        """The two-motor model of ``[dual_drive]`` with the plant's rail damping, force constant and drive
        effects (``design.spec.dual_drive``), and the drive's filters (``[[controller.filters]]``, kept as they
        are: a filter after every channel's PI is, every channel alike, one in series with each motor)."""
        p = self.plant
        effects = tuple(make_effect(name, **params) for name, params in p.effects.items())
        for k, f in enumerate(self.controller.filters):
            spec = f.drive_filter()
            if spec.designed:
                raise ValueError(f"controller.filters.{k}: a two-motor design keeps the drive's filters as they "
                                 "are; give numbers, not ranges")
            effects += (KINDS[spec.kind](**spec.fixed),)
        return self.dual_drive.model(rail_separation_m=p.motor_length_m, damping_n_s_per_m=p.damping_n_s_per_m,
                                     force_constant_n_per_a=p.force_constant_n_per_a, effects=effects)

    @model_validator(mode="after")
    def _admittance_needs_a_model(self):
        if self.admittance is not None and self.plant.measured:
            raise ValueError("admittance: needs the plant model (the mechanical mobility and responses at every "
                             "frequency), not plant.measured; design the PI gains from the data in a spec of their "
                             "own, then give them as controller.kp.value / controller.ki.value here")
        return self

    @model_validator(mode="after")
    def _force_record_needs_a_sampled_one_motor_law(self):
        adm = self.admittance
        if adm is None or adm.locomotion.force_record is None:
            return self
        if self.dual_drive is not None:
            raise ValueError("admittance.locomotion.force_record: the recorded force is checked on Stage X's one "
                             "motor; the two-motor Stage Y is judged on the locomotion profile")
        if adm.rig.update_rate_hz is None:
            raise ValueError("admittance.locomotion.force_record: the motor on a recorded force is computed for a "
                             "sampled law: give admittance.rig.update_rate_hz")
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
                                                                            rate, filters,
                                                                            self.controller.integral == "required"),
                           self.requirements, self.admittance, self.verification)


#: pydantic's bound errors and the comparison each states
_BOUNDS = {"greater_than": ">", "greater_than_equal": ">=", "less_than": "<", "less_than_equal": "<="}
#: pydantic's errors for a value of the wrong kind: a union reports one per member it tried
_WRONG_KIND = ("dataclass_type", "model_type", "dict_type", "float_type", "int_type", "float_parsing",
               "int_parsing", "string_type", "list_type", "literal_error", "none_required")


#: the phrase for each wrong-kind error when a union's members all refuse a value
_KIND_NAMES = {"dataclass_type": "a table", "model_type": "a table", "dict_type": "a table",
               "float_type": "a number", "float_parsing": "a number", "int_type": "an integer",
               "int_parsing": "an integer", "string_type": "a string", "list_type": "a list"}


def _key_path(loc, data) -> str:
    """The key path of an error location as the file writes it: the keys and list indices found in
    ``data``, without the union members pydantic adds (``PayloadRange``, ``constrained-float``)."""
    keys, node = [], data
    for part in loc:
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node):
            node = node[part]
        else:
            continue
        keys.append(str(part))
    return ".".join(keys)


def _message(exc: ValidationError, data: dict) -> str:
    """One line for a validation error: the key path and what is wrong, a bound with the value as written.
    Of a union's errors, a violated bound or rule wins over the members the value is not."""
    errors = exc.errors()
    first = _key_path(errors[0]["loc"], data)
    same = [e for e in errors if _within(_key_path(e["loc"], data), first)]
    err = next((e for e in same if e["type"] not in _WRONG_KIND), errors[0])
    path = _key_path(err["loc"], data)
    if err["type"] == "missing":
        key = str(err["loc"][-1])
        return f"{path + '.' if path else ''}{key}: required, and missing from the spec"
    if err["type"] in ("extra_forbidden", "unexpected_keyword_argument"):
        msg = "unknown key"
    elif err["type"] in _BOUNDS and err.get("ctx"):
        limit = next(iter(err["ctx"].values()))
        return f"{path} = {err['input']!r}: must be {_BOUNDS[err['type']]} {limit:g}"
    elif err["type"] in _WRONG_KIND and len(kinds := _kinds(same)) > 1:
        return f"{path} = {err['input']!r}: must be {' or '.join(kinds)}"
    else:
        msg = err["msg"].removeprefix("Value error, ")
    return f"{path}: {msg}" if path else msg


def _kinds(errors) -> list[str]:
    """What a value of the wrong kind should have been, one phrase per member of the union it failed."""
    kinds = []
    for e in errors:
        kind = _KIND_NAMES.get(e["type"])
        if kind and kind not in kinds:
            kinds.append(kind)
    return kinds


def _within(a: str, b: str) -> bool:
    """One key path lies within the other (a union's members report at and below the key)."""
    return a == b or a.startswith(b + ".") or b.startswith(a + ".")


def _members(tp) -> tuple:
    """The types ``tp`` stands for: itself, or the members of a union, without ``Annotated``."""
    origin = typing.get_origin(tp)
    if origin is Annotated:
        return _members(typing.get_args(tp)[0])
    if origin in (typing.Union, types.UnionType):
        return tuple(m for arg in typing.get_args(tp) for m in _members(arg))
    return (tp,)


def _keys(tp) -> dict[str, object] | None:
    """The keys a table of type ``tp`` takes and the type of each (None: ``tp`` is no record)."""
    for member in _members(tp):
        if isinstance(member, type) and issubclass(member, BaseModel):
            return {(f.alias or name): f.annotation for name, f in member.model_fields.items()}
        if dataclasses.is_dataclass(member):
            hints = typing.get_type_hints(member, include_extras=True)
            return {f.name: hints[f.name] for f in dataclasses.fields(member) if f.init}
    return None


def _unknown(parent: str, key: str, known, hint: str = "") -> str:
    """``parent.key: unknown key (did you mean parent.close?)``, or the keys ``parent`` takes (and ``hint``)
    when none is close."""
    where = f"{parent}." if parent else ""
    close = difflib.get_close_matches(key, list(known), n=1, cutoff=0.6)
    if close:
        return f"{where}{key}: unknown key (did you mean {where}{close[0]}?)"
    return f"{where}{key}: unknown key; {parent or 'the top level'} takes {', '.join(known)}{hint}"


def _unknown_key(data: dict, tp, path: str = "") -> str | None:
    """The first key in ``data`` (in file order, depth first) that its table of type ``tp`` does not
    take, as ``_unknown`` words it; None when every key is known. ``plant.effects`` takes the effects
    and their parameters."""
    known = _keys(tp)
    if known is None:
        return None
    for key, value in data.items():
        where = f"{path}.{key}" if path else str(key)
        if key not in known:
            return _unknown(path, key, known)
        found = _unknown_effect_key(value, where) if where == "plant.effects" else _unknown_below(value, known[key],
                                                                                                  where)
        if found:
            return found
    return None


def _unknown_below(value, tp, path: str) -> str | None:
    """``_unknown_key`` of a table or of the tables in a list or a mapping of type ``tp``."""
    for member in _members(tp):
        origin, args = typing.get_origin(member), typing.get_args(member)
        if isinstance(value, list) and origin is list:
            return next(filter(None, (_unknown_below(v, args[0], f"{path}.{i}") for i, v in enumerate(value))), None)
        if isinstance(value, dict) and origin is dict:
            return next(filter(None, (_unknown_below(v, args[1], f"{path}.{k}") for k, v in value.items())), None)
    if isinstance(value, dict):
        return _unknown_key(value, tp, path)
    return None


def _unknown_effect_key(effects, path: str) -> str | None:
    """``_unknown_key`` of ``plant.effects``: the effect names and each effect's parameters."""
    if not isinstance(effects, dict):
        return None
    for name, params in effects.items():
        if name not in EFFECTS:
            return _unknown(path, name, EFFECTS)
        for param in params if isinstance(params, dict) else ():
            if param not in EFFECTS[name].bounds:
                return _unknown(f"{path}.{name}", param, EFFECTS[name].bounds)
    return None


def _outside(key: str, value: float, bounds: tuple[float, float, str]) -> SpecError | None:
    lo, hi, unit = bounds
    if lo <= value <= hi:
        return None
    return SpecError(f"{key} = {value!r}: outside its limits [{lo:g}, {hi:g}]{' ' + unit if unit else ''}")


def _check_limits(spec: Spec) -> None:
    """Every plant parameter a spec gives, within the bounds of ``Plant.parameters`` (``BASE_BOUNDS`` and
    the effects' ``bounds``: what fits, simulations and every design command check): effect parameters,
    the drive filters, the loop rate's sampling and the uncertainty ranges, named by their keys."""

    plant = spec.plant
    problems = [_outside(f"plant.effects.{name}.{param}", value, EFFECTS[name].bounds[param])
                for name, params in plant.effects.items() for param, value in params.items()]
    rate = spec.controller.loop_rate_hz
    if rate is not None:
        problems.append(_outside("controller.loop_rate_hz", rate, EFFECTS["sampling"].bounds["rate_hz"]))
    for k, f in enumerate(spec.controller.filters):
        bounds = KINDS[f.kind].bounds
        for param, v in f.parameters().items():
            ends = {"": v} if not isinstance(v, FilterRange) else {".min": v.min, ".max": v.max}
            problems += [_outside(f"controller.filters.{k}.{param}{end}", x, bounds[param]) for end, x in ends.items()]
    effects = {name: EFFECTS[name] for name in plant.effects}
    if rate is not None:
        effects["sampling"] = EFFECTS["sampling"]
    effects.update({KINDS[f.kind].name: KINDS[f.kind] for f in spec.controller.filters})
    known = {n: b for n, b in BASE_BOUNDS.items() if n != "mass_kg"}
    known.update({f"{name}.{p}": b for name, cls in effects.items() for p, b in cls.bounds.items()})
    for name, rng in plant.uncertainty.items():
        key = f"plant.uncertainty.{name}"
        if name == "mass_kg":
            raise SpecError(f"{key}: the payload is swept (plant.payload_kg or --payload), it cannot also be uncertain")
        if name not in known:
            raise SpecError(_unknown("plant.uncertainty", name, known, " (an effect's parameters need the effect under "
                                                                     "plant.effects)"))
        problems += [_outside(f"{key}.{end}", getattr(rng, end), known[name]) for end in ("min", "max")]
    for problem in problems:
        if problem is not None:
            raise problem


#: the spec keys that take true / false
BOOLEAN_KEYS = ("admittance.codesign", "admittance.mouse.floating")


def _booleans(data) -> None:
    """The ``BOOLEAN_KEYS`` take true or false only (pydantic would read "yes" or 1 as true)."""
    for key in BOOLEAN_KEYS:
        node = data
        for part in key.split("."):
            node = node.get(part) if isinstance(node, dict) else None
        if node is not None and not isinstance(node, bool):
            raise SpecError(f"{key}: must be true or false, got {node!r}")


def _no_booleans(data, path: str = "") -> None:
    """Only ``BOOLEAN_KEYS`` take true/false: a boolean where a number belongs is an error, not 1 or 0."""
    if isinstance(data, bool) and path not in BOOLEAN_KEYS:
        raise SpecError(f"{path}: {str(data).lower()} is not a number")
    if isinstance(data, dict):
        for k, v in data.items():
            _no_booleans(v, f"{path}.{k}" if path else str(k))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            _no_booleans(v, f"{path}.{i}")


def parse_spec(data: dict, *, source: str = "spec", folder: str | Path = ".") -> Spec:
    """Validate a spec mapping; ``SpecError`` names the first failing key path (an unknown key first, with
    the closest known one) and, for a value out of bounds, the value as written. Files the spec names are
    relative to ``folder``."""
    try:
        if not data:
            raise SpecError("the spec is empty: it needs at least a [plant] table with stage = \"x\" or \"y\" "
                            "(see specs/stage_x_synth.toml)")
        _check_nesting(data)
        data = _with_force_record(data, Path(folder))
        _no_booleans(data)
        _booleans(data)
        unknown = _unknown_key(data, Spec)
        if unknown:
            raise SpecError(unknown)
        try:
            spec = Spec.model_validate(data)
        except ValidationError as exc:
            raise SpecError(_message(exc, data)) from None
        _check_limits(spec)
    except SpecError as exc:
        raise SpecError(f"{source}: {exc}") from None
    return spec


def _with_force_record(data: dict, folder: Path) -> dict:
    """``data`` with ``admittance.locomotion.force_record`` read: a file name (relative to ``folder``) becomes the
    record's columns ``time_s`` and ``force_n``; an inline table is marked "inline"."""
    adm = data.get("admittance")
    loc = adm.get("locomotion") if isinstance(adm, dict) else None
    record = loc.get("force_record") if isinstance(loc, dict) else None
    if isinstance(record, dict) and "file" not in record:
        record = {"file": "inline", **record}
    elif isinstance(record, str):
        path = folder / record
        try:
            table = CsvTable.read(path)
            columns = table.numbers(["time_s", "force_n"])
        except DataError as exc:
            raise SpecError(f"admittance.locomotion.force_record: {exc}") from None
        bad = next((k for k in range(columns["time_s"].size - 1)
                    if not columns["time_s"][k + 1] > columns["time_s"][k]), None)
        if bad is not None:
            raise SpecError(f"admittance.locomotion.force_record: {path}: row {table.rows[bad + 1]}, column 'time_s': "
                            f"{columns['time_s'][bad + 1]:g} does not follow {columns['time_s'][bad]:g} (time must "
                            "increase)")
        record = {"file": record, "time_s": tuple(map(float, columns["time_s"])),
                  "force_n": tuple(map(float, columns["force_n"]))}
    else:
        return data
    return {**data, "admittance": {**adm, "locomotion": {**loc, "force_record": record}}}


#: tables and arrays of a spec nest at most this deep (the deepest, [[controller.filters]] ranges, takes 4)
MAX_NESTING = 16


def _check_nesting(data: Mapping[str, Any]) -> None:
    """SpecError naming the first key path nested deeper than ``MAX_NESTING`` (walked without recursion)."""
    stack: list[tuple[Any, tuple[str, ...]]] = [(data, ())]
    while stack:
        node, keys = stack.pop()
        if len(keys) > MAX_NESTING:
            raise SpecError(f"{'.'.join(keys[:MAX_NESTING + 1])}: nested more than {MAX_NESTING} levels deep; "
                            "no spec key nests that deep")
        items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
        stack.extend((v, (*keys, str(k))) for k, v in items)


def load_spec(path: str | Path, *, plant: Mapping[str, Any] | None = None) -> Spec:
    """Read and validate a TOML spec file; ``plant`` updates its ``[plant]`` table first (keys as the file
    writes them: the plant a fit found)."""
    path = Path(path)
    text = read_spec_text(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{path}: not valid TOML: {exc}") from None
    except RecursionError:
        raise SpecError(f"{path}: arrays or tables nested thousands deep; a spec nests at most "
                        f"{MAX_NESTING} levels") from None
    if plant:
        if not isinstance(data.get("plant", {}), dict):
            raise SpecError(f"{path}: plant: must be a table")
        data.setdefault("plant", {}).update(plant)
    return parse_spec(data, source=str(path), folder=path.parent)
