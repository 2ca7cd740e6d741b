"""The ``[admittance]`` section of a spec file (validated with pydantic; errors name the key path).

Shape (see ``specs/stage_x_admittance.toml``; every key optional, defaults below)::

    [admittance]
    m_v = { min = 0.005, max = 100.0 }        # virtual mass bounds, kg
    b_v = { min = 0.01, max = 500.0 }         # virtual damping bounds, N*s/m
    phase_margin_deg = 45.0                   # interaction loop
    gain_margin_db = 6.0
    [admittance.mouse]                        # ranges: { min, max } or one number
    head_mass_kg = { min = 0.002, max = 0.004 }
    body_mass_kg = { min = 0.020, max = 0.035 }
    neck_stiffness_n_per_m = { min = 20.0, max = 200.0 }
    neck_damping_n_s_per_m = { min = 0.2, max = 1.0 }
    peak_force_n = 0.3
    [admittance.locomotion]
    peak_speed_m_per_s = 0.5
    peak_acceleration_m_per_s2 = 5.0
    [admittance.hardware]
    motor_peak_force_n = 300.0
    force_sensor_resolution_n = 0.00625
    max_current_per_sensor_step_a = 0.1
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field, model_validator


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Range(_Strict):
    """A positive range; a single number means min = max."""

    min: float = Field(gt=0, le=1e6)
    max: float = Field(gt=0, le=1e6)

    @model_validator(mode="before")
    @classmethod
    def _number(cls, v):
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            return {"min": v, "max": v}
        return v

    @model_validator(mode="after")
    def _ordered(self):
        if self.max < self.min:
            raise ValueError(f"max ({self.max}) must be >= min ({self.min})")
        return self

    def corners(self) -> tuple[float, ...]:
        return (self.min,) if self.min == self.max else (self.min, self.max)


class MouseSpec(_Strict):
    """The mouse at the head clamp: head mass beyond the force sensor (moves with the gantry),
    body mass coupled to the head through the neck (stiffness, damping), and the peak force it
    exerts on the clamp. Defaults are assumptions (see the example spec)."""

    head_mass_kg: Range = Range(min=0.002, max=0.004)
    body_mass_kg: Range = Range(min=0.020, max=0.035)
    neck_stiffness_n_per_m: Range = Range(min=20.0, max=200.0)
    neck_damping_n_s_per_m: Range = Range(min=0.2, max=1.0)
    #: peak force the mouse exerts on the head clamp, i.e. the sensed force (N)
    peak_force_n: float = Field(0.3, gt=0, le=100)


class LocomotionSpec(_Strict):
    """Trapezoidal locomotion profile the mouse should be able to perform."""

    peak_speed_m_per_s: float = Field(0.5, gt=0, le=10)
    peak_acceleration_m_per_s2: float = Field(5.0, gt=0, le=200)


class HardwareSpec(_Strict):
    motor_peak_force_n: float = Field(300.0, gt=0, le=1e5)
    #: thesis section 1.2: ATI Nano17, resolution 6.25 mN
    force_sensor_resolution_n: float = Field(0.00625, gt=0, le=10)
    #: motor current caused by a one-resolution-step change of the sensed force, at most (A)
    max_current_per_sensor_step_a: float = Field(0.1, gt=0, le=1000)


class AdmittanceSpec(_Strict):
    """Bounds of the virtual dynamics 1/(m_v s + b_v), interaction-loop margins, mouse, profile, hardware."""

    m_v: Range = Range(min=0.005, max=100.0)          # kg
    b_v: Range = Range(min=0.01, max=500.0)           # N*s/m
    phase_margin_deg: float = Field(45.0, ge=0, lt=90)
    gain_margin_db: float = Field(6.0, ge=0, le=60)
    mouse: MouseSpec = MouseSpec()
    locomotion: LocomotionSpec = LocomotionSpec()
    hardware: HardwareSpec = HardwareSpec()
