"""Gain schedule: the best PI gains for each payload point alone, for experiments where the
payload is known beforehand, and the bandwidth they gain over the robust design.

Each point is solved like one round of ``design.synth.pi.synthesise_pi`` with a single payload
(scan, then casadi + IPOPT from the robust gains and from the best scan seed) on the corners of the
uncertainty at that payload, checked with the cubic-refined margins on its check scenarios and
verified with python-control. The schedule is
verified at its points only: gains interpolated between points are not checked.
"""

from __future__ import annotations

from dataclasses import dataclass

from design.loop.controller import PI
from design.problem import LoopProblem
from design.synth.evaluation import evaluate
from design.synth.exact import exact_design
from design.synth.pi import verification_scenarios
from design.synth.scan import W_OPT, scan_gains
from design.synth.scenarios import check_scenarios, design_scenarios
from design.synth.verify import verify


@dataclass(frozen=True)


class SchedulePoint:
    payload_kg: float
    controller: PI
    bandwidth_hz: float
    phase_margin_deg: float
    gain_margin_db: float
    #: bandwidth of the robust (single) gains at this payload
    robust_bandwidth_hz: float
    verified: bool
    failures: tuple[str, ...]


def gain_schedule(problem: LoopProblem, controller: PI) -> list[SchedulePoint]:
    """Per-payload optimum gains at the problem's payload points, each robust to its uncertainty; ``controller``
    is the design for the whole range."""
    plant = problem.plant.plant()
    out = []
    for m in problem.plant.payload_kg.design_points():
        corners, check = design_scenarios(problem, [m]), check_scenarios(problem, [m])
        robust = evaluate(problem, controller, check)
        scan = scan_gains(problem, corners.plants(plant).frd(W_OPT))
        starts = [controller] + [PI(scan.kp[i], scan.ki[i]) for i in scan.best(scan.meets, scan.worst_bandwidth_hz, 1)]
        best = robust
        for start in starts:
            ex = exact_design(problem, corners, start)
            if ex.success:
                ev = evaluate(problem, ex.controller, check)
                if ev.meets and ev.worst_bandwidth_hz > best.worst_bandwidth_hz:
                    best = ev
        v = verify(problem, best.controller, verification_scenarios(corners, check, best),
                   claimed_worst_bandwidth_hz=best.worst_bandwidth_hz)
        out.append(SchedulePoint(float(m), best.controller, float(best.bandwidth_hz[0]),
                                 float(best.phase_margin_deg[0]), float(best.gain_margin_db[0]),
                                 float(robust.bandwidth_hz[0]), v.verified, v.failures))
    return out
