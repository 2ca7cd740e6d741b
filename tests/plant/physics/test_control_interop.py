"""A linear ``Plant``'s realisation (``Plant.to_state_space``) is what python-control takes: ``ct.bode_plot``,
``ct.margin``, ``ct.feedback``, ``ct.step_response`` and ``*`` with python-control systems, and what they compute is
held to references built here: the exact response ``plant.frd`` (a plant without a delay), the closed-form [n/n] Pade
approximant of the delay times the rest of the plant, a dense-grid margin computed with numpy from ``plant.frd``
and the tool's own margins (``design.loop.analysis.analyse_loop``). The realisation behind it is well scaled
where the product of transfer functions (``to_control``) is not."""

from __future__ import annotations

import dataclasses
from math import factorial

import control as ct
import matplotlib
import numpy as np
import pytest

from design.loop.analysis import analyse_loop
from design.loop.controller import PI
from plant import CoulombFriction, CurrentLoop, Delay, Resonance, SensorFilter, TiltCoupling, stage_x, stage_y
from plant.errors import EffectError, ParameterError
from plant.physics.effect_base import PADE_ORDER

matplotlib.use("Agg")

W = 2 * np.pi * np.geomspace(0.1, 1000.0, 500)
#: thesis Stage X gains (A/(m/s), A/m)
THESIS_PI = PI(236.0, 47.0)
#: a loop with both margins finite: Stage X with a 0.8 ms delay and a 700 Hz current loop
DELAYED = stage_x(mass_kg=35.0) * Delay(0.0008) * CurrentLoop(700.0)
DELAYED_PI = PI(178.5, 1.915e4)


def _resp(sys, w=W):
    return np.asarray(sys(1j * w)).reshape(-1)


def _pade(delay_s: float, order: int, s: np.ndarray) -> np.ndarray:
    """The [n/n] Pade approximant of exp(-s T) from its closed form: sum c_k (-sT)^k / sum c_k (sT)^k with
    c_k = (2n - k)! n! / ((2n)! k! (n - k)!)."""
    n = order
    c = [factorial(2 * n - k) * factorial(n) / (factorial(2 * n) * factorial(k) * factorial(n - k))
         for k in range(n + 1)]
    x = s * delay_s
    return sum(ck * (-x) ** k for k, ck in enumerate(c)) / sum(ck * x**k for k, ck in enumerate(c))


def _without(plant, name):
    return dataclasses.replace(plant, effects=tuple(e for e in plant.effects if e.name != name))


def _dense_margins(plant, controller, w):
    """Phase margin (deg) at |L| = 1 and gain margin (dB) at the phase's -180 deg crossing, from ``plant.frd`` on
    a dense grid by linear interpolation in log frequency."""
    L = plant.frd(w) * controller.frd(w)
    lw, mag, ph = np.log(w), np.abs(L), np.unwrap(np.angle(L))
    i = np.flatnonzero((mag[:-1] - 1) * (mag[1:] - 1) <= 0)[0]
    wc = np.interp(0.0, np.log(mag[i:i + 2])[::-1], lw[i:i + 2][::-1])
    pm = 180.0 + np.degrees(np.interp(wc, lw[i:i + 2], ph[i:i + 2]))
    j = np.flatnonzero((ph[:-1] + np.pi) * (ph[1:] + np.pi) <= 0)[0]
    wp = np.interp(-np.pi, ph[j:j + 2][::-1], lw[j:j + 2][::-1])
    gm = -20 * np.log10(np.interp(wp, lw[j:j + 2], mag[j:j + 2]))
    return gm, pm


def test_the_realisation_is_a_python_control_system_whose_response_is_the_exact_one():
    plant = stage_x(mass_kg=35.0) * Resonance() * SensorFilter(200.0) * CurrentLoop(700.0)
    sys = plant.to_state_space()
    assert isinstance(sys, ct.StateSpace) and sys.issiso()
    assert (sys.input_labels, sys.output_labels, sys.name) == (["current"], ["velocity"], "stage_x")
    # no delay: the realisation is exact, against the plant's own response and python-control's
    assert np.allclose(_resp(sys), plant.frd(W), rtol=1e-6, atol=0)
    assert np.allclose(ct.frequency_response(sys, W).complex, plant.frd(W), rtol=1e-6, atol=0)
    # the thesis plant is Eq. 3.15, K_t / (M s + b), with its one pole
    thesis = stage_x(mass_kg=20.0).to_state_space()
    assert np.allclose(_resp(thesis), 20.0 / (20.0 * 1j * W + 440.0), rtol=1e-12)
    assert np.allclose(thesis.poles(), [-440.0 / 20.0])


@pytest.mark.parametrize("order", [PADE_ORDER, 3])
def test_a_delay_is_its_pade_approximant_of_the_order_asked(order):
    sys = DELAYED.to_state_space(pade_order=order)
    reference = _without(DELAYED, "delay").frd(W) * _pade(0.0008, order, 1j * W)
    assert np.allclose(_resp(sys), reference, rtol=1e-6, atol=0)
    # against the exact delay: the [n/n] approximant of exp(-x) is all-pass, its relative error
    # (n!)^2 / ((2n)! (2n+1)!) x^(2n+1) to leading order in x = w T; within 10 % of it where w T < 1
    err = np.abs(_resp(sys) / DELAYED.frd(W) - 1)
    x = W * 0.0008
    bound = factorial(order) ** 2 / (factorial(2 * order) * factorial(2 * order + 1)) * x ** (2 * order + 1)
    assert np.all(err[x < 1] <= 1.1 * bound[x < 1] + 1e-12)
    assert np.all(err[x < 1] >= 0.9 * bound[x < 1] - 1e-12)


def test_stage_y_with_the_tilting_beam_is_the_mean_of_the_rails():
    plant = stage_y() * TiltCoupling() * CurrentLoop(700.0)
    sys = plant.to_state_space()
    assert np.allclose(_resp(sys), plant.frd(W), rtol=1e-6, atol=0)
    assert sys.nstates == 3 + 1                 # the beam's (alpha, v_c, omega) and the current loop
    assert np.all(np.linalg.eigvals(sys.A).real < 0)


def test_margin_of_plant_times_controller_is_the_tools_and_the_dense_grids():
    C = ct.tf([DELAYED_PI.kp, DELAYED_PI.ki], [1.0, 0.0])
    gm, pm, wpc, wgc = ct.margin(DELAYED.to_state_space() * C)
    tool = analyse_loop(DELAYED, DELAYED_PI).margins
    w = np.geomspace(2 * np.pi * 1.0, 2 * np.pi * 1000.0, 200_000)
    dense_gm_db, dense_pm = _dense_margins(DELAYED, DELAYED_PI, w)
    # the Pade approximant differs from the delay by < 1e-7 at the crossovers (130 and 1480 rad/s)
    assert pm == pytest.approx(float(tool.phase_margin_deg), abs=0.01)
    assert pm == pytest.approx(dense_pm, abs=0.01)
    assert 20 * np.log10(gm) == pytest.approx(float(tool.gain_margin_db), abs=0.01)
    assert 20 * np.log10(gm) == pytest.approx(dense_gm_db, abs=0.01)
    assert wgc / (2 * np.pi) == pytest.approx(float(tool.gain_crossover_hz), rel=1e-4)
    assert wpc / (2 * np.pi) == pytest.approx(float(tool.phase_crossover_hz), rel=1e-4)


def test_feedback_and_step_response_with_the_thesis_gains():
    C = THESIS_PI.tf()
    closed = ct.feedback(stage_x().to_state_space() * C)
    assert np.all(closed.poles().real < 0)
    # the closed form of thesis Eq. 3.19: K_t (Kp s + Ki) / (M s^2 + (b + K_t Kp) s + K_t Ki)
    M, b, kt = 35.0, 440.0, 20.0
    assert np.allclose(np.sort_complex(closed.poles()),
                       np.sort_complex(np.roots([M, b + kt * 236.0, kt * 47.0])), rtol=1e-9)
    loop = ct.feedback(DELAYED.to_state_space() * DELAYED_PI.tf())
    step = ct.step_response(loop, T=np.linspace(0, 0.2, 2001))
    assert np.all(loop.poles().real < 0)
    assert step.outputs[-1] == pytest.approx(1.0, abs=1e-3)


def test_bode_plot_takes_the_realisation():
    sys = DELAYED.to_state_space()
    fig_lines = ct.bode_plot(sys, omega=W)
    mag = fig_lines.lines[0, 0][0].get_ydata()
    assert np.allclose(mag, np.abs(DELAYED.frd(W)), rtol=1e-6)
    matplotlib.pyplot.close("all")


def test_a_plant_with_no_rational_model_says_why():
    with pytest.raises(EffectError, match="coulomb_friction is nonlinear"):
        (stage_x(excitation_current_a=1.0) * CoulombFriction()).to_state_space()
    with pytest.raises(ParameterError, match="batch"):
        stage_x().with_payload(np.array([10.0, 20.0])).to_state_space()


def test_the_realisation_is_well_conditioned_where_the_transfer_function_is_not():
    plant = stage_x(mass_kg=35.0) * Resonance() * Delay(0.0008) * CurrentLoop(700.0) * SensorFilter(200.0)
    tf = plant.to_control()
    coeffs = np.abs(np.concatenate([tf.num[0][0], tf.den[0][0]]))
    coeffs = coeffs[coeffs > 0]
    assert coeffs.max() / coeffs.min() > 1e25                  # the product of transfer functions
    assert np.linalg.cond(ct.ss(tf).A) > 1e6                  # its companion form
    sys = plant.to_state_space()
    assert np.linalg.cond(sys.A) < 1e5 and np.abs(sys.A).max() < 1e6
    # the same system: equal to the transfer function's response where that one is accurate (below 300 Hz)
    low = W < 2 * np.pi * 300
    assert np.allclose(_resp(sys)[low], _resp(tf)[low], rtol=1e-7)
    assert np.allclose(_resp(sys)[low], plant.frd(W)[low], rtol=1e-7)
