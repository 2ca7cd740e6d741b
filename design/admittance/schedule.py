"""The admittance scheduled over payload: the co-design (Kp, Ki, m_v, b_v; or m_v, b_v at the given PI gains)
made for each design payload of the spec alone, every other requirement and its verification kept, beside the
one robust design for the whole range; at each payload the force the mouse feels with each (nominal
parameters, ``design.admittance.profile.FeltForce``). The robust design holds at every payload of the range, so it
is a candidate at each: where the payload's own design asks the mouse more (its co-design scores gains on a
reduced set, and the full checks can then scale its virtual dynamics up), the schedule keeps the robust design
there and says so. A rig carries one payload at a time: the schedule says what a design for the payload it
carries would spare the mouse."""

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
    #: the payload's own design asked more than the robust design (or was not found): the robust one is kept here;
    #: the own design's force felt (N; nan when it was not designed)
    kept_robust: bool = False
    own_force_felt_n: float = float("nan")


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
        own = r.feel.peak_force_n if designed else float("nan")
        kept = felt(robust.m_v, robust.b_v)
        if own <= kept:
            out.append(SchedulePoint(float(p), r.status, r.controller, r.m_v, r.b_v, own, kept, r.peak_resistance_n,
                                     own_force_felt_n=own))
            continue
        status = "optimal" if kept <= problem.admittance.mouse.peak_force_n else "mouse_cannot_drive"
        out.append(SchedulePoint(float(p), status, robust.controller, robust.m_v, robust.b_v, kept, kept,
                                 robust.peak_resistance_n, kept_robust=True, own_force_felt_n=own))
    return tuple(out)
