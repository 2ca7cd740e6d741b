"""Physical effects that the thesis model leaves out, each a small frozen dataclass.

Two kinds:

* ``SeriesEffect``: a dimensionless factor in series with the plant, with a pure
  vectorised ``frd(w_rad_s)`` and a rational ``to_tf()`` (Pade for delays):
  ``delay``, ``current_loop``, ``sampling``, ``resonance``.
* ``MechanicalEffect``: changes the mechanics itself and is evaluated by the plant:
  ``coulomb_friction`` (describing function / exact time-domain force) and
  ``tilt_coupling`` (the finite joint stiffness K_a of Xie & Wang, Stage Y only).

Parameters may be floats or NumPy arrays that broadcast against the frequency axis
(e.g. shape ``(n, 1)`` for a Monte Carlo batch). Parameter names and units follow
``shared/ARCHITECTURE.md``: an effect parameter is written ``effect.parameter``.
"""

from __future__ import annotations

import abc
import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from plant.errors import EffectError, ParameterError
from plant.parameters import Parameter, check_positive

if TYPE_CHECKING:
    import control

#: default Pade order used when a delay is turned into a rational model
PADE_ORDER = 6


class Effect(abc.ABC):
    """Base of all effects: a name, bounded parameters and ``with_values``."""

    name: ClassVar[str]
    #: parameter name -> (lower, upper, unit): physically plausible bounds used by fits
    bounds: ClassVar[dict[str, tuple[float, float, str]]]

    def parameters(self) -> dict[str, Parameter]:
        """The effect's parameters, keyed ``effect.parameter``."""
        out = {}
        for field, (lo, hi, unit) in self.bounds.items():
            value = float(np.mean(getattr(self, field)))
            key = f"{self.name}.{field}"
            out[key] = Parameter(key, value, lo, hi, unit=unit)
        return out

    def with_values(self, **values: float) -> Effect:
        unknown = set(values) - set(self.bounds)
        if unknown:
            raise EffectError(f"effect {self.name} has no parameter {sorted(unknown)[0]!r}; known: {sorted(self.bounds)}")
        return dataclasses.replace(self, **values)

    def _check_positive(self) -> None:
        for field in self.bounds:
            check_positive(f"{self.name}.{field}", getattr(self, field))


class SeriesEffect(Effect):
    """A dimensionless factor in series with the plant (unity gain at DC)."""

    @abc.abstractmethod
    def frd(self, w_rad_s) -> np.ndarray:
        """Complex frequency response of the factor at ``w_rad_s`` (rad/s)."""

    @abc.abstractmethod
    def to_tf(self, *, pade_order: int = PADE_ORDER) -> control.TransferFunction:
        """A rational python-control realisation (Pade for pure delays)."""


class MechanicalEffect(Effect):
    """An effect that changes the mechanics; the plant evaluates it."""


def _scalar(effect: Effect, field: str) -> float:
    value = np.asarray(getattr(effect, field), dtype=float)
    if value.size != 1:
        raise EffectError(f"{effect.name}.{field} is a batch of {value.size} values; a rational model needs one value")
    return float(value.reshape(()))


def _pade_tf(seconds: float, order: int) -> control.TransferFunction:
    import control

    if seconds == 0:
        return control.tf([1.0], [1.0])
    num, den = control.pade(seconds, order)
    return control.tf(num, den)


@dataclass(frozen=True)
class Delay(SeriesEffect):
    """Pure transport delay e^(-s*tau), tau = ``seconds`` (amplifier, bus, filtering)."""

    seconds: float = 0.001
    name: ClassVar[str] = "delay"
    bounds: ClassVar = {"seconds": (0.0, 0.02, "s")}

    def __post_init__(self) -> None:
        check_positive("delay.seconds", self.seconds, allow_zero=True)

    def frd(self, w_rad_s) -> np.ndarray:
        return np.exp(-1j * np.asarray(w_rad_s) * np.asarray(self.seconds))

    def to_tf(self, *, pade_order: int = PADE_ORDER) -> control.TransferFunction:
        return _pade_tf(_scalar(self, "seconds"), pade_order)


@dataclass(frozen=True)
class CurrentLoop(SeriesEffect):
    """Inner current loop as a first-order lag w_c/(s + w_c), w_c = 2*pi*``bandwidth_hz``.

    ``from_motor`` derives the bandwidth from the winding (R_s, L_s, thesis Eq. 2.23-2.24)
    and the current PI gains; see ``plant.motor.current_loop_tf`` for the exact loop.
    """

    bandwidth_hz: float = 1000.0
    name: ClassVar[str] = "current_loop"
    bounds: ClassVar = {"bandwidth_hz": (1.0, 1.0e5, "Hz")}

    def __post_init__(self) -> None:
        self._check_positive()

    @classmethod
    def from_motor(cls, *, resistance_ohm: float, inductance_h: float, kp_v_per_a: float, ki_v_per_a_s: float) -> CurrentLoop:
        """First-order equivalent of the PI current loop of a winding (its exact -3 dB bandwidth)."""
        from plant.motor import current_loop_bandwidth_hz

        return cls(current_loop_bandwidth_hz(resistance_ohm=resistance_ohm, inductance_h=inductance_h,
                                             kp_v_per_a=kp_v_per_a, ki_v_per_a_s=ki_v_per_a_s))

    def frd(self, w_rad_s) -> np.ndarray:
        wc = 2 * np.pi * np.asarray(self.bandwidth_hz)
        return wc / (1j * np.asarray(w_rad_s) + wc)

    def to_tf(self, *, pade_order: int = PADE_ORDER) -> control.TransferFunction:
        import control

        wc = 2 * np.pi * _scalar(self, "bandwidth_hz")
        return control.tf([wc], [1.0, wc])


SAMPLING_PADE_ORDER = 3


@dataclass(frozen=True)
class Sampling(SeriesEffect):
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
    bounds: ClassVar = {"rate_hz": (10.0, 1.0e6, "Hz")}

    def __post_init__(self) -> None:
        self._check_positive()

    def frd(self, w_rad_s) -> np.ndarray:
        sT = 1j * np.asarray(w_rad_s) / np.asarray(self.rate_hz)
        return -np.expm1(-sT) / sT * np.exp(-sT)

    def to_tf(self, *, pade_order: int = PADE_ORDER) -> control.TransferFunction:
        import control

        T = 1.0 / _scalar(self, "rate_hz")
        num, den = (np.asarray(p, float) for p in control.pade(T, min(max(pade_order, 1), SAMPLING_PADE_ORDER)))
        hold = control.tf(np.polysub(den, num)[:-1], T * den)   # (D - N) / (s T D)
        return hold * control.tf(num, den)


@dataclass(frozen=True)
class Resonance(SeriesEffect):
    """Two-mass compliance between motor and payload, velocity sensed at the motor.

    Factor (s^2/wa^2 + 2 z s/wa + 1) / (s^2/wr^2 + 2 z s/wr + 1): an antiresonance
    (notch, ``antiresonance_hz`` = sqrt(k/m_load)/2pi) below the resonance peak
    (``frequency_hz`` = sqrt(k (m_motor + m_load)/(m_motor m_load))/2pi), both with
    ``damping_ratio``. Unity gain at DC, so the rigid-body plant is unchanged there.
    """

    frequency_hz: float = 50.0
    antiresonance_hz: float = 35.0
    damping_ratio: float = 0.05
    name: ClassVar[str] = "resonance"
    bounds: ClassVar = {
        "frequency_hz": (1.0, 5000.0, "Hz"),
        "antiresonance_hz": (0.5, 5000.0, "Hz"),
        "damping_ratio": (0.001, 1.0, ""),
    }

    def __post_init__(self) -> None:
        self._check_positive()
        if np.any(np.asarray(self.antiresonance_hz) >= np.asarray(self.frequency_hz)):
            raise ParameterError(
                "resonance.antiresonance_hz must lie below resonance.frequency_hz "
                "(velocity sensed at the motor of a two-mass system)"
            )

    @classmethod
    def from_two_mass(cls, *, motor_mass_kg: float, load_mass_kg: float, stiffness_n_per_m: float,
                      damping_ratio: float) -> Resonance:
        """Resonance of motor mass and load mass joined by a spring (closed forms above)."""
        for key, value in [("motor_mass_kg", motor_mass_kg), ("load_mass_kg", load_mass_kg),
                           ("stiffness_n_per_m", stiffness_n_per_m)]:
            check_positive(f"resonance.{key}", value)
        wa = math.sqrt(stiffness_n_per_m / load_mass_kg)
        wr = math.sqrt(stiffness_n_per_m * (motor_mass_kg + load_mass_kg) / (motor_mass_kg * load_mass_kg))
        return cls(wr / (2 * np.pi), wa / (2 * np.pi), damping_ratio)

    def frd(self, w_rad_s) -> np.ndarray:
        s = 1j * np.asarray(w_rad_s)
        wa = 2 * np.pi * np.asarray(self.antiresonance_hz)
        wr = 2 * np.pi * np.asarray(self.frequency_hz)
        z = np.asarray(self.damping_ratio)
        return (s**2 / wa**2 + 2 * z * s / wa + 1) / (s**2 / wr**2 + 2 * z * s / wr + 1)

    def to_tf(self, *, pade_order: int = PADE_ORDER) -> control.TransferFunction:
        import control

        wa = 2 * np.pi * _scalar(self, "antiresonance_hz")
        wr = 2 * np.pi * _scalar(self, "frequency_hz")
        z = _scalar(self, "damping_ratio")
        return control.tf([1 / wa**2, 2 * z / wa, 1.0], [1 / wr**2, 2 * z / wr, 1.0])


@dataclass(frozen=True)
class CoulombFriction(MechanicalEffect):
    """Coulomb friction of magnitude ``force_n`` opposing the velocity: F_f = force_n * sign(v).

    Frequency domain: its describing function at velocity amplitude V is a real damping
    N(V) = 4 F_c / (pi V) added to the mechanical impedance (the plant solves for V at
    the excitation current). Time domain: ``force(v)`` is exact.
    """

    force_n: float = 10.0
    name: ClassVar[str] = "coulomb_friction"
    bounds: ClassVar = {"force_n": (0.0, 1000.0, "N")}

    def __post_init__(self) -> None:
        check_positive("coulomb_friction.force_n", self.force_n, allow_zero=True)

    def describing_damping(self, velocity_amplitude_m_per_s) -> np.ndarray:
        """Equivalent damping 4 F_c/(pi V) in N*s/m at velocity amplitude V (m/s)."""
        v = np.asarray(velocity_amplitude_m_per_s, dtype=float)
        with np.errstate(divide="ignore"):
            return np.where(v > 0, 4 * np.asarray(self.force_n) / (np.pi * np.maximum(v, 1e-300)), np.inf)

    def force(self, velocity_m_per_s) -> np.ndarray:
        """Exact friction force (N) opposing motion at velocity v (sliding branch)."""
        return np.asarray(self.force_n) * np.sign(velocity_m_per_s)


@dataclass(frozen=True)
class TiltCoupling(MechanicalEffect):
    """Tilt of the Stage X beam about the load (Xie & Wang Eq. 2.14-2.15, finite joint stiffness).

    ``frequency_hz`` is the tilt mode's natural frequency sqrt(K_a/J); ``stiffness_n_m_per_rad``
    is K_a, from which the beam inertia J = K_a / (2 pi f)^2 follows. The mode is excited
    when the load sits off centre (load_position_m != motor_length_m / 2); Y1 and Y2 then
    disagree around it. Stage Y only.
    """

    frequency_hz: float = 40.0
    stiffness_n_m_per_rad: float = 2.0e5
    name: ClassVar[str] = "tilt_coupling"
    bounds: ClassVar = {"frequency_hz": (1.0, 2000.0, "Hz"), "stiffness_n_m_per_rad": (1.0, 1.0e9, "N*m/rad")}

    def __post_init__(self) -> None:
        self._check_positive()

    @property
    def inertia_kg_m2(self):
        return np.asarray(self.stiffness_n_m_per_rad) / (2 * np.pi * np.asarray(self.frequency_hz)) ** 2


EFFECTS: dict[str, type[Effect]] = {
    cls.name: cls for cls in (Delay, CurrentLoop, Sampling, Resonance, CoulombFriction, TiltCoupling)
}


def make_effect(name: str, **params: float) -> Effect:
    """Build an effect by its name (``delay``, ``current_loop``, ...) with keyword parameters."""
    try:
        cls = EFFECTS[name]
    except KeyError:
        raise EffectError(f"unknown effect {name!r}; known effects: {', '.join(EFFECTS)}") from None
    unknown = set(params) - set(cls.bounds)
    if unknown:
        raise EffectError(f"effect {name} has no parameter {sorted(unknown)[0]!r}; known: {', '.join(cls.bounds)}")
    try:
        return cls(**{k: float(v) if np.ndim(v) == 0 else v for k, v in params.items()})
    except (TypeError, ValueError) as exc:
        if isinstance(exc, ParameterError):
            raise
        raise ParameterError(f"effect {name}: {exc}") from None
