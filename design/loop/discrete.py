"""The design as a drive runs it at its loop rate: discrete PI gains and filter coefficients, and the
discrete loop python-control checks.

* PI: u[k] = kp e[k] + i[k], i[k] = i[k-1] + (ki T / 2)(e[k] + e[k-1]) (trapezoidal integral),
  i.e. C(z) = kp + (ki T / 2)(z + 1)/(z - 1), whose integral keeps the continuous one's -90 deg at
  every frequency (a rectangular integral i[k] = i[k-1] + ki T e[k] adds a lead of wT/2 and raises
  the loop gain: 1 % at 85 Hz and 4 kHz, which moves the crossover and cost 0.3 deg of phase margin
  on the Stage X spec); the drive is given kp (A per m/s) and the integral gain per sample ki T.
* Biquads (the drive's velocity filter, ``sensor_filter``): Tustin with the frequency pre-warped at
  the filter's corner, so the discrete filter has the continuous one's response exactly there:
  H(z) = (b0 + b1 z^-1 + b2 z^-2) / (1 + a1 z^-1 + a2 z^-2).
* The loop: the continuous plant (mechanics, delay as a Pade approximant, current loop) sampled
  with a zero-order hold (``control.c2d``), one sample of computation delay z^-1, C(z) and the
  discrete filters. The continuous design already carries the hold and the computation delay
  (the ``sampling`` effect at the loop rate), so the discrete loop differs from it only by the
  discretisation of the controller and filters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from design.loop.controller import PI
from plant.errors import SpecError
from plant.physics.models import Plant

#: continuous effects realised in the drive's discrete controller (coefficients exported)
DRIVE_FILTERS = ("sensor_filter", "low_pass_filter", "notch_filter")
#: continuous effects the discrete loop replaces by its own hold and computation delay
REPLACED = ("sampling",)


@dataclass(frozen=True)
class DiscreteBiquad:
    """H(z) = (b0 + b1 z^-1 + b2 z^-2) / (1 + a1 z^-1 + a2 z^-2) of a continuous second-order filter."""

    name: str
    frequency_hz: float
    damping_ratio: float
    b0: float
    b1: float
    b2: float
    a1: float
    a2: float


@dataclass(frozen=True)
class DiscreteDesign:
    """Gains and filters per sample period ``1 / loop_rate_hz``."""

    loop_rate_hz: float
    kp: float
    #: ki T: integral increment per sample per unit velocity error (A per m/s per sample)
    ki_per_sample: float
    filters: tuple[DiscreteBiquad, ...]


def tustin_biquad(num_s, den_s, rate_hz: float, prewarp_hz: float) -> tuple[float, float, float, float, float]:
    """(b0, b1, b2, a1, a2) of (n2 s^2 + n1 s + n0) / (d2 s^2 + d1 s + d0) by Tustin's map with
    s = c (1 - z^-1) / (1 + z^-1), c = w0 / tan(w0 T / 2) (pre-warped at ``prewarp_hz``)."""
    T = 1.0 / rate_hz
    w0 = 2 * math.pi * prewarp_hz
    if not 0 < w0 * T / 2 < math.pi / 2:
        raise SpecError(f"a filter at {prewarp_hz:g} Hz is at or above the Nyquist frequency {rate_hz / 2:g} Hz of "
                        "controller.loop_rate_hz")
    c = w0 / math.tan(w0 * T / 2)
    n2, n1, n0 = num_s
    d2, d1, d0 = den_s
    b = (n2 * c * c + n1 * c + n0, 2 * (n0 - n2 * c * c), n2 * c * c - n1 * c + n0)
    a = (d2 * c * c + d1 * c + d0, 2 * (d0 - d2 * c * c), d2 * c * c - d1 * c + d0)
    return b[0] / a[0], b[1] / a[0], b[2] / a[0], a[1] / a[0], a[2] / a[0]


def discretise(plant: Plant, controller: PI, loop_rate_hz: float) -> DiscreteDesign:
    """The drive's numbers for the PI ``controller`` and the plant's drive filters at ``loop_rate_hz``."""
    filters = []
    for e in plant.effects:
        if e.name == "sensor_filter":
            f, z = float(e.frequency_hz), float(e.damping_ratio)
            wn = 2 * math.pi * f
            coef = tustin_biquad((0.0, 0.0, wn * wn), (1.0, 2 * z * wn, wn * wn), loop_rate_hz, f)
            filters.append(DiscreteBiquad(e.name, f, z, *coef))
        elif e.name in DRIVE_FILTERS:
            f = float(e.frequency_hz)
            coef = tustin_biquad(*e.polynomials(), loop_rate_hz, f)
            filters.append(DiscreteBiquad(e.name, f, float(e.damping_ratio), *coef))
    return DiscreteDesign(float(loop_rate_hz), float(controller.kp), float(controller.ki) / loop_rate_hz,
                          tuple(filters))


def zoh_with_delay(system, T: float, delay_s: float):
    """Exact zero-order-hold equivalent of ``system`` (python-control, continuous, strictly proper)
    preceded by a pure delay ``delay_s`` (Astrom & Wittenmark, Computer-Controlled Systems, section 2.3):
    with delay = (d - 1) T + t', 0 < t' <= T, x[k+1] = Phi x[k] + G0 u[k-d+1] + G1 u[k-d], where
    Phi = e^(A T), G0 = int_0^(T-t') e^(A s) ds B, G1 = e^(A (T-t')) int_0^t' e^(A s) ds B."""
    import control
    from scipy.linalg import expm

    ss = control.ss(system)
    A, B, C = (np.asarray(m, float) for m in (ss.A, ss.B, ss.C))
    n = A.shape[0]

    def integral(t):
        """(e^(A t), int_0^t e^(A s) ds B) from one matrix exponential."""
        M = np.zeros((n + 1, n + 1))
        M[:n, :n], M[:n, n:] = A * t, B * t
        E = expm(M)
        return E[:n, :n], E[:n, n:]

    Phi, gamma = integral(T)
    if delay_s <= 0:
        return control.ss(Phi, gamma, C, 0.0, T)
    d = max(int(math.ceil(delay_s / T - 1e-12)), 1)
    frac = delay_s - (d - 1) * T
    E0, G0 = integral(T - frac)
    G1 = E0 @ integral(frac)[1]
    z = control.tf([1.0, 0.0], [1.0], T)
    return (control.ss(Phi, G0, C, 0.0, T) * z ** (-(d - 1)) + control.ss(Phi, G1, C, 0.0, T) * z ** (-d))


def discrete_loop(plant: Plant, design: DiscreteDesign):
    """L(z) of the discrete design around a (scalar) plant, as a python-control transfer function: the
    plant's rational part sampled exactly with its delay (``zoh_with_delay``), one sample of
    computation delay, C(z) and the discrete filters."""
    import control

    T = 1.0 / design.loop_rate_hz
    delay = plant.effect("delay")
    rational = replace(plant, effects=tuple(e for e in plant.effects
                                            if e.name not in (*REPLACED, *DRIVE_FILTERS, "delay")))
    P = zoh_with_delay(rational.to_control(), T, 0.0 if delay is None else float(delay.seconds))
    z = control.tf([1.0, 0.0], [1.0], T)
    C = design.kp + design.ki_per_sample / 2 * (z + 1) / (z - 1)
    L = P * C / z
    for f in design.filters:
        L = L * control.tf([f.b0, f.b1, f.b2], [1.0, f.a1, f.a2], T)
    return L


@dataclass(frozen=True)
class DiscreteCheck:
    """python-control margins of the discrete loop at each checked plant."""

    plants: int
    min_phase_margin_deg: float
    min_gain_margin_db: float
    stable: bool
    failures: tuple[str, ...]

    @property
    def verified(self) -> bool:
        return not self.failures


def _nyquist_grid(rate_hz: float, per_decade: int = 500) -> np.ndarray:
    """0.01 Hz to just below the Nyquist frequency (rad/s), ``per_decade`` points per decade."""
    hi = 0.999 * math.pi * rate_hz
    return np.geomspace(2 * math.pi * 0.01, hi, int(per_decade * math.log10(hi / (2 * math.pi * 0.01))))


def check_discrete(plants: list[tuple[str, Plant]], design: DiscreteDesign, *, phase_margin_deg: float,
                   gain_margin_db: float, tolerance: tuple[float, float] = (0.05, 0.05)) -> DiscreteCheck:
    """Margins of the discrete loop (python-control's FRD margins on a dense grid to the Nyquist frequency)
    and its closed-loop poles inside the unit circle."""
    import warnings

    import control
    from scipy.signal import BadCoefficients

    pms, gms, failures, stable = [], [], [], True
    for label, p in plants:
        with warnings.catch_warnings():     # the z^-d factors give leading zero coefficients, dropped exactly
            warnings.simplefilter("ignore", BadCoefficients)
            L = discrete_loop(p, design)
        poles = control.poles(control.feedback(L, 1))
        if np.any(np.abs(poles) >= 1):
            stable = False
            failures.append(f"unstable discrete closed loop at {label}")
            continue
        # python-control's FRD margins of L(e^(jwT)) on a dense grid up to the Nyquist frequency: its polynomial
        # method finds spurious unit-circle crossings in these high-order loops (a PM of 23 deg at 2 Hz where
        # |L| is 30 dB)
        w = _nyquist_grid(design.loop_rate_hz)
        gm, pm, *_ = control.stability_margins(control.frd(L(np.exp(1j * w / design.loop_rate_hz)), w))
        gm_db = 20 * math.log10(gm) if np.isfinite(gm) and gm > 0 else math.inf
        pms.append(float(pm) if np.isfinite(pm) else math.inf)
        gms.append(gm_db)
        if pms[-1] < phase_margin_deg - tolerance[0]:
            failures.append(f"discrete phase margin {pms[-1]:.2f} deg < {phase_margin_deg:g} at {label}")
        if gm_db < gain_margin_db - tolerance[1]:
            failures.append(f"discrete gain margin {gm_db:.2f} dB < {gain_margin_db:g} at {label}")
    return DiscreteCheck(len(plants), min(pms, default=math.nan), min(gms, default=math.nan), stable,
                         tuple(failures))
