"""What the mouse feels with a design: the force on its locomotion profile, the speed and acceleration its
force budget reaches, the apparent mass and damping over frequency, and the gantry at rest.

* **Force felt on the profile.** The mouse's body follows the trapezoidal profile (velocity v_b(t)); the
  head (mass m_h) rides the clamp, whose velocity answers the sensed force through the rendered
  admittance, v_h = Y_r F_s; the neck (Z_n = c_n + k_n/s) carries the force between body and head. The
  force the mouse feels is the neck force::

      F_n / v_b = Z_n (1 + m_h s Y_r) / (1 + (Z_n + m_h s) Y_r)

  (m_v a + b_v v at low frequency, and bounded at the profile's acceleration steps: the neck is what
  a real mouse pushes through). Computed by FFT over the profile padded with rest, with an exponential
  window (the input times e^(-c t), the response at s = c + jw, the output times e^(c t), c = 8 / the
  window's length) so the circular convolution's wrap-around is damped by e^-8 and slow modes of the
  loop (an integral gain far below the proportional one) come out as the response from rest; at every
  scenario and mouse of the evaluation set; the peak and the RMS over the moving part are reported.
* **Reach.** Pushing with its peak force F from rest, the clamp reaches the speed F Y_r(0) = F / b_v, and
  its acceleration peaks at max d/dt of F times the step response of Y_r.
* **Apparent dynamics.** 1/Y_r = b_app(w) + j w m_app(w): apparent damping and mass over frequency.
* **At rest.** The offset left after taring drifts the gantry at beta / b_v beyond the deadband
  (``design.admittance.model.drift_mm_per_s``); the mouse must push deadband + offset to start it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from design.admittance.model import (
    admittance_problem,
    breakaway_force_n,
    drift_mm_per_s,
)
from design.admittance.mouse import stack
from design.admittance.rig import RigTiming
from design.problem import Locomotion, LoopProblem
from design.synth.scenarios import Scenarios

#: time step (s) and rest before and after the profile (s) of the force computation
DT_S = 1e-3
REST_S = 0.6


@dataclass(frozen=True)
class Profile:
    """A trapezoidal velocity profile: time (s), acceleration (m/s^2), velocity (m/s)."""

    time_s: np.ndarray
    acceleration_m_per_s2: np.ndarray
    velocity_m_per_s: np.ndarray

    @property
    def moving(self) -> np.ndarray:
        return self.velocity_m_per_s > 0


def trapezoid(loc: Locomotion, *, dt_s: float = DT_S, rest_s: float = REST_S) -> Profile:
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


@dataclass(frozen=True)
class MouseFeel:
    """The design as the mouse feels it (worst over the scenarios and mice evaluated)."""

    #: m_v a_pk + b_v v_pk: what the virtual dynamics ask at the profile's corner (N)
    ideal_peak_force_n: float
    #: the neck force with the real loop: peak and RMS over the moving part (N)
    peak_force_n: float
    rms_force_n: float
    #: where the peak occurs (payload and mouse)
    worst: str
    #: with the mouse's peak force from rest: the final speed F / b_v (m/s) and the peak acceleration (m/s^2)
    reachable_speed_m_per_s: float
    reachable_acceleration_m_per_s2: float
    #: the declared mouse can run the declared profile
    can_drive: bool
    drift_mm_per_s: float
    breakaway_force_n: float
    #: apparent mass (kg) and damping (N*s/m) over frequency at the evaluated payloads, (n_payload, n_freq)
    frequency_hz: np.ndarray
    payload_kg: np.ndarray
    apparent_mass_kg: np.ndarray
    apparent_damping_n_s_per_m: np.ndarray
    #: the force felt over the profile at the worst case (time s, N) and the ideal m_v a + b_v v
    profile: Profile
    force_n: np.ndarray
    ideal_force_n: np.ndarray


class FeltForce:
    """The peak force the mouse feels on the locomotion profile for any (m_v, b_v), worst over ``scenarios``
    x the distinct necks and heads of ``corners`` (module docstring): the parts that do not depend on
    (m_v, b_v) are computed once on the profile's FFT grid, so a search can call it many times."""

    def __init__(self, problem: LoopProblem, scenarios, corners, *, loops, timing: RigTiming):
        adm = admittance_problem(problem)
        self.profile = trapezoid(adm.locomotion)
        self.n = self.profile.time_s.size
        self.damping = 8.0 / (self.n * DT_S)
        f = np.fft.rfftfreq(self.n, DT_S)
        s = self.damping + 2j * np.pi * f
        loop = loops.at(s, scenarios)
        self.scenarios, self.timing = scenarios, timing
        self.sg = loop.sensitivity_mobility                                 # (n_s, n_f)
        self.rw = loop.reference * timing.fundamental_at(s)
        self.sigma, self.rho = timing.sigma_at(s), timing.rho_at(s)
        self.necks = list({(m.head_mass_kg, m.neck_stiffness_n_per_m, m.neck_damping_n_s_per_m): m
                           for m in corners}.values())
        batch = stack(self.necks)
        self.zn = (batch.neck_damping_n_s_per_m + batch.neck_stiffness_n_per_m / s)[:, None, :]
        self.mh = (batch.head_mass_kg * s)[:, None, :]
        self.window = np.exp(-self.damping * self.profile.time_s)
        self.vb = np.fft.rfft(self.profile.velocity_m_per_s * self.window)
        self.moving = self.profile.moving
        # the apparent dynamics and the reach are read on the imaginary axis
        self.f_hz = f[1:]
        self.w = 2 * np.pi * self.f_hz
        free = loops.at(1j * self.w, scenarios)
        self._sg_jw = free.sensitivity_mobility
        self._rw_jw = free.reference * timing.fundamental(self.w)
        self._sigma_jw, self._rho_jw = timing.sigma(self.w), timing.rho(self.w)

    def rendered(self, m_v: float, b_v: float) -> np.ndarray:
        """Y_r at the FFT frequencies (on the imaginary axis, without DC), (n_s, n_f)."""
        return self._sg_jw + self._rw_jw / (m_v * self._sigma_jw + b_v * self._rho_jw)

    def forces(self, m_v: float, b_v: float) -> np.ndarray:
        """The neck force over the profile at every neck and scenario, (n_neck, n_s, n_t)."""
        yr = self.sg + self.rw / (m_v * self.sigma + b_v * self.rho)
        h = self.zn * (1 + self.mh * yr) / (1 + (self.zn + self.mh) * yr)
        return np.fft.irfft(h * self.vb, self.n) / self.window

    def __call__(self, m_v: float, b_v: float) -> float:
        return float(np.max(np.abs(self.forces(m_v, b_v)[..., self.moving])))


def feel_scenarios(problem: LoopProblem) -> Scenarios:
    """Where the force felt is evaluated: the lightest, middle and heaviest payloads with the nominal
    parameters (a performance measure; the requirements hold over the uncertainty)."""
    pr = problem.plant.payload_kg
    return Scenarios(pr.grid(3) if pr.max > pr.min else np.array([pr.min]))


def mouse_feel(problem: LoopProblem, *, loops, m_v: float, b_v: float, scenarios, corners,
               timing: RigTiming | None = None, felt: FeltForce | None = None) -> MouseFeel:
    """``MouseFeel`` of (m_v, b_v) at ``scenarios`` x the mice ``corners`` (their neck and head masses
    matter; the legs do not: the body's motion is prescribed)."""
    adm = admittance_problem(problem)
    timing = timing or RigTiming.of(adm.rig)
    loc = adm.locomotion
    felt = felt or FeltForce(problem, scenarios, corners, loops=loops, timing=timing)
    force = felt.forces(m_v, b_v)
    moving = felt.moving
    peak = np.max(np.abs(force[..., moving]), axis=-1)
    rms = np.sqrt(np.mean(force[..., moving] ** 2, axis=-1))
    k, j = np.unravel_index(int(np.argmax(peak)), peak.shape)
    mouse = felt.necks[k]
    yr = felt.rendered(m_v, b_v)
    # reach: the acceleration when the mouse pushes with F from rest is F times the impulse response of Y_r
    # (at the scenario of the worst force); the speed tends to F Y_r(0) = F / b_v
    F = adm.mouse.peak_force_n
    acc = F * np.fft.irfft(np.concatenate([[1.0 / b_v], yr[j]]), felt.n) / DT_S
    prof = felt.profile
    ideal = m_v * prof.acceleration_m_per_s2 + b_v * prof.velocity_m_per_s
    payloads = np.unique(felt.scenarios.payload_kg)
    first = [int(np.flatnonzero(felt.scenarios.payload_kg == p)[0]) for p in payloads]
    z = 1.0 / yr[first]
    return MouseFeel(float(m_v * loc.peak_acceleration_m_per_s2 + b_v * loc.peak_speed_m_per_s),
                     float(peak[k, j]), float(np.max(rms)), f"{felt.scenarios.describe(j)}, mouse ({mouse.label()})",
                     F / b_v, float(np.max(acc[: felt.n // 2])), bool(peak[k, j] <= F),
                     float(drift_mm_per_s(adm, b_v)), breakaway_force_n(adm), felt.f_hz, payloads, z.imag / felt.w,
                     z.real, prof, force[k, j], ideal)
