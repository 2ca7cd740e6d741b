"""The planar mouse run: held to Newton's planar equations integrated by scipy (``tests/reference/
independent_planar_run.py``, no shared code), reduced to the one-axis run on a straight X path, its Runge-Kutta
step shown converged, and its paths' geometry."""

from dataclasses import replace
from pathlib import Path

import independent_planar_run as ref
import numpy as np
import pytest

from design.admittance.mouse_run import RunSettings, simulate_mouse_run
from design.admittance.planar_path import PlanarPath, diagonal_path, planar_path_from_csv, turn_path
from design.admittance.planar_run import (
    MotorDrive,
    PlanarMouse,
    PlanarRunSettings,
    planar_run,
    planar_settings,
    simulate_planar_run,
    substeps,
)
from design.admittance.rig import DiscreteAdmittance, ForceSensor
from design.loop.controller import PI
from design.loop.dual import CommonDifferential, PerMotor
from design.problem import Locomotion
from design.workflows import load_problem
from plant.errors import DataError, ParameterError, SpecError
from plant.physics.models import build_plant
from plant.physics.planar import PlanarGantry

SPECS = Path(__file__).resolve().parents[3] / "specs"
FINE = ForceSensor(1e-12, 0.0, 0.0)          # no quantisation: the comparison sees the dynamics, not rounding


def _settings(y_controller, *, sensor=FINE, rate=2000.0, delay=1, carriage=0.3, x_law=(0.04, 5.0),
              y_law=(0.07, 7.5)) -> PlanarRunSettings:
    machine = PlanarGantry(carriage_mass_kg=30.0, damping_x_n_s_per_m=400.0, damping1_n_s_per_m=420.0,
                           damping2_n_s_per_m=470.0, rotation_inertia_kg_m2=2e-3, rotation_damping_n_m_s_per_rad=0.05)
    drive = MotorDrive(20.0, 900.0, delay, 300.0)
    return PlanarRunSettings(machine, carriage, rate, MotorDrive(20.0, 1100.0, delay, 300.0), (drive, drive),
                             PI(200.0, 1.5e4), y_controller, DiscreteAdmittance.of(*x_law, 100.0, rule="forward_euler"),
                             DiscreteAdmittance.of(*y_law, 100.0, rule="forward_euler"), sensor, sensor,
                             PlanarMouse(0.006, 0.0275, 110.0, 0.6, 300.0, 0.5, 1.2))


def _reference(s: PlanarRunSettings, path: PlanarPath):
    m, mo = s.machine, s.mouse
    c = s.y_controller
    return ref.simulate(
        {"L": m.rail_separation_m, "m_b": m.beam_mass_kg, "J": m.beam_inertia_kg_m2 + m.carriage_inertia_kg_m2,
         "m_c": m.carriage_mass_kg + mo.head_mass_kg, "J_r": m.rotation_inertia_kg_m2, "b1": m.damping1_n_s_per_m,
         "b2": m.damping2_n_s_per_m, "b_x": m.damping_x_n_s_per_m, "b_r": m.rotation_damping_n_m_s_per_rad,
         "K_a": m.yaw_stiffness_n_m_per_rad},
        {"K": [d.force_constant_n_per_a for d in (*s.y_drives, s.x_drive)],
         "f_c": [d.current_loop_hz for d in (*s.y_drives, s.x_drive)],
         "limit": [d.current_limit_a for d in (*s.y_drives, s.x_drive)], "delay": s.x_drive.delay_ticks},
        (s.x_controller.kp, s.x_controller.ki),
        {"t_in": c.t_in, "t_out": c.t_out, "kp": [p.kp for p in c.channels()], "ki": [p.ki for p in c.channels()]},
        {"m_v": [s.x_law.m_v, s.y_law.m_v], "b_v": [s.x_law.b_v, s.y_law.b_v], "T_a": 1 / s.x_law.update_rate_hz},
        {"res": s.x_sensor.resolution_n, "bias": s.x_sensor.bias_n, "deadband": s.x_sensor.deadband_n},
        {"m_h": mo.head_mass_kg, "m_b": mo.body_mass_kg, "k_n": mo.neck_stiffness_n_per_m,
         "c_n": mo.neck_damping_n_s_per_m, "k_l": mo.leg_stiffness_n_per_m, "c_l": mo.leg_damping_n_s_per_m,
         "f_max": mo.peak_force_n, "feedforward": mo.feedforward},
        path.time_s, path.position_m, path.velocity_m_per_s, path.acceleration_m_per_s2,
        start_p=s.carriage_position_m, drive_rate_hz=s.drive_rate_hz, law_ticks=s.law_ticks,
        computation_delay=s.x_law.computation_delay_samples)


SHORT = Locomotion(peak_speed_m_per_s=0.15, peak_acceleration_m_per_s2=1.5, travel_m=0.06)


@pytest.mark.parametrize("structure", [CommonDifferential(220.0, 1.9e4, 190.0, 1.0),
                                       pytest.param(PerMotor(90.0, 6000.0), marks=pytest.mark.slow)],
                         ids=["common_differential", "per_motor"])
def test_the_planar_run_is_newtons_planar_gantry_with_both_axes_laws(structure):
    s = _settings(structure)
    path = diagonal_path(SHORT, s.drive_rate_hz, heading_deg=30.0, rest_s=0.1)
    tool = simulate_planar_run(s, path)
    pos, fs, cur = _reference(s, path)
    assert np.max(np.abs(fs)) > 0.3                                   # the mouse pushes on both axes
    assert np.max(np.abs(fs[:, 1])) > 0.15
    np.testing.assert_allclose(tool.sensed_force_n, fs, atol=2e-4 * np.max(np.abs(fs)))
    np.testing.assert_allclose(tool.clamp_m, pos, atol=1e-6)
    np.testing.assert_allclose(tool.current_a, cur, atol=2e-4 * np.max(np.abs(cur)))


@pytest.mark.slow
def test_with_the_sensor_quantising_the_run_still_agrees_on_what_the_mouse_feels():
    s = _settings(CommonDifferential(220.0, 1.9e4, 190.0, 1.0), sensor=ForceSensor(0.00625, 0.00625, 0.025))
    path = diagonal_path(SHORT, s.drive_rate_hz, heading_deg=60.0, rest_s=0.1)
    tool = simulate_planar_run(s, path)
    _, fs, _ = _reference(s, path)
    assert np.max(np.hypot(*tool.sensed_force_n.T)) == pytest.approx(np.max(np.hypot(*fs.T)), rel=0.01)


def test_a_straight_run_along_x_is_the_one_axis_run_and_leaves_y_at_rest():
    s = _settings(PerMotor(90.0, 6000.0), carriage=0.4, rate=4000.0, delay=2)
    path = diagonal_path(SHORT, s.drive_rate_hz, heading_deg=0.0, rest_s=0.1)
    planar = simulate_planar_run(s, path)
    mo, m, d = s.mouse, s.machine, s.x_drive
    plant = build_plant("x", mass_kg=m.carriage_mass_kg, damping_n_s_per_m=m.damping_x_n_s_per_m,
                        force_constant_n_per_a=20.0, effects={"current_loop": {"bandwidth_hz": d.current_loop_hz}})
    one = RunSettings(plant, d.delay_ticks, s.drive_rate_hz, 200.0, 1.5e4, d.peak_force_n, 0.0, 1e-3, 100.0, 0,
                      s.x_law.m_v, s.x_law.b_v, None, 1, 1e-12, 0.0, 0.0, mo.head_mass_kg, mo.body_mass_kg,
                      mo.neck_stiffness_n_per_m, mo.neck_damping_n_s_per_m, mo.leg_stiffness_n_per_m,
                      mo.leg_damping_n_s_per_m, mo.peak_force_n, law="forward_euler")
    trace = simulate_mouse_run(one, path.time_s, path.position_m[:, 0], path.velocity_m_per_s[:, 0],
                               path.acceleration_m_per_s2[:, 0])
    peak = np.max(np.abs(trace.sensed_force_n))
    assert peak > 0.5
    np.testing.assert_allclose(planar.sensed_force_n[:, 0], trace.sensed_force_n, atol=1e-4 * peak)
    np.testing.assert_allclose(planar.clamp_m[:, 0], trace.x_m, atol=1e-7)
    assert np.max(np.abs(planar.sensed_force_n[:, 1])) < 1e-9 and np.max(np.abs(planar.yaw_rad)) < 1e-12


def test_the_runge_kutta_step_is_converged():
    s = _settings(CommonDifferential(220.0, 1.9e4, 190.0, 1.0), rate=4000.0)
    path = turn_path(Locomotion(peak_speed_m_per_s=0.2, peak_acceleration_m_per_s2=1.0, travel_m=0.12),
                     s.drive_rate_hz, radius_m=0.02, rest_s=0.1)
    n = substeps(s)
    a, b = simulate_planar_run(s, path), simulate_planar_run(s, path, steps=4 * n)
    peak = np.max(np.abs(b.sensed_force_n))
    assert np.max(np.abs(a.sensed_force_n - b.sensed_force_n)) < 1e-5 * peak


def test_axes_that_lag_differently_push_the_mouse_sideways():
    alike = _settings(PerMotor(90.0, 6000.0), y_law=(0.04, 5.0))
    unlike = _settings(PerMotor(90.0, 6000.0), y_law=(0.12, 10.0))
    path = diagonal_path(SHORT, alike.drive_rate_hz, heading_deg=45.0, rest_s=0.1)
    a, b = planar_run(alike, path), planar_run(unlike, path)
    # the heavier, more damped Y law asks more force along Y than X: the felt force turns off the mouse's heading
    assert b.peak_lateral_force_n > 3 * a.peak_lateral_force_n
    assert b.peak_lateral_force_n > 0.1
    assert 0 < a.max_heading_error_deg < b.max_heading_error_deg


def test_paths_follow_their_geometry(tmp_path):
    loc = Locomotion(peak_speed_m_per_s=0.2, peak_acceleration_m_per_s2=1.0, travel_m=0.4)
    d = diagonal_path(loc, 1000.0, heading_deg=30.0)
    np.testing.assert_allclose(d.position_m[-1], 0.4 * np.array([np.cos(np.pi / 6), np.sin(np.pi / 6)]), atol=1e-3)
    assert np.max(d.speed_m_per_s) == pytest.approx(0.2)
    r = 0.05
    t = turn_path(loc, 1000.0, radius_m=r)
    leg = (0.4 - np.pi * r / 2) / 2
    np.testing.assert_allclose(t.position_m[-1], [leg + r, r + leg], atol=1e-3)
    on_arc = (t.position_m[:, 0] > leg + 1e-3) & (t.position_m[:, 1] < r - 1e-3) & (t.position_m[:, 1] > 1e-3)
    speed = t.speed_m_per_s[on_arc]
    v, a = t.velocity_m_per_s[on_arc], t.acceleration_m_per_s2[on_arc]
    lateral = np.abs(v[:, 0] * a[:, 1] - v[:, 1] * a[:, 0]) / speed
    np.testing.assert_allclose(lateral, speed**2 / r, rtol=1e-9)                      # the centripetal part v^2 / R
    assert np.max(np.abs(np.diff(t.position_m, axis=0))) < 0.2 / 1000 * 1.001         # no jump between the pieces
    with pytest.raises(ParameterError, match="radius_m"):
        turn_path(loc, 1000.0, radius_m=0.5)
    csv = tmp_path / "walk.csv"
    csv.write_text("time_s,x_m,y_m\n" + "".join(f"{k / 100},{0.1 * k / 100},{-0.05 * k / 100}\n" for k in range(101)))
    p = planar_path_from_csv(csv, 1000.0, rest_s=0.5)
    np.testing.assert_allclose(p.position_m[-1], [0.1, -0.05], atol=1e-9)
    csv.write_text("time_s,x_m\n0,0\n")
    with pytest.raises(DataError, match="walk.csv: missing column 'y_m'"):
        planar_path_from_csv(csv, 1000.0)
    csv.write_text("time_s,x_m,y_m\n0,0,0\n0.1,zz,0\n0.2,0,0\n")
    with pytest.raises(DataError, match="walk.csv: row 3"):
        planar_path_from_csv(csv, 1000.0)


def test_settings_from_the_bundled_specs_and_what_they_refuse():
    x = load_problem(SPECS / "stage_x_admittance.toml").loop
    y = load_problem(SPECS / "stage_y_admittance.toml")
    s = planar_settings(x, y, x_controller=PI(209.9, 14.12), x_virtual=(0.042, 5.0),
                        y_controller=CommonDifferential(219.8, 1.9e4, 191.2, 1.0), y_virtual=(0.05, 6.0))
    assert s.machine.carriage_mass_kg == 40.0 and s.machine.damping_x_n_s_per_m == 440.0    # Stage X's at 40 kg
    assert s.machine.beam_mass_kg == 16.0 and s.carriage_position_m == pytest.approx(0.4)   # Stage Y's beam
    assert s.x_drive.delay_ticks == 2 and s.drive_rate_hz == 4000.0                         # 0.5 ms at 4 kHz
    with pytest.raises(SpecError, match=r"\[dual_drive\]"):
        planar_settings(x, load_problem(SPECS / "stage_x_admittance.toml"), x_controller=PI(1, 1), x_virtual=(1, 1),
                        y_controller=PerMotor(1, 1), y_virtual=(1, 1))
    with pytest.raises(SpecError, match="carriage_position_m"):
        replace(s, carriage_position_m=0.9)
