"""Co-design of the two-motor Stage Y for the mouse: the structure's translation gains chosen together with the
virtual dynamics (``admittance.codesign = true`` beside ``[dual_drive]``).

The structure's own design (``design.synth.dual``) maximises the translation bandwidth; its stiff integral action
holds the clamp against a braced mouse, and the interaction loop then needs a heavy m_v. As for one motor
(``design.admittance.codesign``), the candidates are the structure's translation channel (both motors' PI for
``per_motor``, the common channel of ``common_differential``, the one PI of ``master_slave``) with its gains times
``KP_FACTORS`` x ``KI_FACTORS``; the yaw channel keeps its design. A candidate is kept only where its velocity loops
meet every requirement the structure was designed to (loop-at-a-time, disk and common-mode margins,
``design.synth.dual.worst_cases``) on the design plants (carriage positions x payloads x uncertainty corners); its
score is the force the mouse feels at its best ray on a reduced set (the travel's ends and middle x the payload's
ends x the uncertainty corners x the mice at the ends of their ranges, ``design.admittance.codesign.least_felt``).
The chosen gains are then checked between the design grid's points and on the Monte Carlo draws as the structure's
own design is (``design.synth.dual_worst.between_check``), before the admittance is designed and verified on them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from design.admittance.codesign import KI_FACTORS, KP_FACTORS, least_felt
from design.admittance.dual import DualLoops
from design.admittance.dual_codesign_record import DualCodesignRecord
from design.admittance.model import admittance_problem
from design.admittance.mouse import mouse_set
from design.admittance.rig import RigTiming
from design.loop.dual import Controller
from design.parallel import thread_map
from design.problem import LoopProblem
from design.synth.dual import DualRequirements, dual_scenarios, monte_carlo_scenarios, worst_cases
from design.synth.dual_worst import between_check
from design.synth.monte_carlo import as_drawn
from plant.physics.dual_drive import DualDriveStageY

#: each structure's translation channel: the fields of its proportional and integral gain
TRANSLATION = {"per_motor": ("kp", "ki"), "master_slave": ("kp", "ki"), "common_differential": ("kp_common",
                                                                                                "ki_common")}


def candidates(controller: Controller) -> list[Controller]:
    """``controller`` first, then its translation gains times ``KP_FACTORS`` x ``KI_FACTORS`` (module doc)."""
    kp, ki = TRANSLATION[controller.name]
    out = [controller]
    for fp in KP_FACTORS:
        for fi in KI_FACTORS:
            c = replace(controller, **{kp: getattr(controller, kp) * fp, ki: getattr(controller, ki) * fi})
            if c != controller:
                out.append(c)
    return out


def dual_codesign(problem: LoopProblem, *, controller: Controller, model: DualDriveStageY,
                  travel_m: tuple[float, float], design_positions: int, stage_x_mass_kg: float,
                  ranges: Mapping[str, tuple[float, float]], requirements: DualRequirements, timing: RigTiming,
                  samples: int, seed: int) -> DualCodesignRecord:
    """``DualCodesignRecord`` of the best translation gains from ``controller`` (module doc)."""
    adm = admittance_problem(problem)
    pr = problem.plant.payload_kg
    lo, hi = travel_m
    masses = stage_x_mass_kg + np.asarray(pr.design_points(), float)
    plants = dual_scenarios(model, np.linspace(lo, hi, design_positions), masses, ranges, stage_x_mass_kg)
    ends = np.unique([pr.min, pr.max])
    travel = np.unique([lo, 0.5 * (lo + hi), hi])
    reduced = dual_scenarios(model, travel, stage_x_mass_kg + ends, ranges, stage_x_mass_kg)
    feel = dual_scenarios(model, travel, stage_x_mass_kg + ends, {}, stage_x_mass_kg)
    corners = mouse_set(adm.mouse, leg_points=1)
    tried = candidates(controller)
    plants.frd                                        # computed once, before the threads share it
    worst = worst_cases(tried, plants, requirements)

    def score(k: int) -> float:
        if not worst[k].feasible:
            return math.inf
        return least_felt(problem, DualLoops(tried[k]), reduced, feel, corners, timing, dtype=np.complex64)

    scores = thread_map(score, range(len(tried)))
    mass_range = (float(masses.min()), float(masses.max()))
    draws = monte_carlo_scenarios(model, (lo, hi), mass_range, ranges, samples, seed, stage_x_mass_kg)
    better = sorted((k for k in range(1, len(tried)) if scores[k] < scores[0]), key=scores.__getitem__)
    for k in better + [0]:          # the best first; the structure's own design, which its synthesis checked, last
        between = between_check(tried[k], model, travel_m=(lo, hi), carriage_masses_kg=mass_range, ranges=ranges,
                                req=requirements, stage_x_mass_kg=stage_x_mass_kg)
        record = DualCodesignRecord(tried[k], controller, float(scores[k]), float(scores[0]),
                                    sum(w.feasible for w in worst), len(tried), worst[k], between,
                                    as_drawn(worst_cases([tried[k]], draws, requirements)[0]))
        if record.verified:
            break
    return record
