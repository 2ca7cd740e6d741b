"""What the admittance section of a design report draws, computed before it is drawn: the rendered
admittance against the virtual dynamics at the light, nominal and heavy payloads, a simulated mouse run
through the sampled loop, and the mouse lab's hand-tuned setting evaluated on the same plant beside the
design (with the numbers of the lab's own bandwidth model, reproduced)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from design.admittance.delays import WorstFelt, evaluator
from design.admittance.feel import feel_scenarios
from design.admittance.lab_model import LabBandwidthModel, admittance_bandwidth_hz
from design.admittance.model import (
    PiLoops,
    admittance_problem,
    gantry_loop,
    mice,
    rendered_admittance,
    virtual_impedance_frd,
)
from design.admittance.mouse_run import MouseRun, mouse_run, run_settings, trapezoid_path
from design.loop.curves import report_payloads
from design.problem import LoopProblem
from design.synth.scenarios import admittance_check_scenarios
from plant.errors import SpecError
from plant.grid import log_grid_rad_s

#: the rendered admittance's plot: 0.1 Hz to 1 kHz, or to the law's Nyquist frequency when it is sampled
RENDERED_HZ, RENDERED_POINTS = (0.1, 1000.0), 800
#: the lab's hand-tuned X-axis setting: bsbrl/exoskeleton, "2. Admittance Controller Tuning/Admittance - 2.
#: X axis mousetrack/Tuning Data and Figures/M4xx_analysis_newsys_m0p04_c4.fig" (m = 0.04 kg, c = 4 N*s/m)
LAB_M_V_KG, LAB_B_V_N_S_PER_M = 0.04, 4.0


@dataclass(frozen=True)
class LabComparison:
    """The lab's setting on the spec's plant, loop and rig, beside the design (same PI gains): worst
    interaction margins (floating and grounded mice, over the dense check), stability, the force felt on
    the profile and the passive band; and the apparent-admittance bandwidth of the lab's own model of its
    robot (``design.admittance.lab_model``, published parameters, axis 1)."""

    m_v: float
    b_v: float
    margins: dict[str, tuple[float, float]]
    stable: bool
    force_felt_n: float
    passive_up_to_hz: float
    lab_model_bandwidth_hz: float
    #: the (scenario, mouse) pairs of the dense check where the lab's setting is unstable, in words
    unstable_at: tuple[str, ...] = ()


@dataclass(frozen=True)
class AdmittanceCurves:
    payload_kg: tuple[float, ...]
    w_rad_s: np.ndarray
    #: 1/(m_v s + b_v), (m/s)/N
    virtual: np.ndarray
    #: velocity per sensed force at each payload (the fundamental when sampled), (n_payload, n_freq)
    rendered: np.ndarray
    run: MouseRun | None
    lab: LabComparison | None
    #: why there is no mouse run (an effect of the plant it cannot simulate), in words
    run_refused: str | None = None


def lab_comparison(problem: LoopProblem, result) -> LabComparison:
    """``LabComparison`` of the lab's setting with ``result``'s PI gains and rig timing (every delay of a range)."""
    corners = mice(problem)
    loops = PiLoops.of(problem, result.controller)
    ev = evaluator(problem, admittance_check_scenarios(problem), loops=loops, timing=result.timing, corners=corners)
    c = ev.evaluate(LAB_M_V_KG, LAB_B_V_N_S_PER_M, bandwidth=False)
    felt = WorstFelt(problem, feel_scenarios(problem), corners, loops=loops, timing=result.timing)
    k, j = np.nonzero(~c.stable)
    return LabComparison(LAB_M_V_KG, LAB_B_V_N_S_PER_M, c.worst_by_legs(), bool(np.all(c.stable)),
                         felt(LAB_M_V_KG, LAB_B_V_N_S_PER_M), float(np.min(c.passive_up_to_hz)),
                         admittance_bandwidth_hz(LabBandwidthModel.published(1)),
                         tuple(f"{c.scenarios.describe(jj)} with mouse ({c.mice[kk].label()})" for kk, jj in zip(k, j)))


def admittance_curves(problem: LoopProblem, result, *, lab: bool = True) -> AdmittanceCurves:
    """The curves of ``result`` (an ``AdmittanceResult``), its mouse run on the spec's profile at the heaviest
    payload when the rig is sampled, and the lab's setting beside it."""
    masses = report_payloads(problem)
    top = RENDERED_HZ[1] if not result.timing.sampled else min(RENDERED_HZ[1], 0.5 / result.timing.period_s)
    w = log_grid_rad_s(RENDERED_HZ[0], top, RENDERED_POINTS)
    loop = gantry_loop(PiLoops.of(problem, result.controller), w, list(masses))
    run = refused = None
    if result.timing.sampled:
        try:
            settings = run_settings(problem, controller=result.controller, m_v=result.m_v, b_v=result.b_v,
                                    timing=result.timing)
        except SpecError as exc:
            refused = str(exc)
        else:
            run = mouse_run(settings, trapezoid_path(admittance_problem(problem).locomotion, settings.drive_rate_hz))
    return AdmittanceCurves(masses, w, 1.0 / virtual_impedance_frd(w, result.m_v, result.b_v),
                            rendered_admittance(loop, result.m_v, result.b_v, result.timing), run,
                            lab_comparison(problem, result) if lab else None, refused)
