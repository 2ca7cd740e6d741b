"""The velocity loop's controller as one object: the PI C(s) = Kp + Ki / s of thesis Eq. 3.17-3.18, Kp in A per
(m/s), Ki in A per m, the motor current per velocity error.

It is what the synthesis chooses (its ``parameters``), what every loop, check and report takes, and what goes to
the rig: its frequency response (broadcast over a batch of gains when they are arrays, ``(..., n_freq)``), its
python-control transfer function and its discrete form at a drive's loop rate. Gains travel as two numbers only at
the edges: the spec, the JSON and a drive's parameters.

May import: ``plant``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from plant.arguments import check_number
from plant.errors import ParameterError

if TYPE_CHECKING:
    import control


@dataclass(frozen=True)
class PI:
    """Kp + Ki / s: ``kp`` A/(m/s), ``ki`` A/m; numbers, or arrays of one shape for a batch of controllers."""

    kp: float | np.ndarray
    ki: float | np.ndarray
    #: the parameters' names and units, in the order of ``parameters``
    NAMES: ClassVar[tuple[str, str]] = ("kp", "ki")
    UNITS: ClassVar[tuple[str, str]] = ("A/(m/s)", "A/m")

    def __post_init__(self):
        for name in self.NAMES:
            value = getattr(self, name)
            if isinstance(value, np.ndarray) and value.ndim > 0:
                if value.dtype.kind not in "iuf" or not np.all(np.isfinite(value)) or np.any(value < 0):
                    raise ParameterError(f"{name}: a batch of gains must be finite and non-negative")
                continue
            object.__setattr__(self, name, check_number(name, value, minimum=0.0))

    @classmethod
    def of(cls, parameters) -> PI:
        """From ``parameters`` = (kp, ki)."""
        kp, ki = parameters
        return cls(float(kp), float(ki))

    @classmethod
    def given(cls, bounds) -> PI | None:
        """The gains a spec gives (``controller.kp.value``, ``controller.ki.value`` of a
        ``design.problem.ControllerBounds``), None when either is not given."""
        kp, ki = bounds.kp.value, bounds.ki.value
        return None if kp is None or ki is None else cls(float(kp), float(ki))

    @property
    def parameters(self) -> np.ndarray:
        """(kp, ki) as an array (A/(m/s), A/m)."""
        return np.array([self.kp, self.ki], float)

    def gains(self) -> dict[str, float]:
        """The gains by name (A/(m/s), A/m)."""
        return {"kp": float(self.kp), "ki": float(self.ki)}

    def at(self, s) -> np.ndarray:
        """C(s) at complex ``s``: (..., n) for gains of shape (...)."""
        return np.asarray(self.kp)[..., None] + np.asarray(self.ki)[..., None] / np.asarray(s)

    def frd(self, w_rad_s) -> np.ndarray:
        """C(jw) on the grid ``w_rad_s`` (rad/s)."""
        return self.at(1j * np.asarray(w_rad_s, float))

    def tf(self) -> control.TransferFunction:
        """(Kp s + Ki) / s as a python-control transfer function (Kp alone without integral action: no s / s)."""
        import control

        if float(self.ki) == 0:
            return control.tf([float(self.kp)], [1.0])
        return control.tf([float(self.kp), float(self.ki)], [1.0, 0.0])

    def discrete(self, period_s: float) -> control.TransferFunction:
        """The PI a drive runs every ``period_s``: Kp + Ki T / 2 (z + 1) / (z - 1), the integral by the trapezoidal
        rule (Tustin's transform of Ki / s)."""
        import control

        if not (math.isfinite(period_s) and period_s > 0):
            raise ParameterError(f"period_s: a loop period must be finite and positive, got {period_s}")
        c = float(self.ki) * period_s / 2
        return control.tf([float(self.kp) + c, c - float(self.kp)], [1.0, -1.0], period_s)

    def __str__(self) -> str:
        return f"Kp = {float(self.kp):.4g} A/(m/s), Ki = {float(self.ki):.4g} A/m"
