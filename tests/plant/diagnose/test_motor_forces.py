"""Position-dependent motor forces found, measured and added, on recordings of the independent linear-motor
simulator (``tests/reference/independent_linear_motor.py``): a force constant falling off towards the ends of
the magnet track, a force ripple at a 20 mm pitch, both together, and (in ``test_interaction_residuals``) a
control with neither. Truths from the simulator's own definitions."""

import math

import independent_linear_motor as lm
import numpy as np
import pytest

from plant import stage_x
from plant.data.recordings import TimeRecording
from plant.diagnose.evidence import EXPLAINED
from plant.diagnose.time_diagnosis import diagnose_time

DROOP, TRAVEL_M = 0.3, 0.3
RIPPLE_N, RIPPLE_PHASE, PITCH_M = 3.0, 0.4, 0.02


def _diagnose(axis, seed):
    t, current, position = lm.slow_sweep(axis, seed=seed)
    return diagnose_time(stage_x(), TimeRecording(t, current, position[None, :], "position", ("x",), source="sweep"))


def _profile_truth(centre_m: float, half_m: float) -> tuple[float, float]:
    """(slope, curvature) of K(x) = K0 (1 - d (2 x / T)^2) written as K(centre) (1 + c1 u + c2 u^2)."""
    a = 4 * DROOP / TRAVEL_M**2
    k_centre = 1 - a * centre_m**2
    return -2 * a * centre_m * half_m / k_centre, -a * half_m**2 / k_centre


def test_force_constant_profile_is_found_and_measured():
    diag = _diagnose(lm.LinearMotorAxis(kt_droop=DROOP, travel_m=TRAVEL_M), seed=1)
    assert diag.selected == ("force_constant_profile",)
    assert diag.verdict == EXPLAINED
    profile = diag.final.plant.effect("force_constant_profile")
    slope, curvature = _profile_truth(profile.centre_m, profile.half_span_m)
    assert profile.slope == pytest.approx(slope, rel=0.03)
    assert profile.curvature == pytest.approx(curvature, rel=0.05)


def test_force_ripple_is_found_with_its_pitch_amplitude_and_phase():
    diag = _diagnose(lm.LinearMotorAxis(ripple_n=(RIPPLE_N,), ripple_phase_rad=(RIPPLE_PHASE,),
                                        ripple_pitch_m=PITCH_M), seed=2)
    assert diag.selected == ("force_ripple",)
    assert diag.verdict == EXPLAINED
    ripple = diag.final.plant.effect("force_ripple")
    assert ripple.pitch_m == pytest.approx(PITCH_M, rel=2e-3)
    # the model's ripple is the force the motor must supply: minus the simulator's pushing force
    assert ripple.sin1_n == pytest.approx(-RIPPLE_N * math.cos(RIPPLE_PHASE), abs=0.05 * RIPPLE_N)
    assert ripple.cos1_n == pytest.approx(-RIPPLE_N * math.sin(RIPPLE_PHASE), abs=0.05 * RIPPLE_N)
    assert ripple.amplitude_n(2) < 0.05 * RIPPLE_N
    assert diag.final.values["mass_kg"] == pytest.approx(35.0, rel=0.01)


def test_both_are_added_one_at_a_time_and_the_error_falls_each_time():
    diag = _diagnose(lm.LinearMotorAxis(kt_droop=DROOP, travel_m=TRAVEL_M, ripple_n=(RIPPLE_N,),
                                        ripple_phase_rad=(RIPPLE_PHASE,), ripple_pitch_m=PITCH_M), seed=3)
    assert set(diag.selected) == {"force_ripple", "force_constant_profile"}
    assert diag.verdict == EXPLAINED
    rms = [step.fit.rms_residual for step in diag.steps]
    assert len(rms) == 3 and rms[0] > rms[1] > rms[2]
    assert rms[2] < 0.15 * rms[0]


@pytest.mark.parametrize("forces", ["droop and ripple", "cable"])
def test_compensation_table_makes_the_simulated_stage_a_rigid_body(tmp_path, forces):
    """The table the diagnosis exports, read back from its CSV and applied by the simulated drive: the stage
    then needs no position-dependent effect and its residual falls to the noise (a droop and a ripple; a cable
    chain of 60 N/m relaxed mid-travel, its pull too: the table covers the travel the recording did)."""
    if forces == "cable":
        _, _, free = lm.slow_sweep(lm.LinearMotorAxis(), seed=4)
        axis = lm.LinearMotorAxis(cable_n_per_m=60.0, cable_rest_m=float(np.mean(free)))
    else:
        axis = lm.LinearMotorAxis(kt_droop=DROOP, travel_m=TRAVEL_M, ripple_n=(RIPPLE_N,),
                                  ripple_phase_rad=(RIPPLE_PHASE,), ripple_pitch_m=PITCH_M)
    diag = _diagnose(axis, seed=4)
    assert diag.selected == (("cable_force",) if forces == "cable" else ("force_ripple", "force_constant_profile"))
    table = diag.compensation()
    path = tmp_path / "compensation.csv"
    table.write(path)
    rows = np.loadtxt(path, delimiter=",", comments="#", skiprows=2)
    x, scale, offset = rows.T

    def drive(command, position):
        return np.interp(position, x, scale) * command + np.interp(position, x, offset)

    compensated = _diagnose_with(axis, drive, seed=5)
    assert compensated.selected == ()
    assert compensated.verdict == EXPLAINED
    before = diag.steps[0].fit.rms_residual
    after = compensated.steps[0].fit.rms_residual
    assert after < 0.15 * before
    assert table.removed_rms_n == pytest.approx(before, rel=0.3)


def _diagnose_with(axis, drive, seed):
    t, current, position = lm.slow_sweep(axis, seed=seed, drive=drive)
    return diagnose_time(stage_x(), TimeRecording(t, current, position[None, :], "position", ("x",), source="comp"))


def test_current_limit_is_found_with_its_limit_and_the_error_falls():
    """The amplifier clips the command at 2.5 A of a 4.3 A peak (the command recorded): the limit is found as
    the simulator's Kt x 2.5 A, a hard clip, mass and damping as without it."""
    axis = lm.LinearMotorAxis(current_limit_a=2.5)
    diag = _diagnose(axis, seed=6)
    assert diag.selected == ("current_limit",)
    assert diag.verdict == EXPLAINED
    limit = diag.final.plant.effect("current_limit")
    assert limit.limit_n == pytest.approx(axis.kt_n_per_a * 2.5, rel=0.01)
    assert limit.fraction_lost == pytest.approx(1.0, abs=0.02)
    assert diag.final.values["mass_kg"] == pytest.approx(axis.mass_kg, rel=0.02)
    assert diag.final.values["damping_n_s_per_m"] == pytest.approx(axis.damping_n_s_per_m, rel=0.02)
    assert diag.steps[-1].fit.rms_residual < 0.3 * diag.steps[0].fit.rms_residual


def test_a_cable_is_found_with_its_stiffness_and_rest_position_and_the_error_falls():
    """A cable chain pulling the carriage towards mid-travel (60 N/m): a force of the position that is neither
    periodic nor proportional to the current. Found as cable_force (nothing else claimed), its stiffness and
    rest position the simulator's, mass and damping as without it, and the residual falls to the noise's size."""
    t, current, free = lm.slow_sweep(lm.LinearMotorAxis(), seed=7)
    axis = lm.LinearMotorAxis(cable_n_per_m=60.0, cable_rest_m=float(np.mean(free)))
    diag = _diagnose(axis, seed=7)
    assert diag.selected == ("cable_force",)
    assert diag.verdict == EXPLAINED
    cable = diag.final.plant.effect("cable_force")
    assert cable.stiffness_n_per_m == pytest.approx(60.0, rel=0.01)
    assert cable.rest_m == pytest.approx(axis.cable_rest_m, abs=1e-3)
    assert diag.final.values["mass_kg"] == pytest.approx(axis.mass_kg, rel=0.01)
    assert diag.final.values["damping_n_s_per_m"] == pytest.approx(axis.damping_n_s_per_m, rel=0.01)
    assert diag.steps[-1].fit.rms_residual < 0.2 * diag.steps[0].fit.rms_residual


def test_a_cable_under_a_chirp_is_claimed_as_neither_an_offset_nor_a_profile():
    """Under a chirp the cable's force along the travel has a mean over the recording (an offset's column) and
    follows the current where the current follows the position (current x position): the cable is found
    (109 N/m, its rest position), not an offset or a force-constant profile."""
    noise = {"current_noise_a": 0.005, "position_noise_m": 2e-6}
    _, _, free = lm.chirp(lm.LinearMotorAxis(), seed=66, **noise)
    axis = lm.LinearMotorAxis(cable_n_per_m=109.0, cable_rest_m=float(np.mean(free)))
    t, current, position = lm.chirp(axis, seed=66, **noise)
    rec = TimeRecording(t, current, position[None, :], "position", ("x",), source="chirp")
    diag = diagnose_time(stage_x(), rec)
    assert diag.verdict == EXPLAINED
    assert diag.selected == ("cable_force",)
    cable = diag.final.plant.effect("cable_force")
    assert cable.stiffness_n_per_m == pytest.approx(109.0, rel=0.01)
    assert cable.rest_m == pytest.approx(axis.cable_rest_m, abs=1e-3)


def test_a_fit_with_a_limit_or_a_ripple_sets_its_shape_from_the_recording_unless_given(tmp_path):
    """``gantry fit --effects current_limit,force_ripple``: the limit and the pitch found as the diagnosis finds
    them (the simulator's Kt x 2.5 A and 20 mm); a value the user sets is where the fit's profile refinement
    starts (within 15 % of it for a limit)."""
    from design.workflows import fit_recording

    axis = lm.LinearMotorAxis(current_limit_a=2.5, ripple_n=(RIPPLE_N,), ripple_phase_rad=(RIPPLE_PHASE,),
                              ripple_pitch_m=PITCH_M)
    t, current, position = lm.slow_sweep(axis, seed=8)
    path = tmp_path / "sweep.csv"
    np.savetxt(path, np.column_stack([t, current, position]), delimiter=",", header="time_s,current_a,position_m",
               comments="")
    fit = fit_recording(path, stage="x", effects=("current_limit", "force_ripple")).result
    assert fit.plant.effect("current_limit").limit_n == pytest.approx(axis.kt_n_per_a * 2.5, rel=0.01)
    assert fit.plant.effect("force_ripple").pitch_m == pytest.approx(PITCH_M, rel=0.01)
    assert fit.explained
    held = fit_recording(path, stage="x", effects=("current_limit",), values={"current_limit.limit_n": 70.0}).result
    assert held.plant.effect("current_limit").limit_n == pytest.approx(0.85 * 70.0, rel=1e-3)


@pytest.mark.parametrize("form, drag, fixed_m", [("slow_sweep", 40.0, -0.25), ("chirp", -60.0, 0.25)])
def test_a_cable_carriers_drag_along_the_travel_is_found_beside_its_spring(form, drag, fixed_m):
    """A cable chain of 30 N/m whose drag grows from its fixed end (at either end of the track: d (x - x_f) >= 0 on
    the travel): a friction that varies along the travel. Found as cable_force with coulomb_friction (the drag's
    value at mid-travel), its stiffness, drag slope and Coulomb force the simulator's, the mass as without it (a
    force-constant profile with the mass 26 % low was the earlier answer)."""
    run = getattr(lm, form)
    _, _, free = run(lm.LinearMotorAxis(), seed=1)
    axis = lm.LinearMotorAxis(cable_n_per_m=30.0, cable_rest_m=float(np.mean(free)), cable_drag_n_per_m=drag,
                              cable_fixed_m=fixed_m)
    t, current, position = run(axis, seed=1)
    diag = diagnose_time(stage_x(), TimeRecording(t, current, position[None, :], "position", ("x",), source=form))
    assert set(diag.selected) == {"cable_force", "coulomb_friction"}
    assert diag.verdict == EXPLAINED
    cable = diag.final.plant.effect("cable_force")
    assert cable.stiffness_n_per_m == pytest.approx(30.0, rel=0.05)
    assert cable.drag_n_per_m == pytest.approx(drag, rel=0.05)
    coulomb = diag.final.plant.effect("coulomb_friction").force_n
    assert coulomb == pytest.approx(drag * (cable.centre_m - fixed_m), rel=0.03)
    assert diag.final.values["mass_kg"] == pytest.approx(axis.mass_kg, rel=0.01)
