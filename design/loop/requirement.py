"""Where a design is judged and which requirement binds it: the typed results the PI synthesis, the admittance
and the views share (``design.views.json`` turns them into the JSON of ``gantry synth --json``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Generic, TypeVar

#: the mouse of an interaction-loop requirement (``design.admittance.mouse.MouseModel``, a package above this one)
Mouse = TypeVar("Mouse")


@dataclass(frozen=True)
class ScenarioPoint:
    """One plant a design is judged on: the payload (kg), the value of each uncertain parameter of
    ``plant.uncertainty`` (in the spec's units) and, on the two-motor Stage Y, the carriage position (m).

    A frozen dataclass rather than a dict: the payload and the carriage are fields every consumer names, while the
    uncertain parameters are the spec's own names, so they stay (name, value) pairs in the spec's order, which keeps
    the point immutable and comparable by value; ``as_dict`` is the {name: value} the JSON prints."""

    payload_kg: float
    parameters: tuple[tuple[str, float], ...] = ()
    carriage_position_m: float | None = None

    def parameter(self, name: str) -> float:
        """The value of the uncertain parameter ``name``."""
        return dict(self.parameters)[name]

    def as_dict(self) -> dict[str, float]:
        """{"carriage_position_m" (two-motor Stage Y only), "payload_kg", each uncertain parameter: value}."""
        carriage = {} if self.carriage_position_m is None else {"carriage_position_m": self.carriage_position_m}
        return {**carriage, "payload_kg": self.payload_kg, **dict(self.parameters)}


@dataclass(frozen=True)
class Binding(Generic[Mouse]):
    """The requirement that binds a design (the one with the least slack), or one the design misses (a
    violation), and where; a field its producer does not know is None."""

    #: the requirement ("phase_margin", "gain_margin", "motor_force", "sensor_current", "passivity", "drift",
    #: "stability", ...) or the bound ("controller.kp.max", "b_v_min", ...)
    constraint: str
    #: the payload where it binds (kg)
    payload_kg: float | None = None
    #: the scenario where it binds
    scenario: ScenarioPoint | None = None
    #: the mouse where it binds (the interaction loop's requirements)
    mouse: Mouse | None = None
    #: the requirement's figure there and its limit, in its unit (deg, dB, N, A, Hz, mm/s; b_v in N*s/m when the
    #: scale of (m_v, b_v) binds); nan for an unstable loop
    value: float | None = None
    limit: float | None = None
    #: how far the figure clears the requirement, in its unit (negative: missed)
    slack: float | None = None
    #: that slack relative to the requirement
    relative_slack: float | None = None
    #: in words, naming the spec key
    detail: str | None = None
    #: the input the figure was computed on when it is not the locomotion profile or the grid ("force_record")
    source: str | None = None
    #: the law's computation delay (samples) where it binds, when the rig's delay is a range
    delay_samples: int | None = None
