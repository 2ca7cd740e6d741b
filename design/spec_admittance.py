"""The ``[admittance]`` section of a spec file: virtual dynamics bounds, the mouse, the
locomotion profile and the hardware limits (validated with pydantic, key paths in errors)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field, model_validator


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Range(_Strict):
    min: float = Field(gt=0)
    max: float = Field(gt=0)

    @model_validator(mode="after")
    def _ordered(self):
        if self.max < self.min:
            raise ValueError(f"max ({self.max}) must be >= min ({self.min})")
        return self


class MouseSpec(_Strict):
    """Mouse coupled at the head clamp: head mass beyond the sensor, body mass through the neck."""

    head_mass_kg: Range = Range(min=0.002, max=0.004)
    body_mass_kg: Range = Range(min=0.020, max=0.035)
    neck_stiffness_n_per_m: Range = Range(min=20.0, max=200.0)
    neck_damping_n_s_per_m: Range = Range(min=0.05, max=0.5)


class LocomotionSpec(_Strict):
    peak_speed_m_per_s: float = Field(0.5, gt=0, le=10)
    peak_acceleration_m_per_s2: float = Field(5.0, gt=0, le=200)
    peak_force_n: float = Field(0.3, gt=0, le=100)


class AdmittanceSpec(_Strict):
    m_v: Range = Range(min=0.01, max=200.0)          # kg
    b_v: Range = Range(min=0.01, max=500.0)          # N*s/m
    phase_margin_deg: float = Field(45.0, ge=0, lt=90)
    gain_margin_db: float = Field(6.0, ge=0, le=60)
    mouse: MouseSpec = MouseSpec()
    locomotion: LocomotionSpec = LocomotionSpec()
    motor_peak_force_n: float = Field(300.0, gt=0)
    force_sensor_resolution_n: float = Field(0.00625, gt=0)
    #: motor current caused by one force-sensor step, at most (A)
    current_per_sensor_step_max_a: float = Field(0.05, gt=0)
