"""A (Kp, Ki) judged on scenarios (``evaluate``: grid margins, bandwidth, the noise limit, stability,
which requirement binds), and the requirements as circles the Nyquist curve must stay outside
(``requirement_circles``), which the solvers of ``design.synth.pi`` constrain."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from design.loop.analysis import analyse_loop
from design.loop.controller import PI
from design.loop.fast import F_LOW_HZ, coarse_grid_rad_s, fast_analyse_loop
from design.loop.requirement import Binding, ScenarioPoint
from design.problem import LoopProblem
from design.synth.scenarios import Scenarios, check_scenarios
from plant.physics.drive_filters import FILTERS

#: the noise limit is checked on this many frequencies from ``requirements.high_frequency_hz`` up to HF_TOP_HZ
HF_POINTS = 120
HF_TOP_HZ = 20_000.0

#: a gain within this relative distance of its upper bound is "on the bound"
ON_BOUND = 1e-3

#: requirements within this relative slack of their limit are listed as active
ACTIVE = 5e-3

#: the solvers aim this far inside the requirements (deg, dB) so the design meets them on the checks
MARGIN_HAIR = 0.01




@dataclass(frozen=True)
class Evaluation:
    """Gains evaluated on a set of scenarios (cubic-refined grid margins of ``design.loop.fast``); the
    per-payload arrays are the worst over the scenarios of each payload."""

    controller: PI
    payload_kg: np.ndarray
    bandwidth_hz: np.ndarray
    phase_margin_deg: np.ndarray
    gain_margin_db: np.ndarray
    meets: bool
    #: every scenario's closed loop stable (PM > 0 and GM > 0 for this stable open loop)
    stable: bool
    worst_bandwidth_hz: float
    #: the tightest requirement (its constraint, payload, scenario and slack in its unit), or a gain's upper bound
    #: (constraint "controller.kp.max" or "controller.ki.max", slack 0, no payload)
    binding: Binding
    #: the requirements within ``ACTIVE`` relative slack of their limit, and a gain's upper bound when it binds
    active: tuple[str, ...]
    #: the smallest slack of any requirement relative to the requirement (negative: violated)
    min_relative_slack: float
    #: the scenario where the tightest requirement binds
    worst_scenario: ScenarioPoint
    #: per scenario: the least relative slack of any requirement, and the bandwidth (Hz; 0: below the grid)
    row_relative_slack: np.ndarray = field(default_factory=lambda: np.zeros(0))
    row_bandwidth_hz: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def tightest(self, k: int) -> np.ndarray:
        """Rows of the ``k`` scenarios with the least slack, and the one with the lowest bandwidth."""
        return np.union1d(np.argsort(self.row_relative_slack, kind="stable")[:k], [np.argmin(self.row_bandwidth_hz)])


def evaluate(problem: LoopProblem, controller: PI, scenarios: Scenarios | None = None) -> Evaluation:
    """Margins and bandwidth of the PI ``controller`` on every scenario (default: the check scenarios)."""
    kp, ki = float(controller.kp), float(controller.ki)
    s = check_scenarios(problem) if scenarios is None else scenarios
    base = problem.plant.plant()
    plant = s.plants(base)
    req = problem.requirements
    n = fast_analyse_loop(plant, controller, level2=req.level2, coarse_response=s.response(base, coarse_grid_rad_s()))
    pm, gm = np.ravel(n.phase_margin_deg), np.ravel(n.gain_margin_db)
    # a bandwidth at the grid's lowest frequency is below the grid: unknown, counted as 0
    bw = np.ravel(np.where(n.closed_loop_bandwidth_hz > 1.01 * F_LOW_HZ, n.closed_loop_bandwidth_hz, 0.0))
    slack = {"phase_margin": pm - req.phase_margin_deg,
             "gain_margin": np.where(np.isfinite(gm), gm - req.gain_margin_db, np.inf)}
    scale = {"phase_margin": max(req.phase_margin_deg, 1.0), "gain_margin": max(req.gain_margin_db, 1.0)}
    if req.peak_sensitivity is not None or req.disk_margin is not None:
        margins = analyse_loop(plant, controller).margins
        if req.peak_sensitivity is not None:
            slack["peak_sensitivity"] = req.peak_sensitivity - np.ravel(margins.peak_sensitivity)
            scale["peak_sensitivity"] = req.peak_sensitivity
        if req.disk_margin is not None:
            slack["disk_margin"] = np.ravel(margins.disk_margin) - req.disk_margin
            scale["disk_margin"] = req.disk_margin
    if problem.controller.integral_required:     # ki = 0: a steady-state velocity error (controller.integral)
        slack["integral_action"] = np.full(len(s), np.inf if ki > 0 else -1.0)
        scale["integral_action"] = 1.0
    stable = bool(np.all(n.stable) and np.all(pm > 0) and np.all(gm > 0))
    hf = high_frequency_gain(problem, controller)
    if hf is not None:
        slack["high_frequency_gain"] = np.full(len(s), req.max_high_frequency_gain - hf)
        scale["high_frequency_gain"] = req.max_high_frequency_gain
    meets = bool(all(np.all(v >= -1e-6) for v in slack.values()) and np.all(bw > 0) and stable)
    rel = {k: float(np.min(v)) / scale[k] for k, v in slack.items()}
    name = min(rel, key=rel.get)
    i = int(np.argmin(slack[name]))
    near = tuple(sorted({k for k, v in slack.items() if np.min(v) / scale[k] < ACTIVE}))
    worst = s.row(i)
    binding, active = Binding(name, float(s.payload_kg[i]), worst, slack=float(slack[name][i])), near
    c = problem.controller
    for gain, value, bound in (("kp", kp, c.kp.max), ("ki", ki, c.ki.max)):
        if meets and value >= bound * (1 - ON_BOUND) and rel[name] > ON_BOUND:
            binding = Binding(f"controller.{gain}.max", slack=0.0)
            active = (*near, f"controller.{gain}.max")
    m, inverse = np.unique(s.payload_kg, return_inverse=True)
    per = {}
    for key, v in (("bw", np.where(bw > 0, bw, np.nan)), ("pm", pm), ("gm", gm)):
        out = np.full(m.size, np.inf)
        np.minimum.at(out, inverse, np.where(np.isnan(v), -np.inf, v))
        per[key] = np.where(out == -np.inf, np.nan, out)
    row_rel = np.min([v / scale[k] for k, v in slack.items()], axis=0)
    return Evaluation(controller, m, per["bw"], per["pm"], per["gm"], meets, stable, float(np.min(bw)),
                      binding, active, rel[name], worst, row_rel, bw)


def margin_circle(phase_margin_deg: float, gain_margin_db: float) -> tuple[float, float]:
    """Centre (real) and radius of the circle through -1/g and e^{j(pi - phi)}."""
    g = 10 ** (gain_margin_db / 20)
    phi = math.radians(phase_margin_deg)
    if abs(1 / g - math.cos(phi)) < 1e-9:   # both points at the same abscissa: use the unit-circle point
        g *= 1.0001
    x0 = (1 - 1 / g**2) / (2 * (1 / g - math.cos(phi)))
    return x0, abs(x0 + 1 / g)


def disk_margin_circle(alpha: float) -> tuple[float, float]:
    """Balanced (skew 0) disk margin >= alpha  <=>  |1/(1+L) - 1/2| <= 1/alpha  <=>  z = 1 + L outside the
    Apollonius circle |z - 2| = k |z|, k = 2/alpha > 1: centre 2/(1 - k^2) - 1 and radius 2k/(k^2 - 1) in L."""
    k = 2.0 / alpha
    return 2.0 / (1 - k**2) - 1.0, 2.0 * k / (k**2 - 1)


def high_frequency_rows(problem: LoopProblem) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(w, a, b) with the controller's response kp a + ki b = (kp + ki/jw) F(jw) at ``HF_POINTS`` frequencies
    from ``requirements.high_frequency_hz`` to ``HF_TOP_HZ`` (or just below the loop rate's Nyquist
    frequency), F the drive filters the plant carries; None without a noise limit."""

    req = problem.requirements
    if req.max_high_frequency_gain is None:
        return None
    top = HF_TOP_HZ if problem.controller.loop_rate_hz is None else 0.49 * problem.controller.loop_rate_hz
    w = 2 * np.pi * np.geomspace(req.high_frequency_hz, max(top, 1.01 * req.high_frequency_hz), HF_POINTS)
    F = np.ones(w.size, complex)
    for e in problem.plant.plant().effects:
        if e.name in FILTERS:
            F = F * e.response(1j * w)
    return w, F, F / (1j * w)


def high_frequency_gain(problem: LoopProblem, controller: PI) -> float | None:
    """max |(kp + ki/jw) F(jw)| above ``requirements.high_frequency_hz`` (A per m/s), or None."""
    kp, ki = float(controller.kp), float(controller.ki)
    rows = high_frequency_rows(problem)
    return None if rows is None else float(np.max(np.abs(kp * rows[1] + ki * rows[2])))


def bandwidth_circle(level2: float) -> tuple[float, float]:
    """(centre, radius) of the circle outside which |T|^2 = |L/(1 + L)|^2 >= level2 (T(0) = 1):
    |L|^2 >= g |1 + L|^2  <=>  |L - g/(1 - g)| >= sqrt(g)/(1 - g), g = level2 (half power: |L - 1| >= sqrt 2)."""
    return level2 / (1 - level2), math.sqrt(level2) / (1 - level2)


def requirement_circles(problem: LoopProblem) -> list[tuple[float, float]]:
    """(centre, radius) of every circle the Nyquist curve must stay outside."""
    req = problem.requirements
    circles = [margin_circle(req.phase_margin_deg, req.gain_margin_db)]
    if req.peak_sensitivity is not None:      # |1 + L| >= 1/Ms
        circles.append((-1.0, 1.0 / req.peak_sensitivity))
    if req.disk_margin is not None:
        circles.append(disk_margin_circle(req.disk_margin))
    return circles
