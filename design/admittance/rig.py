"""The admittance law as the rig runs it: a force filter, a sampler at the update rate, the virtual
dynamics as a difference equation, a computation delay and a zero-order hold on the velocity
reference it hands to the drive's velocity loop.

The virtual dynamics 1/(m_v s + b_v) are run per update of period T by a rule (``law_coefficients``), every
one a first-order difference equation v[k] = alpha v[k-1] + beta F[k] + beta_prev F[k-1] driven by the
newest force sample::

    backward Euler:  alpha = m_v / (m_v + b_v T),  beta = T / (m_v + b_v T)
    forward Euler:   alpha = 1 - b_v T / m_v,  beta = T / m_v   (the mouse lab's LabVIEW law,
                     ``a = inv(m)*(F' - c*v_1)``)
    Tustin:          alpha = (2 m_v - b_v T) / (2 m_v + b_v T),  beta = beta_prev = T / (2 m_v + b_v T)
    exact ZOH:       alpha = e^(-b_v T / m_v),  beta = (1 - alpha) / b_v   (the step-invariant transform,
                     scipy's ``cont2discrete(..., method="zoh")``, without its one sample of delay: the
                     force held over the last period at its newest sample)

so the virtual impedance is 1/Y_v(z) = (1 - alpha z^-1) / (beta + beta_prev z^-1) (``VirtualImpedance``), m_v s
+ b_v when continuous (thesis Eq. 3.23 with k_v = 0; its Eq. 3.24 prints 1/(m_v s^2 + b_v), a typo). Every rule
scales with (m_v, b_v) together: on a ray m_v / b_v = tau, 1/Y_v = b_v q(tau) (``VirtualImpedance.ray``), which
is what the synthesis's rays use (``design.admittance.ray``). Backward Euler, Tustin and the exact ZOH are
stable for any gains; forward Euler only for m_v > b_v T / 2 (|alpha| < 1), which the synthesis keeps. The
velocity output is held (zero-order hold) and reaches the drive ``computation_delay_samples`` samples after the
force sample that caused it.

Broken at the sampled force signal the coupled loop is exactly a discrete-time loop (the rest is
continuous between a hold and a sampler):

    L(e^(jwT)) = e^(-jwdT) Y_v(e^(jwT)) K_d(e^(jwT)),
    K_d(e^(jwT)) = (1/T) sum_k H_f(jw_k) K(jw_k) (1 - e^(-jw_k T)) / (jw_k),   w_k = w + 2 pi k / T

(the step-invariant transform of the continuous path K from velocity reference to sensed force, H_f
the force filter; Astrom & Wittenmark, Computer-Controlled Systems, section 7.6). The tool takes K_d from the
exact zero-order-hold discretisation of the path's state space (``design.admittance.sampled``), not from this
sum: its terms fall as 1/k only up to the drive's current loop (K is flat there) and as 1/k^2 beyond, with a
phase that turns with the delay, so cut at N = 3 the loop gain near the Nyquist frequency is 11 % off (tests).
What the mouse feels at the frequency
it moves at (the fundamental; the sampler adds aliases above the Nyquist frequency) passes the held reference
(1 - e^(-jwT)) / (jwT) e^(-jwdT) H_f(jw) Y_v(e^(jwT)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np


def force_filter_frd(s, frequency_hz: float | None, order: int) -> np.ndarray | float:
    """Butterworth low-pass of ``order`` 1 or 2 at ``frequency_hz`` (1 when None) at complex ``s``."""
    if frequency_hz is None:
        return 1.0
    x = np.asarray(s) / (2 * math.pi * np.asarray(frequency_hz))
    return 1.0 / (1.0 + x) if order == 1 else 1.0 / (1.0 + math.sqrt(2.0) * x + x * x)


def force_filter_polys(frequency_hz: float | None, order: int) -> tuple[np.ndarray, np.ndarray]:
    """The force filter as numerator / denominator polynomials in s."""
    if frequency_hz is None:
        return np.array([1.0]), np.array([1.0])
    a = 1.0 / (2 * math.pi * frequency_hz)
    return np.array([1.0]), (np.array([a, 1.0]) if order == 1 else np.array([a * a, math.sqrt(2.0) * a, 1.0]))


@dataclass(frozen=True)
class ForceSensor:
    """The force sensor on one axis as the law reads it (N): resolution, the bias left after taring, the law's
    deadband (``reading``: rounded half to even, as numpy rounds)."""

    resolution_n: float
    bias_n: float
    deadband_n: float

    def reading(self, force_n: float) -> float:
        r = self.resolution_n * round((force_n + self.bias_n) / self.resolution_n)
        return r if abs(r) > self.deadband_n else 0.0


@dataclass(frozen=True)
class RigTiming:
    """The rig's update period (None: continuous) and computation delay, with the force filter's corner."""

    period_s: float | None
    delay_samples: int = 0
    filter_hz: float | None = None
    filter_order: int = 2
    #: the law's rule (``RULES``; ``law_coefficients``)
    rule: str = "backward_euler"
    #: with a range of computation delay, its largest (samples; ``delay_samples`` its least)
    delay_samples_max: int | None = None

    def __post_init__(self):
        if self.rule not in RULES:
            raise ValueError(f"unknown admittance law rule {self.rule!r} (one of {', '.join(RULES)})")

    @property
    def delays(self) -> tuple[int, ...]:
        """Every computation delay (samples) the design must hold at."""
        top = self.delay_samples if self.delay_samples_max is None else self.delay_samples_max
        return tuple(range(self.delay_samples, max(top, self.delay_samples) + 1))

    def at_delay(self, d: int) -> RigTiming:
        """The same rig with exactly ``d`` samples of computation delay."""
        return replace(self, delay_samples=int(d), delay_samples_max=None)

    def per_delay(self) -> list[RigTiming]:
        return [self.at_delay(d) for d in self.delays]

    @classmethod
    def of(cls, rig, *, filter_hz: float | None = None) -> RigTiming:
        """From the spec's ``admittance.rig`` (``filter_hz`` chooses a designed filter's corner)."""
        f = rig.force_filter
        corner = None if f is None else (f.frequency_hz if not f.designed else filter_hz)
        if f is not None and f.designed and corner is None:
            corner = math.sqrt(f.frequency_hz_min * f.frequency_hz_max)
        lo, hi = rig.delay_range
        return cls(rig.sample_period_s, lo, corner, 2 if f is None else f.order,
                   rig.law if rig.sample_period_s is not None else "backward_euler", hi if hi > lo else None)

    @property
    def forward_euler(self) -> bool:
        return self.rule == "forward_euler" and self.sampled

    @property
    def min_tau_s(self) -> float:
        """The least m_v / b_v the law is stable with: T / 2 for forward Euler (a hair above), else 0."""
        return 0.5 * self.period_s * 1.01 if self.forward_euler else 0.0

    @property
    def sampled(self) -> bool:
        return self.period_s is not None

    @property
    def nyquist_rad_s(self) -> float:
        return math.inf if self.period_s is None else math.pi / self.period_s

    def law(self, m_v, b_v) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(alpha, beta, beta_prev) of the sampled law (``law_coefficients``)."""
        return law_coefficients(m_v, b_v, self.period_s, self.rule)

    def impedance_on(self, s) -> VirtualImpedance:
        """1/Y_v at the complex frequencies ``s``, for any (m_v, b_v)."""
        s = np.asarray(s, complex)
        return VirtualImpedance(self, s if self.period_s is None else np.exp(-s * self.period_s))

    def impedance(self, w_rad_s, m_v, b_v) -> np.ndarray:
        """1/Y_v on a grid of w (rad/s) (N*s/m)."""
        return self.impedance_on(1j * np.asarray(w_rad_s, float))(m_v, b_v)

    def fundamental(self, w_rad_s) -> np.ndarray:
        """What passes from the sensed force to the velocity reference besides Y_v, at the
        input frequency: H_f, times the hold (1 - e^(-jwT)) / (jwT) and e^(-jwdT) when sampled."""
        return self.fundamental_at(1j * np.asarray(w_rad_s, float))

    def fundamental_at(self, s) -> np.ndarray:
        """``fundamental`` at complex frequencies s."""
        s = np.asarray(s, complex)
        h = force_filter_frd(s, self.filter_hz, self.filter_order)
        if self.period_s is None:
            return h * np.ones_like(s)
        T = self.period_s
        return h * _hold(s, T) * np.exp(-s * T * self.delay_samples)

    def folded_rad_s(self, w_rad_s) -> np.ndarray:
        """Frequencies (rad/s) folded into the band below the Nyquist frequency (where a mode above it
        appears in the sampled loop)."""
        w = np.asarray(w_rad_s, float)
        if self.period_s is None:
            return w
        ws = 2 * math.pi / self.period_s
        r = np.mod(w, ws)
        return np.minimum(r, ws - r)


def _hold(s, T: float) -> np.ndarray:
    """(1 - e^(-sT)) / (sT), the zero-order hold's response normalised to 1 at s = 0."""
    x = s * T
    out = np.ones_like(x)
    nz = x != 0
    out[nz] = -np.expm1(-x[nz]) / x[nz]
    return out


def law_coefficients(m_v, b_v, period_s: float, rule: str = "backward_euler") -> tuple[np.ndarray, np.ndarray,
                                                                                         np.ndarray]:
    """(alpha, beta, beta_prev) of v[k] = alpha v[k-1] + beta F[k] + beta_prev F[k-1], the virtual dynamics
    1/(m_v s + b_v) by ``rule`` (module docstring; ``RULES``). beta_prev is 0 but for Tustin."""
    m_v, b_v, T = np.asarray(m_v, float), np.asarray(b_v, float), period_s
    zero = np.zeros(np.broadcast(m_v, b_v).shape)
    if rule == "tustin":
        c = T / (2 * m_v + b_v * T)
        return (2 * m_v - b_v * T) / (2 * m_v + b_v * T), c, c + zero
    if rule == "forward_euler":
        return 1.0 - b_v * T / m_v, T / m_v + zero, zero
    if rule == "zoh":
        x = b_v * T / m_v
        return np.exp(-x) + zero, -np.expm1(-x) / b_v + zero, zero
    return m_v / (m_v + b_v * T), T / (m_v + b_v * T), zero


RULES = {"backward_euler": "backward Euler: v[k] = (m_v v[k-1] + T F[k]) / (m_v + b_v T)",
         "forward_euler": "forward Euler: v[k] = v[k-1] + T (F[k] - b_v v[k-1]) / m_v",
         "tustin": "Tustin (bilinear): v[k] = ((2 m_v - b_v T) v[k-1] + T (F[k] + F[k-1])) / (2 m_v + b_v T)",
         "zoh": "exact ZOH (step-invariant): v[k] = e^(-b_v T / m_v) v[k-1] + (1 - e^(-b_v T / m_v)) F[k] / b_v"}

#: the rules in words
RULE_NAMES = {"backward_euler": "backward Euler", "forward_euler": "forward Euler", "tustin": "Tustin's rule",
              "zoh": "the exact zero-order-hold rule"}


@dataclass(frozen=True)
class VirtualImpedance:
    """1/Y_v of a law at fixed frequencies: m_v s + b_v (continuous) or (1 - alpha z^-1) / (beta + beta_prev
    z^-1) with z^-1 = e^(-sT) tabulated once (``RigTiming.impedance_on``); (m_v, b_v) broadcast against it."""

    timing: RigTiming
    #: s (continuous) or z^-1 = e^(-sT)
    at: np.ndarray

    def __call__(self, m_v, b_v) -> np.ndarray:
        m_v, b_v = np.asarray(m_v, float), np.asarray(b_v, float)
        if self.timing.period_s is None:
            return m_v * self.at + b_v
        alpha, beta, beta_prev = self.timing.law(m_v, b_v)
        den = beta + beta_prev * self.at
        # Tustin's zero at z = -1: 1/Y_v is 0 at the Nyquist frequency; held a hair off it, as its limit
        den = np.where(np.abs(den) < 1e-12 * np.abs(beta), 1e-12 * beta, den)
        return (1.0 - alpha * self.at) / den

    def ray(self, tau_s) -> np.ndarray:
        """q(tau) of 1/Y_v = b_v q on the ray m_v / b_v = tau (s)."""
        return self(tau_s, 1.0)


@dataclass(frozen=True)
class DiscreteAdmittance:
    """The admittance law per update: v[k] = alpha v[k-1] + beta F[k] + beta_prev F[k-1] (``law_coefficients``)."""

    update_rate_hz: float
    m_v: float
    b_v: float
    alpha: float
    beta_m_per_s_per_n: float
    computation_delay_samples: int
    rule: str
    beta_prev_m_per_s_per_n: float = 0.0

    @classmethod
    def of(cls, m_v: float, b_v: float, update_rate_hz: float, computation_delay_samples: int = 0, *,
           rule: str = "backward_euler"):
        a, b, b_prev = law_coefficients(m_v, b_v, 1.0 / update_rate_hz, rule)
        return cls(update_rate_hz, m_v, b_v, float(a), float(b), computation_delay_samples, RULES[rule], float(b_prev))

    @classmethod
    def of_timing(cls, m_v: float, b_v: float, timing: RigTiming) -> DiscreteAdmittance:
        """The law of a sampled ``timing``."""
        return cls.of(m_v, b_v, 1.0 / timing.period_s, timing.delay_samples, rule=timing.rule)

    @property
    def parameters(self) -> np.ndarray:
        """(m_v kg, b_v N*s/m): what the design chooses."""
        return np.array([self.m_v, self.b_v])

    def tf(self):
        """The law with its computation delay as a python-control discrete transfer function, velocity reference
        per sensed force (m/s per N): (beta + beta_prev z^-1) / (1 - alpha z^-1) z^-d."""
        import control

        T = 1.0 / self.update_rate_hz
        d = self.computation_delay_samples
        return control.tf([self.beta_m_per_s_per_n, self.beta_prev_m_per_s_per_n], [1.0, -self.alpha, *[0.0] * d], T)

    def frd(self, w_rad_s) -> np.ndarray:
        """Its response on ``w_rad_s`` (rad/s)."""
        z = np.exp(1j * np.asarray(w_rad_s, float) / self.update_rate_hz)
        return ((self.beta_m_per_s_per_n + self.beta_prev_m_per_s_per_n / z) / (1 - self.alpha / z)
                * z ** (-self.computation_delay_samples))
