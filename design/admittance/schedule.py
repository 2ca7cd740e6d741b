"""The admittance scheduled over payload: the co-design (Kp, Ki, m_v, b_v; or m_v, b_v at the given PI gains)
made for each design payload of the spec alone, every other requirement and its verification kept, beside the
one robust design for the whole range; at each payload the force the mouse feels with each (nominal
parameters, ``design.admittance.profile.FeltForce``). A rig carries one payload at a time: the schedule says
what a design for the payload it carries would spare the mouse."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from design.admittance.model import PiLoops
from design.admittance.profile import FeltForce
from design.admittance.synthesis import AdmittanceResult, synthesise_admittance
from design.loop.controller import PI
from design.problem import LoopProblem, PayloadRange
from design.synth.scenarios import Scenarios


@dataclass(frozen=True)
class SchedulePoint:
    """The design for one payload, and the robust design's force felt at it."""

    payload_kg: float
    status: str
    controller: PI
    m_v: float
    b_v: float
    #: the peak force the mouse feels on the profile at this payload (N, nominal parameters): with the scheduled
    #: design, and with the one robust design for the whole range
    force_felt_n: float
    robust_force_felt_n: float
    #: m_v a_pk + b_v v_pk (N)
    peak_resistance_n: float


def admittance_schedule(problem: LoopProblem, robust: AdmittanceResult, *, controller: PI | None = None,
                        progress: Callable[[str], None] | None = None) -> tuple[SchedulePoint, ...]:
    """A ``SchedulePoint`` at each of the spec's design payloads (``plant.payload_kg.points``)."""
    say = progress or (lambda stage: None)
    out = []
    payloads = problem.plant.payload_kg.design_points()
    for i, p in enumerate(payloads):
        say(f"admittance schedule: payload {p:g} kg ({i + 1} of {payloads.size})")
        one = replace(problem, plant=replace(problem.plant, payload_kg=PayloadRange.fixed(float(p))))
        r = synthesise_admittance(one, controller=controller, tradeoff=False)
        here = Scenarios(np.array([float(p)]))
        felt = FeltForce(one, here, robust.corners, loops=PiLoops.of(one, robust.controller), timing=robust.timing)
        designed = r.status in ("optimal", "mouse_cannot_drive")
        out.append(SchedulePoint(float(p), r.status, r.controller, r.m_v, r.b_v,
                                 r.feel.peak_force_n if designed else float("nan"),
                                 felt(robust.m_v, robust.b_v), r.peak_resistance_n))
    return tuple(out)
