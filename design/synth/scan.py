"""The first stage of ``design.synth.pi``: a log grid of (Kp, Ki) evaluated at the design scenarios on the
constraint grid ``W_OPT``, vectorised over ``GAIN_CHUNK`` gains at a time (the loop responses of all gains x
scenarios x frequencies would take hundreds of MB), seeds for the solvers and a bracket for the bandwidth."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from design.loop.margins import closed_loop_bandwidth_hz, loop_margins, nyquist_stable
from design.problem import LoopProblem
from design.synth.evaluation import bandwidth_circle, requirement_circles
from design.synth.scenarios import Scenarios
from plant.grid import log_grid_rad_s

#: constraint grid of the scan and the optimisation: 1 mHz - 10 kHz, 40 points per decade
W_OPT = log_grid_rad_s(1e-3, 1.0e4, 281)

#: scan grid size per gain
SCAN_POINTS = 20
#: gains evaluated in one vectorised call: their loop responses are GAIN_CHUNK x scenarios x 281 complex
GAIN_CHUNK = 25


def _gain_grid(lo: float, hi: float, n: int) -> np.ndarray:
    return np.array([hi]) if hi <= lo else np.geomspace(max(lo, hi * 1e-6), hi, n)


@dataclass(frozen=True)


class Scan:
    """A log grid of gains evaluated on ``W_OPT`` at the payload points (linear-interpolated margins)."""

    kp: np.ndarray
    ki: np.ndarray
    #: meets PM, GM (and Ms, disk margin) at every point
    meets: np.ndarray
    worst_bandwidth_hz: np.ndarray
    #: meets the requirements and the Nyquist curves stay outside the requirement circles
    circle_ok: np.ndarray
    #: highest grid frequency (Hz) up to which |L - 1| >= sqrt 2 at every point
    circle_bandwidth_hz: np.ndarray
    #: least requirement slack relative to the requirement (for infeasible problems)
    relative_slack: np.ndarray
    #: relative slack per requirement, each shaped (gains, scenarios)
    slack: dict

    def diagnose(self, scenarios: Scenarios) -> dict:
        """Why nothing on the scan meets the requirements: the payload where the best gains for that
        payload alone fall furthest short, or, when each payload alone is feasible, the conflict."""
        per = np.min(np.array(list(self.slack.values())), axis=0)          # (gains, payloads)
        alone = per.max(axis=0)
        j = int(np.argmin(alone))
        if alone[j] < 0:
            i = int(np.argmax(per[:, j]))
            name = min(self.slack, key=lambda k: self.slack[k][i, j])
            return {"constraint": name, "payload_kg": float(scenarios.payload_kg[j]), "where": scenarios.describe(j),
                    "relative_slack": float(alone[j]), "kp": float(self.kp[i]), "ki": float(self.ki[i]),
                    "alone": True}
        i = int(np.argmax(per.min(axis=1)))
        j = int(np.argmin(per[i]))
        name = min(self.slack, key=lambda k: self.slack[k][i, j])
        return {"constraint": name, "payload_kg": float(scenarios.payload_kg[j]), "where": scenarios.describe(j),
                "relative_slack": float(per[i, j]), "kp": float(self.kp[i]), "ki": float(self.ki[i]), "alone": False}

    def best(self, mask: np.ndarray, score: np.ndarray, k: int = 1) -> list[int]:
        """Indices of the ``k`` best entries of ``score`` under ``mask`` (distinct gains)."""
        idx = np.flatnonzero(mask)
        return [int(i) for i in idx[np.argsort(-score[idx])][:k]]


def _evaluate(problem: LoopProblem, P: np.ndarray, kp: np.ndarray, ki: np.ndarray) -> dict[str, np.ndarray]:
    """Margins (gains, scenarios), bandwidth, Nyquist stability, the circles kept clear and the first grid
    frequency inside the bandwidth circle (gains) of the PI loops ``kp``, ``ki`` on ``P``."""
    req = problem.requirements
    L = P[None] * (kp[:, None, None] + ki[:, None, None] / (1j * W_OPT))
    mg = loop_margins(W_OPT, L)
    out = {"phase_margin_deg": mg.phase_margin_deg, "gain_margin_db": mg.gain_margin_db,
           "peak_sensitivity": mg.peak_sensitivity, "disk_margin": mg.disk_margin,
           "bandwidth_hz": closed_loop_bandwidth_hz(W_OPT, L / (1 + L), dc_gain=np.ones(L.shape[:-1]),
                                                    level2=req.level2),
           # Nyquist: with no open-loop poles in the right half-plane, the phase of 1 + L rises by 0 to 90 deg
           # from the lowest to the highest grid frequency when the closed loop is stable, and falls by 180 deg
           # more per unstable closed-loop pole; an unstable loop's margins are wrapped angles: count PM as 0
           "stable": nyquist_stable(L)}
    clear = np.ones(kp.size, bool)
    for centre, radius in requirement_circles(problem):
        clear &= np.all(np.abs(L - centre) >= radius * 1.003, axis=(-2, -1))
    out["circles_clear"] = clear
    bc, br = bandwidth_circle(req.level2)
    inside = np.abs(L - bc) < br
    inside[..., 0] = False
    out["first_inside"] = np.min(np.where(inside.any(axis=-1), np.argmax(inside, axis=-1), W_OPT.size - 1), axis=-1)
    return out


def scan_gains(problem: LoopProblem, P: np.ndarray, *, n: int = SCAN_POINTS) -> Scan:
    """Evaluate an n x n log grid of (kp, ki) on the responses ``P`` (scenarios x ``W_OPT``)."""
    c, req = problem.controller, problem.requirements
    KP, KI = np.meshgrid(_gain_grid(c.kp.min, c.kp.max, n), _gain_grid(c.ki.min, c.ki.max, n), indexing="ij")
    kp, ki = KP.ravel(), KI.ravel()
    parts = [_evaluate(problem, P, kp[s:s + GAIN_CHUNK], ki[s:s + GAIN_CHUNK]) for s in range(0, kp.size, GAIN_CHUNK)]
    ev = {k: np.concatenate([part[k] for part in parts]) for k in parts[0]}
    bw = ev["bandwidth_hz"]
    pm = np.where(ev["stable"], ev["phase_margin_deg"], 0.0)
    slack = {"phase_margin": (pm - req.phase_margin_deg) / max(req.phase_margin_deg, 1.0),
             "gain_margin": np.minimum(ev["gain_margin_db"] - req.gain_margin_db, 1e3) / max(req.gain_margin_db, 1.0),
             "bandwidth_on_grid": np.where(np.isfinite(bw), 0.0, -1.0)}
    if req.peak_sensitivity is not None:
        slack["peak_sensitivity"] = (req.peak_sensitivity - ev["peak_sensitivity"]) / req.peak_sensitivity
    if req.disk_margin is not None:
        slack["disk_margin"] = (ev["disk_margin"] - req.disk_margin) / req.disk_margin
    rel = np.min(np.min(np.array(list(slack.values())), axis=0), axis=-1)
    circle_ok = (rel >= 0) & ev["circles_clear"]     # outside the circles, and on the stable side of them
    circle_bw = W_OPT[np.maximum(ev["first_inside"] - 1, 0)] / (2 * np.pi)
    with np.errstate(invalid="ignore"):
        worst_bw = np.nan_to_num(np.min(bw, axis=-1))
    return Scan(kp, ki, rel >= 0, worst_bw, circle_ok, circle_bw, rel, slack)
