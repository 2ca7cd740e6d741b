"""Physical parameters as plain data, and the thesis's parameter set with sources.

A ``Parameter`` is lmfit's ``Parameter`` without string expressions: a value, bounds
that go straight to the solver, a ``fixed`` flag and a unit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from plant.errors import ParameterError


@dataclass(frozen=True)
class Parameter:
    """One bounded physical parameter (SI units, see ``unit``)."""

    name: str
    value: float
    lower: float = -math.inf
    upper: float = math.inf
    fixed: bool = False
    unit: str = ""
    source: str = ""

    def __post_init__(self) -> None:
        check_finite(self.name, self.value)
        if not self.lower <= self.value <= self.upper:
            raise ParameterError(
                f"parameter {self.name} = {self.value:g} {self.unit} is outside its bounds "
                f"[{self.lower:g}, {self.upper:g}]"
            )



def check_finite(name: str, value) -> None:
    """Raise ``ParameterError`` naming ``name`` unless ``value`` is a real number (or array of them; not a string
    or a bool) and every element is finite."""
    if isinstance(value, float) and math.isfinite(value):
        return
    import numpy as np

    kind = "" if isinstance(value, str | bytes) else np.asarray(value).dtype.kind
    if kind not in ("i", "u", "f"):     # a string, bool or object is refused, not converted
        raise ParameterError(f"parameter {name} must be a number, got {type(value).__name__} {value!r}")
    arr = np.asarray(value, dtype=float)
    if arr.size == 0 or not np.all(np.isfinite(arr)):
        raise ParameterError(f"parameter {name} must be a finite number, got {value!r}")


def check_positive(name: str, value, *, allow_zero: bool = False) -> None:
    """Raise ``ParameterError`` naming ``name`` unless ``value`` is finite and > 0 (>= 0)."""
    import numpy as np

    check_finite(name, value)
    arr = np.asarray(value, dtype=float)
    bad = arr < 0 if allow_zero else arr <= 0
    if np.any(bad):
        word = "non-negative" if allow_zero else "positive"
        raise ParameterError(f"parameter {name} must be {word}, got {value!r}")


def check_batch(name: str, value) -> None:
    """Raise ``ParameterError`` naming ``name`` unless ``value`` is one number or a batch along axis -2 (an
    array whose last axis has length 1, as ``Plant.with_payload`` builds): a flat array of values would pair
    element by element with the frequencies of a response instead of making one response each."""
    import numpy as np

    shape = np.shape(value)
    if shape and shape[-1] != 1:
        raise ParameterError(f"parameter {name} must be one number, or a batch as a column of shape (n, 1) (e.g. "
                             f"Plant.with_payload(array)); got shape {shape}")


# The thesis's parameter set (Dynamic Modelling and Control of Exoskeleton Gantry Robot).
THESIS = {
    "force_constant_n_per_a": Parameter(
        "force_constant_n_per_a", 20.0, 0.0, math.inf, unit="N/A",
        source="thesis section 3.1: PI-USA direct drive motor constant 20 N/A",
    ),
    "damping_n_s_per_m": Parameter(
        "damping_n_s_per_m", 440.0, 330.0, 550.0, unit="N*s/m",
        source="thesis section 3.1: ball-bearing damping 330-550 N*s/m; Appendix A code uses 440",
    ),
    "motor_length_m": Parameter(
        "motor_length_m", 0.8, 0.0, math.inf, unit="m", source="thesis section 3.1 and Appendix A: 0.8 m",
    ),
    "load_position_m": Parameter(
        "load_position_m", 0.4, 0.0, math.inf, unit="m",
        source="thesis Appendix A: y = 0.4 m, load centred on Stage X",
    ),
    "mass_kg": Parameter(
        "mass_kg", 35.0, 0.0, math.inf, unit="kg", source="thesis section 3.1 and Appendix A: payload 35 kg",
    ),
    "kp": Parameter("kp", 236.0, 0.0, math.inf, unit="A/(m/s)", source="thesis Appendix A: Kp = 236"),
    "ki": Parameter("ki", 47.0, 0.0, math.inf, unit="A/m", source="thesis Appendix A: Ki = 94/2 = 47"),
    "optics_payload_kg": Parameter(
        "optics_payload_kg", 27.0, 0.0, math.inf, unit="kg",
        source="thesis section 4.1: Stage X carries 27 kg of rotation stage and optics",
    ),
    "stage_mass_kg": Parameter(
        "stage_mass_kg", 16.0, 0.0, math.inf, unit="kg", source="thesis section 4.1: each stage weighs ~16 kg",
    ),
}
