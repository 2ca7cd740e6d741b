"""The design problem the numerics solve, free of any file format: a plant family (the model at a
payload, the payload range, parameter uncertainty), the PI gain bounds, the loop requirements and
an optional admittance stage.

The admittance stage's section of a spec file, every key optional (defaults below; sources in
``specs/stage_x_admittance.toml``)::

    [admittance]
    m_v = { min = 0.005, max = 100.0 }        # virtual mass bounds, kg
    b_v = { min = 0.01, max = 500.0 }         # virtual damping bounds, N*s/m
    phase_margin_deg = 45.0                   # interaction loop, every scenario and mouse
    gain_margin_db = 6.0
    codesign = false                          # choose the PI gains (and a ranged force filter) as well
    passivity = { up_to_hz = 5.0 }            # optional: Re Y_r >= 0 up to there ({} = everywhere)
    [admittance.mouse]                        # ranges: { min, max } or one number
    head_mass_kg = { min = 0.002, max = 0.010 }
    body_mass_kg = { min = 0.020, max = 0.035 }
    neck_stiffness_n_per_m = { min = 20.0, max = 200.0 }
    neck_damping_n_s_per_m = { min = 0.2, max = 1.0 }
    leg_stiffness_n_per_m = { min = 300.0, max = 1.0e4 }   # 0 allowed: feet off the ground
    leg_damping_n_s_per_m = 0.5
    floating = true                           # also the mouse with its feet off the ground
    peak_force_n = 1.2
    [admittance.locomotion]                   # the trapezoid the mouse should be able to run
    peak_speed_m_per_s = 0.2
    peak_acceleration_m_per_s2 = 1.0
    travel_m = 0.4
    force_record = "mouse_force.csv"          # optional: columns time_s, force_n (relative to the spec)
    [admittance.hardware]
    motor_peak_force_n = 300.0
    motor_force_criterion = "locomotion"      # or "worst_sinusoid": the mouse's peak force at any frequency
    force_sensor_resolution_n = 0.00625
    max_current_per_sensor_step_a = 0.1       # optional
    [admittance.sensor]
    bias_after_tare_n = 0.00625
    deadband_n = 0.0
    max_drift_mm_per_s = 1.0                  # optional
    [admittance.rig]                          # absent: the admittance law is continuous
    update_rate_hz = 100.0
    computation_delay_samples = 0
    force_filter = { frequency_hz = 30.0, order = 2 }

The records are frozen dataclasses; their ``Annotated`` bounds are what ``design.spec.schema``
checks when it reads a spec file (pydantic validates dataclasses field by field), so the limits
live in one place and apply to every command.

May import: ``plant``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Annotated, Literal

import numpy as np
from annotated_types import Ge, Gt, Le, Lt

from plant.physics.drive_filters import FILTERS, KINDS
from plant.physics.models import BASE_BOUNDS, Plant

#: the payloads (kg) every command accepts: the bounds of the plant's ``mass_kg``, which fits, simulations
#: and the loop analyses check too (the moving mass of the thesis gantry is 5-40 kg)
PAYLOAD_MIN_KG, PAYLOAD_MAX_KG = BASE_BOUNDS["mass_kg"][:2]

#: payloads of the range every design is checked at, beyond the points it was computed at
DENSE_PAYLOADS = 50

#: pydantic configuration of every record: a key that is not a field is an error, and so is inf or nan
FORBID = {"extra": "forbid", "allow_inf_nan": False}


def check_ordered(lo: float, hi: float) -> None:
    """A range's ``max`` must not be below its ``min``."""
    if hi < lo:
        raise ValueError(f"max ({hi}) must be >= min ({lo})")


@dataclass(frozen=True)
class PayloadRange:
    """Payload (moving mass M of Eq. 3.15/3.16) range in kg."""

    __pydantic_config__ = FORBID
    min: Annotated[float, Ge(PAYLOAD_MIN_KG), Le(PAYLOAD_MAX_KG)] = 5.0
    max: Annotated[float, Ge(PAYLOAD_MIN_KG), Le(PAYLOAD_MAX_KG)] = 40.0
    #: the design points (the check adds 50 dense payloads and the violators it finds)
    points: Annotated[int, Ge(1), Le(200)] = 8
    nominal: Annotated[float, Ge(PAYLOAD_MIN_KG), Le(PAYLOAD_MAX_KG)] | None = None

    def __post_init__(self):
        check_ordered(self.min, self.max)

    @classmethod
    def fixed(cls, payload_kg: float) -> PayloadRange:
        return cls(min=payload_kg, max=payload_kg, points=1, nominal=payload_kg)

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


@dataclass(frozen=True)
class Uncertainty:
    """A parameter's range for Monte Carlo sweeps (uniform between min and max)."""

    __pydantic_config__ = FORBID
    min: float
    max: float

    def __post_init__(self):
        check_ordered(self.min, self.max)


#: gains (A per m/s, A per m) and their bounds lie within [1/GAIN_LIMIT, GAIN_LIMIT]: the scan spans six
#: decades below the upper bound, and the solvers work on gains scaled by it in double precision
GAIN_LIMIT = 1.0e9


@dataclass(frozen=True)
class GainBounds:
    """A controller gain: ``value`` (used for analysis), and bounds for synthesis."""

    __pydantic_config__ = FORBID
    value: Annotated[float, Ge(0), Le(GAIN_LIMIT)] | None = None
    min: Annotated[float, Ge(0), Le(GAIN_LIMIT)] = 0.0
    max: Annotated[float, Ge(1.0 / GAIN_LIMIT), Le(GAIN_LIMIT)] = 1.0e7

    def __post_init__(self):
        check_ordered(self.min, self.max)
        if self.value is not None and not self.min <= self.value <= self.max:
            raise ValueError(f"value ({self.value}) must lie within [min, max] = [{self.min}, {self.max}]")


@dataclass(frozen=True)
class DriveFilter:
    """A biquad after the PI controller (``plant.physics.drive_filters``): ``kind`` low_pass or notch, its
    fixed parameters and the ranges of those the synthesis chooses (empty: a filter the drive already
    has, kept as it is)."""

    kind: str
    fixed: dict[str, float]
    ranges: dict[str, tuple[float, float]] = field(default_factory=dict)

    @property
    def designed(self) -> bool:
        return bool(self.ranges)

    def start(self) -> dict[str, float]:
        """Its parameters, the designed ones at the geometric (depth: arithmetic) middle of their range."""
        mid = {k: (math.sqrt(lo * hi) if k != "depth" and lo > 0 else 0.5 * (lo + hi))
               for k, (lo, hi) in self.ranges.items()}
        return {**self.fixed, **mid}


@dataclass(frozen=True)
class ControllerBounds:
    """PI gains kp (A per m/s) and ki (A per m); ``loop_rate_hz``: the drive's velocity-loop rate, when
    the design is to be exported as the drive runs it (its hold and computation delay are then in the
    plant as the ``sampling`` effect)."""

    kp: GainBounds
    ki: GainBounds
    loop_rate_hz: float | None = None
    #: biquads after the PI controller, in the loop in this order
    filters: tuple[DriveFilter, ...] = ()
    #: a design must have integral action (ki > 0: no steady-state velocity error); False admits P-only
    integral_required: bool = True


@dataclass(frozen=True)
class Requirements:
    """Loop requirements, checked at every payload."""

    __pydantic_config__ = FORBID
    phase_margin_deg: Annotated[float, Ge(0), Lt(90)] = 45.0
    gain_margin_db: Annotated[float, Ge(0), Le(60)] = 6.0
    disk_margin: Annotated[float, Gt(0), Lt(2)] | None = None
    #: two-motor plants: margins against the same gain or phase change on both motors at once (deg, dB). None:
    #: the loop-at-a-time values above, since two motors on one beam share one drive model, one batch of magnets
    #: and one temperature, so their likeliest change is common to both; 0: not required (reported only)
    common_phase_margin_deg: Annotated[float, Ge(0), Lt(90)] | None = None
    common_gain_margin_db: Annotated[float, Ge(0), Le(60)] | None = None
    peak_sensitivity: Annotated[float, Gt(1)] | None = None
    #: optional: synthesis is infeasible when the worst-case bandwidth cannot reach this
    min_bandwidth_hz: Annotated[float, Gt(0), Le(1e5)] | None = None
    #: closed-loop bandwidth: where |T| falls to 1/sqrt 2 ("half_power", -3.01 dB) or 3 dB below ("minus_3_db",
    #: as MATLAB's ``bandwidth``) the reference |T| = 1, which T(0) reaches with integral action
    bandwidth_definition: Literal["half_power", "minus_3_db"] = "half_power"
    #: optional noise limit: the controller's gain |(kp + ki/jw) F(jw)| in A per (m/s), the drive filters F
    #: included, may not exceed this above ``high_frequency_hz`` (sensor noise reaches the current there)
    max_high_frequency_gain: Annotated[float, Gt(0)] | None = None
    high_frequency_hz: Annotated[float, Gt(0), Le(1e5)] = 500.0

    @property
    def level2(self) -> float:
        """|T(w_b)|^2 / |T(0)|^2 of the bandwidth definition."""
        return 0.5 if self.bandwidth_definition == "half_power" else 10 ** (-0.3)


@dataclass(frozen=True)
class PlantFamily:
    """The plant model at its nominal payload, the payload range it spans, and parameter ranges
    (keyed ``damping_n_s_per_m``, ``delay.seconds``…) for Monte Carlo."""

    nominal: Plant
    payload_kg: PayloadRange
    uncertainty: dict[str, Uncertainty] = field(default_factory=dict)

    @property
    def effects(self) -> tuple[str, ...]:
        return tuple(e.name for e in self.nominal.effects)

    @property
    def force_constant_n_per_a(self) -> float:
        return self.nominal.force_constant_n_per_a

    def plant(self, payload_kg=None) -> Plant:
        """The plant at ``payload_kg`` (default: nominal); an array gives a batch."""
        return self.nominal if payload_kg is None else self.nominal.with_payload(payload_kg)


# --- the admittance stage: virtual dynamics 1/(m_v s + b_v), interaction-loop margins, mouse, profile,
# hardware limits, the force sensor and the rig's sampled loop (spec section [admittance], see
# specs/stage_x_admittance.toml, whose comments give the source of every default)

_Positive = Annotated[float, Gt(0), Le(1e6)]
_NonNegative = Annotated[float, Ge(0), Le(1e7)]


@dataclass(frozen=True)
class Range(Uncertainty):
    """A positive range; a spec file may give one number for min = max."""

    min: _Positive
    max: _Positive

    def corners(self) -> tuple[float, ...]:
        return (self.min,) if self.min == self.max else (self.min, self.max)


@dataclass(frozen=True)
class StanceRange(Range):
    """A range that may start at 0 (a leg stiffness or damping: 0 is a mouse whose body is not on the
    ground); one number for min = max."""

    min: _NonNegative
    max: _NonNegative

    def points(self, inner: int) -> tuple[float, ...]:
        """The ends and ``inner`` log-spaced points between them (a stiffness between its ends can be
        the worst: a mode that meets the velocity loop's crossover)."""
        if self.min == self.max or inner <= 0:
            return self.corners()
        lo = max(self.min, self.max * 1e-3)
        mid = np.geomspace(lo, self.max, inner + 2)[1:-1]
        return tuple(sorted({self.min, *map(float, mid), self.max}))


@dataclass(frozen=True)
class Mouse:
    """The mouse at the head clamp: head mass beyond the force sensor (moves with the gantry), body
    mass coupled to the head through the neck (stiffness, damping) and to the ground through the legs
    (stiffness, damping: a walking or bracing mouse), and the peak force it exerts on the clamp.
    ``floating`` adds the mouse with its feet off the ground (legs 0) to every check."""

    __pydantic_config__ = FORBID
    head_mass_kg: Range = Range(min=0.002, max=0.010)
    body_mass_kg: Range = Range(min=0.020, max=0.035)
    neck_stiffness_n_per_m: Range = Range(min=20.0, max=200.0)
    neck_damping_n_s_per_m: Range = Range(min=0.2, max=1.0)
    leg_stiffness_n_per_m: StanceRange = StanceRange(min=300.0, max=1.0e4)
    leg_damping_n_s_per_m: StanceRange = StanceRange(min=0.5, max=0.5)
    floating: bool = True
    #: peak force the mouse exerts on the head clamp, i.e. the sensed force (N)
    peak_force_n: Annotated[float, Gt(0), Le(100)] = 1.2


@dataclass(frozen=True)
class ForceRecord:
    """A force the mouse put on the head clamp, as recorded: ``time_s`` increasing (s), ``force_n`` (N) at those
    times, linear between them; ``file`` where it came from (the spec's path, or "inline")."""

    __pydantic_config__ = FORBID
    file: str
    time_s: tuple[float, ...]
    force_n: tuple[float, ...]

    def __post_init__(self):
        if len(self.time_s) != len(self.force_n):
            raise ValueError(f"time_s has {len(self.time_s)} values and force_n {len(self.force_n)}")
        if len(self.time_s) < 2:
            raise ValueError("a force record needs at least 2 samples")
        if any(b <= a for a, b in zip(self.time_s, self.time_s[1:])):
            k = next(k for k, (a, b) in enumerate(zip(self.time_s, self.time_s[1:])) if b <= a)
            raise ValueError(f"time_s must increase: sample {k + 2} ({self.time_s[k + 1]:g} s) does not follow "
                             f"{self.time_s[k]:g} s")

    @property
    def duration_s(self) -> float:
        return self.time_s[-1] - self.time_s[0]


@dataclass(frozen=True)
class Locomotion:
    """The trapezoidal locomotion profile the mouse should be able to perform: accelerate at
    ``peak_acceleration_m_per_s2`` to ``peak_speed_m_per_s``, run, decelerate, over ``travel_m``
    (bsbrl/exoskeleton ``MAIN_generate_trapezoidal_profile.m``); optionally a recorded force the motor must also
    follow (``force_record``: in a spec file a CSV file with columns ``time_s`` and ``force_n``, relative to the
    spec, or a table ``{ time_s = [...], force_n = [...] }``)."""

    __pydantic_config__ = FORBID
    peak_speed_m_per_s: Annotated[float, Gt(0), Le(10)] = 0.2
    peak_acceleration_m_per_s2: Annotated[float, Gt(0), Le(200)] = 1.0
    travel_m: Annotated[float, Gt(0), Le(100)] = 0.4
    force_record: ForceRecord | None = None


@dataclass(frozen=True)
class Hardware:
    """The rig's limits. ``motor_force_criterion`` says what the motor's peak force is held to: "locomotion"
    (the default), its largest force while the spec's mouse runs the spec's locomotion profile, at every
    payload, uncertainty corner and mouse; "worst_sinusoid", the mouse's peak force as a sinusoid at the worst
    frequency up to the law's Nyquist frequency (a stricter bound no locomotion needs)."""

    __pydantic_config__ = FORBID
    motor_peak_force_n: Annotated[float, Gt(0), Le(1e5)] = 300.0
    motor_force_criterion: Literal["locomotion", "worst_sinusoid"] = "locomotion"
    #: thesis section 1.2: ATI Nano17, resolution 6.25 mN
    force_sensor_resolution_n: Annotated[float, Gt(0), Le(10)] = 0.00625
    #: optional: motor current one resolution step of the sensed force may cause, at most (A)
    max_current_per_sensor_step_a: Annotated[float, Gt(0), Le(1000)] | None = None


@dataclass(frozen=True)
class Sensor:
    """What the force reading does at rest: the offset left after taring (N), the deadband applied to
    the reading (N; readings within it count as zero, beyond it pass unchanged), and the largest drift
    of the gantry at rest the spec accepts (mm/s; optional)."""

    __pydantic_config__ = FORBID
    bias_after_tare_n: Annotated[float, Ge(0), Le(10)] = 0.00625
    deadband_n: Annotated[float, Ge(0), Le(10)] = 0.0
    max_drift_mm_per_s: Annotated[float, Gt(0), Le(1e4)] | None = None


@dataclass(frozen=True)
class ForceFilter:
    """Low-pass on the force reading before the admittance law samples it: Butterworth of ``order`` 1
    or 2; ``frequency_hz`` fixed, or ``frequency_hz_min``/``frequency_hz_max`` for the co-design to choose."""

    __pydantic_config__ = FORBID
    frequency_hz: Annotated[float, Gt(0), Le(1e5)] | None = None
    frequency_hz_min: Annotated[float, Gt(0), Le(1e5)] | None = None
    frequency_hz_max: Annotated[float, Gt(0), Le(1e5)] | None = None
    order: Literal[1, 2] = 2

    def __post_init__(self):
        ranged = (self.frequency_hz_min, self.frequency_hz_max)
        if (self.frequency_hz is None) == all(v is None for v in ranged):
            raise ValueError("give frequency_hz, or frequency_hz_min and frequency_hz_max for the co-design")
        if self.frequency_hz is None:
            if None in ranged:
                raise ValueError("give both frequency_hz_min and frequency_hz_max")
            check_ordered(*ranged)

    @property
    def designed(self) -> bool:
        return self.frequency_hz is None


@dataclass(frozen=True)
class DelayRange:
    """Whole samples of computation delay from ``min`` to ``max`` (the rig's timing not measured)."""

    __pydantic_config__ = FORBID
    min: Annotated[int, Ge(0), Le(100)]
    max: Annotated[int, Ge(0), Le(100)]

    def __post_init__(self):
        check_ordered(self.min, self.max)


@dataclass(frozen=True)
class Rig:
    """The admittance law as the rig runs it: sampled at ``update_rate_hz`` (None: continuous) with a
    zero-order hold on its velocity output and ``computation_delay_samples`` whole samples between the
    force sample and the output it causes (or a range of them, every one of which the design holds at), after
    an optional force filter; ``law`` is its integration rule."""

    __pydantic_config__ = FORBID
    update_rate_hz: Annotated[float, Gt(0), Le(1e6)] | None = None
    computation_delay_samples: Annotated[int, Ge(0), Le(100)] | DelayRange = 0
    force_filter: ForceFilter | None = None
    #: how the law integrates 1/(m_v s + b_v) per update (``design.admittance.rig``): "backward_euler"
    #: v[k] = (m_v v[k-1] + T F[k]) / (m_v + b_v T), stable for any gains; "forward_euler" v[k] = v[k-1] +
    #: T (F[k] - b_v v[k-1]) / m_v (the lab's LabVIEW law), stable only for m_v > b_v T / 2; "tustin" (bilinear)
    #: v[k] = ((2 m_v - b_v T) v[k-1] + T (F[k] + F[k-1])) / (2 m_v + b_v T); "zoh" (step-invariant) v[k] =
    #: e^(-b_v T / m_v) v[k-1] + (1 - e^(-b_v T / m_v)) F[k] / b_v, exact for a force held over the period
    law: Literal["backward_euler", "forward_euler", "tustin", "zoh"] = "backward_euler"

    @property
    def sample_period_s(self) -> float | None:
        return None if self.update_rate_hz is None else 1.0 / self.update_rate_hz

    @property
    def delay_range(self) -> tuple[int, int]:
        """(least, largest) computation delay in samples."""
        d = self.computation_delay_samples
        return (d.min, d.max) if isinstance(d, DelayRange) else (d, d)


@dataclass(frozen=True)
class Passivity:
    """Optional requirement: Re Y_r(jw) >= 0 (the rendered dynamics absorb energy) from 0 up to
    ``up_to_hz`` (None: the whole band the loop is analysed on)."""

    __pydantic_config__ = FORBID
    up_to_hz: Annotated[float, Gt(0), Le(1e5)] | None = None


@dataclass(frozen=True)
class AdmittanceProblem:
    """Bounds of the virtual dynamics 1/(m_v s + b_v), interaction-loop margins, mouse, profile, hardware,
    sensor and rig; ``codesign`` chooses the PI gains (and a designed force filter) with (m_v, b_v)."""

    __pydantic_config__ = FORBID
    m_v: Range = Range(min=0.005, max=100.0)          # kg
    b_v: Range = Range(min=0.01, max=500.0)           # N*s/m
    phase_margin_deg: Annotated[float, Ge(0), Lt(90)] = 45.0
    gain_margin_db: Annotated[float, Ge(0), Le(60)] = 6.0
    passivity: Passivity | None = None
    codesign: bool = False
    mouse: Mouse = Mouse()
    locomotion: Locomotion = Locomotion()
    hardware: Hardware = Hardware()
    sensor: Sensor = Sensor()
    rig: Rig = Rig()


@dataclass(frozen=True)
class VerificationPlan:
    """How a design is verified beyond its scenarios: ``monte_carlo_samples`` independent draws over
    payload x the uncertainty (seeded with ``seed``)."""

    __pydantic_config__ = FORBID
    monte_carlo_samples: Annotated[int, Ge(1), Le(1_000_000)] = 10_000
    seed: Annotated[int, Ge(0)] = 20_261_124


@dataclass(frozen=True)
class LoopProblem:
    """What a velocity-loop design or analysis needs: the plant family, the gain bounds, the
    requirements, and the admittance stage when there is one."""

    plant: PlantFamily
    controller: ControllerBounds
    requirements: Requirements = Requirements()
    admittance: AdmittanceProblem | None = None
    verification: VerificationPlan = VerificationPlan()


def with_filters(family: PlantFamily, filters: tuple[DriveFilter, ...],
                 values: list[dict] | None = None) -> PlantFamily:
    """The family with the drive's filters in the loop (as effects at the drive, replacing any there):
    at ``values`` (one dict per filter; None leaves a designed filter out), else at their start values."""
    nominal = family.nominal
    kept = tuple(e for e in nominal.effects if e.name not in FILTERS)
    chosen = values if values is not None else [f.start() for f in filters]
    added = tuple(KINDS[f.kind](**v) for f, v in zip(filters, chosen) if v is not None)
    return replace(family, nominal=replace(nominal, effects=(*kept, *added)))


def with_filter_values(problem: LoopProblem, values: list[dict]) -> LoopProblem:
    """The problem with its drive filters at ``values`` (one dict of parameters per filter)."""
    return replace(problem, plant=with_filters(problem.plant, problem.controller.filters, values))
