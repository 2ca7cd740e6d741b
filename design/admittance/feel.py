"""What the mouse feels with a design: the force on its locomotion profile, the speed and acceleration its
force budget reaches, the apparent mass and damping over frequency, and the gantry at rest.

* **Force felt on the profile.** The neck force while the body runs the trapezoid
  (``design.admittance.profile``): m_v a + b_v v at low frequency, and bounded at the profile's
  acceleration steps (the neck is what a real mouse pushes through); at every scenario and mouse of the
  evaluation set; the peak and the RMS over the moving part are reported.
* **Reach.** Pushing with its peak force F from rest, the clamp reaches the speed F Y_r(0) = F / b_v, and
  its acceleration peaks at max d/dt of F times the step response of Y_r.
* **Apparent dynamics.** 1/Y_r = b_app(w) + j w m_app(w): apparent damping and mass over frequency.
* **At rest.** The offset left after taring drifts the gantry at beta / b_v beyond the deadband
  (``design.admittance.model.drift_mm_per_s``); the mouse must push deadband + offset to start it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from design.admittance.model import (
    admittance_problem,
    breakaway_force_n,
    drift_mm_per_s,
)
from design.admittance.profile import FeltForce, Profile
from design.admittance.rig import RigTiming
from design.problem import LoopProblem
from design.synth.scenarios import Scenarios

#: the time step (s) of the reach's impulse response: its peak is the response's first instants (a light virtual
#: mass, a fast law), within 0.15 % of a 0.0625 ms step at 5 and 40 kg for laws at 100 Hz to 1 kHz and a
#: continuous one, where the profile's 2 ms step is up to 18 % off (tests)
REACH_STEP_S = 0.25e-3

#: a velocity shortfall above this fraction is reported (the PI's integral action too slow for the cruise)
SHORTFALL_REPORTED = 0.02


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
    #: how far the velocity loop leaves the gantry short of the law's reference at the end of the profile's
    #: cruise, worst over the payloads (fraction of the peak speed; ``FeltForce.velocity_shortfall``)
    velocity_shortfall: float = 0.0

    @property
    def shortfall_reported(self) -> bool:
        return self.velocity_shortfall > SHORTFALL_REPORTED


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
    # (at the scenario of the worst force, on its own finer grid); the speed tends to F Y_r(0) = F / b_v
    F = adm.mouse.peak_force_n
    fine = FeltForce(problem, felt.scenarios.take([j]), [mouse], loops=loops, timing=timing, max_step_s=REACH_STEP_S)
    acc = F * np.fft.irfft(np.concatenate([[1.0 / b_v], fine.rendered(m_v, b_v)[0]]), fine.n) / fine.step_s
    prof = felt.profile
    ideal = m_v * prof.acceleration_m_per_s2 + b_v * prof.velocity_m_per_s
    payloads = np.unique(felt.scenarios.payload_kg)
    first = [int(np.flatnonzero(felt.scenarios.payload_kg == p)[0]) for p in payloads]
    z = 1.0 / yr[first]
    return MouseFeel(float(m_v * loc.peak_acceleration_m_per_s2 + b_v * loc.peak_speed_m_per_s),
                     float(peak[k, j]), float(np.max(rms)), f"{felt.scenarios.describe(j)}, mouse ({mouse.label()})",
                     F / b_v, float(np.max(acc[: fine.n // 2])), bool(peak[k, j] <= F),
                     float(drift_mm_per_s(adm, b_v)), breakaway_force_n(adm), felt.f_hz, payloads, z.imag / felt.w,
                     z.real, prof, force[k, j], ideal, float(np.max(felt.velocity_shortfall())))
