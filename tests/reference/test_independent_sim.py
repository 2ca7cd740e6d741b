"""The independent simulator against closed forms that do not use the code under test."""

import ast
import csv
from pathlib import Path

import independent_sim as sim
import numpy as np
import pytest

KT = sim.KT_N_PER_A


def _sine_fit(t_s, y, f_hz, periods):
    """Complex amplitude (Re sin + j cos coefficients) over the last whole ``periods`` of a block."""
    n = int(round(periods / f_hz / (t_s[1] - t_s[0])))
    t, y = t_s[-n:], y[-n:]
    w = 2 * np.pi * f_hz
    coef, *_ = np.linalg.lstsq(np.column_stack([np.sin(w * t), np.cos(w * t)]), y, rcond=None)
    return coef[0] + 1j * coef[1]


def _block(net, drive, f_hz, seconds=3.0, fs=1000.0, amplitude_a=1.0):
    ss = sim.state_space(net, drive)
    t = np.arange(int(seconds * fs)) / fs
    v, q = sim.block_response(ss, f_hz, amplitude_a, drive.delay_s, t)
    return t, v, q


def test_module_imports_neither_plant_nor_design():
    tree = ast.parse(Path(sim.__file__).read_text())
    roots = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            roots |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            roots.add((node.module or "").split(".")[0])
    assert not roots & {"plant", "design"}
    assert roots <= {"__future__", "csv", "math", "dataclasses", "pathlib", "numpy", "scipy"}


@pytest.mark.parametrize("f_hz", [1.0, 7.3, 41.0])
def test_rigid_steady_state_is_kt_over_m_jw_plus_b(f_hz):
    mass_kg, b = 35.0, 440.0
    t, v, _ = _block(sim.rigid_stage(mass_kg, b), sim.Drive(), f_hz, seconds=3.0)
    expected = KT / (mass_kg * 2j * np.pi * f_hz + b)
    got = _sine_fit(t, v[:, 0], f_hz, periods=1 if f_hz < 2 else 10)
    assert abs(got - expected) / abs(expected) < 1e-6


def test_rigid_response_from_rest_matches_closed_form():
    """v = (Kt A / M) (a sin wt - w cos wt + w e^{-a t}) / (a^2 + w^2), a = b / M: transient included."""
    mass_kg, b, f_hz, amp = 30.0, 400.0, 3.0, 0.7
    t, v, q = _block(sim.rigid_stage(mass_kg, b), sim.Drive(), f_hz, seconds=1.0, amplitude_a=amp)
    a, w = b / mass_kg, 2 * np.pi * f_hz
    v_exact = KT * amp / mass_kg * (a * np.sin(w * t) - w * np.cos(w * t) + w * np.exp(-a * t)) / (a**2 + w**2)
    np.testing.assert_allclose(v[:, 0], v_exact, rtol=0, atol=1e-12 * np.max(np.abs(v_exact)))
    assert v[0, 0] == pytest.approx(0.0, abs=1e-15) and q[0, 0] == pytest.approx(0.0, abs=1e-15)


def test_delay_shifts_the_response_and_the_phase_by_minus_w_tau():
    net, f_hz, fs = sim.rigid_stage(35.0, 440.0), 12.5, 1000.0
    tau = 0.002                                      # exactly 2 samples
    t, v0, _ = _block(net, sim.Drive(), f_hz, fs=fs)
    _, v1, _ = _block(net, sim.Drive(delay_s=tau), f_hz, fs=fs)
    assert np.all(v1[:2] == 0.0)
    np.testing.assert_allclose(v1[2:, 0], v0[:-2, 0], rtol=0, atol=1e-13)
    tau = 1.37e-3                                    # not on the sample grid
    _, v1, _ = _block(net, sim.Drive(delay_s=tau), f_hz, fs=fs)
    ratio = _sine_fit(t, v1[:, 0], f_hz, 20) / _sine_fit(t, v0[:, 0], f_hz, 20)
    assert abs(ratio) == pytest.approx(1.0, abs=1e-9)
    assert np.angle(ratio) == pytest.approx(-2 * np.pi * f_hz * tau, abs=1e-9)


def test_current_loop_is_first_order_lag_and_sensor_filter_is_butterworth():
    net, f_hz = sim.rigid_stage(35.0, 440.0), np.array([5.0, 60.0, 150.0])
    base = sim.frequency_response(net, sim.Drive(), f_hz)[:, 0]
    lag = sim.frequency_response(net, sim.Drive(current_loop_hz=150.0), f_hz)[:, 0] / base
    np.testing.assert_allclose(lag, 1 / (1 + 1j * f_hz / 150.0), rtol=1e-12)
    filt = sim.frequency_response(net, sim.Drive(sensor_filter_hz=150.0), f_hz)[:, 0] / base
    s = 2j * np.pi * f_hz
    wf = 2 * np.pi * 150.0
    np.testing.assert_allclose(filt, wf**2 / (s**2 + np.sqrt(2) * wf * s + wf**2), rtol=1e-12)
    assert abs(filt[2]) == pytest.approx(1 / np.sqrt(2), rel=1e-12)
    t, v, _ = _block(net, sim.Drive(current_loop_hz=150.0, sensor_filter_hz=150.0), 60.0)
    got = _sine_fit(t, v[:, 0], 60.0, 30)
    assert abs(got / (base[1] * lag[1] * filt[1]) - 1) < 1e-6


def test_two_mass_antiresonance_and_resonance_without_damping():
    m1, m2, k = 20.0, 15.0, 1.2e6
    motor = sim.two_mass(m1, m2, k, 0.0, 0.0, sensed="motor")
    payload = sim.two_mass(m1, m2, k, 0.0, 0.0, sensed="payload")
    f_anti = np.sqrt(k / m2) / (2 * np.pi)
    f_res = np.sqrt(k * (m1 + m2) / (m1 * m2)) / (2 * np.pi)
    assert motor.mode_frequencies_hz() == pytest.approx((f_res,), rel=1e-12)
    f_hz = np.array([3.0, f_anti, 0.5 * (f_anti + f_res), 1.5 * f_res])
    s = 2j * np.pi * f_hz
    den = s * (m1 * m2 * s**2 + k * (m1 + m2))
    np.testing.assert_allclose(sim.frequency_response(motor, sim.Drive(), f_hz)[:, 0],
                               KT * (m2 * s**2 + k) / den, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(sim.frequency_response(payload, sim.Drive(), f_hz)[:, 0], KT * k / den, rtol=1e-9)
    assert abs(sim.frequency_response(motor, sim.Drive(), [f_anti])[0, 0]) < 1e-12
    near = sim.frequency_response(motor, sim.Drive(), [f_res * (1 - 1e-6)])[0, 0]
    assert abs(near) > 1e3 * abs(sim.frequency_response(motor, sim.Drive(), [3.0])[0, 0])
    above = sim.frequency_response(payload, sim.Drive(), [1.5 * f_res])[0, 0]
    assert np.angle(above, deg=True) == pytest.approx(90.0)        # -90 deg - 180 deg, wrapped


def test_tuned_chain_hits_its_modes():
    net = sim.tuned_chain([15.0, 10.0, 8.0, 6.0], [25.0, 45.0, 65.0], 0.03)
    assert net.mode_frequencies_hz() == pytest.approx((25.0, 45.0, 65.0), rel=1e-8)


def test_stage_y_tilt_mode_and_centred_symmetry():
    mass_kg, inertia, f_tilt = 35.0, 2.0, 32.0
    ka = inertia * (2 * np.pi * f_tilt) ** 2
    centred = sim.stage_y_beam(mass_kg, inertia, 0.4, ka)
    off = sim.stage_y_beam(mass_kg, inertia, 0.25, ka)
    assert off.mode_frequencies_hz() == pytest.approx((f_tilt,), rel=1e-12)
    f_hz = np.array([2.0, 30.0, 70.0])
    g = sim.frequency_response(centred, sim.Drive(), f_hz)
    np.testing.assert_allclose(g[:, 0], g[:, 1], rtol=1e-12)
    # centred: the beam translates as a rigid stage with damping 2 b
    np.testing.assert_allclose(g[:, 0], KT / (mass_kg * 2j * np.pi * f_hz + 2 * sim.RAIL_DAMPING_N_S_PER_M),
                               rtol=1e-12)
    g = sim.frequency_response(off, sim.Drive(), f_hz)
    assert np.max(np.abs(g[:, 0] / g[:, 1] - 1)) > 0.05


def test_encoder_velocities_lie_on_the_lattice(tmp_path):
    quantum, fs = 2e-7, 1000.0
    protocol = sim.Protocol(f_hz=(1.0, 20.0), block_s=1.0, sample_rate_hz=fs, first_block_periods=2.2)
    rec = sim.simulate(sim.rigid_stage(), sim.Drive(delay_s=1e-3, encoder_quantum_m=quantum), protocol,
                       noise=0.05, seed=3)
    assert len(rec.time_s[0]) == 2200 and len(rec.time_s[1]) == 1000
    for v in rec.velocity_m_per_s:
        counts = v / (quantum * fs)
        np.testing.assert_allclose(counts, np.round(counts), atol=1e-9)
        assert np.count_nonzero(v) > 0
    path = sim.write_csv(rec, tmp_path / "enc.csv")
    with path.open() as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["frequency_hz", "time_s", "current_a", "velocity_m_per_s"]
    data = np.array(rows[1:], float)
    assert len(data) == 3200
    counts = data[:, 3] / (quantum * fs)
    np.testing.assert_allclose(counts, np.round(counts), atol=1e-6)
    assert data[0, 1] == 0.0 and data[2200, 1] == 0.0 and data[2200, 0] == 20.0


def test_stage_y_csv_has_two_velocity_columns(tmp_path):
    net = sim.stage_y_beam(35.0, 2.0, 0.3, 2.0 * (2 * np.pi * 30) ** 2)
    rec = sim.simulate(net, protocol=sim.Protocol(f_hz=(5.0,), block_s=0.5), noise=0.02, seed=1)
    with sim.write_csv(rec, tmp_path / "y.csv").open() as fh:
        header = next(csv.reader(fh))
    assert header == ["frequency_hz", "time_s", "current_a", "velocity_y1_m_per_s", "velocity_y2_m_per_s"]


def test_noise_levels_are_relative():
    net, fs = sim.rigid_stage(), 2000.0
    protocol = sim.Protocol(f_hz=(10.0,), block_s=2.0, sample_rate_hz=fs, amplitude_a=0.8)
    clean = sim.simulate(net, protocol=protocol)
    noisy = sim.simulate(net, protocol=protocol, noise=0.1, seed=5)
    gain = abs(sim.frequency_response(net, sim.Drive(), [10.0])[0, 0])
    dv = noisy.velocity_m_per_s[0] - clean.velocity_m_per_s[0]
    di = noisy.current_a[0] - clean.current_a[0]
    assert np.std(dv) == pytest.approx(0.1 * 0.8 * gain, rel=0.05)
    assert np.std(di) == pytest.approx(0.1 * 0.8, rel=0.05)


def test_damped_two_mass_matches_its_transfer_function():
    """v1/F = (m2 s^2 + c s + k) / ((m1 s + b)(m2 s^2 + c s + k) + m2 s (c s + k)).

    The payload follows the motor by v2 / v1 = (c s + k) / (m2 s^2 + c s + k).
    """
    m1, m2, k, c, b = 18.0, 12.0, 9e5, 150.0, 440.0
    f_hz = np.geomspace(1, 75, 7)
    s = 2j * np.pi * f_hz
    couple = m2 * s**2 + c * s + k
    v1 = KT * couple / ((m1 * s + b) * couple + m2 * s * (c * s + k))
    np.testing.assert_allclose(
        sim.frequency_response(sim.two_mass(m1, m2, k, c, b, sensed="motor"), sim.Drive(), f_hz)[:, 0], v1, rtol=1e-10)
    np.testing.assert_allclose(
        sim.frequency_response(sim.two_mass(m1, m2, k, c, b, sensed="payload"), sim.Drive(), f_hz)[:, 0],
        v1 * (c * s + k) / couple, rtol=1e-10)
