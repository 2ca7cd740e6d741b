"""The law's computation delay as a range (``admittance.rig.computation_delay_samples = { min, max }``): the
design must hold at every whole number of samples in it, since nobody has measured the rig's timing.

Each check is made at every delay of the range and the results are joined here, worst first: the rays on the
union of the curves of every delay (``span_ray_problem``: a ray's bound is the largest over its curves, so the
union's optimum holds at every delay), the dense check margin by margin (``DelaySpanEvaluator``), the
Monte Carlo draws added up (``join_monte_carlo``), python-control's verification at every delay
(``join_verifications``) and the force felt as its worst (``WorstFelt``). A single delay passes through
unchanged.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from design.admittance.model import AdmittanceCheck, AdmittanceEvaluator
from design.admittance.monte_carlo import AdmittanceMonteCarlo
from design.admittance.profile import FeltForce
from design.admittance.ray import RayProblem
from design.admittance.rig import RigTiming
from design.admittance.verify import AdmittanceVerification
from design.synth.monte_carlo import clopper_pearson_upper


def samples_text(d: int) -> str:
    return f"{d} sample{'' if d == 1 else 's'} of computation delay"


def span_ray_problem(problems: list[RayProblem]) -> RayProblem:
    """One ray problem whose curves are every delay's (rows joined, delay-major)."""
    if len(problems) == 1:
        return problems[0]
    first = problems[0]

    def rows(name):
        parts = [getattr(p, name) for p in problems]
        return None if parts[0] is None else np.concatenate(parts)

    current = None if first.current_peak is None else np.max([p.current_peak for p in problems], axis=0)
    band = first.passive_band
    return replace(first, log_mag=rows("log_mag"), psi=rows("psi"), motor_force=rows("motor_force"),
                   motor_reference=rows("motor_reference"), current_peak=current,
                   passive_re_sg=rows("passive_re_sg"), passive_rw=rows("passive_rw"), passive_band=band)


def join_checks(checks: list[AdmittanceCheck], delays: tuple[int, ...]) -> AdmittanceCheck:
    """The worst of each figure over the delays' checks (same scenarios and mice), every violation kept with its
    delay named."""
    if len(checks) == 1:
        return checks[0]

    def stack(name):
        return np.stack([getattr(c, name) for c in checks])

    pm, gm = (np.fmin.reduce(stack(n), axis=0) for n in ("phase_margin_deg", "gain_margin_db"))   # nan: none computed
    violations = tuple(replace(v, detail=f"{v.detail} with {samples_text(d)}", delay_samples=d)
                       for c, d in zip(checks, delays) for v in c.violations)
    recorded = {}
    if checks[0].recorded_motor_force_n is not None:
        peaks = stack("recorded_motor_force_n")
        worst = np.argmax(peaks, axis=0)
        recorded = {"recorded_motor_force_n": np.max(peaks, axis=0),
                    "recorded_motor_at_s": np.take_along_axis(stack("recorded_motor_at_s"), worst[None], 0)[0]}
    return replace(checks[0], **recorded, phase_margin_deg=pm, gain_margin_db=gm,
                   stable=np.all(stack("stable"), axis=0),
                   bound_ratio=np.max(stack("bound_ratio"), axis=0),
                   sensor_current_a=np.max(stack("sensor_current_a"), axis=0),
                   motor_force_n=np.max(stack("motor_force_n"), axis=0),
                   rendered_bandwidth_hz=np.min(stack("rendered_bandwidth_hz"), axis=0),
                   passive_up_to_hz=np.min(stack("passive_up_to_hz"), axis=0), violations=violations)


class DelaySpanEvaluator:
    """``AdmittanceEvaluator.evaluate`` at every delay of ``timing``, joined (``join_checks``)."""

    def __init__(self, problem, scenarios, *, loops, timing: RigTiming, corners=None):
        self.delays = timing.delays
        self.evaluators = [AdmittanceEvaluator(problem, scenarios, loops=loops, timing=t, corners=corners)
                           for t in timing.per_delay()]
        self.scenarios, self.corners = self.evaluators[0].scenarios, self.evaluators[0].corners

    def evaluate(self, m_v: float, b_v: float, **options) -> AdmittanceCheck:
        return join_checks([e.evaluate(m_v, b_v, **options) for e in self.evaluators], self.delays)


def evaluator(problem, scenarios, *, loops, timing: RigTiming, corners=None):
    """The dense check of ``timing``: one ``AdmittanceEvaluator``, or a ``DelaySpanEvaluator`` for a range."""
    if len(timing.delays) == 1:
        return AdmittanceEvaluator(problem, scenarios, loops=loops, timing=timing, corners=corners)
    return DelaySpanEvaluator(problem, scenarios, loops=loops, timing=timing, corners=corners)


class WorstFelt:
    """The force felt on the profile, worst over the delays of ``timing`` (``FeltForce`` at each)."""

    def __init__(self, problem, scenarios, corners, *, loops, timing: RigTiming):
        self.felts = [FeltForce(problem, scenarios, corners, loops=loops, timing=t) for t in timing.per_delay()]

    def worst(self, m_v: float, b_v: float) -> FeltForce:
        """The delay's ``FeltForce`` at which (m_v, b_v) feels heaviest."""
        return max(self.felts, key=lambda f: f(m_v, b_v))

    def __call__(self, m_v: float, b_v: float) -> float:
        return max(f(m_v, b_v) for f in self.felts)


def join_monte_carlo(runs: list[AdmittanceMonteCarlo]) -> AdmittanceMonteCarlo:
    """The draws of every delay together: violations and samples added, the worst figures and draw kept."""
    if len(runs) == 1:
        return runs[0]
    worst = min(runs, key=lambda r: (r.violations == 0, r.worst_phase_margin_deg))
    samples, bad = sum(r.samples for r in runs), sum(r.violations for r in runs)
    return replace(worst, samples=samples, violations=bad, rate_upper_bound=clopper_pearson_upper(bad, samples),
                   worst_phase_margin_deg=min(r.worst_phase_margin_deg for r in runs),
                   worst_gain_margin_db=min(r.worst_gain_margin_db for r in runs),
                   worst_sensor_current_a=max(r.worst_sensor_current_a for r in runs),
                   worst_motor_force_n=max(r.worst_motor_force_n for r in runs),
                   unstable=sum(r.unstable for r in runs), exact=sum(r.exact for r in runs))


def join_verifications(runs: list[AdmittanceVerification], delays: tuple[int, ...]) -> AdmittanceVerification:
    """python-control's verification at every delay: verified when every one is, its failures named by delay."""
    if len(runs) == 1:
        return runs[0]
    return replace(runs[0], verified=all(r.verified for r in runs),
                   max_closed_loop_pole=max(r.max_closed_loop_pole for r in runs),
                   max_open_loop_pole_real_part=max(r.max_open_loop_pole_real_part for r in runs),
                   min_phase_margin_deg=min(r.min_phase_margin_deg for r in runs),
                   min_gain_margin_db=min(r.min_gain_margin_db for r in runs), cases=sum(r.cases for r in runs),
                   failures=tuple(f"{f} with {samples_text(d)}" for r, d in zip(runs, delays) for f in r.failures))
