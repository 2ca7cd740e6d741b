"""The admittance stage's design problem: bounds of the virtual dynamics 1/(m_v s + b_v), the
interaction loop's margins, the mouse at the head clamp, the locomotion profile and the hardware
limits. Frozen dataclasses; their ``Annotated`` bounds are checked when a spec file's
``[admittance]`` section is read (see ``specs/stage_x_admittance.toml``)::

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

from dataclasses import dataclass
from typing import Annotated

from annotated_types import Ge, Gt, Le, Lt

from design.problem import FORBID, check_ordered

_Positive = Annotated[float, Gt(0), Le(1e6)]


@dataclass(frozen=True)
class Range:
    """A positive range; a spec file may give one number for min = max."""

    __pydantic_config__ = FORBID
    min: _Positive
    max: _Positive

    def __post_init__(self):
        check_ordered(self.min, self.max)

    def corners(self) -> tuple[float, ...]:
        return (self.min,) if self.min == self.max else (self.min, self.max)


@dataclass(frozen=True)
class Mouse:
    """The mouse at the head clamp: head mass beyond the force sensor (moves with the gantry),
    body mass coupled to the head through the neck (stiffness, damping), and the peak force it
    exerts on the clamp. Defaults are assumptions (see the example spec)."""

    __pydantic_config__ = FORBID
    head_mass_kg: Range = Range(min=0.002, max=0.004)
    body_mass_kg: Range = Range(min=0.020, max=0.035)
    neck_stiffness_n_per_m: Range = Range(min=20.0, max=200.0)
    neck_damping_n_s_per_m: Range = Range(min=0.2, max=1.0)
    #: peak force the mouse exerts on the head clamp, i.e. the sensed force (N)
    peak_force_n: Annotated[float, Gt(0), Le(100)] = 0.3


@dataclass(frozen=True)
class Locomotion:
    """Trapezoidal locomotion profile the mouse should be able to perform."""

    __pydantic_config__ = FORBID
    peak_speed_m_per_s: Annotated[float, Gt(0), Le(10)] = 0.5
    peak_acceleration_m_per_s2: Annotated[float, Gt(0), Le(200)] = 5.0


@dataclass(frozen=True)
class Hardware:
    __pydantic_config__ = FORBID
    motor_peak_force_n: Annotated[float, Gt(0), Le(1e5)] = 300.0
    #: thesis section 1.2: ATI Nano17, resolution 6.25 mN
    force_sensor_resolution_n: Annotated[float, Gt(0), Le(10)] = 0.00625
    #: motor current caused by a one-resolution-step change of the sensed force, at most (A)
    max_current_per_sensor_step_a: Annotated[float, Gt(0), Le(1000)] = 0.1


@dataclass(frozen=True)
class AdmittanceProblem:
    """Bounds of the virtual dynamics 1/(m_v s + b_v), interaction-loop margins, mouse, profile, hardware."""

    __pydantic_config__ = FORBID
    m_v: Range = Range(min=0.005, max=100.0)          # kg
    b_v: Range = Range(min=0.01, max=500.0)           # N*s/m
    phase_margin_deg: Annotated[float, Ge(0), Lt(90)] = 45.0
    gain_margin_db: Annotated[float, Ge(0), Le(60)] = 6.0
    mouse: Mouse = Mouse()
    locomotion: Locomotion = Locomotion()
    hardware: Hardware = Hardware()
