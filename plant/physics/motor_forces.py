"""Forces of a linear motor and its drive: force ripple (cogging) periodic in the magnet pitch, a force
constant that varies along the magnet track (end effects), and the drive's current limit.

The first two depend on where the carriage is; they are time-domain effects: a frequency response at one
operating point averages them away, so they are fitted from recordings with the position
(``plant.identify.time_fit``), where the inverse model is linear in their amplitudes. Their shape fields
(the ripple's pitch, the profile's centre and half span) are set from the recording by ``configured`` and
held by the fit.

* ``ForceRipple``: F_r(x) = sum_k a_k sin(2 pi k x / p) + b_k cos(2 pi k x / p), k = 1, 2 (N), the force
  the motor must supply on top of the rigid body where the carriage is (a cogging force pulling against
  the motor is positive, as friction and ``offset``): iron-core motors' cogging and the ripple of the
  commutation at the pole pitch p. The pitch is found from the residual's spectrum over position and
  refined by profile least squares in the fit (``profiled``).
* ``ForceConstantProfile``: K(x) = K (1 + c1 u + c2 u^2), u = (x - centre) / half_span (c1 ``slope``,
  c2 ``curvature``): the motor force K(x) u_drive; with K u_drive on the left of the inverse model, its
  columns are minus the motor force times u and u^2 (exact, not a linearisation).
* ``CurrentLimit``: the drive clips its current command at a limit (its peak current; a drive logs the
  command, not what the amplifier delivered), so the motor force is F - c (F - clip(F, -F_L, F_L)) with
  F = K_f u the commanded force, F_L ``limit_n`` and c ``fraction_lost`` (1: a hard clip). In the time domain
  this is exact, and linear in c once F_L is set: F_L from the residual (``configured``), refined by profile
  least squares. For a sine of force amplitude A the first harmonic of the clipped force is N(A) A with the
  describing function N = 1 - c + c (2 / pi) (asin r + r sqrt(1 - r^2)), r = F_L / A < 1 (Gelb & Vander
  Velde 1968); the plant after the clip being linear, a stepped sine's fundamental is exactly N(A) times
  the linear response.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from plant.errors import EffectError, ParameterError
from plant.physics.effect_base import FitSamples, ForceSignals, MechanicalEffect
from plant.physics.parameters import check_finite, check_positive

#: points of the uniform position grid on which a residual's spectrum over position is taken
POSITION_GRID = 256
#: trial pitches between the spectrum's neighbouring lines around its peak
PITCH_REFINE = 41


def periodic_pitch(position_m: np.ndarray, residual: np.ndarray) -> tuple[float, int]:
    """The pitch (m) of the strongest periodic pattern of ``residual`` over position, and the number of
    pitches searched: the peak of the spectrum of the residual's bin means on a uniform grid of
    ``POSITION_GRID`` points over the travel covered (2 to a quarter of the grid cycles), refined between its
    neighbouring lines by least squares; (nan, 0) when the travel is too short or too sparsely covered."""
    x = np.asarray(position_m, float)
    lo, hi = float(x.min()), float(x.max())
    if not hi > lo:
        return float("nan"), 0
    idx = np.clip(((x - lo) / (hi - lo) * POSITION_GRID).astype(int), 0, POSITION_GRID - 1)
    counts = np.bincount(idx, minlength=POSITION_GRID)
    if np.count_nonzero(counts) < POSITION_GRID // 2:
        return float("nan"), 0
    means = np.bincount(idx, weights=residual, minlength=POSITION_GRID) / np.maximum(counts, 1)
    spectrum = np.abs(np.fft.rfft(means * (counts > 0)))[2:POSITION_GRID // 4]
    k = int(np.argmax(spectrum)) + 2

    def explained(cycles: float) -> float:
        phase = 2 * np.pi * cycles * (x - lo) / (hi - lo)
        basis = np.column_stack([np.sin(phase), np.cos(phase)])
        return float(np.linalg.norm(basis @ np.linalg.lstsq(basis, residual, rcond=None)[0]))

    cycles = max(np.linspace(k - 1, k + 1, PITCH_REFINE), key=explained)
    return (hi - lo) / cycles, spectrum.size


def _position(effect: str, signals: ForceSignals) -> np.ndarray:
    if signals.position_m is None:
        raise EffectError(f"{effect} depends on the position: the recording has velocity only")
    return np.asarray(signals.position_m, float)


@dataclass(frozen=True)
class ForceRipple(MechanicalEffect):
    """Force periodic in position (module doc): fundamental and 2nd harmonic of pitch ``pitch_m``."""

    pitch_m: float = 0.03
    sin1_n: float = 0.0
    cos1_n: float = 0.0
    sin2_n: float = 0.0
    cos2_n: float = 0.0
    name: ClassVar[str] = "force_ripple"
    realised_as: ClassVar[str] = "force"
    bounds: ClassVar = {"pitch_m": (1e-4, 1.0, "m"), "sin1_n": (-1000.0, 1000.0, "N"),
                        "cos1_n": (-1000.0, 1000.0, "N"), "sin2_n": (-1000.0, 1000.0, "N"),
                        "cos2_n": (-1000.0, 1000.0, "N")}
    signature: ClassVar[str] = "a residual force periodic in position (cogging, commutation ripple)"
    main_parameter: ClassVar[str] = "sin1_n"
    neutral: ClassVar = {"sin1_n": 0.0, "cos1_n": 0.0, "sin2_n": 0.0, "cos2_n": 0.0}
    search_fixed: ClassVar = ("pitch_m",)
    profiled: ClassVar = {"pitch_m": 0.05}
    residual_signature: ClassVar = "position, periodic"
    searched: ClassVar[bool] = False
    not_searched: ClassVar[str] = ("a force that depends on the position averages out of a frequency response; "
                                   "fitted from time-domain recordings with the position")
    in_synthesis: ClassVar[bool] = False
    time_domain: ClassVar[bool] = True
    needs_position: ClassVar[bool] = True
    simulated: ClassVar[bool] = False

    def __post_init__(self) -> None:
        check_positive("force_ripple.pitch_m", self.pitch_m)
        for field in ("sin1_n", "cos1_n", "sin2_n", "cos2_n"):
            check_finite(f"force_ripple.{field}", getattr(self, field))

    def amplitude_n(self, harmonic: int = 1) -> float:
        """Amplitude (N) of harmonic 1 or 2."""
        return float(np.hypot(*((self.sin1_n, self.cos1_n) if harmonic == 1 else (self.sin2_n, self.cos2_n))))

    rail_force: ClassVar[bool] = True

    def rail_force_n(self, position_m: float, velocity_m_per_s: float, motor_force_n: float) -> float:
        return -float(self.force(position_m))

    def force(self, position_m) -> np.ndarray:
        """F_r (N) at ``position_m``: the force the motor must supply there (module doc)."""
        phase = 2 * np.pi * np.asarray(position_m, float) / self.pitch_m
        return (self.sin1_n * np.sin(phase) + self.cos1_n * np.cos(phase) + self.sin2_n * np.sin(2 * phase)
                + self.cos2_n * np.cos(2 * phase))

    def force_regressors(self, signals: ForceSignals) -> dict[str, np.ndarray]:
        phase = 2 * np.pi * _position(self.name, signals) / self.pitch_m
        return {"sin1_n": np.sin(phase), "cos1_n": np.cos(phase), "sin2_n": np.sin(2 * phase),
                "cos2_n": np.cos(2 * phase)}

    def configured(self, samples: FitSamples, residual_n) -> ForceRipple:
        if samples.position_m is None:
            return self
        pitch, _ = periodic_pitch(samples.position_m, residual_n)
        return replace(self, pitch_m=pitch) if np.isfinite(pitch) else self


@dataclass(frozen=True)
class ForceConstantProfile(MechanicalEffect):
    """A force constant varying along the travel (module doc): K(x) = K (1 + c1 u + c2 u^2)."""

    centre_m: float = 0.0
    half_span_m: float = 0.1
    slope: float = 0.0
    curvature: float = 0.0
    name: ClassVar[str] = "force_constant_profile"
    realised_as: ClassVar[str] = "force"
    bounds: ClassVar = {"centre_m": (-10.0, 10.0, "m"), "half_span_m": (1e-4, 10.0, "m"),
                        "slope": (-0.9, 0.9, "1"), "curvature": (-0.9, 0.9, "1")}
    signature: ClassVar[str] = "a residual proportional to the current times the position (magnet track's ends)"
    main_parameter: ClassVar[str] = "curvature"
    neutral: ClassVar = {"slope": 0.0, "curvature": 0.0}
    search_fixed: ClassVar = ("centre_m", "half_span_m")
    residual_signature: ClassVar = "current x position"
    searched: ClassVar[bool] = False
    not_searched: ClassVar[str] = ForceRipple.not_searched
    in_synthesis: ClassVar[bool] = False
    time_domain: ClassVar[bool] = True
    needs_position: ClassVar[bool] = True
    simulated: ClassVar[bool] = False

    def __post_init__(self) -> None:
        check_positive("force_constant_profile.half_span_m", self.half_span_m)
        for field in ("centre_m", "slope", "curvature"):
            check_finite(f"force_constant_profile.{field}", getattr(self, field))

    rail_force: ClassVar[bool] = True

    def rail_force_n(self, position_m: float, velocity_m_per_s: float, motor_force_n: float) -> float:
        """The motor's force K i (with the nominal K) scaled by the profile: the difference K i (K(x) / K - 1)."""
        return motor_force_n * (float(self.factor(position_m)) - 1.0)

    def factor(self, position_m) -> np.ndarray:
        """K(x) / K at ``position_m``."""
        u = (np.asarray(position_m, float) - self.centre_m) / self.half_span_m
        return 1.0 + self.slope * u + self.curvature * u**2

    def force_regressors(self, signals: ForceSignals) -> dict[str, np.ndarray]:
        u = (_position(self.name, signals) - self.centre_m) / self.half_span_m
        # K u_drive (1 + c1 u + c2 u^2) = m a + b v + ...: with K u_drive on the left, exactly
        return {"slope": -signals.force_n * u, "curvature": -signals.force_n * u**2}

    def configured(self, samples: FitSamples, residual_n) -> ForceConstantProfile:
        if samples.position_m is None:
            return self
        lo, hi = float(np.min(samples.position_m)), float(np.max(samples.position_m))
        return replace(self, centre_m=(lo + hi) / 2, half_span_m=max((hi - lo) / 2, 1e-4)) if hi > lo else self


@dataclass(frozen=True)
class CurrentLimit(MechanicalEffect):
    """The drive's current limit (module doc): commanded force clipped at ``limit_n`` (N, K_f times the
    drive's peak current), ``fraction_lost`` of the command above it lost (1 for a hard clip)."""

    limit_n: float = 100.0
    fraction_lost: float = 1.0
    name: ClassVar[str] = "current_limit"
    realised_as: ClassVar[str] = "drive_limit"
    bounds: ClassVar = {"limit_n": (1e-3, 1e6, "N"), "fraction_lost": (0.0, 1.0, "1")}
    signature: ClassVar[str] = ("a motor force that falls short of the command at its largest values: odd "
                                "harmonics, and a gain that falls with the amplitude")
    main_parameter: ClassVar[str] = "fraction_lost"
    neutral: ClassVar = {"fraction_lost": 0.0}
    search_fixed: ClassVar = ("limit_n",)
    profiled: ClassVar = {"limit_n": 0.15}
    residual_signature: ClassVar = "motor force"
    linear: ClassVar[bool] = False
    searched: ClassVar[bool] = False
    not_searched: ClassVar[str] = ("at one amplitude a current limit is a gain that trades exactly with mass and "
                                   "damping; fitted from time-domain recordings")
    in_synthesis: ClassVar[bool] = False
    time_domain: ClassVar[bool] = True
    simulated: ClassVar[bool] = False
    #: trial limits of ``configured``, as fractions of the largest recorded |force| of the moving samples
    TRIALS: ClassVar = np.linspace(0.2, 1.0, 49)

    def __post_init__(self) -> None:
        check_positive("current_limit.limit_n", self.limit_n)
        check_finite("current_limit.fraction_lost", self.fraction_lost)
        if not 0.0 <= self.fraction_lost <= 1.0:
            raise ParameterError(f"current_limit.fraction_lost must lie in [0, 1] (1: a hard clip), got "
                                 f"{self.fraction_lost}")

    def delivered(self, force_n) -> np.ndarray:
        """The force (N) the motor delivers for the commanded ``force_n``."""
        f = np.asarray(force_n, float)
        return f - self.fraction_lost * (f - np.clip(f, -self.limit_n, self.limit_n))

    def describing_gain(self, force_amplitude_n) -> np.ndarray:
        """First harmonic of the delivered force per commanded amplitude, for sines of ``force_amplitude_n``."""
        a = np.asarray(force_amplitude_n, float)
        r = np.clip(self.limit_n / np.maximum(a, 1e-300), 0.0, 1.0)
        clipped = 2 / np.pi * (np.arcsin(r) + r * np.sqrt(1 - r**2))
        return 1.0 - self.fraction_lost + self.fraction_lost * clipped

    def force_regressors(self, signals: ForceSignals) -> dict[str, np.ndarray]:
        # K u = m a + b v + ... + c (K u - clip(K u)): the lost force on the right, exactly
        f = np.asarray(signals.force_n, float)
        return {"fraction_lost": f - np.clip(f, -self.limit_n, self.limit_n)}

    def configured(self, samples: FitSamples, residual_n) -> CurrentLimit:
        """The trial limit whose force lost by a hard clip, with mass, damping and a constant refitted to what
        remains (the parent's absorb part of a limit they do not model), leaves the residual smallest. The
        clip is held hard here: a soft one at a low limit trades with mass and damping."""
        f = np.asarray(samples.force_n, float)
        e = np.asarray(residual_n, float)
        known = np.column_stack([samples.acceleration_m_per_s2, samples.velocity_m_per_s, np.ones_like(f)])

        def remaining(limit: float) -> float:
            r = e - (f - np.clip(f, -limit, limit))
            return float(np.sum((r - known @ np.linalg.lstsq(known, r, rcond=None)[0]) ** 2))

        peak = float(np.max(np.abs(f))) if f.size else 0.0
        return replace(self, limit_n=float(min(self.TRIALS * peak, key=remaining))) if peak > 0 else self
