"""A drive's compensation table from a fitted time-domain model with position-dependent motor forces.

With the force constant K(x) = K (1 + d(x)) (``force_constant_profile``) and the force F_r(x) the motor
must supply on top of the rigid body (``force_ripple``, a cable's ``cable_force``), a current command i_cmd
that a controller computes for an ideal motor of constant K becomes

    i = s(x) i_cmd + o(x),    s(x) = 1 / (1 + d(x)),    o(x) = F_r(x) / (K (1 + d(x)))

so that K(x) i = K i_cmd + F_r(x): the stage then moves as the rigid body the controller was designed for.
The table holds s (dimensionless) and o (A) on a grid over the travel the recording covered (outside it
the fit says nothing); a drive interpolates linearly. The predicted error reduction is the rms over the
recording of the force the table removes against the fitted model's residual.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from plant.errors import ParameterError
from plant.host.files import atomic_write_text
from plant.identify.time_fit import TimeFitResult

#: grid points of the table: four per ripple pitch at least, and at least this many
MIN_POINTS = 201


@dataclass(frozen=True)
class CompensationTable:
    """Current scale and offset by position (module doc), and what the fit predicts they remove."""

    position_m: np.ndarray
    current_scale: np.ndarray
    current_offset_a: np.ndarray
    force_constant_n_per_a: float
    #: rms over the recording of the position-dependent force the table removes (N)
    removed_rms_n: float
    #: the fitted model's residual rms (N): what is left
    residual_rms_n: float

    def current(self, command_a, position_m) -> np.ndarray:
        """The compensated current (A) for commands ``command_a`` at ``position_m`` (linear interpolation)."""
        s = np.interp(position_m, self.position_m, self.current_scale)
        o = np.interp(position_m, self.position_m, self.current_offset_a)
        return s * np.asarray(command_a, float) + o

    def csv_text(self) -> str:
        head = (f"# gantry compensation table: i = current_scale * i_cmd + current_offset_a; force constant "
                f"{self.force_constant_n_per_a:g} N/A; removes {self.removed_rms_n:.3g} N rms, leaves "
                f"{self.residual_rms_n:.3g} N rms\nposition_m,current_scale,current_offset_a\n")
        return head + "".join(f"{x:.9g},{s:.9g},{o:.9g}\n" for x, s, o in
                              zip(self.position_m, self.current_scale, self.current_offset_a))

    def write(self, path: str | Path) -> None:
        atomic_write_text(path, self.csv_text())


def compensation_table(fit: TimeFitResult, position_m: np.ndarray) -> CompensationTable:
    """The table of ``fit`` (a time-domain fit whose plant holds a force that depends on the position:
    ``force_ripple``, ``force_constant_profile``, ``cable_force``) over the travel of ``position_m``, the
    positions at the fit's samples. Each such effect's force on the rails at motor force F is a(x) + c(x) F
    (``rail_force_n``, with its ground spring ``rail_stiffness``): F_r = -a and d = c."""
    along = [e for e in fit.plant.effects if e.needs_position and e.rail_force]
    if not along:
        raise ParameterError("the selected model has no position-dependent force (force_ripple, "
                             "force_constant_profile, cable_force): there is nothing to compensate")
    position_m = np.asarray(position_m, float)
    if position_m.shape != fit.measured.shape:
        raise ParameterError(f"{position_m.size} positions for a fit of {fit.measured.size} samples")
    lo, hi = float(position_m.min()), float(position_m.max())
    pitches = [e.pitch_m for e in along if hasattr(e, "pitch_m")]
    n = max([MIN_POINTS] + [int(np.ceil(4 * (hi - lo) / p)) + 1 for p in pitches])
    x = np.linspace(lo, hi, n)
    k = float(fit.plant.force_constant_n_per_a)

    def along_travel(xs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(F_r, K(x) / K) at ``xs``: minus the rails' force without a motor force, and 1 + its part per newton."""
        a, c = (np.array([sum(e.rail_force_n(float(xi), 0.0, motor_n) - float(e.rail_stiffness()) * xi for e in along)
                          for xi in xs]) for motor_n in (0.0, 1.0))
        return -a, 1.0 + c - a

    force, factor = along_travel(x)
    force_at, factor_at = along_travel(position_m)
    # uncompensated, the motor's force differs from the ideal K i by K d(x) i - F_r(x)
    error = (factor_at - 1) * fit.measured - force_at
    return CompensationTable(x, 1 / factor, force / (k * factor), k, float(np.sqrt(np.mean(error**2))),
                             float(fit.rms_residual))
