"""The mechanics as a lumped network of masses, springs and dampers, and its effects.

Stage X (and a centred Stage Y) is a chain of bodies: body 0 carries the motor force and the
rail damping b (thesis Eq. 3.15 / 3.16 when it is the only body); a mode effect splits the
last body in two, joined by a spring k and a damper c. The velocity is recorded at the motor
(``resonance``: antiresonance then resonance) or at the payload (``payload_resonance``: no
antiresonance, the phase falls by a further 180 deg); ``second_resonance`` splits the payload
again (three-mass chain). The response follows exactly from the network by its mechanical
impedance ladder (one formula of ``s`` for NumPy and casadi): for a body i with coupling
impedance Z_c = k/s + c to the rest of the chain,

    Z_i = m_i s + Z_c Z_(i+1) / (Z_c + Z_(i+1)),    v_(i+1) = v_i Z_c / (Z_c + Z_(i+1)),

and v_0 = F / (Z_0 + b). A mode is parameterised by the frequencies it shows (better
conditioned for fitting than masses and stiffnesses, and an exact reparameterisation): for a
body of mass m split into m_a (kept) and m_b (the new tail),

    f_a = sqrt(k / m_b) / 2pi (antiresonance, the tail on its spring with the rest held),
    f_r = sqrt(k / mu) / 2pi, mu = m_a m_b / m (resonance of the pair on its own),
    zeta = c / (2 sqrt(k mu)) (its damping ratio),

so m_a = m (f_a / f_r)^2, k = m_b (2 pi f_a)^2, c = 2 zeta sqrt(k mu). With a viscous
coupling the antiresonance's damping ratio is zeta f_a / f_r: pole and zero pairs are damped
differently, as in the physical two-mass stage. The network's own modes (``BodyChain.modes_hz``)
shift slightly from f_r with the rail damping and further bodies.

The Y rails with an off-centre load tilt (Xie & Wang, thesis Eq. 2.14-2.15): ``tilt_coupling``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from plant.errors import ParameterError
from plant.physics.effect_base import FitSamples, ForceSignals, MechanicalEffect
from plant.physics.parameters import check_finite, check_positive

#: a mode this high (Hz) is far above any recorded band: the bodies move as one
RIGID_HZ = 1.0e7
#: damping ratios tried for a mode before the fit (light to well damped)
ZETA_GRID = (0.01, 0.03, 0.1, 0.3)
#: antiresonance / resonance ratios tried when the data show no notch
SPLIT_GRID = (0.4, 0.7, 0.9)


def _local_extrema(y: np.ndarray, *, maxima: bool) -> np.ndarray:
    """Indices of interior local maxima (or minima) of y, most prominent first."""
    z = y if maxima else -y
    idx = np.flatnonzero((z[1:-1] > z[:-2]) & (z[1:-1] >= z[2:])) + 1
    prominence = z[idx] - np.minimum(np.minimum.accumulate(z)[idx], z.min())
    return idx[np.argsort(-prominence)]


def _band_grid_hz(f_hz: np.ndarray, n: int = 8) -> np.ndarray:
    """Log-spaced mode frequencies over the recorded band and a little above it."""
    return np.geomspace(max(f_hz[0] * 3, f_hz[0]), f_hz[-1] * 1.6, n)


@dataclass(frozen=True)
class ModeEffect(MechanicalEffect):
    """A compliance that splits the chain's last body (see module doc for the parameters)."""

    frequency_hz: float = 50.0
    antiresonance_hz: float = 35.0
    damping_ratio: float = 0.05
    bounds: ClassVar = {
        "frequency_hz": (1.0, RIGID_HZ, "Hz"),
        "antiresonance_hz": (0.5, RIGID_HZ, "Hz"),
        "damping_ratio": (0.001, 2.0, ""),
    }
    limits_bandwidth: ClassVar[bool] = True
    main_parameter: ClassVar[str] = "frequency_hz"
    in_band: ClassVar = ("frequency_hz",)
    neutral: ClassVar = {"frequency_hz": RIGID_HZ, "antiresonance_hz": 0.7 * RIGID_HZ}
    #: 1: splits the base body; 2: splits the payload of a first mode
    order: ClassVar[int] = 1
    #: where the velocity is recorded: "motor", "payload", or "" to keep the first mode's choice
    sensed: ClassVar[str] = "motor"

    def __post_init__(self) -> None:
        self._check_positive()
        if np.any(np.asarray(self.antiresonance_hz) >= np.asarray(self.frequency_hz)):
            raise ParameterError(
                f"{self.name}.antiresonance_hz must lie below {self.name}.frequency_hz "
                "(the tail on its spring is slower than the free pair)")

    @classmethod
    def from_two_mass(cls, *, motor_mass_kg: float, load_mass_kg: float, stiffness_n_per_m: float,
                      damping_ratio: float):
        """The mode of a motor mass and a load mass joined by a spring (closed forms of the module doc)."""
        for key, value in [("motor_mass_kg", motor_mass_kg), ("load_mass_kg", load_mass_kg),
                           ("stiffness_n_per_m", stiffness_n_per_m)]:
            check_positive(f"{cls.name}.{key}", value)
        wa = np.sqrt(stiffness_n_per_m / load_mass_kg)
        wr = np.sqrt(stiffness_n_per_m * (motor_mass_kg + load_mass_kg) / (motor_mass_kg * load_mass_kg))
        return cls(float(wr / (2 * np.pi)), float(wa / (2 * np.pi)), damping_ratio)

    def split(self, mass_kg):
        """(kept mass, tail mass, stiffness N/m, damper N*s/m) of a body of ``mass_kg``."""
        fr, fa, z = (np.asarray(v, float) for v in (self.frequency_hz, self.antiresonance_hz, self.damping_ratio))
        m_keep = mass_kg * (fa / fr) ** 2
        m_tail = mass_kg - m_keep
        k = m_tail * (2 * np.pi * fa) ** 2
        c = 2 * z * np.sqrt(k * m_keep * m_tail / mass_kg)
        return m_keep, m_tail, k, c

    def guesses(self, w_rad_s, ratio) -> list[dict[str, float]]:
        f = w_rad_s / (2 * np.pi)
        mag = 20 * np.log10(np.abs(np.mean(np.atleast_2d(ratio), axis=0)))
        peaks = [f[i] for i in _local_extrema(mag, maxima=True)[:3]]
        notches = _local_extrema(mag, maxima=False)
        out = []
        for fr in peaks + list(_band_grid_hz(f)):
            below = [f[i] for i in notches if f[i] < fr][:2]
            fas = below if below and self.sensed == "motor" else [fr * r for r in SPLIT_GRID]
            for fa in fas:
                for z in ZETA_GRID:
                    out.append({"frequency_hz": float(fr), "antiresonance_hz": float(min(fa, 0.98 * fr)),
                                "damping_ratio": z})
        return out


@dataclass(frozen=True)
class Resonance(ModeEffect):
    """Two-mass compliance between motor and payload, velocity recorded at the motor."""

    name: ClassVar[str] = "resonance"
    realised_as: ClassVar[str] = "state_space"
    signature: ClassVar[str] = ("a notch (antiresonance) then a peak (resonance) in magnitude, "
                                "with a phase lead then lag around them")
    excludes: ClassVar = ("payload_resonance", "tilt_coupling")
    sensed: ClassVar[str] = "motor"


@dataclass(frozen=True)
class PayloadResonance(ModeEffect):
    """Two-mass compliance between motor and payload, velocity recorded at the payload."""

    name: ClassVar[str] = "payload_resonance"
    realised_as: ClassVar[str] = "state_space"
    signature: ClassVar[str] = ("a peak in magnitude, then a steeper roll-off, with the phase falling "
                                "by a further 180 deg through it (no notch)")
    excludes: ClassVar = ("resonance", "tilt_coupling")
    sensed: ClassVar[str] = "payload"


@dataclass(frozen=True)
class SecondResonance(ModeEffect):
    """A second compliance inside the payload (three-mass chain); the sensor stays where the first
    mode put it."""

    frequency_hz: float = 120.0
    antiresonance_hz: float = 90.0
    name: ClassVar[str] = "second_resonance"
    realised_as: ClassVar[str] = "state_space"
    signature: ClassVar[str] = "a second peak (and notch) in magnitude above the first mode"
    requires_any: ClassVar = ("resonance", "payload_resonance")
    excludes: ClassVar = ("tilt_coupling",)
    order: ClassVar[int] = 2
    sensed: ClassVar[str] = ""


@dataclass(frozen=True)
class BodyChain:
    """A chain of bodies: masses (kg), couplings between neighbours (N/m, N*s/m), rail damping on
    body 0 (N*s/m), the index of the body whose velocity is recorded, and a stiffness between body 0 and the
    ground (N/m: an effect's ``rail_stiffness``, a cable carrier's spring; 0 for a free stage)."""

    masses_kg: tuple
    stiffness_n_per_m: tuple
    damping_n_s_per_m: tuple
    rail_damping_n_s_per_m: object
    sensed: int
    rail_stiffness_n_per_m: object = 0.0

    @property
    def grounded(self) -> bool:
        """Body 0 has a spring to the ground."""
        return bool(np.any(np.asarray(self.rail_stiffness_n_per_m, float) != 0))

    def velocity_per_force(self, s):
        """Recorded velocity per motor force (m/s per N) at the Laplace variable ``s`` (ladder)."""
        n = len(self.masses_kg)
        tail = [None] * n
        Z = self.masses_kg[-1] * s
        couplings = [None] * n
        for i in range(n - 2, -1, -1):
            Zc = self.stiffness_n_per_m[i] / s + self.damping_n_s_per_m[i]
            couplings[i], tail[i + 1] = Zc, Z
            Z = self.masses_kg[i] * s + Zc * Z / (Zc + Z)
        rail = self.rail_damping_n_s_per_m + (self.rail_stiffness_n_per_m / s if self.grounded else 0.0)
        v = 1.0 / (Z + rail)
        for i in range(self.sensed):
            v = v * couplings[i] / (couplings[i] + tail[i + 1])
        return v

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Mass, damping and stiffness matrices (one plant: every value a scalar)."""
        m = [float(np.asarray(x).reshape(())) for x in self.masses_kg]
        n = len(m)
        D = np.zeros((n, n))
        K = np.zeros((n, n))
        D[0, 0] = float(np.asarray(self.rail_damping_n_s_per_m).reshape(()))
        K[0, 0] = float(np.asarray(self.rail_stiffness_n_per_m).reshape(()))
        for i in range(n - 1):
            for mat, val in ((K, self.stiffness_n_per_m[i]), (D, self.damping_n_s_per_m[i])):
                v = float(np.asarray(val).reshape(()))
                mat[i, i] += v
                mat[i + 1, i + 1] += v
                mat[i, i + 1] -= v
                mat[i + 1, i] -= v
        return np.diag(m), D, K

    def modes_hz(self) -> np.ndarray:
        """Undamped natural frequencies of the chain (Hz), the rigid-body zero left out (and the stage on a
        ground spring, which a damper far above critical holds: the bodies' own modes)."""
        M, _, K = replace(self, rail_stiffness_n_per_m=0.0).matrices()
        lam = np.linalg.eigvals(np.linalg.solve(M, K)).real
        return np.sort(np.sqrt(np.maximum(lam[lam > 1e-9 * max(lam.max(), 1.0)], 0.0)) / (2 * np.pi))

    def antiresonances_hz(self) -> np.ndarray:
        """Undamped antiresonances of the recorded velocity (Hz): for a force on body 0 and the velocity
        of body j, the modes of the bodies beyond j with body j held (none when j is the last body)."""
        keep = list(range(self.sensed + 1, len(self.masses_kg)))
        if not keep:
            return np.zeros(0)
        M, _, K = self.matrices()
        lam = np.linalg.eigvals(np.linalg.solve(M[np.ix_(keep, keep)], K[np.ix_(keep, keep)])).real
        return np.sort(np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi))


def body_chain(mass_kg, rail_damping_n_s_per_m, modes: tuple[ModeEffect, ...]) -> BodyChain:
    """The chain of a rigid body of ``mass_kg`` with ``modes`` applied in their order."""
    masses, ks, cs = [mass_kg], [], []
    sensed_at = "motor"
    for mode in sorted(modes, key=lambda e: e.order):
        keep, tail, k, c = mode.split(masses[-1])
        masses[-1:] = [keep, tail]
        ks.append(k)
        cs.append(c)
        sensed_at = mode.sensed or sensed_at
    return BodyChain(tuple(masses), tuple(ks), tuple(cs), rail_damping_n_s_per_m,
                     0 if sensed_at == "motor" else len(masses) - 1)


@dataclass(frozen=True)
class CoulombFriction(MechanicalEffect):
    """Coulomb friction of magnitude ``force_n`` opposing the velocity: F_f = force_n * sign(v).

    Frequency domain, at the plant's excitation current: on a rigid body, the exact first harmonic of
    the periodic steady state with stick-slip (``plant.physics.coulomb_response``); on a chain of several
    bodies, a stage on a ground spring or the tilting beam, the describing function, a real damping
    N(V) = 4 F_c / (pi V) at velocity amplitude V added to the rail damping (approximate: it assumes a
    sinusoidal velocity).
    Time domain: ``force(v)`` is exact.
    The default 3 N is a slide's static friction well under the thesis drive's 10 N (0.5 A x 20 N/A), so a
    stepped sine with the defaults breaks it loose.
    """

    force_n: float = 3.0
    name: ClassVar[str] = "coulomb_friction"
    realised_as: ClassVar[str] = "force"
    bounds: ClassVar = {"force_n": (0.0, 1000.0, "N")}
    linear: ClassVar[bool] = False
    in_synthesis: ClassVar[bool] = False
    signature: ClassVar[str] = "amplitude dependence and odd harmonics, strongest at low velocity"
    main_parameter: ClassVar[str] = "force_n"
    neutral: ClassVar = {"force_n": 0.0}

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

    time_domain: ClassVar[bool] = True

    def force_regressors(self, signals: ForceSignals) -> dict[str, np.ndarray]:
        return {"force_n": np.sign(signals.velocity_m_per_s)}


@dataclass(frozen=True)
class StribeckFriction(MechanicalEffect):
    """The rise of the friction towards rest on top of Coulomb friction (Stribeck curve): the friction
    force is (F_c + ``excess_n`` exp(-(v / ``velocity_m_per_s``)^2)) sign(v), so the static friction is
    F_c + excess_n (Armstrong-Helouvry, Dupont & Canudas de Wit 1994, the exponent held at 2).

    Time domain only: the inverse model is linear in ``excess_n``; the Stribeck velocity is set from the
    residual of the model it is added to (``configured``: the best of a log grid) and refined by profile
    least squares. A frequency response at one amplitude cannot tell it from Coulomb friction."""

    excess_n: float = 0.0
    velocity_m_per_s: float = 0.01
    name: ClassVar[str] = "stribeck_friction"
    realised_as: ClassVar[str] = "force"
    bounds: ClassVar = {"excess_n": (0.0, 1000.0, "N"), "velocity_m_per_s": (1e-5, 1.0, "m/s")}
    signature: ClassVar[str] = "a residual that opposes the motion and grows towards rest"
    main_parameter: ClassVar[str] = "excess_n"
    neutral: ClassVar = {"excess_n": 0.0}
    requires_any: ClassVar = ("coulomb_friction",)
    search_fixed: ClassVar = ("velocity_m_per_s",)
    profiled: ClassVar = {"velocity_m_per_s": 0.3}
    residual_signature: ClassVar = "velocity"
    searched: ClassVar[bool] = False
    not_searched: ClassVar[str] = ("a frequency response at one amplitude cannot tell it from Coulomb friction; "
                                   "fitted from time-domain recordings")
    in_synthesis: ClassVar[bool] = False
    time_domain: ClassVar[bool] = True
    simulated: ClassVar[bool] = False
    linear: ClassVar[bool] = False
    frequency_response: ClassVar[bool] = False
    #: trial Stribeck velocities (m/s) of ``configured``
    GRID: ClassVar = np.geomspace(1e-4, 0.3, 40)

    def __post_init__(self) -> None:
        check_finite("stribeck_friction.excess_n", self.excess_n)
        if self.excess_n < 0:
            raise ParameterError(f"stribeck_friction.excess_n must be >= 0 (the static friction exceeds Coulomb's), "
                                 f"got {self.excess_n}")
        check_positive("stribeck_friction.velocity_m_per_s", self.velocity_m_per_s)

    def force(self, velocity_m_per_s) -> np.ndarray:
        """The friction force (N) above Coulomb's at velocity v, opposing it."""
        v = np.asarray(velocity_m_per_s, float)
        return self.excess_n * np.exp(-(v / self.velocity_m_per_s) ** 2) * np.sign(v)

    def force_regressors(self, signals: ForceSignals) -> dict[str, np.ndarray]:
        v = np.asarray(signals.velocity_m_per_s, float)
        return {"excess_n": np.exp(-(v / self.velocity_m_per_s) ** 2) * np.sign(v)}

    def configured(self, samples: FitSamples, residual_n) -> StribeckFriction:
        """The grid velocity whose rise, fitted to the residual together with a Coulomb step and a constant
        (the parent's friction and offset absorb part of a rise they do not model), reduces it most."""
        v = np.asarray(samples.velocity_m_per_s, float)
        e = np.asarray(residual_n, float)
        known = np.column_stack([np.sign(v), np.ones_like(v)])

        def reduction(vs: float) -> float:
            X = np.column_stack([known, np.exp(-(v / vs) ** 2) * np.sign(v)])
            coef, *_ = np.linalg.lstsq(X, e, rcond=None)
            return float(np.sum(e**2) - np.sum((e - X @ coef) ** 2)) if coef[-1] > 0 else 0.0

        return replace(self, velocity_m_per_s=float(max(self.GRID, key=reduction)))


@dataclass(frozen=True)
class Offset(MechanicalEffect):
    """A constant force ``force_n`` (N) the motor must supply whatever the motion: gravity on a
    tilted axis, a cable carrier's pull, an amplifier offset (force = force_constant x current
    offset). It changes no frequency response (a constant force has no component at a
    non-zero frequency), so it is fitted from time-domain data only (the EMPS benchmark's
    "offset", Janot, Gautier & Brunot 2019)."""

    force_n: float = 0.0
    name: ClassVar[str] = "offset"
    realised_as: ClassVar[str] = "force"
    bounds: ClassVar = {"force_n": (-1000.0, 1000.0, "N")}
    residual_signature: ClassVar = "constant"
    signature: ClassVar[str] = "a residual force of one sign whatever the direction of motion"
    main_parameter: ClassVar[str] = "force_n"
    neutral: ClassVar = {"force_n": 0.0}
    searched: ClassVar[bool] = False
    not_searched: ClassVar[str] = ("a constant force leaves no trace in a frequency response; fitted from "
                                   "time-domain recordings")
    #: a constant force does not enter a velocity loop's small-signal response: nothing to design for
    in_synthesis: ClassVar[bool] = False
    complexity: ClassVar[int] = 0
    simulated: ClassVar[bool] = False

    def __post_init__(self) -> None:
        check_finite("offset.force_n", self.force_n)

    time_domain: ClassVar[bool] = True

    rail_force: ClassVar[bool] = True

    def rail_force_n(self, position_m: float, velocity_m_per_s: float, motor_force_n: float) -> float:
        return -float(self.force_n)

    def force_regressors(self, signals: ForceSignals) -> dict[str, np.ndarray]:
        return {"force_n": np.ones_like(np.asarray(signals.velocity_m_per_s, dtype=float))}


@dataclass(frozen=True)
class TiltCoupling(MechanicalEffect):
    """Tilt of the Stage X beam about the load (Xie & Wang Eq. 2.14-2.15, finite joint stiffness).

    ``frequency_hz`` is the tilt mode's natural frequency sqrt(K_a/J); ``stiffness_n_m_per_rad``
    is K_a, from which the beam inertia J = K_a / (2 pi f)^2 follows. ``offset_m`` moves the load
    from the plant's ``load_position_m`` towards rail Y2 (a fit finds it from the Y1-Y2
    difference). The mode is excited when the load sits off centre; Y1 and Y2 then disagree
    around it. Stage Y only, with both rails recorded.
    """

    frequency_hz: float = 40.0
    stiffness_n_m_per_rad: float = 2.0e5
    offset_m: float = 0.0
    name: ClassVar[str] = "tilt_coupling"
    realised_as: ClassVar[str] = "beam"
    bounds: ClassVar = {"frequency_hz": (1.0, RIGID_HZ, "Hz"), "stiffness_n_m_per_rad": (1.0, 1.0e9, "N*m/rad"),
                        "offset_m": (-0.35, 0.35, "m")}
    limits_bandwidth: ClassVar[bool] = True
    signature: ClassVar[str] = "Y1 and Y2 disagreeing around a mode"
    main_parameter: ClassVar[str] = "frequency_hz"
    in_band: ClassVar = ("frequency_hz",)
    neutral: ClassVar = {"frequency_hz": RIGID_HZ}
    excludes: ClassVar = ("resonance", "payload_resonance", "second_resonance")
    stages: ClassVar = ("y",)
    min_outputs: ClassVar[int] = 2
    in_synthesis: ClassVar[bool] = False

    def __post_init__(self) -> None:
        for field in ("frequency_hz", "stiffness_n_m_per_rad"):
            check_positive(f"tilt_coupling.{field}", getattr(self, field))
        if not np.all(np.isfinite(np.asarray(self.offset_m, float))):
            raise ParameterError(f"tilt_coupling.offset_m must be finite, got {self.offset_m!r}")

    @property
    def inertia_kg_m2(self):
        return np.asarray(self.stiffness_n_m_per_rad) / (2 * np.pi * np.asarray(self.frequency_hz)) ** 2

    def guesses(self, w_rad_s, ratio) -> list[dict[str, float]]:
        r = np.atleast_2d(ratio)
        if r.shape[0] < 2:
            return []
        f = w_rad_s / (2 * np.pi)
        diff = np.abs(r[0] - r[1])
        peaks = [f[i] for i in _local_extrema(diff, maxima=True)[:2]] + list(_band_grid_hz(f, 5))
        return [{"frequency_hz": float(fr), "stiffness_n_m_per_rad": ka, "offset_m": off}
                for fr in peaks for ka in (1e3, 1e4, 1e5, 1e6) for off in (-0.2, -0.08, 0.08, 0.2)]
