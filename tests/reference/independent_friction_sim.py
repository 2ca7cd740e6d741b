"""An axis with friction under closed position control, simulated without the tool's code.

NumPy only (a test checks that nothing from ``plant`` or ``design`` is imported). The axis is
one rigid mass with viscous and Coulomb friction, a constant force and, optionally, a force
that depends on position (cogging, a cable) and a Stribeck rise of the friction towards rest:
m dv/dt = F - b v - (F_c + F_s exp(-(v / v_s)^2)) sign(v) - F_0 - F_p(x), sticking below F_c + F_s.
It is integrated at ``INTERNAL_HZ`` by semi-implicit Euler with a Karnopp stick band: when the
velocity would cross zero in a step, or is inside the band, and the driving force is below the
static friction F_c + F_s, the axis sticks (v = 0). A PD position controller with a velocity feedforward runs at the
logging rate on the encoder reading (quantised position) and the backward-difference
velocity; its command (V) becomes force through a gain (N/V), which may drift in time (a coil warming), with additive
drive noise.
Logged: time, command, encoder position and the reference, as the EMPS benchmark logs them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

INTERNAL_HZ = 20_000
LOG_HZ = 1_000


@dataclass(frozen=True)
class Axis:
    mass_kg: float = 90.0
    viscous_n_s_per_m: float = 200.0
    coulomb_n: float = 20.0
    offset_n: float = -3.0
    #: amplitude (N) and spatial period (m) of a position-dependent force, 0 for none
    ripple_n: float = 0.0
    ripple_period_m: float = 0.02
    #: Stribeck friction: the static force exceeds F_c by this (N), decaying as exp(-(v / v_s)^2), v_s in m/s
    stribeck_n: float = 0.0
    stribeck_velocity_m_per_s: float = 0.01
    gain_n_per_v: float = 35.0
    #: the drive's gain drifts in time, gain (1 + rate t) (a coil warming), 1/s
    gain_rate_per_s: float = 0.0


@dataclass(frozen=True)
class Log:
    time_s: np.ndarray
    command_v: np.ndarray
    position_m: np.ndarray
    reference_m: np.ndarray


def reference(duration_s: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A smooth back-and-forth trajectory (sum of a few slow sines) and its velocity at the log rate."""
    t = np.arange(int(round(duration_s * LOG_HZ))) / LOG_HZ
    f = np.array([0.3, 0.7, 1.3, 2.1]) * rng.uniform(0.9, 1.1, 4)
    a = np.array([0.08, 0.03, 0.015, 0.006])
    ph = rng.uniform(0, 2 * np.pi, 4)
    r = np.sum(a[:, None] * (np.sin(2 * np.pi * f[:, None] * t + ph[:, None]) - np.sin(ph[:, None])), axis=0)
    rd = np.sum(a[:, None] * 2 * np.pi * f[:, None] * np.cos(2 * np.pi * f[:, None] * t + ph[:, None]), axis=0)
    return t, r, rd


def simulate(axis: Axis, *, duration_s: float = 20.0, seed: int = 0, encoder_m: float = 1e-6,
             drive_noise_v: float = 0.02, kp_n_per_m: float = 6e4, kd_n_s_per_m: float = 1.5e3) -> Log:
    """Closed-loop run from rest on the reference of ``reference``; noise from ``seed``."""
    rng = np.random.default_rng(seed)
    t, r, rd = reference(duration_s, rng)
    sub = INTERNAL_HZ // LOG_HZ
    h = 1.0 / INTERNAL_HZ
    x = v = 0.0
    prev_q = 0.0
    damping_per_mass = axis.viscous_n_s_per_m / axis.mass_kg
    u_log = np.empty(t.size)
    q_log = np.empty(t.size)
    for k in range(t.size):
        q = np.round(x / encoder_m) * encoder_m
        v_est = (q - prev_q) * LOG_HZ if k else 0.0
        prev_q = q
        u = (kp_n_per_m * (r[k] - q) + kd_n_s_per_m * (rd[k] - v_est)) / axis.gain_n_per_v
        u += drive_noise_v * rng.standard_normal()
        u_log[k] = u
        q_log[k] = q
        force = axis.gain_n_per_v * u if not axis.gain_rate_per_s else \
            axis.gain_n_per_v * (1.0 + axis.gain_rate_per_s * t[k]) * u
        for _ in range(sub):
            drive = force - axis.offset_n - axis.ripple_n * math.sin(2 * math.pi * x / axis.ripple_period_m)
            static = axis.coulomb_n + axis.stribeck_n
            if v == 0.0 and abs(drive) <= static:
                continue
            direction = math.copysign(1.0, v if v != 0.0 else drive)
            friction = axis.coulomb_n + axis.stribeck_n * math.exp(-(v / axis.stribeck_velocity_m_per_s) ** 2)
            v_new = (v + h * (drive - friction * direction) / axis.mass_kg) / (1 + h * damping_per_mass)
            if v != 0.0 and v_new * v < 0 and abs(drive) <= static:
                v_new = 0.0
            v = v_new
            x += h * v
    return Log(t, u_log, q_log, r)
