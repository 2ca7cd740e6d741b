"""Stepped-sine simulator (plant/experiment/simulate.py) and ``gantry simulate``.

References are independent of the simulator: ``Plant.frd`` / ``frd_outputs`` (closed forms of thesis
Eq. 3.15/3.16, Xie-Wang Eq. 2.14-2.15 and the effects), a plain least-squares sine fit written here,
and an event-driven scipy ``solve_ivp`` integration of the Coulomb-friction mechanics.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from plant import (
    CoulombFriction,
    CurrentLoop,
    Delay,
    ParameterError,
    Resonance,
    Sampling,
    TiltCoupling,
    stage_x,
    stage_y,
)
from plant.experiment.simulate import simulate_stepped_sine

GANTRY = [sys.executable, "-c", "from design.cli import main; main()"]


def sine_phasor(y, t_s, f_hz, *, harmonic=1):
    """Least-squares phasor (relative to sin) of harmonic k of f over the whole periods of the block's second half."""
    w = 2 * np.pi * f_hz * harmonic
    period = 1 / f_hz
    n_periods = int(np.floor(t_s[-1] / 2 / period))
    sel = t_s >= t_s[-1] - n_periods * period - 1e-12
    basis = np.column_stack([np.sin(w * t_s[sel]), np.cos(w * t_s[sel])])
    coef, *_ = np.linalg.lstsq(basis, np.atleast_2d(y)[:, sel].T, rcond=None)
    return coef[0] + 1j * coef[1]


def measured_response(rec):
    """Velocity phasor / current phasor per block, shape (n_outputs, n_blocks)."""
    return np.stack([sine_phasor(b.velocity_m_per_s, b.time_s, b.f_hz) / sine_phasor(b.current_a, b.time_s, b.f_hz)
                     for b in rec.blocks], axis=-1)


F_HZ = np.array([1.0, 3.0, 7.5, 18.0, 38.0, 41.0, 75.0])


@pytest.mark.parametrize("plant", [
    # delay of 2.46 samples at 2 kHz: a non-integer shift must be exact
    stage_x(mass_kg=40.0) * Delay(0.00123) * CurrentLoop(200.0),
    stage_x() * Resonance(50.0, 35.0, 0.05) * Delay(0.0005),
    # controller at 10 kHz, recording at 2 kHz, delay not on either grid
    stage_x() * Sampling(10000.0) * Delay(0.00037) * CurrentLoop(300.0),
    stage_y(),
], ids=["x-delay-current_loop", "x-resonance", "x-sampling", "y-rigid"])
def test_linear_fundamental_matches_frd(plant):
    rec = simulate_stepped_sine(plant, f_hz=F_HZ, current_amplitude_a=0.5)
    G = measured_response(rec)
    ref = plant.frd_outputs(2 * np.pi * F_HZ)       # closed form: thesis Eq. 3.15/3.16 times the effects
    assert np.max(np.abs(G - ref) / np.abs(ref)) < 1e-3
    assert rec.f_hz.tolist() == F_HZ.tolist()
    assert rec.output_names == (("velocity_m_per_s",) if plant.stage == "x"
                                else ("velocity_y1_m_per_s", "velocity_y2_m_per_s"))


def test_tilt_coupling_off_centre_two_rails_match_xie_wang():
    plant = stage_y(load_position_m=0.25) * TiltCoupling(40.0, 2.0e5) * Delay(0.0007)
    rec = simulate_stepped_sine(plant, f_hz=F_HZ, current_amplitude_a=1.75)
    G = measured_response(rec)
    ref = plant.frd_outputs(2 * np.pi * F_HZ)       # closed form: Xie-Wang (thesis Eq. 2.14-2.15), f1 = f2 = K_t i/2
    assert np.max(np.abs(G - ref) / np.abs(ref)) < 1e-3
    # the test has teeth: near the 40 Hz tilt mode the rails disagree by far more than the tolerance
    k = int(np.argmin(np.abs(F_HZ - 41.0)))
    assert abs(G[0, k] - G[1, k]) / abs(G[0, k]) > 0.05


def test_blocks_start_from_rest_and_the_transient_is_real():
    plant = stage_x(mass_kg=40.0) * Delay(0.0021)
    rec = simulate_stepped_sine(plant, f_hz=[5.0], current_amplitude_a=0.5)
    b = rec.blocks[0]
    v = b.velocity_m_per_s[0]
    # nothing moves before the delayed input arrives (samples at 0, 0.5, 1.0, 1.5, 2.0 ms)
    assert np.all(v[b.time_s < 0.0021] == 0.0)
    ph = sine_phasor(v, b.time_s, 5.0)
    steady = ph.real * np.sin(2 * np.pi * 5.0 * b.time_s) + ph.imag * np.cos(2 * np.pi * 5.0 * b.time_s)
    amp = abs(ph)
    first = b.time_s < 0.2
    last = b.time_s >= b.time_s[-1] - 0.2
    # first-order plant from rest: v - v_ss decays as e^(-b t/m), tau = 40/440 s (closed form); at
    # 5 Hz the steady state starts at ~-0.94 of its amplitude, so the first period differs visibly
    assert np.max(np.abs(v[first] - steady[first])) > 0.5 * amp
    assert np.max(np.abs(v[last] - steady[last])) < 1e-9 * amp


def _event_driven_friction(*, m_kg, b_n_s_per_m, kt_n_per_a, fc_n, amp_a, f_hz, t_s):
    """Reference: m v' = K_t A sin(w t) - b v - F_c sign(v) with exact stick/slip events (scipy solve_ivp)."""
    w = 2 * np.pi * f_hz

    def force(t):
        return kt_n_per_a * amp_a * np.sin(w * t)

    out = np.zeros_like(t_s)
    t, v, end = 0.0, 0.0, t_s[-1]
    while t < end:
        if v == 0.0 and abs(force(t)) <= fc_n:            # stuck until the drive force exceeds F_c
            grid = np.linspace(t, min(end, t + 1 / f_hz), 4001)
            over = np.flatnonzero(np.abs(force(grid)) > fc_n)
            t_break = grid[-1] if len(over) == 0 else grid[over[0]]
            if len(over):
                from scipy.optimize import brentq
                t_break = brentq(lambda s: abs(force(s)) - fc_n, grid[over[0] - 1], grid[over[0]], xtol=1e-14)
            t = t_break + 1e-12 if len(over) else t_break
            continue
        s = np.sign(v) if v != 0 else np.sign(force(t))

        def rhs(tt, y, s=s):
            return [(force(tt) - b_n_s_per_m * y[0] - s * fc_n) / m_kg]

        def stop(tt, y, s=s):
            return y[0]
        stop.terminal, stop.direction = True, -s
        sel = (t_s > t) & (t_s <= end)
        sol = solve_ivp(rhs, (t, end), [v], events=stop, rtol=1e-11, atol=1e-14, dense_output=True, method="DOP853")
        t_next = sol.t_events[0][0] if len(sol.t_events[0]) else end
        within = sel & (t_s <= t_next)
        out[within] = sol.sol(t_s[within])[0]
        t, v = t_next, 0.0 if len(sol.t_events[0]) else sol.y[0, -1]
    return out


def test_coulomb_stick_slip_agrees_with_event_driven_reference():
    m, b, kt, fc, amp, f = 40.0, 440.0, 20.0, 6.0, 0.5, 3.0     # drive force 10 N against 6 N of friction
    plant = stage_x(mass_kg=m, damping_n_s_per_m=b, force_constant_n_per_a=kt, excitation_current_a=amp)
    rec = simulate_stepped_sine(plant.with_effects(CoulombFriction(fc)), f_hz=[f], current_amplitude_a=amp,
                                duration_s=1.5)
    blk = rec.blocks[0]
    v = blk.velocity_m_per_s[0]
    ref = _event_driven_friction(m_kg=m, b_n_s_per_m=b, kt_n_per_a=kt, fc_n=fc, amp_a=amp, f_hz=f, t_s=blk.time_s)
    stuck = ref == 0.0
    assert 0.1 < stuck.mean() < 0.8                      # the stage really sticks every half period
    assert np.max(np.abs(v - ref)) < 1e-4 * np.max(np.abs(ref))     # measured 2e-7 at the 20 kHz default
    # stuck means exactly at rest, not creeping (no chattering around v = 0)
    assert np.mean(v[stuck] == 0.0) > 0.95


def test_coulomb_friction_fundamental_follows_describing_function_with_odd_harmonics():
    f = np.array([2.0, 10.0, 40.0])
    base = stage_x(mass_kg=40.0, excitation_current_a=0.5)
    plant = base.with_effects(CoulombFriction(2.0))
    rec = simulate_stepped_sine(plant, f_hz=f, current_amplitude_a=0.5, duration_s=3.0)
    G = measured_response(rec)[0]
    df = plant.frd(2 * np.pi * f)                        # describing function 4 F_c/(pi V) (effects.CoulombFriction)
    assert np.max(np.abs(G - df) / np.abs(df)) < 0.05
    # friction matters: the plant without it is more than 20 % off (thesis Eq. 3.15 alone)
    assert np.min(np.abs(base.frd(2 * np.pi * f) - df) / np.abs(df)) > 0.2
    for blk in rec.blocks:
        v = blk.velocity_m_per_s[0]
        h1 = abs(sine_phasor(v, blk.time_s, blk.f_hz)[0])
        h2 = abs(sine_phasor(v, blk.time_s, blk.f_hz, harmonic=2)[0])
        h3 = abs(sine_phasor(v, blk.time_s, blk.f_hz, harmonic=3)[0])
        # sign(v) is odd-symmetric: odd harmonics only (Fourier series of a square wave)
        assert h3 / h1 > 0.01
        assert h2 / h1 < 0.1 * h3 / h1


def test_friction_result_converges_with_the_internal_step():
    plant = stage_x(mass_kg=40.0, excitation_current_a=0.5) * CoulombFriction(2.0)
    kw = dict(f_hz=[2.0, 20.0], current_amplitude_a=0.5, duration_s=2.0)
    coarse = measured_response(simulate_stepped_sine(plant, **kw))
    fine = measured_response(simulate_stepped_sine(plant, friction_rate_hz=80000.0, **kw))
    assert np.max(np.abs(coarse - fine) / np.abs(fine)) < 5e-3   # O(h) Moreau scheme, h = 50 us vs 12.5 us


def test_two_rail_friction_equals_single_contact_for_a_centred_load():
    # load centred: no tilt is excited, rails move together, F_c/2 per rail acts like F_c on the stage
    kw = dict(f_hz=[2.0, 15.0], current_amplitude_a=1.75, duration_s=1.0)
    y = stage_y(excitation_current_a=1.75)
    rigid = simulate_stepped_sine(y * CoulombFriction(20.0), **kw)
    tilt = simulate_stepped_sine(y.with_effects(CoulombFriction(20.0), TiltCoupling()), **kw)
    v_rigid = rigid.blocks[0].velocity_m_per_s
    assert np.mean(v_rigid == 0.0) > 0.1                 # stick phases present
    for a, b in zip(rigid.blocks, tilt.blocks):
        np.testing.assert_allclose(b.velocity_m_per_s, a.velocity_m_per_s, rtol=0,
                                   atol=1e-9 * np.abs(a.velocity_m_per_s).max())


def test_noise_fraction_sets_the_noise_level():
    plant = stage_x() * Delay(0.001)
    kw = dict(f_hz=[2.0, 30.0], current_amplitude_a=0.5, seed=7)
    clean = simulate_stepped_sine(plant, noise_fraction=0.0, **kw)
    noisy = simulate_stepped_sine(plant, noise_fraction=0.03, **kw)
    for c, n in zip(clean.blocks, noisy.blocks):
        amp_v = abs(sine_phasor(c.velocity_m_per_s, c.time_s, c.f_hz)[0])
        # 10000 samples: the std estimate is within ~1.5 % (2 sigma) of the truth
        assert np.std(n.velocity_m_per_s - c.velocity_m_per_s) / (0.03 * amp_v) == pytest.approx(1.0, abs=0.04)
        assert np.std(n.current_a - c.current_a) / (0.03 * 0.5) == pytest.approx(1.0, abs=0.04)
    assert noisy.metadata["seed"] == 7 and noisy.metadata["noise_fraction"] == 0.03


def test_absolute_noise_quantisation_and_seed():
    plant = stage_x()
    kw = dict(f_hz=[5.0], current_amplitude_a=0.5, current_noise_a=0.002, velocity_noise_m_per_s=1e-4,
              current_quantum_a=1e-3, velocity_quantum_m_per_s=5e-5)
    a = simulate_stepped_sine(plant, seed=3, **kw).blocks[0]
    b = simulate_stepped_sine(plant, seed=3, **kw).blocks[0]
    c = simulate_stepped_sine(plant, seed=4, **kw).blocks[0]
    np.testing.assert_array_equal(a.velocity_m_per_s, b.velocity_m_per_s)
    np.testing.assert_array_equal(a.current_a, b.current_a)
    assert not np.array_equal(a.velocity_m_per_s, c.velocity_m_per_s)
    for x, q in [(a.current_a, 1e-3), (a.velocity_m_per_s, 5e-5)]:
        np.testing.assert_allclose(x / q, np.round(x / q), atol=1e-6)
    clean = simulate_stepped_sine(plant, f_hz=[5.0], current_amplitude_a=0.5).blocks[0]
    # std of noise + uniform rounding error q^2/12 (closed form)
    expected = np.hypot(1e-4, 5e-5 / np.sqrt(12))
    assert np.std(a.velocity_m_per_s - clean.velocity_m_per_s) / expected == pytest.approx(1.0, abs=0.05)


@pytest.mark.parametrize("kwargs, message", [
    (dict(f_hz=[5.0, 5.0]), "5 Hz twice"),
    (dict(f_hz=[600.0]), "fewer than 4 samples per period"),
    (dict(f_hz=[5.0], current_amplitude_a=-1.0), "current_amplitude_a must be positive"),
    (dict(f_hz=[5.0], noise_fraction=0.01, current_noise_a=0.1), "either noise_fraction"),
    (dict(f_hz=[5.0], seed=-1), "seed must be a non-negative integer"),
    (dict(f_hz=[5.0], duration_s=0.0), "duration_s must be positive"),
    (dict(f_hz=[5.0], velocity_quantum_m_per_s=0.0), "velocity_quantum_m_per_s must be positive"),
])
def test_bad_arguments_raise_named_errors(kwargs, message):
    kwargs.setdefault("current_amplitude_a", 0.5)
    with pytest.raises(ParameterError, match=message):
        simulate_stepped_sine(stage_x(), **kwargs)


def test_batch_plant_and_incommensurate_rates_are_refused():
    with pytest.raises(ParameterError, match="mass_kg is a batch"):
        simulate_stepped_sine(stage_x().with_payload([5.0, 40.0]), f_hz=[5.0], current_amplitude_a=0.5)
    with pytest.raises(ParameterError, match="sampling.rate_hz"):
        simulate_stepped_sine(stage_x() * Sampling(2000.0 * np.sqrt(2.0)), f_hz=[5.0], current_amplitude_a=0.5)


def _run(args, cwd):
    return subprocess.run([*GANTRY, "simulate", *args], cwd=cwd, capture_output=True, text=True, timeout=120)


def test_cli_writes_csv_and_sidecar(tmp_path):
    # the command a fit round trip relies on (shorter grid to keep the test fast)
    r = _run(["--stage", "x", "--set", "mass_kg=40", "--effects", "delay.seconds=0.001", "--f-hz", "2,20,60",
              "--duration-s", "1", "--seed", "11", "--out", "rec.csv"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout.count("\n") == 1 and "rec.csv" in r.stdout
    header = (tmp_path / "rec.csv").read_text().splitlines()[0]
    assert header == "frequency_hz,time_s,current_a,velocity_m_per_s"
    data = np.loadtxt(tmp_path / "rec.csv", delimiter=",", skiprows=1)
    assert data.shape == (3 * 2000, 4)
    assert sorted(set(data[:, 0])) == [2.0, 20.0, 60.0]
    side = json.loads((tmp_path / "rec.json").read_text())
    s = side["settings"]
    assert s["seed"] == 11 and s["parameters"]["mass_kg"] == 40.0 and s["parameters"]["delay.seconds"] == 0.001
    assert s["noise_fraction"] == 0.01 and s["current_amplitude_a"] == [0.5, 0.5, 0.5]   # thesis 0.5 A for Stage X
    # the recorded data carry the model: 20 Hz block, |G| within 5 % (1 % noise) of thesis Eq. 3.15 x delay
    blk = data[data[:, 0] == 20.0]
    G = sine_phasor(blk[:, 3], blk[:, 1], 20.0) / sine_phasor(blk[:, 2], blk[:, 1], 20.0)
    ref = (stage_x(mass_kg=40.0) * Delay(0.001)).frd([2 * np.pi * 20.0])
    assert abs(G[0] - ref[0]) / abs(ref[0]) < 0.05


def test_cli_spec_stage_y_json(tmp_path):
    r = _run(["--spec", "specs/thesis_stage_y.toml", "--set", "load_position_m=0.25", "--effects", "tilt_coupling",
              "--f-hz", "5:40:3", "--f-spacing", "linear", "--duration-s", "0.5", "--noise-fraction", "0",
              "--json", "--out", str(tmp_path / "y.csv")], cwd=_repo_root())
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["f_hz"] == [5.0, 22.5, 40.0] and out["stage"] == "y" and out["effects"] == ["tilt_coupling"]
    assert out["current_amplitude_a"] == 1.75                  # thesis section 4.1, Stage Y
    header = (tmp_path / "y.csv").read_text().splitlines()[0]
    assert header == "frequency_hz,time_s,current_a,velocity_y1_m_per_s,velocity_y2_m_per_s"


def _repo_root():
    from pathlib import Path

    return Path(__file__).resolve().parents[3]


@pytest.mark.parametrize("args, message", [
    (["--stage", "x", "--effects", "delay.sec=1"], "--effects 'delay.sec=1': effect delay has no parameter 'sec'"),
    (["--stage", "x", "--effects", "warp"], "--effects 'warp': unknown effect 'warp'"),
    (["--stage", "x", "--set", "mass_kg=heavy"], "--set 'mass_kg=heavy': 'heavy' is not a number"),
    (["--stage", "x", "--set", "mass_kg=-3"], "mass_kg must be positive"),
    (["--stage", "x", "--set", "delay.seconds=0.1"], "--set delay.seconds: the plant has no effect delay"),
    (["--stage", "x", "--effects", "tilt_coupling"], "tilt_coupling applies to Stage Y only"),
    (["--stage", "q"], "--stage must be x or y"),
    ([], "give exactly one of --spec FILE or --stage"),
    (["--stage", "x", "--f-hz", "1:75"], "--f-hz '1:75': write START:STOP:COUNT"),
    (["--stage", "x", "--f-hz", "5,5"], "--f-hz '5,5': a frequency is listed twice"),
    (["--stage", "x", "--f-hz", "1:900:5"],
     "--f-hz 900 Hz has fewer than 4 samples per period at --sample-rate-hz 2000"),
    (["--stage", "x", "--amplitude-a", "0"], "--amplitude-a must be finite and > 0"),
    (["--stage", "x", "--noise-fraction", "0.1", "--current-noise-a", "0.01"], "either --noise-fraction"),
    (["--stage", "x", "--duration-s", "-1"], "--duration-s must be finite and > 0"),
])
def test_cli_bad_input_exits_2_with_one_line(tmp_path, monkeypatch, capsys, args, message):
    # design.cli.common.main in-process (what the gantry entry point runs), to keep the test fast
    from design.cli import main

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", ["gantry", "simulate", *args, "--out", "rec.csv"])
    with pytest.raises(SystemExit) as exc:
        main()
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "rec.csv").exists() and not (tmp_path / "rec.json").exists()


def test_cli_out_must_be_csv(tmp_path):
    r = _run(["--stage", "x", "--out", "rec.txt"], tmp_path)
    assert r.returncode == 2 and "--out rec.txt" in r.stderr and r.stderr.count("\n") == 1
