"""The mouse run (``design.admittance.mouse_run.simulate_mouse_run``) against an independent reference simulator
(``independent_mouse_run``: solve_ivp between drive ticks, imports nothing from the tool): the traces at the
drive ticks on the lab's trapezoid, closed-form steady states, the sampled law and the PI rebuilt from a trace,
the mouse's force limit."""

import math
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import independent_mouse_run as ref
import numpy as np
import pytest
from bundled_specs import admittance_data

from design.admittance.mouse_run import RunSettings, simulate_mouse_run
from design.loop.controller import PI
from plant.physics.mechanics import Offset
from plant.physics.models import build_plant

#: realistic rig and mouse (SI units): 40 kg payload, the lab's PI, the bundled virtual dynamics
BASE = dict(gantry_mass_kg=40.0, damping_n_s_per_m=440.0, force_constant_n_per_a=20.0, current_loop_hz=None,
            delay_ticks=0, drive_rate_hz=1000.0, kp=140.0, ki=15.3, motor_peak_force_n=1e4, friction_n=0.0,
            friction_velocity_m_per_s=1e-3, admittance_rate_hz=100.0, computation_delay_samples=0, m_v=0.0057,
            b_v=9.07, force_filter_hz=None, force_filter_order=2, resolution_n=1e-9, bias_n=0.0, deadband_n=0.0,
            head_mass_kg=0.005, body_mass_kg=0.03, neck_stiffness_n_per_m=100.0, neck_damping_n_s_per_m=0.5,
            leg_stiffness_n_per_m=300.0, leg_damping_n_s_per_m=0.5, mouse_peak_force_n=1.2, feedforward=True,
            law="backward_euler")
#: case (b): the rig as it is (current loop, delays, filter, quantised and offset sensor, deadband, friction) with
#: a motor too weak for the payload, so the drive saturates and the integrator's anti-windup acts
RIG = dict(BASE, current_loop_hz=1000.0, drive_rate_hz=2000.0, delay_ticks=1, computation_delay_samples=1,
           force_filter_hz=30.0, force_filter_order=2, resolution_n=6.25e-3, bias_n=6.25e-3, deadband_n=0.01,
           friction_n=3.0, motor_peak_force_n=50.0, kp=140.0, ki=15.0)
#: an ideal current loop with delays, quantiser and deadband, no filter, a weak motor: the law and PI rebuild exactly
CONSISTENCY = dict(BASE, drive_rate_hz=2000.0, admittance_rate_hz=500.0, delay_ticks=3, computation_delay_samples=2,
                   resolution_n=6.25e-3, bias_n=6.25e-3, deadband_n=0.025, friction_n=3.0, motor_peak_force_n=50.0)
#: a floating mouse: no legs on the ground, no push
FLOATING = dict(leg_stiffness_n_per_m=0.0, leg_damping_n_s_per_m=0.0, feedforward=False, mouse_peak_force_n=1e6)


def _path(rate_hz, rest_s=0.3, rest_after_s=1.5, t_max_s=None):
    """The lab's trapezoid: 0.4 m at 0.2 m/s peak, 1 m/s^2, with rest before and after."""
    t, x, v, a = ref.trapezoid_path(0.4, 0.2, 1.0, rate_hz, rest_s, rest_after_s)
    if t_max_s is not None:
        keep = t <= t_max_s + 1e-12
        t, x, v, a = t[keep], x[keep], v[keep], a[keep]
    return t, x, v, a


#: the reference's plant keywords; the tool takes a Plant built from them instead
PLANT_KEYS = ("gantry_mass_kg", "damping_n_s_per_m", "force_constant_n_per_a", "current_loop_hz")


def tool_settings(settings):
    """The tool's ``RunSettings`` for the reference's keywords: a rigid Stage X of that mass, damping and force
    constant, with a current loop when the reference has one."""
    rest = {k: v for k, v in settings.items() if k not in PLANT_KEYS}
    fc = settings["current_loop_hz"]
    plant = build_plant("x", mass_kg=settings["gantry_mass_kg"], damping_n_s_per_m=settings["damping_n_s_per_m"],
                        force_constant_n_per_a=settings["force_constant_n_per_a"],
                        effects={} if fc is None else {"current_loop": {"bandwidth_hz": fc}})
    return RunSettings(plant=plant, **rest)


def _tool(settings, t, x, v, a):
    return simulate_mouse_run(tool_settings(settings), t, x, v, a)


def _close(name, tool, reference, rtol, atol):
    tool, reference = np.asarray(tool), np.asarray(reference)
    assert tool.shape == reference.shape, name
    err = np.max(np.abs(tool - reference))
    bound = rtol * np.max(np.abs(reference)) + atol
    k = int(np.argmax(np.abs(tool - reference)))
    assert err <= bound, f"{name}: max |tool - reference| = {err:.3g} at tick {k} > {bound:.3g}"


def _compare(settings, path, *, current_rtol=1e-3):
    """Both simulators on the same settings and path; every trace within 1e-3 of its peak (plus a small floor)."""
    t, x, v, a = path
    tool = _tool(settings, t, x, v, a)
    r = ref.simulate(t, x, v, a, **settings)
    np.testing.assert_array_equal(tool.time_s, t)
    _close("sensed force", tool.sensed_force_n, r.F_s, 1e-3, 1e-6)
    _close("velocity", tool.v_m_per_s, r.v, 1e-3, 1e-7)
    _close("position", tool.x_m, r.x, 1e-3, 1e-7)
    _close("body velocity", tool.body_v_m_per_s, r.v_b, 1e-3, 1e-7)
    _close("body position", tool.body_x_m, r.x_b, 1e-3, 1e-7)
    _close("leg force", tool.leg_force_n, r.F_leg, 1e-3, 1e-6)
    _close("velocity reference", tool.reference_m_per_s, r.v_ref, 1e-3, 1e-7)
    _close("current", tool.current_a, r.i, current_rtol, 1e-6)
    np.testing.assert_array_equal(tool.intended_x_m, x)
    np.testing.assert_array_equal(tool.intended_v_m_per_s, v)
    return tool, r


def _rebuild(settings, F_read, v, v_ref):
    """The sampled law and the PI as stated, rerun on a trace's own samples: the velocity reference at every tick
    and the current command in force over the interval ending at every tick (ideal current loop), with counts of
    the quantiser rounding, the deadband zeroing and the anti-windup holding the integrator."""
    s = settings
    n = len(v)
    n_a = int(round(s["drive_rate_hz"] / s["admittance_rate_hz"]))
    alpha, beta = ref.law_coefficients(s["m_v"], s["b_v"], s["admittance_rate_hz"], s["law"])
    res, bias, band = s["resolution_n"], s["bias_n"], s["deadband_n"]
    imax = s["motor_peak_force_n"] / s["force_constant_n_per_a"]
    T = 1.0 / s["drive_rate_hz"]
    hist = [0.0] * (s["computation_delay_samples"] + 1)
    v_a = vr = integ = e_prev = 0.0
    want_vref, cmd = np.zeros(n), np.zeros(n)
    counts = dict(rounded=0, deadband=0, held=0)
    for k in range(n):
        if k % n_a == 0:
            q = res * np.round((F_read[k] + bias) / res)
            counts["rounded"] += abs(q - F_read[k]) > 1e-3 * res
            if abs(q) <= band:
                counts["deadband"] += q != 0.0
                q = 0.0
            v_a = alpha * v_a + beta * q
            hist = hist[1:] + [v_a]
            vr = hist[0]
        want_vref[k] = vr
        e = vr - v[k]
        trial = integ + s["ki"] * T * (e + e_prev) / 2
        u = s["kp"] * e + trial
        if (u > imax and e > 0) or (u < -imax and e < 0):
            counts["held"] += 1
            trial = integ
            u = s["kp"] * e + integ
        integ, e_prev = trial, e
        cmd[k] = min(max(u, -imax), imax)
    lag = 1 + s["delay_ticks"]
    want_current = np.concatenate([np.zeros(lag), cmd[:-lag]])
    return want_vref, want_current, counts


# --- the reference on its own ----------------------------------------------------------------------------------
def test_reference_reading_rounds_as_numpy_and_deadband_is_inclusive():
    # half to even: 0.5 -> 0, 1.5 -> 2, 2.5 -> 2; the deadband zeroes |r| <= d, keeps |r| > d
    np.testing.assert_array_equal(ref.reading([0.5, 1.5, 2.5, -1.5], 1.0, 0.0, 0.0), [0.0, 2.0, 2.0, -2.0])
    # offset 6.25e-3 on a 6.25e-3 step, deadband two steps: 1 and 2 steps zeroed (inclusive), 3 and 4 kept
    np.testing.assert_allclose(ref.reading([0.0, 0.004, 0.01, 0.02], 6.25e-3, 6.25e-3, 0.0125),
                               [0.0, 0.0, 0.01875, 0.025], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(ref.reading([0.0], 1.0, 0.0, 0.0), [0.0])


def test_reference_law_coefficients():
    a, b = ref.law_coefficients(0.0057, 9.07, 100.0)
    assert a == pytest.approx(0.0057 / (0.0057 + 0.0907)) and b == pytest.approx(0.01 / (0.0057 + 0.0907))
    a, b = ref.law_coefficients(0.05, 8.0, 100.0, "forward_euler")
    assert a == pytest.approx(1 - 8.0 * 0.01 / 0.05) and b == pytest.approx(0.01 / 0.05)


def _steady_push(force_n, **changes):
    """A mouse pushing a constant force F (legs slack, the feed-forward m_v a_d with a constant a_d, body mass
    included) from rest, with a stiff integrator so the steady state arrives within the run."""
    s = dict(BASE, ki=1500.0, leg_stiffness_n_per_m=0.0, leg_damping_n_s_per_m=0.0)
    s.update(changes)
    n = int(round(3.0 * s["drive_rate_hz"]))
    t = np.arange(n) / s["drive_rate_hz"]
    a = np.full(n, force_n / (s["body_mass_kg"] + s["m_v"]))
    return s, t, np.zeros(n), np.zeros(n), a


PUSHES = [
    # force, changes, expected reading (what the law integrates; v -> r / b_v)
    (0.1, dict(), 0.1),
    (0.1, dict(friction_n=3.0, resolution_n=6.25e-3, bias_n=0.0), 0.1),                    # 16 steps
    (0.1, dict(friction_n=3.0, resolution_n=6.25e-3, bias_n=0.004), 0.10625),               # 16.64 -> 17
    (0.02, dict(resolution_n=6.25e-3, bias_n=0.0, deadband_n=0.025), 0.0),                  # inside the deadband
    (0.03, dict(resolution_n=6.25e-3, bias_n=0.0, deadband_n=0.025, force_filter_hz=30.0), 0.03125),
    (0.1, dict(force_filter_hz=20.0, force_filter_order=1, law="forward_euler", admittance_rate_hz=1000.0,
               computation_delay_samples=2, delay_ticks=3, current_loop_hz=1000.0), 0.1),
    (0.1, dict(law="tustin"), 0.1),                                                          # Tustin's rule
    (0.1, dict(law="zoh"), 0.1),                                                             # the exact ZOH rule
]


@pytest.mark.parametrize("force, changes, reading", PUSHES)
def test_reference_steady_push_reaches_reading_over_b_v(force, changes, reading):
    """At rest in the end every acceleration is zero: the neck carries the whole push (F_s = F), the law settles
    at v_a = beta r / (1 - alpha) = r / b_v, and the integrator takes the velocity error to zero; the motor
    carries the rail's damping and friction."""
    s, t, x, v, a = _steady_push(force, **changes)
    r = ref.simulate(t, x, v, a, **s)
    v_end = reading / s["b_v"]
    assert r.F_leg[-1] == pytest.approx(force, rel=1e-12)
    assert r.F_s[-1] == pytest.approx(force, rel=1e-6)
    assert r.v_ref[-1] == pytest.approx(v_end, rel=1e-9, abs=1e-15)
    assert r.v[-1] == pytest.approx(v_end, rel=1e-6, abs=1e-10)
    i_end = (s["damping_n_s_per_m"] * v_end + s["friction_n"] * math.tanh(v_end / s["friction_velocity_m_per_s"])
             - force) / s["force_constant_n_per_a"]
    assert r.i[-1] == pytest.approx(i_end, rel=1e-5, abs=1e-7)


def test_reference_at_rest_stays_exactly_at_rest():
    n = 500
    t = np.arange(n) / 1000.0
    z = np.zeros(n)
    for changes in (dict(), dict(RIG, drive_rate_hz=1000.0, bias_n=0.0, deadband_n=0.0), FLOATING):
        r = ref.simulate(t, z, z, z, **dict(BASE, **changes))
        for name in ("x", "v", "x_b", "v_b", "F_s", "F_leg", "i", "v_ref"):
            assert np.all(getattr(r, name) == 0.0), name


def test_reference_sampled_law_and_pi_as_stated():
    """The law's input quantised, deadbanded and delayed, and the PI's command delayed and clipped, exactly as the
    reference's docstring states (rebuilt from the trace's own samples)."""
    s = dict(CONSISTENCY)
    r = ref.simulate(*_path(s["drive_rate_hz"], t_max_s=1.2), **s)
    want_vref, want_current, counts = _rebuild(s, r.F_s, r.v, r.v_ref)
    np.testing.assert_allclose(r.v_ref, want_vref, rtol=0, atol=1e-14)
    np.testing.assert_allclose(r.i, want_current, rtol=0, atol=1e-12)
    assert counts["rounded"] > 10 and counts["deadband"] > 0 and counts["held"] > 10, counts


def test_reference_integrator_agrees_with_another():
    """DOP853 against LSODA (Adams / BDF) on the rig case's start: the reference's integration error is far below
    the tolerances the tool is held to."""
    path = _path(RIG["drive_rate_hz"], rest_s=0.05, t_max_s=0.3)
    a = ref.simulate(*path, **RIG)
    b = ref.simulate(*path, **RIG, method="LSODA")
    for name, scale in (("F_s", 1e-7), ("v", 1e-9), ("x", 1e-10), ("i", 1e-7)):
        assert np.max(np.abs(getattr(a, name) - getattr(b, name))) < scale, name


# --- the tool against the reference ----------------------------------------------------------------------------
@pytest.mark.parametrize("changes", [dict(), dict(gantry_mass_kg=5.0, m_v=0.05, b_v=8.0, law="forward_euler"),
                                     dict(gantry_mass_kg=5.0, m_v=0.05, b_v=8.0, law="tustin"),
                                     dict(gantry_mass_kg=5.0, m_v=0.05, b_v=8.0, law="zoh")],
                         ids=["backward-40kg", "forward-5kg", "tustin-5kg", "zoh-5kg"])
def test_continuous_like_run_matches_reference(changes):
    """(a) No friction, ideal current loop, no filter, a fine quantiser without offset or deadband; 1 kHz drive,
    100 Hz law."""
    s = dict(BASE, **changes)
    tool, r = _compare(s, _path(s["drive_rate_hz"]))
    assert np.max(np.abs(r.F_leg)) == pytest.approx(s["mouse_peak_force_n"])     # the mouse runs at its limit


@pytest.fixture(scope="module")
def rig_run():
    path = _path(RIG["drive_rate_hz"], rest_after_s=2.0)
    return path, _compare(RIG, path)


def test_rig_run_matches_reference(rig_run):
    """(b) Current loop 1 kHz, command delay 0.5 ms, law at 100 Hz one sample late, 30 Hz Butterworth filter, the
    real sensor's step, offset and deadband, 3 N friction, the motor's 50 N limit. At 2 kHz the drive's period is
    pi / w_c, and the current loop's response to the command's steps is exact in the tool's step (the linear part
    discretised exactly), so the current is held to 1e-3 of its peak as every other trace."""
    (t, _, _, _), (tool, r) = rig_run
    imax = RIG["motor_peak_force_n"] / RIG["force_constant_n_per_a"]
    saturated = np.abs(r.i) >= imax * (1 - 1e-9)
    assert 0.3 < np.mean(saturated) < 0.95                                     # the limit acts, and lets go
    # cruising with both the motor and the mouse at their limits: b v + F_c tanh(v / v_s) = F_mot + F_max
    v = 0.11
    for _ in range(50):
        v = (RIG["motor_peak_force_n"] + RIG["mouse_peak_force_n"]
             - RIG["friction_n"] * math.tanh(v / RIG["friction_velocity_m_per_s"])) / RIG["damping_n_s_per_m"]
    cruise = (t > 2.0) & (t < 2.5)                                            # the body's neck mode has died out
    np.testing.assert_allclose(r.v[cruise], v, rtol=1e-6)
    np.testing.assert_allclose(r.F_s[cruise], RIG["mouse_peak_force_n"], rtol=1e-5)
    assert abs(r.v[-1]) < 2e-3 and abs(r.x[-1] - 0.4) < 1e-3 and abs(r.i[-1]) < 0.1 * imax   # stopping at the end


def test_rig_run_leg_force_never_exceeds_mouse_limit(rig_run):
    """(d) The tool's leg force stays within the mouse's peak force, and reaches it."""
    _, (tool, _) = rig_run
    f_max = RIG["mouse_peak_force_n"]
    assert np.max(np.abs(tool.leg_force_n)) <= f_max
    assert np.max(np.abs(tool.leg_force_n)) == pytest.approx(f_max)
    tool_a = _tool(BASE, *_path(BASE["drive_rate_hz"]))
    assert np.max(np.abs(tool_a.leg_force_n)) <= BASE["mouse_peak_force_n"]


def test_rig_run_at_10khz_matches_reference():
    """(b) at the drive's real 10 kHz with the 0.5 ms delay as 5 ticks, over the start and the run into the limit."""
    s = dict(RIG, drive_rate_hz=10000.0, delay_ticks=5)
    _compare(s, _path(s["drive_rate_hz"], t_max_s=0.8))


@pytest.mark.slow
def test_rig_run_at_10khz_whole_path_matches_reference():
    s = dict(RIG, drive_rate_hz=10000.0, delay_ticks=5)
    _compare(s, _path(s["drive_rate_hz"], rest_after_s=2.0))


def test_fast_current_loop_at_a_slow_drive_rate():
    """A 1 kHz current loop under a 1 kHz drive (w_c T = 2 pi): the continuous part must stay accurate (and finite)
    however fast the current loop is against the drive's period. (Fixed-step RK4 with two steps per period
    diverges here: its stability ends at h w_c = 2.79.)"""
    s = dict(BASE, current_loop_hz=1000.0)
    _compare(s, _path(s["drive_rate_hz"], rest_after_s=0.5))


def test_at_rest_everything_stays_exactly_zero():
    """(c) No push, no offset: nothing moves, exactly, for a standing and for a floating mouse, with the rig's
    current loop, filter, delays and friction."""
    n = 2000
    t = np.arange(n) / 1000.0
    z = np.zeros(n)
    for changes in (dict(), dict(RIG, drive_rate_hz=1000.0, bias_n=0.0, deadband_n=0.0), FLOATING):
        tool = _tool(dict(BASE, **changes), t, z, z, z)
        for name in ("x_m", "v_m_per_s", "body_x_m", "body_v_m_per_s", "sensed_force_n", "leg_force_n",
                     "current_a", "reference_m_per_s"):
            assert np.all(getattr(tool, name) == 0.0), name


@pytest.mark.parametrize("changes", [dict(), dict(friction_n=3.0, force_filter_hz=30.0, force_filter_order=1,
                                                  law="forward_euler", m_v=0.05, b_v=8.0, current_loop_hz=400.0)],
                         ids=["plain", "friction-filter-forward"])
def test_floating_mouse_drifts_at_offset_over_b_v(changes):
    """(c) A floating mouse (nothing on the ground) under the sensor's offset: the free gantry drifts at exactly
    bias / b_v with no force sensed, the motor carrying the rail's damping and friction; the tool and the
    reference both reach it (a stiff integrator so it arrives within the run)."""
    s = dict(BASE, ki=1500.0, bias_n=0.025, **FLOATING)
    s.update(changes)
    n = 3000
    t = np.arange(n) / s["drive_rate_hz"]
    z = np.zeros(n)
    tool = _tool(s, t, z, z, z)
    r = ref.simulate(t, z, z, z, **s)
    v_end = 0.025 / s["b_v"]
    i_end = (s["damping_n_s_per_m"] * v_end + s["friction_n"] * math.tanh(v_end / s["friction_velocity_m_per_s"])
             ) / s["force_constant_n_per_a"]
    for v, i, f in ((tool.v_m_per_s, tool.current_a, tool.sensed_force_n), (r.v, r.i, r.F_s)):
        assert v[-1] == pytest.approx(v_end, rel=1e-9)
        assert i[-1] == pytest.approx(i_end, rel=1e-9)
        assert abs(f[-1]) < 1e-9
    _close("velocity", tool.v_m_per_s, r.v, 1e-3, 1e-9)


def test_tool_sampled_law_and_pi_as_stated():
    """The tool's own trace obeys the stated law and PI: the reference it records at each tick is the law run on
    the sensed forces it records (quantised with numpy's rounding, deadband, computation delay), and the current
    (ideal loop) is the PI's clipped command with the conditional-integration anti-windup, ``delay_ticks`` late;
    and the trace matches the reference's."""
    s = dict(CONSISTENCY)
    path = _path(s["drive_rate_hz"], t_max_s=1.2)
    tool, _ = _compare(s, path)
    want_vref, want_current, counts = _rebuild(s, tool.sensed_force_n, tool.v_m_per_s, tool.reference_m_per_s)
    np.testing.assert_allclose(tool.reference_m_per_s, want_vref, rtol=0, atol=1e-14)
    np.testing.assert_allclose(tool.current_a, want_current, rtol=0, atol=1e-12)
    assert counts["rounded"] > 10 and counts["deadband"] > 0 and counts["held"] > 10, counts


def test_settings_are_the_reference_keywords():
    """The reference takes exactly the tool's settings, the plant as its parameters (so every test runs both on the
    same numbers)."""
    tool = tool_settings(BASE)
    assert set(asdict(tool)) - {"plant"} == set(BASE) - set(PLANT_KEYS)
    assert tool.gantry_mass_kg == BASE["gantry_mass_kg"]
    assert tool.force_constant_n_per_a == BASE["force_constant_n_per_a"]


def test_stage_y_runs_with_both_rails_damping():
    # thesis Eq. 3.16: Stage Y's rigid body is m_e = 2 m l / L with the damping of both rails, 2 b
    from design.admittance.mouse_run import gantry_model, run_settings
    from design.spec.schema import load_spec

    spec = load_spec(Path(__file__).resolve().parents[3] / "specs" / "stage_y_admittance.toml").problem()
    plant = spec.plant.plant(spec.plant.payload_kg.max)
    s = run_settings(spec, controller=PI(200.0, 20.0), m_v=0.05, b_v=5.0)
    m_e = 2 * float(plant.mass_kg) * float(plant.load_position_m) / float(plant.motor_length_m)
    assert s.gantry_mass_kg == pytest.approx(m_e, rel=1e-12)
    # the gantry alone (no head, no neck) coasts down at the rate of both rails' damping over that mass
    alone = replace(s, head_mass_kg=0.0, neck_stiffness_n_per_m=0.0, neck_damping_n_s_per_m=0.0)
    poles = np.linalg.eigvals(gantry_model(alone).A)
    assert np.min(np.abs(poles + 2 * float(plant.damping_n_s_per_m) / m_e)) < 1e-9 * abs(poles).max()


@pytest.mark.parametrize("rule", ["forward_euler", pytest.param("backward_euler", marks=pytest.mark.slow)])
def test_force_felt_and_motor_force_on_the_profile_match_a_time_simulation_of_the_sampled_law(rule):
    # the synthesis scores a design by the neck and motor forces on the trapezoid computed in the frequency domain
    # with the sampled law's fundamental only (design.admittance.profile): against the independent reference, which
    # runs the 100 Hz law, the 2 kHz PI and the drive in time, with legs stiff enough (1e5 N/m) that the body
    # follows the profile to 0.05 mm: the neck force's peak agrees to 0.2 % (what the law's aliases add to it is
    # that small); the motor's is the fundamental's peak plus the staircase estimate, 0-4 % above the true peak
    # (the fundamental alone is 16 % below it: the held reference steps 0.01 m/s every 10 ms, and Kp answers at once)
    from design.admittance.model import PiLoops
    from design.admittance.mouse import MouseModel
    from design.admittance.profile import FeltForce
    from design.admittance.rig import RigTiming
    from design.spec.schema import parse_spec
    from design.synth.scenarios import Scenarios

    data = admittance_data()
    data["plant"]["effects"] = {"delay": {"seconds": 0.0005}, "current_loop": {"bandwidth_hz": 1000.0}}
    data["plant"].pop("uncertainty")
    spec = parse_spec(data).problem()
    kp, ki, m_v, b_v = 199.9, 18.54, 0.0414, 4.957
    mouse = MouseModel(0.005, 0.03, 100.0, 0.5, 1e5, 100.0)
    felt = FeltForce(spec, Scenarios(np.array([40.0])), [mouse], loops=PiLoops.of(spec, PI(kp, ki)),
                     timing=RigTiming(0.01, rule=rule))
    t, x, v, a = ref.trapezoid_path(0.4, 0.2, 1.0, 2000.0, 0.3, 1.0)
    r = ref.simulate(t, x, v, a, **dict(BASE, gantry_mass_kg=40.0, current_loop_hz=1000.0, delay_ticks=1,
                                        drive_rate_hz=2000.0, kp=kp, ki=ki, m_v=m_v, b_v=b_v,
                                        leg_stiffness_n_per_m=1e5, leg_damping_n_s_per_m=100.0,
                                        mouse_peak_force_n=1e3, motor_peak_force_n=1e5, law=rule))
    assert np.max(np.abs(r.x_b - x)) < 1e-4
    neck = 100.0 * (r.x_b - r.x) + 0.5 * (r.v_b - r.v)
    moving = v > 0
    assert felt(m_v, b_v) == pytest.approx(np.max(np.abs(neck[moving])), rel=2e-3)
    true_peak = 20.0 * np.max(np.abs(r.i))
    assert true_peak <= float(felt.motor_peak_n(m_v, b_v)[0]) <= 1.04 * true_peak
    assert float(np.max(np.abs(felt.motor_forces(m_v, b_v)))) < 0.9 * true_peak


#: effects a spec can only hold beside another
NEEDS = {"second_resonance": ("resonance",), "stribeck_friction": ("coulomb_friction",)}


@pytest.mark.parametrize("name", list(__import__("plant.physics.effects", fromlist=["EFFECTS"]).EFFECTS))
def test_the_mouse_run_simulates_an_effect_or_refuses_it_by_name(name):
    from design.admittance.mouse_run import SIMULATED_EFFECTS, run_settings
    from design.loop.controller import PI
    from design.spec.schema import parse_spec
    from plant.errors import EffectError, SpecError

    data = admittance_data()
    data["plant"]["effects"] = {n: {"force_n": 3.0} if n == "offset" else {} for n in (*NEEDS.get(name, ()), name)}
    data["plant"].pop("uncertainty")
    try:
        problem = parse_spec(data).problem()
        problem.plant.plant()
    except (SpecError, EffectError):
        pytest.skip(f"{name}: not an effect a Stage X spec designs with")
    if name in SIMULATED_EFFECTS:
        run_settings(problem, controller=PI(200.0, 20.0), m_v=0.05, b_v=5.0)
        return
    with pytest.raises(SpecError, match=name):
        run_settings(problem, controller=PI(200.0, 20.0), m_v=0.05, b_v=5.0)


def test_a_payload_mode_and_a_sensor_filter_are_simulated_as_the_plant_has_them():
    # the run's continuous part is the plant's own linear model: a two-body chain (the resonance's masses, spring
    # and damper as the plant splits them) and the sensor filter the drive reads through, against the reference
    # with those bodies and that filter written out from the forces
    plant = build_plant("x", mass_kg=40.0, damping_n_s_per_m=440.0, force_constant_n_per_a=20.0,
                        effects={"current_loop": {"bandwidth_hz": 1000.0},
                                 "resonance": {"frequency_hz": 80.0, "antiresonance_hz": 60.0, "damping_ratio": 0.05},
                                 "sensor_filter": {"frequency_hz": 300.0, "damping_ratio": 0.6}})
    chain = plant.mechanics()
    (m0, m1), (k,), (c,) = chain.masses_kg, chain.stiffness_n_per_m, chain.damping_n_s_per_m
    settings = dict(RIG, gantry_mass_kg=float(m0), damping_n_s_per_m=float(chain.rail_damping_n_s_per_m),
                    current_loop_hz=1000.0, motor_peak_force_n=1e4)
    t, x, v, a = _path(settings["drive_rate_hz"], t_max_s=1.5)
    rest = {key: val for key, val in settings.items() if key not in PLANT_KEYS}
    tool = simulate_mouse_run(RunSettings(plant=plant, **rest), t, x, v, a)
    r = ref.simulate(t, x, v, a, **settings, payload_mass_kg=float(m1), payload_stiffness_n_per_m=float(k),
                     payload_damping_n_s_per_m=float(c), sensor_filter_hz=300.0, sensor_damping_ratio=0.6)
    _close("sensed force", tool.sensed_force_n, r.F_s, 1e-3, 1e-6)
    _close("velocity", tool.v_m_per_s, r.v, 1e-3, 1e-7)
    _close("current", tool.current_a, r.i, 1e-3, 1e-6)
    # and the mode matters: without it the run differs by far more than that tolerance
    rigid = ref.simulate(t, x, v, a, **dict(settings, gantry_mass_kg=float(m0 + m1)), sensor_filter_hz=300.0,
                         sensor_damping_ratio=0.6)
    assert np.max(np.abs(rigid.i - r.i)) > 10 * (1e-3 * np.max(np.abs(r.i)) + 1e-6)


def test_forces_along_the_travel_are_simulated_as_the_plant_has_them():
    # an offset, a force ripple and a force constant that varies along the travel, each from the plant's effect
    # (its rail_force_n), against the reference with those forces written out
    ripple = {"sin1_n": 1.5, "cos1_n": -0.8, "sin2_n": 0.4, "cos2_n": 0.2, "pitch_m": 0.032}
    profile = {"centre_m": 0.1, "half_span_m": 0.3, "slope": 0.05, "curvature": -0.03}
    plant = build_plant("x", mass_kg=40.0, damping_n_s_per_m=440.0, force_constant_n_per_a=20.0,
                        effects={"current_loop": {"bandwidth_hz": 1000.0}, "offset": {"force_n": 2.0},
                                 "force_ripple": ripple, "force_constant_profile": profile})
    settings = dict(RIG, current_loop_hz=1000.0, motor_peak_force_n=1e4)
    t, x, v, a = _path(settings["drive_rate_hz"], t_max_s=2.0)
    rest = {key: val for key, val in settings.items() if key not in PLANT_KEYS}
    tool = simulate_mouse_run(RunSettings(plant=plant, **rest), t, x, v, a)
    r = ref.simulate(t, x, v, a, **settings, offset_n=2.0,
                     ripple=tuple(ripple[k] for k in ("sin1_n", "cos1_n", "sin2_n", "cos2_n", "pitch_m")),
                     profile=tuple(profile[k] for k in ("centre_m", "half_span_m", "slope", "curvature")))
    _close("sensed force", tool.sensed_force_n, r.F_s, 1e-3, 1e-6)
    _close("velocity", tool.v_m_per_s, r.v, 1e-3, 1e-7)
    _close("current", tool.current_a, r.i, 1e-3, 1e-6)
    plain = ref.simulate(t, x, v, a, **settings)
    assert np.max(np.abs(plain.i - r.i)) > 10 * (1e-3 * np.max(np.abs(r.i)) + 1e-6)


def test_a_cable_carriers_spring_is_simulated_from_where_the_run_starts():
    # a cable chain of 60 N/m relaxed at 0.1 m, the run starting at 0.15 m (the realisation's ground spring is
    # relaxed at 0: the run sets it to its start), against the reference with the cable's force written out
    k, rest_m, centre_m = 60.0, 0.1, 0.3
    plant = build_plant("x", mass_kg=40.0, damping_n_s_per_m=440.0, force_constant_n_per_a=20.0,
                        effects={"current_loop": {"bandwidth_hz": 1000.0},
                                 "cable_force": {"stiffness_n_per_m": k, "centre_m": centre_m,
                                                 "pull_n": k * (centre_m - rest_m)}})
    settings = dict(RIG, current_loop_hz=1000.0, motor_peak_force_n=1e4)
    t, x, v, a = _path(settings["drive_rate_hz"], t_max_s=2.0)
    x = x + 0.15
    rest = {key: val for key, val in settings.items() if key not in PLANT_KEYS}
    tool = simulate_mouse_run(RunSettings(plant=plant, **rest), t, x, v, a)
    r = ref.simulate(t, x, v, a, **settings, cable=(k, rest_m))
    _close("sensed force", tool.sensed_force_n, r.F_s, 1e-3, 1e-6)
    _close("velocity", tool.v_m_per_s, r.v, 1e-3, 1e-7)
    _close("current", tool.current_a, r.i, 1e-3, 1e-6)
    plain = ref.simulate(t, x, v, a, **settings)
    assert np.max(np.abs(plain.i - r.i)) > 10 * (1e-3 * np.max(np.abs(r.i)) + 1e-6)


@dataclass(frozen=True)
class _Drag(Offset):
    """A rail force of the velocity alone: a viscous drag -c v (N), the form of a cable carrier's drag."""

    drag_n_s_per_m: float = 0.0

    def rail_force_n(self, position_m, velocity_m_per_s, motor_force_n):
        return -self.drag_n_s_per_m * velocity_m_per_s


@pytest.mark.slow                 # two reference runs (~6 s)
def test_a_rail_force_sees_the_rails_velocity():
    # a drag of 200 N*s/m applied as a rail force against the reference with that much more rail damping
    settings = dict(RIG, current_loop_hz=1000.0, motor_peak_force_n=1e4)
    t, x, v, a = _path(settings["drive_rate_hz"], t_max_s=1.2)
    plain = tool_settings(settings)
    tool = simulate_mouse_run(replace(plain, plant=plain.plant * _Drag(0.0, drag_n_s_per_m=200.0)), t, x, v, a)
    r = ref.simulate(t, x, v, a, **dict(settings, damping_n_s_per_m=settings["damping_n_s_per_m"] + 200.0))
    _close("sensed force", tool.sensed_force_n, r.F_s, 1e-3, 1e-6)
    _close("velocity", tool.v_m_per_s, r.v, 1e-3, 1e-7)
    _close("current", tool.current_a, r.i, 1e-3, 1e-6)
    # and the drag matters by far more than that tolerance
    without = simulate_mouse_run(plain, t, x, v, a).current_a
    assert np.max(np.abs(without - r.i)) > 10 * (1e-3 * np.max(np.abs(r.i)) + 1e-6)
