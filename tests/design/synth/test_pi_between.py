"""The PI design's search between its dense check's points, held against the loop written out in closed form here
(Stage X: K_t / (M s + b) with the drive's delay and first-order current loop, thesis Eq. 3.15; the PI; margins on
a dense grid), nothing of the tool's evaluator."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from design.loop.controller import PI
from design.spec.schema import load_spec
from design.synth.between import search_pi_between
from design.synth.scenarios import Scenarios

SPEC = Path(__file__).resolve().parents[3] / "specs" / "stage_x_synth.toml"
W = np.geomspace(2 * np.pi * 0.01, 2 * np.pi * 5e3, 200_000)


def closed_form_slack(kp, ki, *, mass, damping, delay, current_hz, kt=20.0, pm_req=45.0, gm_req=6.0) -> float:
    """The least relative margin of the closed-form loop (PM and GM read at their crossings on a dense grid)."""
    s = 1j * W
    wc = 2 * np.pi * current_hz
    L = kt / (mass * s + damping) * np.exp(-s * delay) * wc / (s + wc) * (kp + ki / s)
    mag, ph = np.abs(L), np.unwrap(np.angle(L))
    c = np.flatnonzero((mag[:-1] >= 1) & (mag[1:] < 1))[0]
    pm = math.degrees(ph[c] + math.pi)
    p = np.flatnonzero((ph[:-1] > -math.pi) & (ph[1:] <= -math.pi))[0]
    gm = -20 * math.log10(mag[p])
    return min((pm - pm_req) / pm_req, (gm - gm_req) / gm_req)


def closed_form_bandwidth_hz(kp, ki, *, mass, damping, delay, current_hz, kt=20.0) -> float:
    """The first frequency where |T| = |L / (1 + L)| falls to 1/sqrt(2) (half power; T(0) = 1 with the integrator)."""
    s = 1j * W
    wc = 2 * np.pi * current_hz
    L = kt / (mass * s + damping) * np.exp(-s * delay) * wc / (s + wc) * (kp + ki / s)
    T = np.abs(L / (1 + L))
    k = np.flatnonzero(T < 1 / math.sqrt(2))[0]
    return float(W[k] / (2 * np.pi))


def test_the_search_moves_from_a_coarse_check_to_the_boxs_worst_point():
    """Started from a check that holds only 10 and 20 kg, the search reaches the worst plant of the whole box (the
    heaviest payload, the slowest drive, the least damping: a brute force over the box's corners and 36 payloads of
    the closed-form loop finds none lower), and its slack there is the closed form's."""
    problem = load_spec(SPEC).problem()
    ranges = problem.plant.uncertainty
    names = sorted(ranges)
    pi = PI(178.5, 19150.0)
    corners = list(itertools.product(*[(ranges[n].min, ranges[n].max) for n in names]))
    coarse = Scenarios(np.repeat([10.0, 20.0], len(corners)),
                       {n: np.tile([c[i] for c in corners], 2) for i, n in enumerate(names)})
    found = search_pi_between(problem, pi, coarse)
    x = dict(zip(found.coordinates, found.values))

    def slack_at(payload, values):
        v = dict(zip(names, values))
        return closed_form_slack(pi.kp, pi.ki, mass=payload, damping=v["damping_n_s_per_m"],
                                 delay=v["delay.seconds"], current_hz=v["current_loop.bandwidth_hz"])

    brute = min(slack_at(m, c) for m in np.linspace(5.0, 40.0, 36) for c in corners)
    here = slack_at(x["payload_kg"], [x[n] for n in names])
    assert found.slack < found.grid_slack - 0.01                     # it left the coarse check's points
    assert here == pytest.approx(found.slack, abs=2e-3)              # the tool's slack there is the closed form's
    assert here <= brute + 2e-3                                      # and no corner or payload of the box is lower
    assert x["payload_kg"] == pytest.approx(40.0, abs=0.1)
    # the second search: the least closed-loop bandwidth over the box, which the coarse check (10, 20 kg) misses
    b = found.bandwidth_scenario.as_dict()
    here_bw = closed_form_bandwidth_hz(pi.kp, pi.ki, mass=b["payload_kg"], damping=b["damping_n_s_per_m"],
                                       delay=b["delay.seconds"], current_hz=b["current_loop.bandwidth_hz"])
    brute_bw = min(closed_form_bandwidth_hz(pi.kp, pi.ki, mass=m, **dict(zip(("damping", "delay", "current_hz"), (
        dict(zip(names, c))[n] for n in ("damping_n_s_per_m", "delay.seconds", "current_loop.bandwidth_hz")))))
        for m in np.linspace(5.0, 40.0, 36) for c in corners)
    assert found.least_bandwidth_hz < found.grid_bandwidth_hz
    assert here_bw == pytest.approx(found.least_bandwidth_hz, rel=5e-3)
    assert here_bw <= brute_bw * (1 + 5e-3)
