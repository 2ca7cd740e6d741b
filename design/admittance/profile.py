"""The locomotion profile and the forces on it, for any (m_v, b_v): the neck force the mouse feels and the force
each motor makes while the mouse runs the spec's trapezoid.

The mouse's body follows the trapezoidal profile (velocity v_b(t)); the head (mass m_h) rides the clamp, whose
velocity answers the sensed force through the rendered admittance, v_h = Y_r F_s; the neck (Z_n = c_n + k_n/s)
carries the force between body and head::

    F_n / v_b = Z_n (1 + m_h s Y_r) / (1 + (Z_n + m_h s) Y_r),   F_s = F_n / (1 + m_h s Y_r)

and each motor's force is F_m = (S - 1 + K_t E C S W Y_v) F_s (``design.admittance.model``;
M a + b v - F_s for a rigid Stage X). Computed by FFT over the profile padded with rest, with an exponential
window (the input times e^(-c t), the response at s = c + jw, the output times e^(c t), c = 8 / the window's
length) so the circular convolution's wrap-around is damped by e^-8 and slow modes of the loop come out as the
response from rest. A sampled law enters by its response at the input frequency (the fundamental: the hold,
the delay, the law's difference equation); the aliases it adds above its Nyquist frequency carry a small part
of a locomotion profile's neck force (0.2 % against a time simulation of the sampled loop, tests), but the
motor answers the held reference's steps at once, and its peak adds an estimate of that (``staircase_n``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from design.admittance.mouse import stack
from design.admittance.rig import RigTiming, force_filter_frd
from design.problem import Locomotion, LoopProblem

#: the largest time step (s) of the force computation (its FFT grid reaches 1 / (2 MAX_STEP_S), five times the
#: neck's fastest mode of the bundled mice, 50 Hz; tests show the forces converged against a 0.25 ms step) and the
#: rest before and after the profile (s)
MAX_STEP_S = 2e-3
REST_S = 0.6
#: scenarios per block of the motor-force computation (memory: a few complex arrays of necks x block x FFT grid)
MOTOR_BLOCK = 32


def step_for(timing: RigTiming, max_step_s: float = MAX_STEP_S) -> float:
    """The force computation's time step for a law sampled as ``timing`` says: the largest step up to
    ``max_step_s`` that divides the law's period (its output's steps fall on the grid), ``max_step_s`` for a
    continuous law."""
    if not timing.sampled:
        return max_step_s
    return timing.period_s / math.ceil(timing.period_s / max_step_s * (1 - 1e-9))


@dataclass(frozen=True)
class Profile:
    """A trapezoidal velocity profile: time (s), acceleration (m/s^2), velocity (m/s)."""

    time_s: np.ndarray
    acceleration_m_per_s2: np.ndarray
    velocity_m_per_s: np.ndarray

    @property
    def moving(self) -> np.ndarray:
        return self.velocity_m_per_s > 0


def trapezoid(loc: Locomotion, *, dt_s: float = MAX_STEP_S, rest_s: float = REST_S) -> Profile:
    """Accelerate at a_pk to v_pk, run, decelerate, over the travel (a triangle when the travel is too short
    to reach v_pk), with ``rest_s`` of rest before and after (bsbrl/exoskeleton
    ``MAIN_generate_trapezoidal_profile.m``, after Dombre & Khalil)."""
    a, v, d = loc.peak_acceleration_m_per_s2, loc.peak_speed_m_per_s, loc.travel_m
    t_acc = v / a
    if a * t_acc**2 > d:                       # triangle: never reaches v_pk
        t_acc = math.sqrt(d / a)
        v = a * t_acc
    t_run = (d - a * t_acc**2) / v
    total = 2 * t_acc + t_run
    t = np.arange(0.0, total + 2 * rest_s, dt_s)
    tau = t - rest_s
    acc = np.where((tau >= 0) & (tau < t_acc), a, np.where((tau >= t_acc + t_run) & (tau < total), -a, 0.0))
    vel = np.clip(np.where(tau < t_acc, a * tau, np.where(tau < t_acc + t_run, v, v - a * (tau - t_acc - t_run))),
                  0.0, v)
    return Profile(t, acc, np.where((tau >= 0) & (tau <= total), vel, 0.0))


class FeltForce:
    """The peak force the mouse feels on the locomotion profile for any (m_v, b_v), worst over ``scenarios``
    x the distinct necks and heads of ``corners``, and the motors' forces there (module docstring): the parts
    that do not depend on (m_v, b_v) are computed once on the profile's FFT grid, so a search can call it many
    times. With ``paired``, ``corners`` is a batch of mice ((n_s, 1) fields), mouse k at scenario k. The time step
    is ``step_for(timing, max_step_s)``."""

    def __init__(self, problem: LoopProblem, scenarios, corners, *, loops, timing: RigTiming, paired: bool = False,
                 max_step_s: float = MAX_STEP_S):
        self.step_s = step_for(timing, max_step_s)
        self.profile = trapezoid(problem.admittance.locomotion, dt_s=self.step_s)
        self.n = self.profile.time_s.size
        self.damping = 8.0 / (self.n * self.step_s)
        f = np.fft.rfftfreq(self.n, self.step_s)
        s = self.damping + 2j * np.pi * f
        loop = loops.at(s, scenarios)
        self.scenarios, self.timing = scenarios, timing
        self.sg = loop.sensitivity_mobility                                 # (n_s, n_f)
        self.r = loop.reference
        self.rw = loop.reference * timing.fundamental_at(s)
        self.mf, self.mr = loop.motor_force, loop.motor_reference * timing.fundamental_at(s)     # (n_motor, n_s, n_f)
        self.s = s
        self.impedance = timing.impedance_on(s)
        if paired:
            self.necks, batch = None, corners
        else:
            self.necks = list({(m.head_mass_kg, m.neck_stiffness_n_per_m, m.neck_damping_n_s_per_m): m
                               for m in corners}.values())
            batch = stack(self.necks)
        column = [np.asarray(getattr(batch, f), float).reshape(-1, 1)
                  for f in ("neck_damping_n_s_per_m", "neck_stiffness_n_per_m", "head_mass_kg")]
        self.zn = (column[0] + column[1] / s)[None] if paired else (column[0] + column[1] / s)[:, None, :]
        self.mh = (column[2] * s)[None] if paired else (column[2] * s)[:, None, :]
        self.window = np.exp(-self.damping * self.profile.time_s)
        self.vb = np.fft.rfft(self.profile.velocity_m_per_s * self.window)
        self.moving = self.profile.moving
        # the apparent dynamics and the reach are read on the imaginary axis (``rendered``, when asked)
        self.f_hz = f[1:]
        self.w = 2 * np.pi * self.f_hz
        self._loops = loops

    @cached_property
    def _on_axis(self) -> tuple[np.ndarray, np.ndarray, object]:
        """S G, R W and the law's 1/Y_v on the imaginary axis at the FFT frequencies."""
        free = self._loops.at(1j * self.w, self.scenarios)
        t = self.timing
        return free.sensitivity_mobility, free.reference * t.fundamental(self.w), t.impedance_on(1j * self.w)

    def rendered(self, m_v: float, b_v: float) -> np.ndarray:
        """Y_r at the FFT frequencies (on the imaginary axis, without DC), (n_s, n_f)."""
        sg, rw, impedance = self._on_axis
        return sg + rw / impedance(m_v, b_v)

    def forces(self, m_v: float, b_v: float) -> np.ndarray:
        """The neck force over the profile at every neck and scenario, (n_neck, n_s, n_t)."""
        yr = self.sg + self.rw / self.impedance(m_v, b_v)
        h = self.zn * (1 + self.mh * yr) / (1 + (self.zn + self.mh) * yr)
        return np.fft.irfft(h * self.vb, self.n) / self.window

    def _sensed(self, z: np.ndarray, rows: slice) -> np.ndarray:
        """The sensed force's spectrum F_s = F_n / (1 + m_h s Y_r) at every neck and the scenarios ``rows``."""
        yr = self.sg[rows] + self.rw[rows] / z
        zn, mh = (a if a.shape[-2] == 1 else a[..., rows, :] for a in (self.zn, self.mh))
        return zn / (1 + (zn + mh) * yr) * self.vb

    def motor_forces(self, m_v: float, b_v: float, rows: slice = slice(None)) -> np.ndarray:
        """Each motor's force over the profile at every neck and the scenarios ``rows``, (n_motor, n_neck, n_s,
        n_t) (N)."""
        z = self.impedance(m_v, b_v)
        return self._motor_forces(z, self._sensed(z, rows), rows)

    def _motor_forces(self, z: np.ndarray, sensed: np.ndarray, rows: slice) -> np.ndarray:
        per_sensed = self.mf[:, rows] + self.mr[:, rows] / z
        return np.fft.irfft(per_sensed[:, None] * sensed[None], self.n) / self.window

    def motor_peak_n(self, m_v: float, b_v: float) -> np.ndarray:
        """The largest motor force over the profile, motors and necks, per scenario (N), (n_s,): the fundamental's
        peak plus the held reference's staircase (``staircase_n``), ``MOTOR_BLOCK`` scenarios at a time (the sensed
        force's spectrum of a block computed once for both)."""
        n_s = len(self.scenarios)
        z = self.impedance(m_v, b_v)
        out = np.empty(n_s)
        for start in range(0, n_s, MOTOR_BLOCK):
            rows = slice(start, start + MOTOR_BLOCK)
            sensed = self._sensed(z, rows)
            out[rows] = (np.max(np.abs(self._motor_forces(z, sensed, rows)), axis=(0, 1, 3))
                         + self.staircase_n(m_v, b_v, rows, sensed=sensed))
        return out

    @cached_property
    def _reference_gain_above_nyquist(self) -> np.ndarray:
        """sup over w above the law's Nyquist frequency of |motor force per velocity reference| (R / G: K_t E C S,
        K_t Kp where the loop no longer acts), per motor and scenario, on the imaginary axis (N*s/m)."""
        t = self.timing
        w = np.geomspace(t.nyquist_rad_s, 100 * t.nyquist_rad_s, 200)
        return np.max(np.abs(self._loops.at(1j * w, self.scenarios).motor_reference), axis=-1)

    def staircase_n(self, m_v: float, b_v: float, rows: slice = slice(None), *,
                    sensed: np.ndarray | None = None) -> np.ndarray:
        """What the held reference's steps add to the motor force, per scenario (N), (n_s,): a sampled law's output
        is a staircase whose steps dv the velocity loop answers at once (K_t Kp dv through the drive); about the
        staircase's fundamental (what ``motor_forces`` carries) it swings by dv / 2, so the estimate is
        sup |R / G| above the Nyquist frequency times half the largest step of the law's output on the profile (the
        law run on the sensed force sampled at its rate), at the scenarios ``rows``. Against a time simulation of
        the sampled loop it is 0-4 % above the true peak (tests); 0 for a continuous law (the law's period is a
        whole number of the profile's steps, ``step_for``). ``sensed``: the block's ``_sensed`` spectrum when
        already computed."""
        t = self.timing
        if not t.sampled:
            return np.zeros(len(self.scenarios))[rows]
        n_a = round(t.period_s / self.step_s)
        from scipy.signal import lfilter

        if sensed is None:
            sensed = self._sensed(self.impedance(m_v, b_v), rows)
        filtered = sensed * force_filter_frd(self.s, t.filter_hz, t.filter_order)
        reading = (np.fft.irfft(filtered, self.n) / self.window)[..., ::n_a]
        alpha, beta, beta_prev = (float(c) for c in t.law(m_v, b_v))
        v_law = lfilter([beta, beta_prev], [1.0, -alpha], reading, axis=-1)
        step = np.max(np.abs(np.diff(v_law, axis=-1)), axis=(0, -1))          # (n_neck, n_s, n_samples) -> (n_s,)
        return np.max(self._reference_gain_above_nyquist[:, rows], axis=0) * step / 2

    def velocity_shortfall(self) -> np.ndarray:
        """How far the gantry's velocity falls short of a reference that runs the profile, at the end of its
        cruise (the last sample at peak speed), as a fraction of the peak speed, per scenario (n_s,): what the
        velocity loop's integral action has not yet made up (the mouse pushes that much harder to keep up)."""
        v = np.fft.irfft(self.r * self.vb, self.n) / self.window
        vel = self.profile.velocity_m_per_s
        end = int(np.flatnonzero(vel >= vel.max() * (1 - 1e-12))[-1])
        return (vel[end] - v[..., end]) / vel[end]

    def __call__(self, m_v: float, b_v: float) -> float:
        return float(np.max(np.abs(self.forces(m_v, b_v)[..., self.moving])))
