"""The design as a drive runs it: Tustin biquads against scipy's bilinear transform, the exact
sampled plant with a delay against the continuous step response, and designs at 4 kHz and 16 kHz
whose exported numbers give a discrete loop (rebuilt here with python-control) meeting the margins."""

from __future__ import annotations

import json
import math

import control
import numpy as np
import pytest
import scipy.linalg
import scipy.signal
from in_process import gantry

from design.loop.discrete import tustin_biquad, zoh_with_delay
from plant.errors import SpecError


@pytest.mark.parametrize("f_hz,zeta,rate_hz", [(200.0, 1 / math.sqrt(2), 4000.0), (800.0, 0.5, 16000.0),
                                                (1500.0, 0.3, 4000.0)])
def test_tustin_biquad_is_scipys_bilinear_transform_of_the_prewarped_filter(f_hz, zeta, rate_hz):
    wn = 2 * math.pi * f_hz
    b0, b1, b2, a1, a2 = tustin_biquad((0.0, 0.0, wn * wn), (1.0, 2 * zeta * wn, wn * wn), rate_hz, f_hz)
    # pre-warping: the analog corner moved to 2 fs tan(wn / (2 fs)), then scipy's plain bilinear transform
    ww = 2 * rate_hz * math.tan(wn / (2 * rate_hz))
    b, a = scipy.signal.bilinear([ww * ww], [1.0, 2 * zeta * ww, ww * ww], fs=rate_hz)
    np.testing.assert_allclose([b0, b1, b2], b / a[0], rtol=1e-10)
    np.testing.assert_allclose([1.0, a1, a2], a / a[0], rtol=1e-10, atol=1e-14)
    # at the corner the discrete filter has the continuous response exactly: -90 deg, 1 / (2 zeta)
    z = np.exp(1j * wn / rate_hz)
    h = (b0 + b1 / z + b2 / z**2) / (1 + a1 / z + a2 / z**2)
    assert h == pytest.approx(1 / (2j * zeta), rel=1e-9)


def test_a_filter_at_the_nyquist_frequency_is_refused():
    with pytest.raises(SpecError, match="Nyquist"):
        tustin_biquad((0.0, 0.0, 1.0), (1.0, 1.0, 1.0), 4000.0, 2000.0)


@pytest.mark.parametrize("delay_s", [0.0, 5e-4, 5.3e-4, 2e-5])
def test_sampled_plant_with_delay_is_the_continuous_step_response_at_the_samples(delay_s):
    # a step through a zero-order hold is a step: the discrete model's step response must be the continuous
    # system's step response, delayed, at t = kT; reference: the closed form C A^-1 (e^(A t) - I) B
    T = 1 / 4000
    P = control.tf([1.0], [40.0, 440.0]) * control.tf([2 * math.pi * 700], [1.0, 2 * math.pi * 700])
    Pd = zoh_with_delay(P, T, delay_s)
    k = np.arange(200)
    y_d = control.step_response(Pd, k * T).outputs.ravel()
    A, B, Cm, _ = scipy.signal.tf2ss(np.asarray(P.num[0][0], float), np.asarray(P.den[0][0], float))
    t = k * T - delay_s
    y_c = np.array([0.0 if tk <= 0 else (Cm @ np.linalg.solve(A, scipy.linalg.expm(A * tk) - np.eye(2)) @ B).item()
                    for tk in t])
    np.testing.assert_allclose(y_d, y_c, atol=1e-9 * np.max(np.abs(y_c)))


def _design(tmp_path, rate_hz):
    """``gantry synth --json`` of the Stage X plant (thesis Eq. 3.15, delay, current loop) with the drive's
    800 Hz velocity filter at ``rate_hz``."""
    spec = tmp_path / "drive.toml"
    lines = [f'name = "drive at {rate_hz:g} Hz"', "[plant]", 'stage = "x"',
             'payload_kg = { min = 5.0, max = 40.0, points = 8, nominal = 35.0 }', "[plant.effects]",
             "delay = { seconds = 0.0005 }", "current_loop = { bandwidth_hz = 1000.0 }",
             "sensor_filter = { frequency_hz = 800.0 }", "[controller]",
             "kp = { min = 0.0, max = 10000.0 }", "ki = { min = 0.0, max = 1.0e7 }", f"loop_rate_hz = {rate_hz}"]
    spec.write_text("\n".join(lines) + "\n")
    out = gantry("synth", str(spec), "--json")
    assert out.returncode == 0, out.stderr + out.stdout[-2000:]
    return json.loads(out.stdout)


@pytest.mark.parametrize("rate_hz", [4000.0, pytest.param(16000.0, marks=pytest.mark.slow)])
def test_discrete_design_meets_the_margins_as_the_drive_runs_it(tmp_path, rate_hz):
    res = _design(tmp_path, rate_hz)
    d = res["discrete"]
    assert res["status"] == "optimal" and d["verification"]["verified"]
    assert d["kp"] == res["gains"]["kp"] and d["ki_per_sample"] == pytest.approx(res["gains"]["ki"] / rate_hz)
    (f,) = d["filters"]
    assert f["name"] == "sensor_filter" and f["frequency_hz"] == 800.0
    # rebuilt here from the exported numbers only: the delay of 0.5 ms is a whole number of samples at both
    # rates, so the plant is python-control's zero-order-hold c2d times z^-d; one more sample of computation
    T = 1 / rate_hz
    z = control.tf([1.0, 0.0], [1.0], T)
    C = d["kp"] + d["ki_per_sample"] / 2 * (z + 1) / (z - 1)
    F = control.tf([f["b0"], f["b1"], f["b2"]], [1.0, f["a1"], f["a2"]], T)
    d_samples = round(5e-4 / T)
    w = np.geomspace(2 * math.pi * 0.05, 0.999 * math.pi * rate_hz, 2000)   # 6,000: the same margins within 1e-9
    for m in np.linspace(5.0, 40.0, 8):
        P = (control.tf([20.0], [m, 440.0]) * control.tf([2 * math.pi * 1000], [1.0, 2 * math.pi * 1000]))
        L = control.c2d(P, T, method="zoh") * z ** (-(d_samples + 1)) * C * F
        assert np.all(np.abs(control.poles(control.feedback(L, 1))) < 1)
        gm, pm, *_ = control.stability_margins(control.frd(L(np.exp(1j * w * T)), w))
        assert pm >= 45.0 - 0.05 and 20 * math.log10(gm) >= 6.0 - 0.05, (m, pm, gm)
