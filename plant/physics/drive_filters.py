"""The drive's velocity-loop filters: biquads after the PI controller, as Copley, Kollmorgen and
Beckhoff drives implement them.

* low-pass: w^2 / (s^2 + 2 zeta w s + w^2), w = 2 pi ``frequency_hz`` (Copley's default: 2-pole
  Butterworth, zeta = 1/sqrt 2, at 200 Hz);
* notch: (s^2 + 2 depth zeta w s + w^2) / (s^2 + 2 zeta w s + w^2): ``damping_ratio`` zeta sets its
  width (-3 dB width about 2 zeta w for a deep notch), ``depth`` = |H(jw)| at the centre (0: full
  notch, 1: no notch).

Both act in the loop like the plant's own effects (the loop is P F (kp + ki/s)), so they join the
plant chain as effects at the drive and every loop computation (margins, casadi, python-control,
the discrete export) sees them. Their responses are written with ordinary operators, so the same
formula takes casadi symbols for the parameters when the synthesis designs them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from plant.errors import ParameterError
from plant.physics.algebra import NUMPY
from plant.physics.chain import ChainEffect


def _value(x, ops):
    """A parameter as the formula uses it: an array with NumPy, the value itself (float or casadi
    symbol) with casadi."""
    return np.asarray(x) if ops is NUMPY else x


@dataclass(frozen=True)
class LowPassFilter(ChainEffect):
    """Second-order low-pass after the PI controller."""

    frequency_hz: float = 200.0
    damping_ratio: float = 1 / math.sqrt(2)
    name: ClassVar[str] = "low_pass_filter"
    bounds: ClassVar = {"frequency_hz": (1.0, 1e6, "Hz"), "damping_ratio": (0.05, 2.0, "")}
    place: ClassVar[str] = "drive"
    limits_bandwidth: ClassVar[bool] = True
    searched: ClassVar[bool] = False
    main_parameter: ClassVar[str] = "frequency_hz"

    def __post_init__(self) -> None:
        self._check_positive()

    def response(self, s, ops=NUMPY):
        w = 2 * np.pi * _value(self.frequency_hz, ops)
        z = _value(self.damping_ratio, ops)
        return w * w / (s * s + 2 * z * w * s + w * w)

    def polynomials(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """(numerator, denominator) coefficients in s, highest power first."""
        w = 2 * math.pi * float(self.frequency_hz)
        return (0.0, 0.0, w * w), (1.0, 2 * float(self.damping_ratio) * w, w * w)

    def to_tf(self, **_):
        import control

        return control.tf(*self.polynomials())


@dataclass(frozen=True)
class NotchFilter(ChainEffect):
    """Second-order notch after the PI controller."""

    frequency_hz: float = 100.0
    damping_ratio: float = 0.3
    depth: float = 0.1
    name: ClassVar[str] = "notch_filter"
    bounds: ClassVar = {"frequency_hz": (1.0, 1e6, "Hz"), "damping_ratio": (0.01, 2.0, ""), "depth": (0.0, 1.0, "")}
    place: ClassVar[str] = "drive"
    searched: ClassVar[bool] = False
    main_parameter: ClassVar[str] = "frequency_hz"

    def __post_init__(self) -> None:
        for field in ("frequency_hz", "damping_ratio"):
            if not np.all(np.asarray(getattr(self, field)) > 0):
                raise ParameterError(f"notch_filter.{field} must be > 0, got {getattr(self, field)!r}")
        if not np.all((np.asarray(self.depth) >= 0) & (np.asarray(self.depth) <= 1)):
            raise ParameterError(f"notch_filter.depth must lie in [0, 1], got {self.depth!r}")

    def response(self, s, ops=NUMPY):
        w = 2 * np.pi * _value(self.frequency_hz, ops)
        z = _value(self.damping_ratio, ops)
        d = _value(self.depth, ops)
        return (s * s + 2 * d * z * w * s + w * w) / (s * s + 2 * z * w * s + w * w)

    def polynomials(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        w, z, d = 2 * math.pi * float(self.frequency_hz), float(self.damping_ratio), float(self.depth)
        return (1.0, 2 * d * z * w, w * w), (1.0, 2 * z * w, w * w)

    def to_tf(self, **_):
        import control

        return control.tf(*self.polynomials())


FILTERS = {cls.name: cls for cls in (LowPassFilter, NotchFilter)}
#: the spec's ``kind`` of a filter -> its effect class
KINDS = {"low_pass": LowPassFilter, "notch": NotchFilter}
