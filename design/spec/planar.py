"""Planar spec files: the gantry as one machine (``design.synth.planar``), Stage X's and Stage Y's own specs named
and the rotation stage's drive, gains and requirements given here.

Shape (see ``specs/planar.toml``)::

    name = "Planar gantry"
    [planar]
    stage_x = "stage_x_synth.toml"          # relative to this file: Stage X's loop, payloads, uncertainty
    stage_y = "stage_y_dual.toml"           # Stage Y's two-motor spec ([dual_drive])
    y_structures = ["common_differential"]  # optional: default the Stage Y spec's structures
    [rotation]
    inertia_kg_m2 = 0.05                    # what turns: the rotation table and the head stage on it
    damping_n_m_s_per_rad = 0.05
    torque_constant_n_m_per_a = 2.0
    [rotation.effects]                      # the rotation drive's chain, as plant.effects
    delay = { seconds = 0.0005 }
    [rotation.uncertainty]                  # ranges of the three above or of effect.parameter
    inertia_kg_m2 = { min = 0.02, max = 0.1 }
    [rotation.controller]                   # the gain box: kp in A/(rad/s), ki in A/rad
    kp = { min = 0.0, max = 1000.0 }
    [rotation.requirements]
    phase_margin_deg = 45.0
    [verification]                          # the joint check's Monte Carlo
    monte_carlo_samples = 2000
"""

from __future__ import annotations

import tomllib
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from design.loop.dual import BY_NAME
from design.spec.bundled import read_spec_text
from design.spec.dual_drive import ParameterRange
from plant.errors import GantryError, SpecError
from plant.physics.effect_base import ChainEffect
from plant.physics.effects import make_effect

#: the rotation stage's parameters a ``[rotation.uncertainty]`` range may name besides ``effect.parameter``
ROTATION_FIELDS = ("inertia_kg_m2", "damping_n_m_s_per_rad", "torque_constant_n_m_per_a")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Stages(_Strict):
    stage_x: str = Field(min_length=1)
    stage_y: str = Field(min_length=1)
    #: None: the Stage Y spec's ``dual_drive.structures``
    y_structures: list[str] | None = Field(None, min_length=1)

    @field_validator("y_structures")
    @classmethod
    def _known(cls, names):
        for n in names or ():
            if n not in BY_NAME:
                raise ValueError(f"unknown structure {n!r}; known: {', '.join(BY_NAME)}")
        return names


class Gain(_Strict):
    min: float = Field(0.0, ge=0, le=1e9)
    max: float = Field(gt=0, le=1e9)

    @model_validator(mode="after")
    def _ordered(self):
        if self.max <= self.min:
            raise ValueError(f"max ({self.max}) must be > min ({self.min})")
        return self


class RotationGains(_Strict):
    """The scan box: kp in A per (rad/s), ki in A per rad."""

    kp: Gain = Gain(max=1000.0)
    ki: Gain = Gain(max=1.0e6)


class RotationRequirements(_Strict):
    """The rotation channel's loop-at-a-time margins, the other loops closed."""

    phase_margin_deg: float = Field(45.0, ge=0, lt=90)
    gain_margin_db: float = Field(6.0, ge=0, le=60)


class Rotation(_Strict):
    """The rotation stage on Stage X's carriage: what turns (kg m^2), its bearing's damping (N m s/rad), its motor
    (N m/A), the drive's effects, their ranges, the gain box and the requirements."""

    inertia_kg_m2: float = Field(gt=0, le=1e3)
    damping_n_m_s_per_rad: float = Field(ge=0, le=1e4)
    torque_constant_n_m_per_a: float = Field(gt=0, le=1e4)
    effects: dict[str, dict[str, float]] = Field(default_factory=dict)
    uncertainty: dict[str, ParameterRange] = Field(default_factory=dict)
    controller: RotationGains = RotationGains()
    requirements: RotationRequirements = RotationRequirements()

    @field_validator("effects")
    @classmethod
    def _chain(cls, effects):
        for name, params in effects.items():
            try:
                e = make_effect(name, **params)
            except GantryError as exc:
                raise ValueError(str(exc)) from None
            if not isinstance(e, ChainEffect) or e.place != "drive":
                raise ValueError(f"{name}: the rotation drive takes drive effects (delay, current_loop, sampling, "
                                 "...), not mechanical or sensor ones")
        return effects

    @model_validator(mode="after")
    def _ranges_name_parameters(self):
        for key in self.uncertainty:
            effect, _, parameter = key.partition(".")
            if parameter:
                if effect not in self.effects:
                    raise ValueError(f"uncertainty.{key}: names the effect {effect!r}, which rotation.effects does "
                                     "not have")
                try:
                    make_effect(effect, **{**self.effects[effect], parameter: self.uncertainty[key].min})
                    make_effect(effect, **{**self.effects[effect], parameter: self.uncertainty[key].max})
                except GantryError as exc:
                    raise ValueError(f"uncertainty.{key}: {exc}") from None
            elif key not in ROTATION_FIELDS:
                raise ValueError(f"uncertainty.{key}: not a rotation parameter; known: {', '.join(ROTATION_FIELDS)} "
                                 "or effect.parameter")
            elif key != "damping_n_m_s_per_rad" and self.uncertainty[key].min <= 0:
                raise ValueError(f"uncertainty.{key}: min must be > 0")
        return self

    def drive_effects(self) -> tuple:
        return tuple(make_effect(name, **params) for name, params in self.effects.items())


class Verification(_Strict):
    monte_carlo_samples: int = Field(2000, ge=0, le=1_000_000)
    seed: int = Field(20261204, ge=0)


class PlanarSpec(_Strict):
    name: str = ""
    planar: Stages
    rotation: Rotation
    verification: Verification = Verification()


def load_planar_spec(path: str | Path) -> PlanarSpec:
    """Read and validate a planar spec; ``SpecError`` names the file and the key."""
    from design.spec.schema import _message, _unknown_key

    path = Path(path)
    try:
        data = tomllib.loads(read_spec_text(path))
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{path}: not valid TOML: {exc}") from None
    if "planar" not in data:
        raise SpecError(f"{path}: a planar spec needs a [planar] table naming stage_x and stage_y (see "
                        "specs/planar.toml)")
    unknown = _unknown_key(data, PlanarSpec)
    if unknown:
        raise SpecError(f"{path}: {unknown}")
    try:
        return PlanarSpec.model_validate(data)
    except ValidationError as exc:
        raise SpecError(f"{path}: {_message(exc, data)}") from None
