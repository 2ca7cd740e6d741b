"""The curves a design report plots, computed once from the problem and the gains: plant and loop
frequency responses, Nyquist curves and closed-loop step responses at the light, nominal and
heavy payloads (nominal parameters) and at the binding scenario (a payload with the uncertain
parameters where the requirement with the least slack binds), with the loop margins of each."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from design.loop.controller import PI
from design.loop.loops import closed_loop_tf, open_loop_frd
from design.loop.margins import closed_loop_bandwidth_hz, loop_margins
from design.loop.requirement import ScenarioPoint
from design.problem import LoopProblem
from plant.grid import log_grid_rad_s
from plant.physics.effect_base import balanced

#: Bode frequencies: 100 per decade resolve a mode of damping ratio 0.02 (half-power width 4 %)
W_BODE = log_grid_rad_s(0.1, 2000.0, 430)
#: Nyquist frequencies: from deep in the integrator's range to far past the crossover
W_NYQUIST = log_grid_rad_s(0.05, 5000.0, 500)
#: step response times (s)
STEP_TIME_S = np.linspace(0.0, 0.25, 2000)


@dataclass(frozen=True)
class LoopCurves:
    """Curves of the loop with gains (kp, ki); rows are the plants named ``labels``: the payloads
    ``payload_kg`` at the nominal parameters, then the binding scenario when there is one."""

    payload_kg: tuple[float, ...]
    labels: tuple[str, ...]
    bode_w_rad_s: np.ndarray
    plant: np.ndarray
    loop: np.ndarray
    nyquist_w_rad_s: np.ndarray
    nyquist_loop: np.ndarray
    step_time_s: np.ndarray
    #: closed velocity-loop response to a unit velocity-reference step (rational model, Pade for delays)
    step_response: np.ndarray
    #: per row: gain crossover (Hz) and phase margin (deg), phase crossover (Hz) and gain margin (dB)
    gain_crossover_hz: np.ndarray
    phase_margin_deg: np.ndarray
    phase_crossover_hz: np.ndarray
    gain_margin_db: np.ndarray
    #: the row of the binding scenario (None: none given)
    binding_row: int | None = None
    #: per row: closed-loop bandwidth (Hz), where |T|^2 first falls below the requirements' level2 (nan: nowhere on
    #: the grid), and the peaks of |S| and |T| (dimensionless) on the Bode grid
    bandwidth_hz: np.ndarray | None = None
    peak_sensitivity: np.ndarray | None = None
    peak_complementary: np.ndarray | None = None

    @property
    def sensitivity(self) -> np.ndarray:
        """S = 1 / (1 + L) per row on ``bode_w_rad_s``."""
        return 1.0 / (1.0 + self.loop)

    @property
    def complementary(self) -> np.ndarray:
        """T = L / (1 + L) per row on ``bode_w_rad_s``."""
        return self.loop / (1.0 + self.loop)


def report_payloads(problem: LoopProblem) -> tuple[float, ...]:
    """Light, nominal and heavy payloads (kg), without repeats."""
    rng = problem.plant.payload_kg
    return tuple(sorted({rng.min, rng.nominal_kg, rng.max}))


def scenario_label(row: ScenarioPoint) -> str:
    """'binding: 40 kg, damping_n_s_per_m 330, delay.seconds 0.0008'."""
    return f"binding: {row.payload_kg:.3g} kg" + "".join(f", {k} {v:.3g}" for k, v in row.as_dict().items()
                                                         if k != "payload_kg")


def loop_curves(problem: LoopProblem, controller: PI, binding: ScenarioPoint | None = None) -> LoopCurves:
    """The curves at the report payloads and, with ``binding`` (as ``Evaluation.worst_scenario``), at that
    scenario."""
    import control


    masses = report_payloads(problem)
    base = problem.plant.plant()
    plants = [base.with_values({"mass_kg": m}) for m in masses]
    labels = [f"{m:g} kg" for m in masses]
    if binding is not None:
        plants.append(base.with_values({"mass_kg": binding.payload_kg, **dict(binding.parameters)}))
        labels.append(scenario_label(binding))
    P = np.array([p.frd(W_BODE) for p in plants])
    with np.errstate(over="ignore", invalid="ignore"):        # an unstable loop's response diverges
        steps = [np.squeeze(control.step_response(balanced(closed_loop_tf(p, controller)), STEP_TIME_S).outputs)
                 for p in plants]
    L = open_loop_frd(P, W_BODE, controller)
    m = loop_margins(W_BODE, L)
    with np.errstate(divide="ignore", invalid="ignore"):
        T = L / (1 + L)
        S = 1 / (1 + L)
    bandwidth = closed_loop_bandwidth_hz(W_BODE, T, dc_gain=np.ones(len(plants)), level2=problem.requirements.level2)
    return LoopCurves(masses, tuple(labels), W_BODE, P, L, W_NYQUIST,
                      np.array([open_loop_frd(p, W_NYQUIST, controller) for p in plants]), STEP_TIME_S, np.array(steps),
                      m.gain_crossover_hz, m.phase_margin_deg, m.phase_crossover_hz, m.gain_margin_db,
                      len(plants) - 1 if binding is not None else None, np.asarray(bandwidth, float),
                      np.max(np.abs(S), axis=-1), np.max(np.abs(T), axis=-1))
