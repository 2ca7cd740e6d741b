"""The two-motor Stage Y and its loops (plant/physics/dual_drive.py, design/loop/dual.py) against the
reference built from Lagrange's equations in rail coordinates with python-control
(tests/reference/independent_dual_drive.py), thesis Eq. 3.16, and python-control's margins, bandwidth and
disk margins (slycot's mu bound for the MIMO disk margin)."""

from __future__ import annotations

import ast
from dataclasses import replace
from pathlib import Path

import control
import numpy as np
import pytest
from independent_dual_drive import (
    Rig,
    channel_loop,
    closed_loop,
    controller,
    input_loop,
    mechanics,
    plant,
    unstable_poles,
)
from scipy.optimize import brentq

from design.loop.dual import CommonDifferential, MasterSlave, PerMotor, loop_figures, offset_ramp_a_per_s
from plant.physics.drive_filters import LowPassFilter
from plant.physics.dual_drive import DualDriveStageY
from plant.physics.effects import make_effect

W = 2 * np.pi * np.logspace(-2, 3.7, 4000)
STRUCTURES = {"per_motor": PerMotor, "common_differential": CommonDifferential, "master_slave": MasterSlave}
#: a rig unlike the thesis's symmetric one: rails that differ, an off-centre carriage with its own inertia
SKEWED = Rig(beam_mass_kg=14.0, beam_inertia_kg_m2=0.9, carriage_mass_kg=42.0, carriage_inertia_kg_m2=0.3,
             carriage_position_m=0.17, b1=380.0, b2=520.0, k1=19.0, k2=21.5, yaw_stiffness=8.0e4,
             current_loop_hz=900.0)


def tool_plant(rig: Rig) -> DualDriveStageY:
    effects = ()
    if rig.delay_s > 0:
        effects += (make_effect("delay", seconds=rig.delay_s),)
    if rig.current_loop_hz is not None:
        effects += (make_effect("current_loop", bandwidth_hz=rig.current_loop_hz),)
    if rig.low_pass_hz is not None:
        effects += (LowPassFilter(frequency_hz=rig.low_pass_hz),)
    return DualDriveStageY(beam_mass_kg=rig.beam_mass_kg, beam_inertia_kg_m2=rig.beam_inertia_kg_m2,
                           carriage_mass_kg=rig.carriage_mass_kg, carriage_inertia_kg_m2=rig.carriage_inertia_kg_m2,
                           rail_separation_m=rig.rail_separation_m, carriage_position_m=rig.carriage_position_m,
                           damping1_n_s_per_m=rig.b1, damping2_n_s_per_m=rig.b2, force_constant1_n_per_a=rig.k1,
                           force_constant2_n_per_a=rig.k2, yaw_stiffness_n_m_per_rad=rig.yaw_stiffness,
                           effects=effects)


def reference_frd(sys: control.StateSpace, w: np.ndarray) -> np.ndarray:
    r = sys.frequency_response(w)
    return r.magnitude * np.exp(1j * r.phase)


def test_reference_is_independent_of_the_tool():
    source = (Path(__file__).parents[2] / "reference" / "independent_dual_drive.py").read_text()
    tree = ast.parse(source)
    names = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    names |= {n.module.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
    assert not names & {"plant", "design"}


@pytest.mark.parametrize("rig", [Rig(), SKEWED, Rig(carriage_position_m=0.72, yaw_stiffness=3e4, delay_s=6e-4,
                                                     current_loop_hz=1200.0)])
def test_plant_is_newtons_law_in_rail_coordinates(rig):
    """Centre-of-mass and yaw coordinates (the tool) and rail coordinates (the reference) are one body."""
    s = 1j * W
    drive = np.exp(-s * rig.delay_s) * (1.0 if rig.current_loop_hz is None
                                        else 2 * np.pi * rig.current_loop_hz / (s + 2 * np.pi * rig.current_loop_hz))
    expected = reference_frd(mechanics(rig), W) * drive
    np.testing.assert_allclose(tool_plant(rig).frd(W), expected, rtol=1e-8, atol=1e-14)


def test_state_space_is_the_reference_mechanics():
    np.testing.assert_allclose(reference_frd(tool_plant(SKEWED).state_space(), W),
                               reference_frd(mechanics(SKEWED), W), rtol=1e-9, atol=1e-14)


def test_centred_rig_on_equal_currents_is_thesis_eq_3_16():
    """K_t L / (2 M l s + 2 b L) with l = L / 2 and the total current I = i1 + i2 shared equally."""
    rig = Rig(carriage_position_m=0.4)
    g = tool_plant(rig).frd(W)
    M, b, kt, L, l = 16.0 + 35.0, 440.0, 20.0, 0.8, 0.4
    thesis = kt * L / (2 * M * l * 1j * W + 2 * b * L)
    for rail in (0, 1):
        np.testing.assert_allclose(0.5 * (g[rail, 0] + g[rail, 1]), thesis, rtol=1e-12)


def test_a_batch_of_carriage_positions_and_payloads_is_the_plants_one_by_one():
    p = np.linspace(0.05, 0.75, 4)[:, None]
    m = np.array([20.0, 45.0, 75.0])[None, :]
    batch = DualDriveStageY(carriage_position_m=p, carriage_mass_kg=m).frd(W[::40])
    for i in range(4):
        for j in range(3):
            one = DualDriveStageY(carriage_position_m=float(p[i, 0]), carriage_mass_kg=float(m[0, j])).frd(W[::40])
            np.testing.assert_allclose(batch[i, j], one, rtol=1e-12)


CASES = [
    (Rig(current_loop_hz=1000.0), "per_motor", (118.0, 23.5)),
    (SKEWED, "per_motor", (300.0, 4000.0)),
    (SKEWED, "common_differential", (500.0, 6000.0, 150.0, 900.0)),
    (Rig(carriage_position_m=0.1, current_loop_hz=1000.0), "common_differential", (236.0, 47.0, 400.0, 20.0)),
    (Rig(carriage_position_m=0.4, current_loop_hz=1000.0), "master_slave", (236.0, 47.0)),
    (Rig(carriage_position_m=0.1, current_loop_hz=1000.0), "master_slave", (236.0, 47.0)),
    (SKEWED, "master_slave", (150.0, 800.0)),
    (Rig(current_loop_hz=300.0), "per_motor", (2500.0, 1e5)),
]


@pytest.mark.parametrize(("rig", "structure", "gains"), CASES)
def test_stability_from_the_winding_of_det_is_the_closed_loops_poles(rig, structure, gains):
    fig = loop_figures(W, tool_plant(rig).frd(W), STRUCTURES[structure](*gains))
    assert int(fig.unstable_poles) == unstable_poles(rig, structure, gains)


def test_stability_with_a_delay_agrees_with_pade():
    """The tool keeps the exact delay; python-control a Pade approximant of order 8 (agreement away from the
    stability boundary)."""
    for gains in ((200.0, 3000.0), (1400.0, 3000.0), (2600.0, 3000.0)):
        rig = Rig(carriage_position_m=0.2, delay_s=8e-4, current_loop_hz=1000.0)
        fig = loop_figures(W, tool_plant(rig).frd(W), PerMotor(*gains))
        assert int(fig.unstable_poles) == unstable_poles(rig, "per_motor", gains)
    assert int(loop_figures(W, tool_plant(rig).frd(W), PerMotor(2600.0, 3000.0)).unstable_poles) > 0


@pytest.mark.parametrize(("rig", "structure", "gains"), [c for c in CASES[:4]])
def test_loop_at_a_time_margins_are_python_controls(rig, structure, gains):
    fig = loop_figures(W, tool_plant(rig).frd(W), STRUCTURES[structure](*gains))
    gms, pms = [], []
    for j in range(2):    # on the tool's grid: a loop near |l| = 1 towards DC crosses 1 below any grid
        gm, pm, *_ = control.stability_margins(control.frd(channel_loop(rig, structure, gains, j), W))
        gms.append(20 * np.log10(gm) if gm > 0 else np.inf)
        pms.append(pm)
    np.testing.assert_allclose(float(fig.gain_margin_db), min(gms), atol=0.05)
    np.testing.assert_allclose(float(fig.phase_margin_deg), min(pms), atol=0.1)


def test_master_slaves_loop_is_the_one_pi_on_the_master_rail():
    rig = Rig(carriage_position_m=0.3, current_loop_hz=1000.0)
    from independent_dual_drive import pi, plant

    loop = pi(236.0, 47.0) * (plant(rig)[0, 0] + plant(rig)[0, 1]) * 0.5
    gm, pm, *_ = control.stability_margins(loop)
    fig = loop_figures(W, tool_plant(rig).frd(W), MasterSlave(236.0, 47.0))
    np.testing.assert_allclose(float(fig.gain_margin_db), 20 * np.log10(gm), atol=0.05)
    np.testing.assert_allclose(float(fig.phase_margin_deg), pm, atol=0.1)


@pytest.mark.parametrize(("rig", "structure", "gains"), [CASES[0], CASES[2], CASES[4]])
def test_simultaneous_disk_margin_is_python_controls_mu_bound(rig, structure, gains):
    pytest.importorskip("slycot")
    fig = loop_figures(W, tool_plant(rig).frd(W), STRUCTURES[structure](*gains))
    omega = W[::8]
    dm, _, _ = control.disk_margins(input_loop(rig, structure, gains), omega, skew=0.0)
    # the tool's grid is 8 times denser: its worst case is at most slycot's on the coarser grid
    assert float(fig.disk_margin) <= dm * (1 + 1e-6)
    assert float(fig.disk_margin) == pytest.approx(dm, rel=0.02)


@pytest.mark.parametrize(("rig", "structure", "gains"), [CASES[1], CASES[3], CASES[4]])
def test_bandwidth_and_yaw_coupling_are_the_closed_loops(rig, structure, gains):
    T = closed_loop(rig, structure, gains)
    mean = 0.5 * (T[0, 0] + T[1, 0])
    half_difference = 0.5 * (T[1, 0] - T[0, 0])
    fig = loop_figures(W, tool_plant(rig).frd(W), STRUCTURES[structure](*gains))
    # python-control's bandwidth divides by dcgain, which the free rigid-body position (a pole at 0, unobservable
    # in velocity) leaves undefined; integral action makes |T(0)| = 1 exactly, so the -3 dB point is |T| = 1/sqrt 2
    mag = np.abs(reference_frd(mean, W))
    k = int(np.argmax(mag < 2**-0.5))
    w3 = brentq(lambda w: abs(mean(1j * w)) - 2**-0.5, W[k - 1], W[k], xtol=1e-10)
    assert float(fig.bandwidth_hz) == pytest.approx(w3 / (2 * np.pi), rel=1e-4)
    assert float(fig.yaw_coupling) == pytest.approx(np.abs(reference_frd(half_difference, W)).max(), rel=1e-6,
                                                    abs=1e-9)


@pytest.mark.parametrize(("rig", "structure", "gains"), [CASES[1], CASES[2], CASES[6]])
def test_translation_step_is_the_reference_closed_loops_step(rig, structure, gains):
    from design.loop.dual import translation_step

    t = np.linspace(0.0, 0.2, 2001)
    tool = translation_step(tool_plant(rig), STRUCTURES[structure](*gains), t)
    reference = control.forced_response(closed_loop(rig, structure, gains), t, np.ones_like(t)).outputs
    np.testing.assert_allclose(tool, reference, atol=1e-6 * max(1.0, np.abs(reference).max()))


FILTERED = [(Rig(carriage_position_m=0.15, current_loop_hz=1000.0, low_pass_hz=150.0), "per_motor", (100.0, 5000.0)),
            (Rig(carriage_position_m=0.65, current_loop_hz=1000.0, low_pass_hz=80.0), "common_differential",
             (200.0, 10000.0, 100.0, 10.0)),
            (Rig(carriage_position_m=0.4, current_loop_hz=1000.0, low_pass_hz=40.0), "per_motor", (900.0, 40000.0))]


@pytest.mark.parametrize(("rig", "structure", "gains"), FILTERED)
def test_a_drive_filter_after_every_channel_is_one_before_each_motor(rig, structure, gains):
    """The tool puts a kept drive filter in series with each motor (``Spec.dual_model``); the reference after
    each channel's PI: the same loop, its stability, margins and bandwidth."""
    fig = loop_figures(W, tool_plant(rig).frd(W), STRUCTURES[structure](*gains))
    assert int(fig.unstable_poles) == unstable_poles(rig, structure, gains)
    if int(fig.unstable_poles) == 0:       # the first two cases (the third: four right-half-plane poles)
        pms = [control.stability_margins(control.frd(channel_loop(rig, structure, gains, j), W))[1] for j in range(2)]
        np.testing.assert_allclose(float(fig.phase_margin_deg), min(pms), atol=0.1)
        T = closed_loop(rig, structure, gains)
        mean = 0.5 * (T[0, 0] + T[1, 0])
        k = int(np.argmax(np.abs(reference_frd(mean, W)) < 2**-0.5))
        w3 = brentq(lambda w: abs(mean(1j * w)) - 2**-0.5, W[k - 1], W[k], xtol=1e-10)
        assert float(fig.bandwidth_hz) == pytest.approx(w3 / (2 * np.pi), rel=1e-4)


#: the spec's worst corner for today's per-motor design (0.4 m, 5 kg: 16 + 5 kg on the carriage), a skewed rig, and
#: master-slave at the far end with 40 kg
SPEC_CORNER = dict(b1=330.0, b2=330.0, delay_s=8e-4, current_loop_hz=700.0)
COMMON = [(Rig(carriage_position_m=0.4, carriage_mass_kg=21.0, **SPEC_CORNER), "per_motor", (124.8, 17757.5)),
          (replace(SKEWED, delay_s=5e-4), "common_differential", (219.1, 19615.2, 191.2, 1.0)),
          (Rig(carriage_position_m=0.72, carriage_mass_kg=56.0, **SPEC_CORNER), "master_slave", (75.04, 4072.6))]


def _gain_boundary(rig, structure, gains, up: bool) -> float:
    """The common factor on both motors' force constants at which the reference closed loop (python-control,
    Pade order 8) first becomes unstable, searched up (or down) from 1 by doubling and bisection (dB)."""
    def stable(g):
        return unstable_poles(replace(rig, k1=rig.k1 * g, k2=rig.k2 * g), structure, gains) == 0

    assert stable(1.0)
    lo, hi = 0.0, 20 * np.log10(2.0) * (1 if up else -1)
    while stable(10 ** (hi / 20)):
        lo, hi = hi, 2 * hi
        if abs(hi) > 200:
            return np.inf
    for _ in range(40):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if stable(10 ** (mid / 20)) else (lo, mid)
    return abs(hi)


@pytest.mark.parametrize(("rig", "structure", "gains"), COMMON)
def test_common_mode_gain_margin_is_where_the_same_gain_on_both_motors_destabilises(rig, structure, gains):
    """Both force constants scaled by the same factor in the reference's state space: the closed loop's poles
    cross into the right half-plane at the tool's common-mode gain margin (either way from 1)."""
    fig = loop_figures(W, tool_plant(rig).frd(W), STRUCTURES[structure](*gains))
    boundary = min(_gain_boundary(rig, structure, gains, True), _gain_boundary(rig, structure, gains, False))
    assert float(fig.common_gain_margin_db) == pytest.approx(boundary, abs=0.05)


@pytest.mark.parametrize(("rig", "structure", "gains"), COMMON)
def test_common_mode_phase_margin_is_the_least_common_rotation_that_closes_det(rig, structure, gains):
    """On the reference's loop at the motor inputs (python-control's response of K P): the least |theta| for which
    det(I + e^(-j theta) L(jw)) = 0 at some w, from the quadratic in z = e^(-j theta) at each frequency
    (det L z^2 + tr L z + 1 = 0) where a root sits on the unit circle; the tool's is within 0.1 deg."""
    fig = loop_figures(W, tool_plant(rig).frd(W), STRUCTURES[structure](*gains))
    w = 2 * np.pi * np.logspace(-2, 3.7, 40000)
    L = reference_frd(input_loop(rig, structure, gains), w)
    tr, det = L[0, 0] + L[1, 1], L[0, 0] * L[1, 1] - L[0, 1] * L[1, 0]
    best = np.inf
    for sign in (1, -1):
        with np.errstate(all="ignore"):
            disc = np.sqrt(tr * tr - 4 * det)
            z = np.where(np.abs(det) > 1e-12 * np.abs(tr) ** 2, (-tr + sign * disc) / (2 * det), -1 / tr)
        m = np.log(np.abs(z))
        cross = np.flatnonzero(np.sign(m[:-1]) != np.sign(m[1:]))
        for k in cross:
            t = m[k] / (m[k] - m[k + 1])
            theta = np.angle(z[k] * (z[k + 1] / z[k]) ** t)          # e^(-j theta) = z on the unit circle
            best = min(best, abs(np.degrees(theta)))
    assert float(fig.common_phase_margin_deg) == pytest.approx(best, abs=0.1)


@pytest.mark.parametrize(("structure", "gains", "ramps"), [("per_motor", (124.8, 17757.5), True),
                                                          ("per_motor", (84.56, 6221.0), True),
                                                          ("common_differential", (219.8, 18957.0, 191.2, 40.0), True),
                                                          ("common_differential", (219.8, 18957.0, 191.2, 0.0), False),
                                                          ("master_slave", (74.83, 4061.0), False)])
def test_a_sensor_offset_ramps_the_differential_current_as_the_reference_closed_loop_does(structure, gains, ramps):
    """A constant 1 mm/s offset on rail Y1's velocity sensor, the reference's closed loop (python-control state
    space, Pade 8) simulated for 20 s: the half-difference of the motor currents ends on a ramp whose slope the
    tool's residue at s = 0 gives (to 1e-4), or settles where the loop has no pole at s = 0."""
    rig = Rig(carriage_position_m=0.4, carriage_mass_kg=38.5, delay_s=5.5e-4, current_loop_hz=1000.0)
    loop = -control.feedback(controller(structure, gains), plant(rig, 8))
    t = np.linspace(0.0, 20.0, 20001)
    u = control.forced_response(loop[:, 0], t, np.full(t.size, 1e-3)).outputs
    half = (u[1] - u[0]) / 2
    slope = (half[-1] - half[-2001]) / (t[-1] - t[-2001])
    tool = 1e-3 * offset_ramp_a_per_s(tool_plant(rig), STRUCTURES[structure](*gains))
    if ramps:
        assert abs(slope) > 1e-4 and tool == pytest.approx(slope, rel=1e-4)
    else:
        assert tool == 0.0 and abs(slope) < 1e-9


@pytest.mark.parametrize(("rig", "structure", "gains"), COMMON)
def test_common_delay_margin_is_the_extra_delay_in_both_drives_that_destabilises(rig, structure, gains):
    """Extra delay in both drives of the reference (python-control, Pade order 8 of the whole delay), found by
    bisection where the closed loop first has a right-half-plane pole: the tool's common delay margin within 1e-4."""
    fig = loop_figures(W, tool_plant(rig).frd(W), STRUCTURES[structure](*gains))

    def stable(extra_s):
        return unstable_poles(replace(rig, delay_s=rig.delay_s + extra_s), structure, gains, pade_order=10) == 0

    lo, hi = 0.0, 1e-4
    while stable(hi):
        lo, hi = hi, 2 * hi
    for _ in range(30):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    assert float(fig.common_delay_margin_s) == pytest.approx(hi, rel=1e-4)
