"""The curves a design report plots, computed once from the problem and the gains: plant and loop
frequency responses, Nyquist curves and closed-loop step responses at the light, nominal and
heavy payloads."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from design.loop.loops import balanced, closed_loop_tf, open_loop_frd
from design.problem import LoopProblem
from plant.grid import log_grid_rad_s

#: Bode frequencies: 100 per decade resolve a mode of damping ratio 0.02 (half-power width 4 %)
W_BODE = log_grid_rad_s(0.1, 2000.0, 430)
#: Nyquist frequencies: from deep in the integrator's range to far past the crossover
W_NYQUIST = log_grid_rad_s(0.05, 5000.0, 500)
#: step response times (s)
STEP_TIME_S = np.linspace(0.0, 0.25, 2000)


@dataclass(frozen=True)
class LoopCurves:
    """Curves of the loop with gains (kp, ki); rows are the payloads ``payload_kg``."""

    payload_kg: tuple[float, ...]
    bode_w_rad_s: np.ndarray
    plant: np.ndarray
    loop: np.ndarray
    nyquist_w_rad_s: np.ndarray
    nyquist_loop: np.ndarray
    step_time_s: np.ndarray
    #: closed velocity-loop response to a unit velocity-reference step (rational model, Pade for delays)
    step_response: np.ndarray


def report_payloads(problem: LoopProblem) -> tuple[float, ...]:
    """Light, nominal and heavy payloads (kg), without repeats."""
    rng = problem.plant.payload_kg
    return tuple(sorted({rng.min, rng.nominal_kg, rng.max}))


def loop_curves(problem: LoopProblem, kp: float, ki: float) -> LoopCurves:
    import control

    masses = report_payloads(problem)
    plants = problem.plant.plant(np.array(masses))
    P = plants.frd(W_BODE)
    with np.errstate(over="ignore", invalid="ignore"):        # an unstable loop's response diverges
        steps = [np.squeeze(control.step_response(balanced(closed_loop_tf(problem.plant.plant(m), kp, ki)),
                                                  STEP_TIME_S).outputs) for m in masses]
    return LoopCurves(masses, W_BODE, P, open_loop_frd(P, W_BODE, kp, ki), W_NYQUIST,
                      open_loop_frd(plants, W_NYQUIST, kp, ki), STEP_TIME_S, np.array(steps))
