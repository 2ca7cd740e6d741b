"""The curves the admittance section of a design report plots: the rendered admittance against the
virtual dynamics at the light, nominal and heavy payloads, and the resistance over the locomotion
profile."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from design.admittance.model import admittance_problem, gantry_loop, rendered_admittance, virtual_impedance_frd
from design.loop.curves import report_payloads
from design.problem import LoopProblem
from plant.grid import log_grid_rad_s

W_RENDERED = log_grid_rad_s(0.1, 1000.0, 800)


@dataclass(frozen=True)
class AdmittanceCurves:
    payload_kg: tuple[float, ...]
    w_rad_s: np.ndarray
    #: 1/(m_v s + b_v), (m/s)/N
    virtual: np.ndarray
    #: velocity per sensed force at each payload, (n_payload, n_freq)
    rendered: np.ndarray
    profile_time_s: np.ndarray
    #: m_v a + b_v v and b_v v over the trapezoidal locomotion profile (N)
    resistance_n: np.ndarray
    damping_part_n: np.ndarray


def locomotion_profile(v_pk: float, a_pk: float, points: int = 800) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Accelerate at a_pk to v_pk, run, decelerate: time (s), acceleration (m/s^2), speed (m/s)."""
    t_acc = v_pk / a_pk
    t = np.linspace(0.0, 4 * t_acc, points)
    acc = np.where(t < t_acc, a_pk, np.where(t < 3 * t_acc, 0.0, -a_pk))
    v = np.clip(np.where(t < 3 * t_acc, a_pk * t, v_pk - a_pk * (t - 3 * t_acc)), 0.0, v_pk)
    return t, acc, v


def admittance_curves(problem: LoopProblem, *, kp: float, ki: float, m_v: float, b_v: float) -> AdmittanceCurves:
    masses = report_payloads(problem)
    loop = gantry_loop(problem, W_RENDERED, list(masses), kp=kp, ki=ki)
    loc = admittance_problem(problem).locomotion
    t, acc, v = locomotion_profile(loc.peak_speed_m_per_s, loc.peak_acceleration_m_per_s2)
    return AdmittanceCurves(masses, W_RENDERED, 1.0 / virtual_impedance_frd(W_RENDERED, m_v, b_v),
                            rendered_admittance(loop, m_v, b_v), t, m_v * acc + b_v * v, b_v * v)
