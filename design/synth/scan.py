"""The first stage of ``design.synth.pi``: a log grid of (Kp, Ki) evaluated at the design scenarios on the
constraint grid ``W_OPT``, vectorised over ``GAIN_CHUNK`` gains at a time (the loop responses of all gains x
scenarios x frequencies would take hundreds of MB), seeds for the solvers and a bracket for the bandwidth."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from design.loop.margins import closed_loop_bandwidth_hz, crossover_margins, loop_margins, nyquist_stable
from design.loop.requirement import Binding
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
class ScanDiagnosis:
    """Why no gains of the scan meet the requirements (``Scan.diagnose``)."""

    #: the requirement that falls short, the payload (kg) and the relative slack there (negative)
    binding: Binding
    #: that scenario in words ('5.0 kg, damping_n_s_per_m = 330')
    where: str
    #: the gains that fall least short there (A/(m/s), A/m)
    kp: float
    ki: float
    #: even the gains best for that payload alone miss it (False: each payload alone is feasible, no single pair of
    #: gains holds at every payload)
    alone: bool


@dataclass(frozen=True)
class RequirementSlack:
    """Relative slack per requirement: ``values[r]`` that of requirement ``names[r]`` (its ``Binding`` name),
    each shaped (gains, scenarios); negative where it fails."""

    names: tuple[str, ...]
    values: np.ndarray


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
    #: relative slack per requirement
    slack: RequirementSlack
    #: the gains failing at the lightest or heaviest payload were evaluated there alone (their slack at the
    #: other scenarios is nan, their figures are those of the screening scenarios)
    screened: bool = False

    def diagnose(self, scenarios: Scenarios) -> ScanDiagnosis:
        """Why nothing on the scan meets the requirements: the payload where the best gains for that
        payload alone fall furthest short, or, when each payload alone is feasible, the conflict."""
        if self.screened:
            raise ValueError("diagnose needs a scan of every gain on every scenario (scan_gains without payload_kg)")
        per = np.min(self.slack.values, axis=0)          # (gains, payloads)
        alone = per.max(axis=0)
        j = int(np.argmin(alone))
        if alone[j] < 0:
            i = int(np.argmax(per[:, j]))
        else:
            i = int(np.argmax(per.min(axis=1)))
            j = int(np.argmin(per[i]))
        name = self.slack.names[int(np.argmin(self.slack.values[:, i, j]))]
        binding = Binding(name, float(scenarios.payload_kg[j]), relative_slack=float(per[i, j]))
        return ScanDiagnosis(binding, scenarios.describe(j), float(self.kp[i]), float(self.ki[i]), bool(alone[j] < 0))

    def best(self, mask: np.ndarray, score: np.ndarray, k: int = 1) -> list[int]:
        """Indices of the ``k`` best entries of ``score`` under ``mask`` (distinct gains)."""
        idx = np.flatnonzero(mask)
        return [int(i) for i in idx[np.argsort(-score[idx])][:k]]


def _evaluate(problem: LoopProblem, P: np.ndarray, kp: np.ndarray, ki: np.ndarray) -> dict[str, np.ndarray]:
    """Margins (gains, scenarios), bandwidth, Nyquist stability, the circles kept clear and the first grid
    frequency inside the bandwidth circle (gains) of the PI loops ``kp``, ``ki`` on ``P``."""
    req = problem.requirements
    L = P[None] * (kp[:, None, None] + ki[:, None, None] / (1j * W_OPT))
    # Nyquist: with no open-loop poles in the right half-plane, the phase of 1 + L rises by 0 to 90 deg
    # from the lowest to the highest grid frequency when the closed loop is stable, and falls by 180 deg
    # more per unstable closed-loop pole; an unstable loop's margins are wrapped angles: count PM as 0
    if req.peak_sensitivity is None and req.disk_margin is None:
        gm, pm = crossover_margins(W_OPT, L)
        out = {"phase_margin_deg": pm, "gain_margin_db": gm, "stable": nyquist_stable(L)}
    else:
        mg = loop_margins(W_OPT, L)
        out = {"phase_margin_deg": mg.phase_margin_deg, "gain_margin_db": mg.gain_margin_db,
               "peak_sensitivity": mg.peak_sensitivity, "disk_margin": mg.disk_margin,
               "stable": mg.closed_loop_stable}
    out["bandwidth_hz"] = closed_loop_bandwidth_hz(W_OPT, L / (1 + L), dc_gain=np.ones(L.shape[:-1]),
                                                   level2=req.level2)
    clear = np.ones(kp.size, bool)
    for centre, radius in requirement_circles(problem):
        clear &= np.all(np.abs(L - centre) >= radius * 1.003, axis=(-2, -1))
    out["circles_clear"] = clear
    bc, br = bandwidth_circle(req.level2)
    inside = np.abs(L - bc) < br
    inside[..., 0] = False
    out["first_inside"] = np.min(np.where(inside.any(axis=-1), np.argmax(inside, axis=-1), W_OPT.size - 1), axis=-1)
    return out


def _chunked(problem: LoopProblem, P: np.ndarray, kp: np.ndarray, ki: np.ndarray) -> dict[str, np.ndarray]:
    parts = [_evaluate(problem, P, kp[s:s + GAIN_CHUNK], ki[s:s + GAIN_CHUNK]) for s in range(0, kp.size, GAIN_CHUNK)]
    return {k: np.concatenate([part[k] for part in parts]) for k in parts[0]}


def _slack(problem: LoopProblem, ev: dict[str, np.ndarray]) -> RequirementSlack:
    """Relative slack per requirement (gains, scenarios)."""
    req = problem.requirements
    bw = ev["bandwidth_hz"]
    pm = np.where(ev["stable"], ev["phase_margin_deg"], 0.0)
    slack = {"phase_margin": (pm - req.phase_margin_deg) / max(req.phase_margin_deg, 1.0),
             "gain_margin": np.minimum(ev["gain_margin_db"] - req.gain_margin_db, 1e3) / max(req.gain_margin_db, 1.0),
             "bandwidth_on_grid": np.where(np.isfinite(bw), 0.0, -1.0)}
    if req.peak_sensitivity is not None:
        slack["peak_sensitivity"] = (req.peak_sensitivity - ev["peak_sensitivity"]) / req.peak_sensitivity
    if req.disk_margin is not None:
        slack["disk_margin"] = (ev["disk_margin"] - req.disk_margin) / req.disk_margin
    return RequirementSlack(tuple(slack), np.stack(list(slack.values())))


def scan_gains(problem: LoopProblem, P: np.ndarray, payload_kg: np.ndarray | None = None, *,
               n: int = SCAN_POINTS) -> Scan:
    """Evaluate an n x n log grid of (kp, ki) on the responses ``P`` (scenarios x ``W_OPT``).

    With ``payload_kg`` (per scenario) every gain is evaluated first on the scenarios at the lightest and
    heaviest payloads, and only the gains that meet the requirements there on the others: a gain failing
    them cannot meet the requirements, and its slack elsewhere stays nan (``Scan.screened``). When no gain
    meets the requirements, every gain is evaluated on every scenario, so that ``Scan.diagnose`` sees all."""
    c = problem.controller
    KP, KI = np.meshgrid(_gain_grid(c.kp.min, c.kp.max, n), _gain_grid(c.ki.min, c.ki.max, n), indexing="ij")
    kp, ki = KP.ravel(), KI.ravel()
    if payload_kg is not None:
        rows = np.isin(payload_kg, [np.min(payload_kg), np.max(payload_kg)])
        if not rows.all():
            first = _chunked(problem, P[rows], kp, ki)
            slack_first = _slack(problem, first)
            rel = _relative(slack_first)
            passed = rel >= 0
            if passed.any():
                rest = _chunked(problem, P, kp[passed], ki[passed])
                slack_rest = _slack(problem, rest)
                rel[passed] = _relative(slack_rest)
                if np.any(rel >= 0):
                    values = np.full((len(slack_first.names), kp.size, P.shape[0]), np.nan)
                    values[:, :, rows] = slack_first.values
                    values[:, passed] = slack_rest.values
                    slack = RequirementSlack(slack_first.names, values)
                    bw = np.full((kp.size, P.shape[0]), np.nan)
                    bw[:, rows] = first["bandwidth_hz"]
                    bw[passed] = rest["bandwidth_hz"]
                    ev = {k: first[k].copy() for k in ("circles_clear", "first_inside")}
                    for k in ev:
                        ev[k][passed] = rest[k]
                    return _scan(kp, ki, rel, slack, bw, ev, True)
    ev = _chunked(problem, P, kp, ki)
    slack = _slack(problem, ev)
    return _scan(kp, ki, _relative(slack), slack, ev["bandwidth_hz"], ev, False)


def _relative(slack: RequirementSlack) -> np.ndarray:
    """Least relative slack per gain over the requirements and the scenarios."""
    return np.min(np.min(slack.values, axis=0), axis=-1)


def _scan(kp, ki, rel, slack, bw, ev, screened: bool) -> Scan:
    circle_ok = (rel >= 0) & ev["circles_clear"]     # outside the circles, and on the stable side of them
    circle_bw = W_OPT[np.maximum(ev["first_inside"] - 1, 0)] / (2 * np.pi)
    with np.errstate(invalid="ignore"):
        worst_bw = np.nan_to_num(np.min(bw, axis=-1))
    return Scan(kp, ki, rel >= 0, worst_bw, circle_ok, circle_bw, rel, slack, screened)
