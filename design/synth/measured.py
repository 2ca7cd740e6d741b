"""Data-driven PI synthesis: the plant is given as measured responses, one recording per payload.

The loop L_m(jw_k) = G_m(jw_k) (kp + ki/jw_k) is affine in the gains, so the convex-concave
procedure of ``design.synth.pi`` runs unchanged on the measured frequencies; there is no
model for the exact casadi step or for Pade poles, so the design is verified on the data with
python-control (``stability_margins`` of the ``FrequencyResponseData``) and a stable open loop
is assumed (a stepped-sine recording of a runaway plant is not possible). Crossings must lie
inside the measured band; otherwise the margins are not known and the design is refused.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from design.loop.controller import PI
from design.loop.margins import closed_loop_bandwidth_hz, loop_margins
from design.loop.requirement import Binding
from design.problem import LoopProblem
from design.synth.ccp import _CCP
from plant.data.frequency_response import MeasuredResponse
from plant.errors import DataError


@dataclass(frozen=True)
class MeasuredPlants:
    """Measured responses on their common frequencies: G (n_payloads, n_freq) in (m/s)/A."""

    payload_kg: np.ndarray
    w_rad_s: np.ndarray
    response: np.ndarray

    @classmethod
    def from_responses(cls, payload_kg, responses: list[MeasuredResponse]) -> MeasuredPlants:
        order = np.argsort(payload_kg)
        resp = [responses[i] for i in order]
        common = resp[0].f_hz
        for r in resp[1:]:
            common = np.intersect1d(common, r.f_hz)
        if common.size < 5:
            raise DataError(f"plant.measured: the recordings share {common.size} frequencies; at least 5 are needed")
        G = np.array([r.response.mean(axis=0)[np.searchsorted(r.f_hz, common)] for r in resp])
        return cls(np.asarray(payload_kg, float)[order], 2 * np.pi * common, G)


@dataclass(frozen=True)
class MeasuredDesign:
    """PI gains designed and verified on measured responses; gains and the per-payload numbers are
    None / empty when no gains meet the requirements in the measured band."""

    status: str
    message: str
    controller: PI | None
    payload_kg: np.ndarray
    bandwidth_hz: np.ndarray
    phase_margin_deg: np.ndarray
    gain_margin_db: np.ndarray
    #: the requirement with the least slack relative to the requirement: its constraint, payload and slack
    binding: Binding | None
    verified: bool
    failures: tuple[str, ...]
    seconds: float
    lp_solves: int
    band_hz: tuple[float, float]


def _numbers(w, G, controller: PI, problem: LoopProblem):
    L = G * controller.frd(w)
    m = loop_margins(w, L)
    bw = closed_loop_bandwidth_hz(w, L / (1 + L), dc_gain=1.0, level2=problem.requirements.level2)
    req = problem.requirements
    gm = np.where(np.isfinite(m.gain_margin_db), m.gain_margin_db, np.inf)
    ok = bool(np.all(m.phase_margin_deg >= req.phase_margin_deg - 1e-6) and np.all(gm >= req.gain_margin_db - 1e-6)
              and np.all(np.isfinite(m.gain_crossover_hz)) and np.all(np.isfinite(bw)))
    return m, bw, ok


def _binding(payload, pm, gm, problem: LoopProblem) -> Binding:
    """The requirement with the least slack relative to the requirement, and where."""
    req = problem.requirements
    slack = {"phase_margin": (pm - req.phase_margin_deg, max(req.phase_margin_deg, 1.0)),
             "gain_margin": (np.where(np.isfinite(gm), gm - req.gain_margin_db, np.inf), max(req.gain_margin_db, 1.0))}
    name = min(slack, key=lambda k: np.min(slack[k][0]) / slack[k][1])
    i = int(np.argmin(slack[name][0]))
    return Binding(name, float(payload[i]), slack=float(slack[name][0][i]))


def _independent_failures(payload, w, G, controller: PI, problem: LoopProblem) -> list[str]:
    """python-control's margins of every measured loop, against the requirements."""
    import control

    req, failures = problem.requirements, []
    for k, p in enumerate(payload):
        gm, pm, *_ = control.stability_margins(control.frd(G[k] * controller.frd(w), w))
        if pm < req.phase_margin_deg - 0.05:
            failures.append(f"phase margin {pm:.2f} deg at {p:g} kg (python-control, FRD)")
        if np.isfinite(gm) and 20 * math.log10(gm) < req.gain_margin_db - 0.05:
            failures.append(f"gain margin {20 * math.log10(gm):.2f} dB at {p:g} kg (python-control, FRD)")
    return failures


def synthesise_from_data(problem: LoopProblem, data: MeasuredPlants) -> MeasuredDesign:
    """Largest bandwidth target the convex-concave procedure meets on every measured response
    (bisection on its log), then an independent check of the design on the data."""

    payload, w, G = data.payload_kg, data.w_rad_s, data.response
    t0 = time.perf_counter()
    c = problem.controller
    ccp = _CCP(G, w, problem)
    lo, hi = math.log(w[0]), math.log(w[-1])
    x = np.array([max(c.kp.min, 1e-6 * c.kp.max), max(c.ki.min, 1e-6 * c.ki.max)]) / ccp.scale
    best, solves = None, 0
    for _ in range(24):
        mid = 0.5 * (lo + hi)
        xn, t = ccp.solve(x if best is None else best, math.exp(mid))
        solves += 1
        if t >= 0:
            lo, best = mid, xn
        else:
            hi = mid
        if hi - lo < 0.01:
            break
    seconds = time.perf_counter() - t0
    band = (float(w[0] / 2 / np.pi), float(w[-1] / 2 / np.pi))
    empty = np.array([])
    if best is None:
        return MeasuredDesign("infeasible", "no gains meet the requirements on the measured data even at the lowest "
                              "bandwidth target in the measured band", None, payload, empty, empty, empty,
                              None, False, (), seconds, solves, band)
    controller = PI.of(best * ccp.scale)
    m, bw, ok = _numbers(w, G, controller, problem)
    failures = _independent_failures(payload, w, G, controller, problem)
    if not np.all(np.isfinite(m.gain_crossover_hz)):
        failures.append("a gain crossover lies outside the measured band: measure to higher frequency")
    verified = ok and not failures
    return MeasuredDesign("optimal" if verified else "infeasible",
                          "verified on the data" if verified else "; ".join(failures or ["margins not met"]),
                          controller, payload, bw, m.phase_margin_deg, m.gain_margin_db,
                          _binding(payload, m.phase_margin_deg, m.gain_margin_db, problem), verified,
                          tuple(failures), seconds, solves, band)
