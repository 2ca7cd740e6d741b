"""The ``[dual_drive]`` section of a Stage Y spec: the two-motor model (``plant.physics.dual_drive``) and the
loop structures to design and compare (``design.synth.dual``). The payload range, the drive effects, the
rail damping and force constant, the requirements, the gain box (``[controller]``) and the Monte Carlo
(``[verification]``) are the spec's own; the payload rides on Stage X's carriage."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from design.loop.dual import BY_NAME
from plant.physics.dual_drive import DualDriveStageY

#: the parameters a ``[dual_drive.uncertainty]`` range may name besides ``effect.parameter`` of a drive effect
UNCERTAIN_FIELDS = ("damping1_n_s_per_m", "damping2_n_s_per_m", "force_constant1_n_per_a", "force_constant2_n_per_a",
                    "yaw_stiffness_n_m_per_rad", "beam_inertia_kg_m2", "carriage_inertia_kg_m2")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class ParameterRange(_Strict):
    min: float
    max: float

    @model_validator(mode="after")
    def _ordered(self):
        if self.max < self.min:
            raise ValueError(f"max ({self.max}) must be >= min ({self.min})")
        return self


class PositionRange(ParameterRange):
    """The carriage's travel along the beam, from rail Y1 (m): the design points span it evenly."""

    min: float = Field(gt=0)
    max: float = Field(gt=0)
    points: int = Field(5, ge=1, le=50)


class DualDriveSpec(_Strict):
    """Stage Y as two motors. Masses in kg, lengths in m, stiffness in N*m/rad."""

    beam_mass_kg: float = Field(gt=0, le=1e4)
    #: None: a slender beam, beam_mass_kg L^2 / 12
    beam_inertia_kg_m2: float | None = Field(None, gt=0, le=1e5)
    #: Stage X's carriage without the payload (the payload range is ``plant.payload_kg``)
    stage_x_mass_kg: float = Field(gt=0, le=1e4)
    carriage_inertia_kg_m2: float = Field(0.0, ge=0, le=1e5)
    carriage_position_m: PositionRange
    yaw_stiffness_n_m_per_rad: float = Field(gt=0, le=1e12)
    #: per rail; None: the plant's damping_n_s_per_m and force_constant_n_per_a on both
    damping1_n_s_per_m: float | None = Field(None, gt=0, le=1e6)
    damping2_n_s_per_m: float | None = Field(None, gt=0, le=1e6)
    force_constant1_n_per_a: float | None = Field(None, gt=0, le=1e4)
    force_constant2_n_per_a: float | None = Field(None, gt=0, le=1e4)
    #: the loop structures compared (``design.loop.dual.BY_NAME``: one class each)
    structures: list[str] = Field(default_factory=lambda: list(BY_NAME), min_length=1)
    #: ranges (min, max) of the parameters above or of ``effect.parameter`` of the plant's drive effects
    uncertainty: dict[str, ParameterRange] = Field(default_factory=dict)

    @field_validator("structures")
    @classmethod
    def _structures(cls, v):
        for name in v:
            if name not in BY_NAME:
                raise ValueError(f"unknown structure {name!r}; known: {', '.join(BY_NAME)}")
        return v

    @field_validator("uncertainty")
    @classmethod
    def _names(cls, v):
        for name in v:
            if "." not in name and name not in UNCERTAIN_FIELDS:
                raise ValueError(f"unknown parameter {name!r}; ranges may name {', '.join(UNCERTAIN_FIELDS)} or "
                                 "effect.parameter of a drive effect (delay.seconds)")
        return v

    @field_validator("structures")
    @classmethod
    def _once(cls, v):
        if len(set(v)) < len(v):
            raise ValueError("a structure is named twice")
        return v

    def model(self, *, rail_separation_m: float, damping_n_s_per_m: float, force_constant_n_per_a: float,
              effects=()) -> DualDriveStageY:
        """The two-motor model at the first design position and the spec's nominal values (the scenarios set
        positions, payloads and the uncertain values)."""
        if not self.carriage_position_m.max < rail_separation_m:
            raise ValueError(f"carriage_position_m.max ({self.carriage_position_m.max}) must lie between the rails, "
                             f"below plant.motor_length_m ({rail_separation_m})")
        inertia = self.beam_inertia_kg_m2 if self.beam_inertia_kg_m2 is not None else \
            self.beam_mass_kg * rail_separation_m**2 / 12
        b, k = damping_n_s_per_m, force_constant_n_per_a
        return DualDriveStageY(beam_mass_kg=self.beam_mass_kg, beam_inertia_kg_m2=inertia,
                               carriage_mass_kg=self.stage_x_mass_kg,
                               carriage_inertia_kg_m2=self.carriage_inertia_kg_m2,
                               rail_separation_m=rail_separation_m, carriage_position_m=self.carriage_position_m.min,
                               damping1_n_s_per_m=self.damping1_n_s_per_m or b,
                               damping2_n_s_per_m=self.damping2_n_s_per_m or b,
                               force_constant1_n_per_a=self.force_constant1_n_per_a or k,
                               force_constant2_n_per_a=self.force_constant2_n_per_a or k,
                               yaw_stiffness_n_m_per_rad=self.yaw_stiffness_n_m_per_rad, effects=tuple(effects))
