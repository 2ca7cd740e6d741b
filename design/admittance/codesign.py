"""Co-design: the PI gains of the velocity loop (and a force filter whose corner the spec leaves to the
design) chosen together with the virtual dynamics.

The interaction loop depends on the PI gains through R and S (``design.admittance.model``): a lower
integral gain, for one, makes the velocity loop softer against a braced mouse. For a candidate
(Kp, Ki[, f_c]) the score is the peak force the mouse feels on the locomotion profile
(``design.admittance.profile.FeltForce``) at the best ray of ``design.admittance.ray`` on a reduced set
(four payloads x the uncertainty corners x the mice with legs off, at the ends of their range; a coarse
grid); a candidate whose velocity loop misses the spec's PI requirements (phase and gain margin at the
same scenarios) is out. The search is a log grid over the gain bounds around the given gains,
then Nelder-Mead (scipy) in log coordinates from the best point. The synthesis then designs and
checks (m_v, b_v) at the chosen gains on the full sets.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from design.admittance.feel import feel_scenarios
from design.admittance.model import PiLoops, admittance_problem, interaction_responses, with_mode_points
from design.admittance.mouse import mouse_set
from design.admittance.profile import FeltForce
from design.admittance.ray import best_ray, ray_problem
from design.admittance.rig import RigTiming
from design.loop.controller import PI
from design.loop.margins import loop_margins
from design.parallel import thread_map
from design.problem import LoopProblem
from design.synth.scenarios import design_scenarios
from plant.grid import log_grid_rad_s

#: the factors of the given gains the coarse grid tries (within the spec's bounds)
KP_FACTORS = (0.6, 1.0, 1.5)
KI_FACTORS = (1.0, 0.1, 0.01, 0.001)
NELDER_MEAD_EVALUATIONS = 16
W_PI = log_grid_rad_s(0.01, 3000.0, 500)


@dataclass(frozen=True)
class CodesignRecord:
    controller: PI
    timing: RigTiming
    #: least force on the profile at the chosen gains and at the given ones, on the reduced set (N)
    force_n: float
    given_force_n: float
    given: PI
    evaluations: int
    #: the velocity loop's worst margins at the chosen gains over the reduced scenarios
    pi_phase_margin_deg: float
    pi_gain_margin_db: float


def codesign_score(problem: LoopProblem, *, controller: PI) -> float:
    """The co-design's score of the PI ``controller`` with the spec's rig (the force filter at its middle when
    designed): the force felt at the best ray on the reduced set, inf when the velocity loop misses its
    requirements."""
    adm = admittance_problem(problem)
    return _scorer(problem, RigTiming.of(adm.rig))(controller, None)[0]


def _scorer(problem: LoopProblem, timing: RigTiming):
    """score(controller, filter_hz) -> (force felt N, worst velocity-loop PM deg, GM dB) on the reduced set."""
    adm = admittance_problem(problem)
    pr = problem.plant.payload_kg
    scenarios = design_scenarios(problem, pr.grid(4) if pr.max > pr.min else None)
    feel = feel_scenarios(problem)
    corners = mouse_set(adm.mouse, leg_points=1)
    P = scenarios.plants(problem.plant.plant()).frd(W_PI)
    req = problem.requirements

    def score(controller: PI, filter_hz: float | None):
        t = timing if filter_hz is None else replace(timing, filter_hz=filter_hz)
        mg = loop_margins(W_PI, P * controller.frd(W_PI))
        pm, gm = float(np.min(mg.phase_margin_deg)), float(np.min(mg.gain_margin_db))
        if not (np.all(mg.closed_loop_stable) and pm >= req.phase_margin_deg and gm >= req.gain_margin_db):
            return math.inf, pm, gm
        return least_felt(problem, PiLoops.of(problem, controller), scenarios, feel, corners, t), pm, gm

    return score


def least_felt(problem: LoopProblem, loops, scenarios, feel, corners, timing: RigTiming, *, dtype=complex) -> float:
    """The co-design's score of velocity ``loops`` (``PiLoops``, ``design.admittance.dual.DualLoops``): the peak
    force felt on the locomotion profile (worst over the ``feel`` scenarios and ``corners``) at the best ray on
    ``scenarios`` x ``corners`` and a coarse grid (``design.admittance.ray``); inf when no ray holds."""
    adm = admittance_problem(problem)
    w = with_mode_points(_coarse(timing), corners, timing, points=12)
    resp = interaction_responses(problem, scenarios, w, loops=loops, timing=timing, corners=corners, dtype=dtype)
    felt = FeltForce(problem, feel, corners, loops=loops, timing=timing)
    ray = best_ray(ray_problem(resp, adm), objective=lambda r: felt(r.m_v, r.b_v), points=16, refine=1)
    return felt(ray.m_v, ray.b_v) if ray.feasible else math.inf


def codesign(problem: LoopProblem, *, controller: PI, timing: RigTiming) -> CodesignRecord:
    """``CodesignRecord`` of the best (Kp, Ki[, f_c]) from ``controller`` (module docstring)."""
    kp, ki = float(controller.kp), float(controller.ki)
    from scipy.optimize import minimize

    adm = admittance_problem(problem)
    score = _scorer(problem, timing)
    filt = adm.rig.force_filter
    designed = filt is not None and filt.designed
    bounds = [(problem.controller.kp.min, problem.controller.kp.max),
              (problem.controller.ki.min, problem.controller.ki.max)]
    if designed:
        bounds.append((filt.frequency_hz_min, filt.frequency_hz_max))
    log_bounds = np.log([(max(lo, 1e-9), hi) for lo, hi in bounds])
    cache: dict[tuple, tuple[float, float, float]] = {}

    def unpack(v):
        x = np.exp(np.clip(v, log_bounds[:, 0], log_bounds[:, 1]))
        t = replace(timing, filter_hz=float(x[2])) if designed else timing
        return float(x[0]), float(x[1]), t

    def force(v) -> float:
        key = tuple(np.round(v, 6))
        if key not in cache:
            k_p, k_i, t = unpack(v)
            cache[key] = score(PI(k_p, k_i), t.filter_hz if designed else None)
        return cache[key][0]

    start = [math.log(kp), math.log(max(ki, 1e-9))] + ([math.log(math.sqrt(filt.frequency_hz_min *
                                                                             filt.frequency_hz_max))]
                                                          if designed else [])
    filters = list(np.linspace(log_bounds[2, 0], log_bounds[2, 1], 3)) if designed else [None]
    grid = [np.array(start)]
    for fk in KP_FACTORS:
        for fi in KI_FACTORS:
            for lf in filters:
                v = np.array([math.log(kp * fk), math.log(max(ki * fi, 1e-9))] + ([lf] if designed else []))
                if np.all((v >= log_bounds[:, 0] - 1e-12) & (v <= log_bounds[:, 1] + 1e-12)):
                    grid.append(v)
    scores = thread_map(force, grid)
    given = scores[0]
    candidates = sorted((f, tuple(v)) for f, v in zip(scores[1:], grid[1:]))
    best_v, best_f = np.array(start), given
    for f0, v0 in candidates[:1]:
        if not math.isfinite(f0):
            continue
        res = minimize(lambda v: force(v) if math.isfinite(force(v)) else 1e12, np.array(v0), method="Nelder-Mead",
                       options={"maxfev": NELDER_MEAD_EVALUATIONS, "xatol": 1e-3, "fatol": 1e-4})
        if force(res.x) < best_f:
            best_v, best_f = res.x, force(res.x)
        if f0 < best_f:
            best_v, best_f = np.array(v0), f0
    k_p, k_i, t = unpack(best_v)
    _, pm, gm = cache[tuple(np.round(best_v, 6))]
    return CodesignRecord(PI(k_p, k_i), t, best_f, given, controller, len(cache), pm, gm)


def _coarse(timing: RigTiming) -> np.ndarray:
    if not timing.sampled:
        return log_grid_rad_s(0.01, 3000.0, 300)
    top = timing.nyquist_rad_s
    return np.geomspace(2 * math.pi * 0.01, top, int(60 * math.log10(top / 0.02 / math.pi)))

