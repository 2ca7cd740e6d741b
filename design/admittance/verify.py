"""Independent verification of an admittance design on the rational (Pade) model.

The frequency-grid check of ``design.admittance.model`` and the optimiser share the grid
responses; this check does not: it builds the coupled gantry-mouse system from python-control
transfer functions (Pade for delays), takes the roots of its characteristic polynomial at every
verified scenario (payload and uncertain parameters) and mouse corner, and recomputes the
interaction loop's margins with ``control.stability_margins`` at the worst scenarios (phase and
gain margin) of every corner.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from design.admittance.model import (
    AdmittanceCheck,
    MouseModel,
    admittance_problem,
    mechanical_plant,
    mouse_corners,
)
from design.problem import LoopProblem
from design.synth.scenarios import Scenarios
from plant.models import Plant

#: python-control margins may fall short of the requirement by this much (deg, dB): grid rounding
MARGIN_TOLERANCE = (0.1, 0.05)
PADE_ORDER = 6


@dataclass(frozen=True)


class AdmittanceVerification:
    verified: bool
    #: largest real part of the coupled closed-loop poles over the verified scenarios x mouse corners (1/s)
    max_closed_loop_pole_real_part: float
    #: largest real part of the roots of char_D: the poles of D = 1 + P C + G Z_m (velocity loop with
    #: the mouse attached; Nyquist needs them < 0), which include the mechanical pole -b/M once more
    max_open_loop_pole_real_part: float
    #: python-control stability_margins at the worst scenarios (PM, GM) of each corner
    min_phase_margin_deg: float
    min_gain_margin_db: float
    cases: int
    failures: tuple[str, ...]


def _polys(tf) -> tuple[np.ndarray, np.ndarray]:
    return np.atleast_1d(np.asarray(tf.num[0][0], float)), np.atleast_1d(np.asarray(tf.den[0][0], float))


def loop_polynomials(plant: Plant, *, kp: float, ki: float) -> tuple[np.ndarray, ...]:
    """(nP, dP, nG, dG, nC, dC): plant P, mechanical mobility G and PI controller C as polynomials."""
    nP, dP = _polys(plant.to_control(pade_order=PADE_ORDER))
    nG, dG = _polys(mechanical_plant(plant).to_control(pade_order=PADE_ORDER))
    nG = nG / float(np.asarray(plant.force_constant_n_per_a))
    nC, dC = (np.array([kp, ki]), np.array([1.0, 0.0])) if ki > 0 else (np.array([kp]), np.array([1.0]))
    return nP, dP, nG, dG, nC, dC


def coupled_polynomials(plant: Plant, mouse: MouseModel, *, kp: float, ki: float, m_v: float, b_v: float,
                        loop: tuple[np.ndarray, ...] | None = None):
    """Rational interaction loop L = num / den and the polynomial of D, from python-control models
    (``loop``: ``loop_polynomials(plant, ...)`` when already computed).

    With P = nP/dP, G = nG/dG, C = nC/dC, Z_m = nZ/dZ, Y_v = 1/y:
    D dP dC dG dZ = dP dC dG dZ + nP nC dG dZ + nG nZ dP dC (=: char_D), L = nZ nP nC dG / (y char_D),
    and the closed loop's characteristic polynomial is y char_D + nZ nP nC dG.
    """
    pm = np.polymul
    nP, dP, nG, dG, nC, dC = loop_polynomials(plant, kp=kp, ki=ki) if loop is None else loop
    nZ, dZ = mouse.impedance_polys()
    y = np.array([m_v, b_v])
    char_d = np.polyadd(np.polyadd(pm(pm(dP, dC), pm(dG, dZ)), pm(pm(nP, nC), pm(dG, dZ))), pm(pm(nG, nZ), pm(dP, dC)))
    num_l = pm(pm(nZ, nP), pm(nC, dG))
    return num_l, pm(y, char_d), char_d


def verify_admittance(problem: LoopProblem, check: AdmittanceCheck, *, kp: float, ki: float,
                      scenarios: Scenarios | None = None) -> AdmittanceVerification:
    """Poles of the coupled closed loop and of D at every mouse corner of ``scenarios`` (default: every
    scenario of ``check``); python-control margins at the worst scenarios of ``check`` for every
    corner; ``check``'s violations count as failures too."""
    import control

    adm = admittance_problem(problem)
    corners = mouse_corners(problem)
    base = problem.plant.plant()
    scenarios = check.scenarios if scenarios is None else scenarios
    failures = [v["detail"] for v in check.violations]
    max_cl = max_ol = -math.inf
    for j in range(len(scenarios)):
        plant = scenarios.plant(base, j)
        loop = loop_polynomials(plant, kp=kp, ki=ki)
        for mouse in corners:
            num, den, char_d = coupled_polynomials(plant, mouse, kp=kp, ki=ki, m_v=check.m_v, b_v=check.b_v, loop=loop)
            cl = float(np.max(np.roots(np.polyadd(den, num)).real))
            ol = float(np.max(np.roots(char_d).real))
            if cl >= 0:
                failures.append(f"unstable coupled loop at {scenarios.describe(j)} with mouse ({mouse.label()}): pole "
                                f"real part {cl:.3g} 1/s")
            if ol >= 0:
                failures.append(f"velocity loop with the mouse attached unstable at {scenarios.describe(j)} "
                                f"({mouse.label()})")
            max_cl, max_ol = max(max_cl, cl), max(max_ol, ol)
    pms, gms = [], []
    for k, j in sorted({(k, int(np.argmin(check.phase_margin_deg[k]))) for k in range(len(corners))}
                       | {(k, int(np.argmin(check.gain_margin_db[k]))) for k in range(len(corners))}):
        mouse, plant = corners[k], check.scenarios.plant(base, j)
        num, den, _ = coupled_polynomials(plant, mouse, kp=kp, ki=ki, m_v=check.m_v, b_v=check.b_v)
        with np.errstate(over="ignore", invalid="ignore"):
            gm, pm, *_ = control.stability_margins(control.tf(num, den))
        gm_db = 20 * math.log10(gm) if np.isfinite(gm) and gm > 0 else math.inf
        pm = float(pm) if np.isfinite(pm) else math.inf
        pms.append(pm)
        gms.append(gm_db)
        if pm < adm.phase_margin_deg - MARGIN_TOLERANCE[0] or gm_db < adm.gain_margin_db - MARGIN_TOLERANCE[1]:
            failures.append(f"python-control margins PM {pm:.2f} deg, GM {gm_db:.2f} dB at "
                            f"{check.scenarios.describe(j)} with mouse ({mouse.label()})")
    return AdmittanceVerification(not failures, max_cl, max_ol, float(np.min(pms)), float(np.min(gms)),
                                  len(scenarios) * len(corners), tuple(failures))
