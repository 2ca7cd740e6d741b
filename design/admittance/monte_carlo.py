"""Monte Carlo verification of an admittance design: independent uniform draws over payload x the
spec's ``plant.uncertainty`` x the mouse ranges (a drawn mouse, not a corner), none of them a design
scenario, and the violation rate with its exact one-sided 95 % upper bound (Clopper-Pearson,
``design.synth.monte_carlo``).

Each draw is evaluated as the dense check evaluates a scenario (``design.admittance.model``): the
interaction loop's margins and Nyquist stability on the dense grid, and the hardware peaks. A draw
violates when a margin falls short by more than ``MARGIN_TOLERANCE`` (grid rounding, as in the
python-control verification), a hardware peak exceeds its limit by more than ``HARDWARE_TOLERANCE``,
or the coupled loop (or the velocity loop with the mouse attached) is unstable.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from design.admittance.model import (
    W_DENSE,
    MouseModel,
    admittance_problem,
    gantry_loop,
    interaction_gain,
    mouse_corners,
    virtual_impedance_frd,
    with_neck_modes,
)
from design.admittance.verify import MARGIN_TOLERANCE
from design.loop.margins import loop_margins, nyquist_stable
from design.problem import LoopProblem
from design.synth.monte_carlo import clopper_pearson_upper, draw_settings
from design.synth.scenarios import random_scenarios

#: relative excess of a hardware peak over its limit that counts as a violation
HARDWARE_TOLERANCE = 1e-3
CHUNK = 512


@dataclass(frozen=True)
class AdmittanceMonteCarlo:
    """(m_v, b_v) checked on ``samples`` independent draws (seed ``seed``)."""

    samples: int
    seed: int
    violations: int
    #: the one-sided 95 % upper bound on the violation rate (Clopper-Pearson)
    rate_upper_bound: float
    worst_phase_margin_deg: float
    worst_gain_margin_db: float
    worst_sensor_current_a: float
    worst_motor_force_n: float
    unstable: int
    #: the draw with the least slack: payload_kg and the uncertain parameters (the scenario)
    worst_scenario: dict
    #: and its mouse
    worst_mouse: dict

    @property
    def rate(self) -> float:
        return self.violations / self.samples


def random_mice(problem: LoopProblem, samples: int, *, seed: int) -> MouseModel:
    """``samples`` uniform draws over the spec's mouse ranges, as one ``MouseModel`` of (n, 1) arrays."""
    m = admittance_problem(problem).mouse
    rng = np.random.default_rng((seed, 1))
    return MouseModel(*(rng.uniform(r.min, r.max, (samples, 1)) for r in (
        m.head_mass_kg, m.body_mass_kg, m.neck_stiffness_n_per_m, m.neck_damping_n_s_per_m)))


def admittance_monte_carlo(problem: LoopProblem, *, kp: float, ki: float, m_v: float, b_v: float,
                           samples: int | None = None, seed: int | None = None) -> AdmittanceMonteCarlo:
    """Margins, stability and hardware peaks of (m_v, b_v) under the PI gains (kp, ki) on ``samples``
    draws (default: the problem's ``verification`` settings)."""
    adm = admittance_problem(problem)
    hw = adm.hardware
    samples, seed = draw_settings(problem, samples, seed)
    draws = random_scenarios(problem, samples, seed=seed)
    mice = random_mice(problem, samples, seed=seed)
    w = with_neck_modes(W_DENSE, mouse_corners(problem))
    z = virtual_impedance_frd(w, m_v, b_v)
    pm, gm, cur, force = (np.empty(samples) for _ in range(4))
    stable = np.empty(samples, bool)
    for start in range(0, samples, CHUNK):
        rows = np.arange(start, min(start + CHUNK, samples))
        loop = gantry_loop(problem, w, draws.take(rows), kp=kp, ki=ki)
        mouse = MouseModel(*(np.asarray(v)[rows] for v in mice.as_dict().values()))
        zm = mouse.impedance_frd(w)
        mg = loop_margins(w, interaction_gain(loop, mouse) / z)
        attached = nyquist_stable(loop.sensitivity * loop.mobility * zm)   # D = (1 + P C)(1 + S G Z_m)
        pm[rows], gm[rows] = mg.phase_margin_deg, mg.gain_margin_db
        stable[rows] = mg.closed_loop_stable & attached
        cur[rows] = np.max(np.abs(loop.controller * loop.sensitivity / z), axis=-1) * hw.force_sensor_resolution_n
        force[rows] = np.max(np.abs(loop.complementary * (1.0 / (loop.mobility * z) - 1.0)), axis=-1) \
            * adm.mouse.peak_force_n
    d_pm, d_gm = MARGIN_TOLERANCE
    bad = ((pm < adm.phase_margin_deg - d_pm) | (gm < adm.gain_margin_db - d_gm) | ~stable
           | (cur > hw.max_current_per_sensor_step_a * (1 + HARDWARE_TOLERANCE))
           | (force > hw.motor_peak_force_n * (1 + HARDWARE_TOLERANCE)))
    slack = np.min(np.stack([(pm - adm.phase_margin_deg) / max(adm.phase_margin_deg, 1.0),
                             np.where(np.isfinite(gm), gm - adm.gain_margin_db, np.inf) / max(adm.gain_margin_db, 1.0),
                             1 - cur / hw.max_current_per_sensor_step_a, 1 - force / hw.motor_peak_force_n]), axis=0)
    i = int(np.argmin(np.where(stable, slack, -np.inf)))
    k = int(bad.sum())
    return AdmittanceMonteCarlo(samples, seed, k, clopper_pearson_upper(k, samples), float(np.min(pm)),
                                float(np.min(gm)), float(np.max(cur)), float(np.max(force)), int(np.sum(~stable)),
                                draws.row(i), {n: float(np.asarray(v)[i, 0]) for n, v in mice.as_dict().items()})

