"""Effects of the drive and sensor chain: dimensionless factors in series with the mechanics.

Drive (current command -> motor force): ``delay``, ``current_loop``, ``sampling``.
Sensor (moving mass -> recorded velocity): ``sensor_filter``, ``encoder_velocity``.
Each factor is one formula of ``s`` shared by NumPy and casadi (``plant.physics.algebra``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from plant.physics.algebra import NUMPY
from plant.physics.effect_base import PADE_ORDER, ChainEffect, phase_delay_s, scalar, series_tf
from plant.physics.parameters import check_batch, check_positive
from plant.physics.state_space import StateSpace, column, pade_polys, tf_ss, unity

if TYPE_CHECKING:
    import control

#: coarse grid of equivalent delays (s) tried besides the data's phase slope
DELAY_GRID_S = (1e-4, 3e-4, 1e-3, 3e-3)
#: an effect's corner this high (Hz) is far above any recorded band: the effect has vanished
VANISHED_HZ = 1.0e12


def _delay_starts(w_rad_s, ratio) -> list[float]:
    """Equivalent delays (s) to start from: the data's phase slope (and half and twice it), a coarse grid."""
    tau = phase_delay_s(w_rad_s, ratio)
    seen = [tau * k for k in (0.5, 1.0, 2.0)] if tau > 0 else []
    return seen + list(DELAY_GRID_S)


def _pade_tf(seconds: float, order: int) -> control.TransferFunction:
    import control

    if seconds == 0:
        return control.tf([1.0], [1.0])
    num, den = control.pade(seconds, order)
    return control.tf(num, den)


@dataclass(frozen=True)
class Delay(ChainEffect):
    """Pure transport delay e^(-s*tau), tau = ``seconds`` (amplifier, bus, filtering)."""

    seconds: float = 0.001
    name: ClassVar[str] = "delay"
    realised_as: ClassVar[str] = "applied"
    bounds: ClassVar = {"seconds": (0.0, 0.02, "s")}
    place: ClassVar[str] = "drive"
    limits_bandwidth: ClassVar[bool] = True
    signature: ClassVar[str] = "phase error growing linearly with frequency, magnitude unchanged"
    main_parameter: ClassVar[str] = "seconds"
    neutral: ClassVar = {"seconds": 0.0}
    complexity: ClassVar[int] = 0

    def __post_init__(self) -> None:
        check_positive("delay.seconds", self.seconds, allow_zero=True)
        check_batch("delay.seconds", self.seconds)

    def response(self, s, ops=NUMPY):
        return ops.exp_product(s, np.asarray(self.seconds) if ops is NUMPY else float(self.seconds))

    def to_tf(self, *, pade_order: int = PADE_ORDER) -> control.TransferFunction:
        return _pade_tf(scalar(self, "seconds"), pade_order)

    def state_space(self, n: int, *, pade_order: int = PADE_ORDER) -> StateSpace:
        """The Pade approximant realised once in the dimensionless s tau and scaled by each plant's tau (a plant
        without delay: the all-pass's feedthrough alone)."""
        tau = column(self.seconds, n)
        if np.all(tau == 0):
            return unity(n)
        unit = tf_ss(*pade_polys(1.0, pade_order))
        t = np.where(tau > 0, tau, 1.0)[:, None, None]
        A, B = unit.A[None] / t, unit.B[None] / t
        C = np.broadcast_to(unit.C, (n, *unit.C.shape))
        D = np.broadcast_to(unit.D, (n, 1, 1)).copy()
        zero = tau == 0
        B, C = np.where(zero[:, None, None], 0.0, B), np.where(zero[:, None, None], 0.0, C)
        D[zero] = 1.0
        return StateSpace(A, B, C, D)

    def guesses(self, w_rad_s, ratio) -> list[dict[str, float]]:
        return [{"seconds": t} for t in _delay_starts(w_rad_s, ratio)]

    def equivalent_delay_s(self) -> float:
        return float(np.mean(self.seconds))


@dataclass(frozen=True)
class CurrentLoop(ChainEffect):
    """Inner current loop as a first-order lag w_c/(s + w_c), w_c = 2*pi*``bandwidth_hz``.

    ``from_motor`` derives the bandwidth from the winding (R_s, L_s, thesis Eq. 2.23-2.24)
    and the current PI gains; see ``plant.physics.motor.current_loop_tf`` for the exact loop.
    """

    bandwidth_hz: float = 1000.0
    name: ClassVar[str] = "current_loop"
    bounds: ClassVar = {"bandwidth_hz": (1.0, VANISHED_HZ, "Hz")}
    place: ClassVar[str] = "drive"
    limits_bandwidth: ClassVar[bool] = True
    signature: ClassVar[str] = "phase lag with a small magnitude roll-off towards high frequency"
    main_parameter: ClassVar[str] = "bandwidth_hz"
    neutral: ClassVar = {"bandwidth_hz": VANISHED_HZ}
    complexity: ClassVar[int] = 1

    def __post_init__(self) -> None:
        self._check_positive()

    @classmethod
    def from_motor(cls, *, resistance_ohm: float, inductance_h: float, kp_v_per_a: float,
                   ki_v_per_a_s: float) -> CurrentLoop:
        """First-order equivalent of the PI current loop of a winding (its exact -3 dB bandwidth)."""
        from plant.physics.motor import current_loop_bandwidth_hz

        return cls(current_loop_bandwidth_hz(resistance_ohm=resistance_ohm, inductance_h=inductance_h,
                                             kp_v_per_a=kp_v_per_a, ki_v_per_a_s=ki_v_per_a_s))

    def response(self, s, ops=NUMPY):
        wc = 2 * np.pi * (np.asarray(self.bandwidth_hz) if ops is NUMPY else float(self.bandwidth_hz))
        return wc / (s + wc)

    def to_tf(self, *, pade_order: int = PADE_ORDER) -> control.TransferFunction:
        import control

        wc = 2 * np.pi * scalar(self, "bandwidth_hz")
        return control.tf([wc], [1.0, wc])

    def state_space(self, n: int, *, pade_order: int = PADE_ORDER) -> StateSpace:
        """x' = w_c (u - x), y = x, per plant of the batch."""
        wc = 2 * math.pi * column(self.bandwidth_hz, n)[:, None, None]
        return StateSpace(-wc, wc, np.ones((n, 1, 1)), np.zeros((n, 1, 1)))

    def guesses(self, w_rad_s, ratio) -> list[dict[str, float]]:
        return [{"bandwidth_hz": 1.0 / (2 * np.pi * t)} for t in _delay_starts(w_rad_s, ratio)]

    def equivalent_delay_s(self) -> float:
        return float(np.mean(1.0 / (2 * np.pi * np.asarray(self.bandwidth_hz))))


SAMPLING_PADE_ORDER = 3


@dataclass(frozen=True)
class Sampling(ChainEffect):
    """Digital loop at ``rate_hz``: zero-order hold (1 - e^(-sT))/(sT) times one sample
    of computation delay e^(-sT), T = 1/rate_hz. Rational form: the same expression with e^(-sT)
    replaced by its Pade approximant N/D, i.e. (D - N)/(s T D) * N/D (D - N vanishes at s = 0,
    so the division by s is exact); it keeps the hold's magnitude droop sinc(wT/2), which a
    Pade of the 1.5 T equivalent delay would drop (0.1-0.2 deg of phase margin at crossover).
    The Pade order is 1 to ``SAMPLING_PADE_ORDER`` (3): exact to 2e-5 up to wT = 1, and the
    loop's polynomials stay within what python-control's polynomial margins can take (order 6
    here and for a delay overflows ``stability_margins``)."""

    rate_hz: float = 10000.0
    name: ClassVar[str] = "sampling"
    realised_as: ClassVar[str] = "applied"
    bounds: ClassVar = {"rate_hz": (10.0, VANISHED_HZ, "Hz")}
    place: ClassVar[str] = "drive"
    limits_bandwidth: ClassVar[bool] = True
    signature: ClassVar[str] = "phase lag linear in frequency (1.5 sample periods) with a slight sinc magnitude droop"
    main_parameter: ClassVar[str] = "rate_hz"
    neutral: ClassVar = {"rate_hz": VANISHED_HZ}
    complexity: ClassVar[int] = 1

    def __post_init__(self) -> None:
        self._check_positive()

    def response(self, s, ops=NUMPY):
        sT = s / (np.asarray(self.rate_hz) if ops is NUMPY else float(self.rate_hz))
        return -ops.expm1(-sT) / sT * ops.exp(-sT)

    def to_tf(self, *, pade_order: int = PADE_ORDER) -> control.TransferFunction:
        import control

        T = 1.0 / scalar(self, "rate_hz")
        num, den = (np.asarray(p, float) for p in control.pade(T, min(max(pade_order, 1), SAMPLING_PADE_ORDER)))
        hold = control.tf(np.polysub(den, num)[:-1], T * den)   # (D - N) / (s T D)
        return series_tf(hold, control.tf(num, den))

    def guesses(self, w_rad_s, ratio) -> list[dict[str, float]]:
        return [{"rate_hz": 1.5 / t} for t in _delay_starts(w_rad_s, ratio)]

    def equivalent_delay_s(self) -> float:
        return float(np.mean(1.5 / np.asarray(self.rate_hz)))


@dataclass(frozen=True)
class SensorFilter(ChainEffect):
    """Second-order low-pass on the measured velocity (a drive's velocity filter; Copley's default
    is a 2-pole Butterworth): w_n^2 / (s^2 + 2 zeta w_n s + w_n^2), w_n = 2*pi*``frequency_hz``.
    Below its corner it is a delay of 2 zeta / w_n with a magnitude flat to fourth order (Butterworth),
    so only data near the corner tell it from a pure delay. The model search holds
    ``damping_ratio`` at 1/sqrt(2)."""

    frequency_hz: float = 200.0
    damping_ratio: float = 1 / math.sqrt(2)
    name: ClassVar[str] = "sensor_filter"
    bounds: ClassVar = {"frequency_hz": (1.0, VANISHED_HZ, "Hz"), "damping_ratio": (0.05, 2.0, "")}
    place: ClassVar[str] = "sensor"
    limits_bandwidth: ClassVar[bool] = True
    signature: ClassVar[str] = ("phase lag growing with frequency, magnitude flat until it drops "
                                "near the filter corner")
    main_parameter: ClassVar[str] = "frequency_hz"
    neutral: ClassVar = {"frequency_hz": VANISHED_HZ}
    search_fixed: ClassVar = ("damping_ratio",)

    def __post_init__(self) -> None:
        self._check_positive()

    def response(self, s, ops=NUMPY):
        num = (lambda v: np.asarray(v)) if ops is NUMPY else float
        wn = 2 * np.pi * num(self.frequency_hz)
        z = num(self.damping_ratio)
        return wn**2 / (s * s + 2 * z * wn * s + wn**2)

    def to_tf(self, *, pade_order: int = PADE_ORDER) -> control.TransferFunction:
        import control

        wn = 2 * np.pi * scalar(self, "frequency_hz")
        return control.tf([wn**2], [1.0, 2 * scalar(self, "damping_ratio") * wn, wn**2])

    def guesses(self, w_rad_s, ratio) -> list[dict[str, float]]:
        z = float(np.mean(self.damping_ratio))
        return [{"frequency_hz": 2 * z / (2 * np.pi * t)} for t in _delay_starts(w_rad_s, ratio)]

    def equivalent_delay_s(self) -> float:
        return float(np.mean(2 * np.asarray(self.damping_ratio) / (2 * np.pi * np.asarray(self.frequency_hz))))


@dataclass(frozen=True)
class EncoderVelocity(ChainEffect):
    """Velocity by differencing an encoder position at ``rate_hz``: v_k = (x_k - x_(k-1)) * rate,
    whose response to a sinusoid is (1 - e^(-sT)) / (sT), T = 1/rate_hz: half a sample of delay and
    the sinc droop sinc(wT/2). A property of the sensor, set from the recording (its velocity on a
    lattice of encoder steps), not searched for."""

    rate_hz: float = 2000.0
    name: ClassVar[str] = "encoder_velocity"
    realised_as: ClassVar[str] = "approximate"
    bounds: ClassVar = {"rate_hz": (10.0, VANISHED_HZ, "Hz")}
    place: ClassVar[str] = "sensor"
    limits_bandwidth: ClassVar[bool] = True
    signature: ClassVar[str] = "half a sample of delay with the sinc droop of a difference quotient"
    main_parameter: ClassVar[str] = "rate_hz"
    neutral: ClassVar = {"rate_hz": VANISHED_HZ}
    searched: ClassVar[bool] = False
    not_searched: ClassVar[str] = "a property of the sensor, set from the recording, not searched for"

    def __post_init__(self) -> None:
        self._check_positive()

    def response(self, s, ops=NUMPY):
        sT = s / (np.asarray(self.rate_hz) if ops is NUMPY else float(self.rate_hz))
        return -ops.expm1(-sT) / sT

    def to_tf(self, *, pade_order: int = PADE_ORDER) -> control.TransferFunction:
        import control

        T = 1.0 / scalar(self, "rate_hz")
        num, den = (np.asarray(p, float) for p in control.pade(T, min(max(pade_order, 1), SAMPLING_PADE_ORDER)))
        return control.tf(np.polysub(den, num)[:-1], T * den)

    def equivalent_delay_s(self) -> float:
        return float(np.mean(0.5 / np.asarray(self.rate_hz)))
