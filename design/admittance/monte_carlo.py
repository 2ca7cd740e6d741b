"""Monte Carlo verification of an admittance design: independent draws over payload x the spec's
``plant.uncertainty`` x the mouse ranges (a drawn mouse, floating or on its legs, not a corner), none
of them a design scenario, and the violation rate with its exact one-sided 95 % upper bound
(Clopper-Pearson, ``design.synth.monte_carlo``).

Each draw is one curve (scenario and mouse) evaluated as the screened dense check evaluates one
(``design.admittance.model.AdmittanceEvaluator.evaluate``): its ray bound, on a coarse grid of the exactly
sampled loop (``design.admittance.sampled``), certifies it, or, when the bound comes within ``SCREEN_RATIO``
of b_v (and for the ``WORST_EXACT`` draws with the largest bounds), its loop is computed anew on the check
grid and its grid margins and the coupled discrete loop's poles are read; the hardware
peaks and the stability of the velocity loop with the mouse attached are computed for every draw. A draw violates
when a margin falls short by more than ``MARGIN_TOLERANCE`` (grid rounding, as in the python-control
verification), a hardware peak exceeds its limit by more than ``HARDWARE_TOLERANCE``, or a loop is
unstable.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from design.admittance.bounds import curve_bounds, polar
from design.admittance.model import (
    SCREEN_POINTS_PER_DECADE,
    SCREEN_RATIO,
    admittance_problem,
    attached_loop,
    check_grid_for,
    coupled_gain,
    current_path,
    mice,
    motor_force_peak,
    paired_margins,
    with_mode_points,
)
from design.admittance.mouse import FIELDS, MouseModel, random_mice
from design.admittance.profile import FeltForce
from design.admittance.rig import RigTiming
from design.loop.margins import nyquist_stable
from design.loop.requirement import ScenarioPoint
from design.parallel import thread_map
from design.problem import LoopProblem
from design.synth.monte_carlo import draw_settings, tally
from design.synth.scenarios import random_scenarios
from plant.grid import log_grid_rad_s

#: python-control margins may fall short of the requirement by this much (deg, dB): grid rounding
MARGIN_TOLERANCE = (0.1, 0.05)
#: relative excess of a hardware peak over its limit that counts as a violation
HARDWARE_TOLERANCE = 1e-3
#: draws per chunk, and the draws with the largest ray bounds whose margins are always computed
CHUNK = 128

WORST_EXACT = 8


@dataclass(frozen=True)
class AdmittanceMonteCarlo:
    """(m_v, b_v) checked on ``samples`` independent draws (seed ``seed``)."""

    samples: int
    seed: int
    violations: int
    #: the one-sided 95 % upper bound on the violation rate (Clopper-Pearson)
    rate_upper_bound: float
    #: worst margins over the draws whose margins were computed (the others are certified by their ray bound)
    worst_phase_margin_deg: float
    worst_gain_margin_db: float
    worst_sensor_current_a: float
    worst_motor_force_n: float
    unstable: int
    #: the draw with the least slack: its scenario
    worst_scenario: ScenarioPoint
    #: and its mouse
    worst_mouse: MouseModel
    #: draws whose margins were computed on the grid
    exact: int

    @property
    def rate(self) -> float:
        return self.violations / self.samples


def admittance_monte_carlo(problem: LoopProblem, *, loops, m_v: float, b_v: float, timing: RigTiming | None = None,
                           samples: int | None = None, seed: int | None = None, draws=None) -> AdmittanceMonteCarlo:
    """Margins, stability and hardware peaks of (m_v, b_v) under the velocity ``loops`` on ``samples`` draws
    (default: the problem's ``verification`` settings) of the scenarios (default: payload x uncertainty,
    ``random_scenarios``; ``draws``: a scenario set of ``samples`` rows drawn by the caller) and the mouse."""
    adm = admittance_problem(problem)
    timing = timing or RigTiming.of(adm.rig)
    hw = adm.hardware
    samples, seed = draw_settings(problem, samples, seed)
    draws = random_scenarios(problem, samples, seed=seed) if draws is None else draws
    if len(draws) != samples:
        raise ValueError(f"{len(draws)} scenario draws for {samples} samples")
    drawn = random_mice(adm.mouse, samples, seed=seed)
    corners = mice(problem)
    w = with_mode_points(check_grid_for(timing, per_decade=SCREEN_POINTS_PER_DECADE), corners, timing)
    wc = with_mode_points(log_grid_rad_s(1e-3, 3000.0, 500), corners, RigTiming(None))
    z = timing.impedance(w, m_v, b_v)
    g = 10 ** (adm.gain_margin_db / 20)
    bound, cur, force = (np.empty(samples) for _ in range(3))
    stable = np.empty(samples, bool)

    def batch(rows):
        return draws.take(rows), MouseModel(*(np.asarray(getattr(drawn, f))[rows] for f in FIELDS))

    def screen(start: int) -> None:
        rows = np.arange(start, min(start + CHUNK, samples))
        sc, mouse = batch(rows)
        gain = coupled_gain(loops, sc, mouse, w, timing, paired=True)
        bound[rows] = curve_bounds(*polar(gain), timing.impedance(w, m_v / b_v, 1.0), adm.phase_margin_deg, g,
                                   timing.sampled)
        loop = loops.at(1j * w, sc)
        W = timing.fundamental(w)
        cur[rows] = np.max(current_path(loop, W) / np.abs(z), axis=-1) * hw.force_sensor_resolution_n
        if hw.motor_force_criterion == "locomotion":
            force[rows] = FeltForce(problem, sc, mouse, loops=loops, timing=timing, paired=True).motor_peak_n(m_v, b_v)
        else:
            force[rows] = motor_force_peak(loop.motor_force, loop.motor_reference * W, z) * adm.mouse.peak_force_n
        free = loops.at(1j * wc, sc)
        stable[rows] = nyquist_stable(attached_loop(free, mouse, paired=True))

    thread_map(screen, range(0, samples, CHUNK))
    # every draw near its bound and the WORST_EXACT largest bounds: their loops anew on the check grid, their grid
    # margins and closed-loop poles
    keep = np.union1d(np.flatnonzero(bound >= SCREEN_RATIO * b_v), np.argsort(-bound)[:WORST_EXACT])
    pm, gm = np.full(samples, np.inf), np.full(samples, np.inf)
    wk = with_mode_points(check_grid_for(timing), corners, timing)
    def exact(start: int) -> None:
        rows = keep[start:start + CHUNK]
        sc, mouse = batch(rows)
        p_, g_, st = paired_margins(loops, sc, mouse, wk, timing, m_v, b_v)
        pm[rows], gm[rows] = p_, g_
        stable[rows] &= st

    thread_map(exact, range(0, keep.size, CHUNK))
    d_pm, d_gm = MARGIN_TOLERANCE
    limit_i = hw.max_current_per_sensor_step_a
    bad = ((pm < adm.phase_margin_deg - d_pm) | (gm < adm.gain_margin_db - d_gm) | ~stable
           | (force > hw.motor_peak_force_n * (1 + HARDWARE_TOLERANCE)))
    if limit_i is not None:
        bad |= cur > limit_i * (1 + HARDWARE_TOLERANCE)
    slack = np.min(np.stack([(pm - adm.phase_margin_deg) / max(adm.phase_margin_deg, 1.0),
                             np.where(np.isfinite(gm), gm - adm.gain_margin_db, np.inf) / max(adm.gain_margin_db, 1.0),
                             np.ones(samples) if limit_i is None else 1 - cur / limit_i,
                             1 - force / hw.motor_peak_force_n, 1 - bound / b_v]), axis=0)
    t = tally(bad, slack, stable)
    computed = np.isfinite(pm)
    return AdmittanceMonteCarlo(samples, seed, t.violations, t.rate_upper_bound,
                                float(np.min(pm[computed])) if computed.any() else float("inf"),
                                float(np.min(gm[computed])) if computed.any() else float("inf"),
                                float(np.max(cur)), float(np.max(force)), t.unstable, draws.row(t.worst),
                                MouseModel(*(float(np.asarray(getattr(drawn, n))[t.worst, 0]) for n in FIELDS)),
                                int(keep.size))

