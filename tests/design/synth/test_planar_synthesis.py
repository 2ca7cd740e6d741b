"""The planar synthesis's figures held to Newton-Euler equations written out in the tests and python-control
(``tests/reference/independent_planar_loops.py``), its rotation design held to its boundary, and the whole loop's
check shown able to fail."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from independent_planar_loops import Gains, Machine, channel_loops, closed_loop_poles, margins

from design.loop.dual import CommonDifferential
from design.spec.planar import load_planar_spec
from design.synth import planar as pl
from design.synth.dual import W_RAD_S, dual_scenarios
from design.workflows import load_problem

SPECS = Path(__file__).resolve().parents[3] / "specs"
Y_GAINS = dict(kp_common=219.8, ki_common=18957.0, kp_differential=191.2, ki_differential=1.0)
DENSE_W = 2 * np.pi * np.logspace(-2, 3.5, 50000)


@pytest.fixture(scope="module")
def setting():
    y = load_problem(SPECS / "stage_y_dual.toml")
    r = load_planar_spec(SPECS / "planar.toml").rotation
    stage = pl.RotationStage(r.inertia_kg_m2, r.damping_n_m_s_per_rad, r.torque_constant_n_m_per_a, r.drive_effects())
    return y.spec.dual_model(), stage, y.spec.dual_drive.stage_x_mass_kg


def _one(setting, position, payload, y_values, r_values):
    model, stage, mx = setting
    ys = dual_scenarios(model, [position], [mx + payload], {k: (v, v) for k, v in y_values.items()}, mx)
    return pl.PlanarScenarios(ys, stage, {k: np.array([v]) for k, v in r_values.items()})


def _machine(position, payload, y_values, r_values, mx=16.0):
    return Machine(carriage_mass_kg=mx + payload, carriage_position_m=position,
                   damping1_n_s_per_m=y_values["damping1_n_s_per_m"], damping2_n_s_per_m=y_values["damping2_n_s_per_m"],
                   y_delay_s=y_values["delay.seconds"], y_current_loop_hz=y_values["current_loop.bandwidth_hz"],
                   rotation_inertia_kg_m2=r_values["inertia_kg_m2"], rotation_delay_s=r_values["delay.seconds"])


CASES = [
    # the bundled design's least-slack corner, then points inside the box
    (0.08, 40.0, dict(damping1_n_s_per_m=330, damping2_n_s_per_m=330, **{"delay.seconds": 3e-4,
                                                                          "current_loop.bandwidth_hz": 1300}),
     {"inertia_kg_m2": 0.02, "delay.seconds": 8e-4}),
    (0.5113, 17.3, dict(damping1_n_s_per_m=401, damping2_n_s_per_m=529, **{"delay.seconds": 6.1e-4,
                                                                            "current_loop.bandwidth_hz": 811}),
     {"inertia_kg_m2": 0.083, "delay.seconds": 4.4e-4}),
    (0.703, 5.0, dict(damping1_n_s_per_m=550, damping2_n_s_per_m=350, **{"delay.seconds": 8e-4,
                                                                          "current_loop.bandwidth_hz": 700}),
     {"inertia_kg_m2": 0.1, "delay.seconds": 3e-4}),
]


@pytest.mark.parametrize("position, payload, y_values, r_values", CASES)
def test_whole_loop_margins_match_newton_euler_and_python_control(setting, position, payload, y_values, r_values):
    rotation = pl.PI(7.11, 562.3)
    f = pl.planar_figures(W_RAD_S, _one(setting, position, payload, y_values, r_values).frd_of(0, 1),
                          CommonDifferential(**Y_GAINS), rotation)
    m = _machine(position, payload, y_values, r_values)
    g = Gains(**Y_GAINS, kp_rotation=rotation.kp, ki_rotation=rotation.ki)
    (gm_c, pm_c), (gm_d, pm_d), (gm_r, pm_r) = (margins(loop) for loop in channel_loops(DENSE_W, m, g))
    assert f.y.phase_margin_deg[0] == pytest.approx(min(pm_c, pm_d), abs=0.01)
    assert f.y.gain_margin_db[0] == pytest.approx(min(gm_c, gm_d), abs=0.01)
    assert f.rotation_phase_margin_deg[0] == pytest.approx(pm_r, abs=0.01)
    assert f.rotation_gain_margin_db[0] == pytest.approx(gm_r, abs=0.01)
    assert f.unstable_poles[0] == 0
    assert closed_loop_poles(m, g).real.max() < 1e-6


def test_a_rotation_loop_too_fast_for_its_drive_is_found_unstable_by_both(setting):
    position, payload, y_values, r_values = CASES[0]
    too_fast = pl.PI(7.11 * 6, 562.3 * 6)
    f = pl.planar_figures(W_RAD_S, _one(setting, position, payload, y_values, r_values).frd_of(0, 1),
                          CommonDifferential(**Y_GAINS), too_fast)
    g = Gains(**Y_GAINS, kp_rotation=too_fast.kp, ki_rotation=too_fast.ki)
    assert f.unstable_poles[0] > 0
    assert closed_loop_poles(_machine(position, payload, y_values, r_values), g).real.max() > 1.0


def test_the_rotation_design_sits_on_its_requirement_and_the_reference_agrees(setting):
    model, stage, mx = setting
    plants = pl.planar_scenarios(model, stage, [0.08, 0.4, 0.72], mx + np.array([5.0, 40.0]),
                                 {"delay.seconds": (3e-4, 8e-4)}, {"inertia_kg_m2": (0.02, 0.1),
                                                                   "delay.seconds": (3e-4, 8e-4)}, mx)
    y = CommonDifferential(**Y_GAINS)
    channels = pl.rotation_channel(W_RAD_S, plants.frd_of(0, len(plants)), y)
    req = pl.RotationRequirements()
    d = pl.design_rotation(channels, req, (0.0, 1000.0), (0.0, 1e6))
    gm, pm, bw = pl.rotation_figures(W_RAD_S, channels, d.pi)
    assert pm.min() >= 45.0 and gm.min() >= 6.0 and bw.min() == pytest.approx(d.bandwidth_hz)
    # faster gains break a requirement on some plant: the scan stopped at the boundary, not short of it
    for factor in (1.03, 1.1):
        gm2, pm2, _ = pl.rotation_figures(W_RAD_S, channels, pl.PI(d.pi.kp * factor, d.pi.ki * factor))
        assert pm2.min() < 45.0 or gm2.min() < 6.0
    k = int(np.argmin(pm))
    point = plants.point(k)
    y_values = dict(damping1_n_s_per_m=440.0, damping2_n_s_per_m=440.0, **{"delay.seconds": point["delay.seconds"],
                                                                            "current_loop.bandwidth_hz": 1000.0})
    m = _machine(point["carriage_position_m"], point["payload_kg"], y_values,
                 {"inertia_kg_m2": point["rotation.inertia_kg_m2"], "delay.seconds": point["rotation.delay.seconds"]})
    loops = channel_loops(DENSE_W, m, Gains(**Y_GAINS, kp_rotation=d.pi.kp, ki_rotation=d.pi.ki))
    assert margins(loops[2])[1] == pytest.approx(pm[k], abs=0.01)


def test_the_whole_loop_check_fails_a_design_that_fails_between_the_grid(setting):
    """A rotation PI that holds 45 deg only on plants of the lightest rotation stage: the check on a grid that
    holds only that inertia passes it, the check over the declared box does not."""
    model, stage, mx = setting
    light = pl.planar_scenarios(model, stage, [0.4], mx + np.array([22.5]), {}, {"inertia_kg_m2": (0.02, 0.02)}, mx)
    channels = pl.rotation_channel(W_RAD_S, light.frd_of(0, 1), CommonDifferential(**Y_GAINS))
    d = pl.design_rotation(channels, pl.RotationRequirements(), (0.0, 1000.0), (0.0, 1e6))
    c = pl.check(CommonDifferential(**Y_GAINS), d.pi, design=light, y_model=model, rotation=stage,
                 travel_m=(0.08, 0.72), mass_range_kg=(mx + 5.0, mx + 40.0), y_ranges={},
                 rotation_ranges={"inertia_kg_m2": (0.02, 0.1)}, y_req=pl.DualRequirements(),
                 r_req=pl.RotationRequirements(), stage_x_mass_kg=mx, samples=0, seed=1)
    assert c.design.holds and not c.between.holds and not c.holds
