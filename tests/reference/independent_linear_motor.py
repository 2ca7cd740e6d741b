"""Independent simulator of a linear-motor axis with the physics of real motors (numpy only).

Shares no code with ``plant`` or ``design``; its recordings are an independent truth for the diagnosis.

Physics
    A rigid carriage of mass m (kg) at position x (m), velocity v (m/s), on guides with viscous damping
    b (N s/m):

        m v' = Kt(x) sat(i) + ripple(x) - k_c (x - x_c) - d (x - x_f) tanh(v / v_d) - b v,      x' = v

    * amplifier current limit: sat(i) = clip(i, -limit, limit) (A); the recorded current is the commanded
      one, as a drive logs its current command;
    * force constant along the magnet track: Kt(x) = Kt0 (1 - droop (2 x / travel)^2) (N/A), falling
      off towards the ends of the track;
    * force ripple (cogging): sum_k a_k sin(2 pi k x / pitch + phi_k) (N);
    * guides whose damping drifts in time, b (1 + r t) (a lubricant warming up), and a force constant that
      drifts in time, Kt(x) (1 + r_K t) (a coil warming up: its magnets' remanence falls);
    * a cable chain pulling towards its rest position x_c with stiffness k_c (N/m): a force that depends on
      the position but is neither periodic nor proportional to the current; and the chain's drag, a friction
      d (x - x_f) that grows with the length of chain moving, from its fixed end x_f (m), smoothed at rest as
      d (x - x_f) tanh(v / ``DRAG_VELOCITY_M_PER_S``) (a regularised friction, so the integration stays smooth).

Integration
    Classical fourth-order Runge-Kutta on ``SUBSTEPS`` steps per sample (fewer for slow, smooth currents);
    every force above is smooth in (t, x, v) except the clip, which is continuous, so the error is below
    1e-7 of the velocity amplitude at the rates used here (checked in
    ``tests/reference/test_independent_linear_motor.py`` against the exact response of the linear axis).
"""

from __future__ import annotations

from dataclasses import dataclass

import independent_sim
import numpy as np

SUBSTEPS = 16
#: velocity (m/s) below which the cable's drag is smoothed (module doc): its slope d (x - x_f) / v_d, tens of
#: thousands of N s/m, leaves a time constant m v_d / (d (x - x_f)) above a millisecond, within Runge-Kutta's reach
DRAG_VELOCITY_M_PER_S = 2e-4


@dataclass(frozen=True)
class LinearMotorAxis:
    """The axis of the module doc; defaults: the thesis's Stage X (35 kg, 440 N s/m, 20 N/A)."""

    mass_kg: float = 35.0
    damping_n_s_per_m: float = 440.0
    kt_n_per_a: float = 20.0
    current_limit_a: float | None = None
    kt_droop: float = 0.0
    travel_m: float = 0.5
    ripple_pitch_m: float = 0.03
    ripple_n: tuple[float, ...] = ()
    ripple_phase_rad: tuple[float, ...] = ()
    cable_n_per_m: float = 0.0
    cable_rest_m: float = 0.0
    cable_drag_n_per_m: float = 0.0
    cable_fixed_m: float = -0.25
    #: the guides' damping drifts in time, b (1 + rate t) (a lubricant warming), 1/s
    damping_rate_per_s: float = 0.0
    #: the force constant drifts in time, Kt (1 + rate t) (a coil warming), 1/s
    kt_rate_per_s: float = 0.0

    def force_n(self, i_a: np.ndarray, x_m: np.ndarray, v_m_per_s=0.0, t_s=0.0) -> np.ndarray:
        """Force (N) of the motor and the cable for commanded current ``i_a`` at position ``x_m``, velocity
        ``v_m_per_s`` and time ``t_s``."""
        i = i_a if self.current_limit_a is None else np.minimum(np.maximum(i_a, -self.current_limit_a),
                                                                 self.current_limit_a)
        kt = self.kt_n_per_a * (1.0 - self.kt_droop * (2.0 * x_m / self.travel_m) ** 2)
        if self.kt_rate_per_s:
            kt = kt * (1.0 + self.kt_rate_per_s * t_s)
        f = kt * i
        for k, (a, phi) in enumerate(zip(self.ripple_n, self.ripple_phase_rad or (0.0,) * len(self.ripple_n)), 1):
            f = f + a * np.sin(2 * np.pi * k * x_m / self.ripple_pitch_m + phi)
        f = f - self.cable_n_per_m * (x_m - self.cable_rest_m)
        if self.cable_drag_n_per_m:
            f = f - self.cable_drag_n_per_m * (x_m - self.cable_fixed_m) * np.tanh(v_m_per_s / DRAG_VELOCITY_M_PER_S)
        return f

    def run(self, current, t_s: np.ndarray, n: int = 1, substeps: int = SUBSTEPS,
            drive=None) -> tuple[np.ndarray, np.ndarray]:
        """Positions (m) and velocities (m/s), each (t_s.size, n), at ``t_s`` (uniform, from 0) of ``n``
        experiments side by side, each from rest at x = 0 under the commanded current ``current(t)`` (a
        function of time in s giving n currents, A, or one scalar when n = 1); ``substeps`` Runge-Kutta
        steps per sample. ``drive`` (command A, position m) -> current A: what the drive makes of the command
        where the carriage is (a compensation table), None: the command itself. One experiment runs on
        scalars, ten times faster than on arrays of one element."""
        dt = (t_s[1] - t_s[0]) / substeps
        m, b = self.mass_kg, self.damping_n_s_per_m

        def rate(t, x, v):
            i = current(t) if drive is None else drive(current(t), x)
            return v, (self.force_n(i, x, v, t) - b * (1.0 + self.damping_rate_per_s * t) * v) / m

        x, v = (0.0, 0.0) if n == 1 else (np.zeros(n), np.zeros(n))
        xs, vs = np.empty((t_s.size, n)), np.empty((t_s.size, n))
        t = 0.0
        for k in range(t_s.size):
            xs[k], vs[k] = x, v
            for _ in range(substeps):
                k1 = rate(t, x, v)
                k2 = rate(t + dt / 2, x + dt / 2 * k1[0], v + dt / 2 * k1[1])
                k3 = rate(t + dt / 2, x + dt / 2 * k2[0], v + dt / 2 * k2[1])
                k4 = rate(t + dt, x + dt * k3[0], v + dt * k3[1])
                x = x + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
                v = v + dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
                t += dt
        return xs, vs


def stepped_sine(axis: LinearMotorAxis, f_hz, *, amplitude_a: float, block_s: float, sample_rate_hz: float,
                 noise: float = 0.0, seed: int = 0) -> independent_sim.Recording:
    """A stepped-sine recording (``independent_sim.Recording``): every block from rest at x = 0, the
    commanded current A sin(2 pi f t) recorded; white noise of ``noise`` times A on the current and
    ``noise`` times the block's velocity amplitude on the velocity."""
    rng = np.random.default_rng(seed)
    f = np.asarray(f_hz, float)
    t = np.arange(int(round(block_s * sample_rate_hz))) / sample_rate_hz
    _, v_all = axis.run(lambda s: amplitude_a * np.sin(2 * np.pi * f * s), t, f.size)
    times, currents, velocities = [], [], []
    for j, fj in enumerate(f):
        v = v_all[:, j]
        i = amplitude_a * np.sin(2 * np.pi * fj * t)
        if noise > 0:
            v = v + rng.normal(0.0, noise * np.max(np.abs(v[t.size // 2:])), v.size)
            i = i + rng.normal(0.0, noise * amplitude_a, i.size)
        times.append(t)
        currents.append(i)
        velocities.append(v[:, None])
    return independent_sim.Recording(f, times, currents, velocities, ("velocity_m_per_s",))


def record(axis: LinearMotorAxis, current, duration_s: float, *, sample_rate_hz: float = 500.0, seed: int = 0,
           current_noise_a: float = 0.005, position_noise_m: float = 1e-6, substeps: int = 4, drive=None):
    """A time recording of the command ``current(t)`` (A, a function of time in s) from rest at x = 0, through
    ``drive`` (``run``). Returns (t s, command A, position m), the command and position with white measurement
    noise."""
    t = np.arange(int(round(duration_s * sample_rate_hz))) / sample_rate_hz

    x, _ = axis.run(current, t, 1, substeps, drive)
    rng = np.random.default_rng(seed)
    return (t, current(t) + rng.normal(0.0, current_noise_a, t.size),
            x[:, 0] + rng.normal(0.0, position_noise_m, t.size))


def slow_sweep(axis: LinearMotorAxis, *, duration_s: float = 16.0, **kw):
    """``record`` of a 0.25 Hz, 3 A current command with 0.8 A at 3.1 Hz and 0.5 A at 7.3 Hz on top (the
    carriage covers about 0.17 m)."""
    return record(axis, lambda s: 3.0 * np.sin(2 * np.pi * 0.25 * s) + 0.8 * np.sin(2 * np.pi * 3.1 * s)
                  + 0.5 * np.sin(2 * np.pi * 7.3 * s + 1.0), duration_s, **kw)


def chirp(axis: LinearMotorAxis, *, amplitude_a: float = 3.0, f0_hz: float = 0.2, f1_hz: float = 8.0,
          duration_s: float = 24.0, **kw):
    """``record`` of a logarithmic chirp A sin(2 pi f0 T (r^(t/T) - 1) / ln r), r = f1 / f0, T the duration:
    the carriage covers about 0.2 m at its start."""
    r = f1_hz / f0_hz
    return record(axis, lambda s: amplitude_a * np.sin(2 * np.pi * f0_hz * duration_s * (r ** (s / duration_s) - 1)
                                                       / np.log(r)), duration_s, **kw)


def stepped(axis: LinearMotorAxis, f_hz=(0.25, 0.5, 1.0, 2.0, 4.0, 8.0), *, amplitude_a: float = 3.0,
            block_s: float = 4.0, **kw):
    """``record`` of a stepped sine in one continuous run: A sin(2 pi f_k t) during block k, the motion carried
    over from block to block."""
    f = np.asarray(f_hz, float)

    def current(s):
        k = np.minimum((np.asarray(s) // block_s).astype(int), f.size - 1)
        return amplitude_a * np.sin(2 * np.pi * f[k] * s)

    return record(axis, current, block_s * f.size, **kw)
