"""Effects of plant.effects: frequency responses against closed forms, rational (Pade) models,
the Coulomb describing function, and bad input that names the parameter.

Every reference is a closed form written out here or python-control 0.10.2.
"""

import math

import numpy as np
import pytest

from plant import (
    CoulombFriction,
    CurrentLoop,
    Delay,
    Plant,
    Resonance,
    Sampling,
    TiltCoupling,
    make_effect,
    stage_x,
    stage_y,
)
from plant.effects import SensorFilter
from plant.errors import EffectError, GridError, ParameterError
from plant.grid import check_grid

W = np.geomspace(0.05, 2.0e4, 600)
S = 1j * W
# thesis section 3.1 and Appendix A
KT, B, M, L_M, L_POS = 20.0, 440.0, 35.0, 0.8, 0.4


# --- series effects against their closed forms ------------------------------------------------------

def test_delay_closed_form_and_constant_group_delay():
    tau = 0.0013
    g = Delay(tau).frd(W)
    assert np.allclose(g, np.exp(-1j * W * tau), rtol=1e-14)               # e^(-j w tau)
    group_delay = -np.gradient(np.unwrap(np.angle(g)), W)
    assert np.allclose(group_delay, tau, rtol=1e-6)


def test_current_loop_is_a_first_order_lag():
    f_c = 300.0
    wc = 2 * math.pi * f_c
    assert np.allclose(CurrentLoop(f_c).frd(W), wc / (S + wc), rtol=1e-14)   # w_c / (s + w_c)
    corner = CurrentLoop(f_c).frd(np.array([wc]))[0]
    assert abs(corner) == pytest.approx(1 / math.sqrt(2), rel=1e-14)          # -3 dB at bandwidth_hz
    assert math.degrees(np.angle(corner)) == pytest.approx(-45.0, rel=1e-13)


def test_sampling_is_zero_order_hold_and_one_sample():
    rate = 2500.0
    T = 1 / rate
    g = Sampling(rate).frd(W)
    # ZOH (1 - e^(-sT)) / (sT) times the computation delay e^(-sT)
    assert np.allclose(g, (1 - np.exp(-S * T)) / (S * T) * np.exp(-S * T), rtol=1e-12)
    below = W < 2 * math.pi * rate
    x = W[below] * T / 2
    assert np.allclose(np.abs(g[below]), np.sin(x) / x, rtol=1e-12)            # |ZOH| = sinc(wT/2)
    assert np.allclose(np.unwrap(np.angle(g[below])), -1.5 * W[below] * T, rtol=1e-12)   # 1.5 samples
    assert abs(Sampling(rate).frd(np.array([2 * math.pi * rate]))[0]) < 1e-12   # ZOH zero at the rate


# --- rational models (to_tf) against frd --------------------------------------------------------------

@pytest.mark.parametrize("effect", [CurrentLoop(300.0), SensorFilter(150.0)], ids=["lag", "sensor_filter"])
def test_rational_effects_are_exact(effect):
    assert np.allclose(effect.to_tf()(S), effect.frd(W), rtol=1e-10)           # python-control 0.10.2


@pytest.mark.parametrize("order", [2, 4, 6])
def test_delay_pade_is_accurate_at_low_frequency(order):
    tau = 0.0008
    pade = Delay(tau).to_tf(pade_order=order)
    low = W * tau < 0.5
    # Pade (n, n) of e^(-x) is all-pass with a phase error ~ x^(2n+1) / ((2n)!(2n+1)!) * (n!)^2 ...;
    # at x <= 0.5 this is < 1e-4 for n = 2 and far smaller above
    tol = {2: 1e-4, 4: 1e-9, 6: 1e-12}[order]
    assert np.allclose(pade(S[low]), Delay(tau).frd(W[low]), rtol=tol, atol=0)
    assert np.allclose(np.abs(pade(S)), 1.0, rtol=1e-9)                         # all-pass everywhere


def test_sampling_rational_model_is_the_hold_and_one_sample():
    # to_tf is (1 - e^{-sT})/(sT) e^{-sT} with e^{-sT} replaced by its Pade approximant: equal to the
    # exact frd (closed form) where the Pade is exact, including the hold's droop sinc(wT/2)
    rate = 4000.0
    T = 1 / rate
    low = W * T < 0.3
    e = Sampling(rate)
    exact = (1 - np.exp(-S[low] * T)) / (S[low] * T) * np.exp(-S[low] * T)
    assert np.allclose(e.to_tf()(S[low]), exact, rtol=1e-8)     # Pade(3) error ~1e-5 (wT)^7
    assert abs(e.to_tf()(0.0) - 1.0) < 1e-12                                    # unity DC gain


def test_batched_effect_parameters_broadcast():
    taus = np.array([[0.0005], [0.001], [0.002]])
    g = (stage_x() * Delay(taus)).frd(W)
    assert g.shape == (3, W.size)
    assert np.allclose(g, KT / (B + M * S) * np.exp(-S * taus), rtol=1e-13)
    with pytest.raises(EffectError, match="delay.seconds is a batch"):
        Delay(taus).to_tf()


# --- Coulomb friction: describing function and exact force ---------------------------------------

def test_describing_function_is_the_first_harmonic_of_the_exact_force():
    fc = 3.0
    friction = CoulombFriction(fc)
    theta = np.linspace(0.0, 2 * math.pi, 100000, endpoint=False)
    for v in (0.01, 0.3, 4.0):
        force = friction.force(v * np.sin(theta))                      # exact F_c sign(v)
        assert np.array_equal(np.abs(force), np.full(theta.size, fc) * (np.sin(theta) != 0))
        first_harmonic = 2 * np.mean(force * np.sin(theta))            # Fourier sine coefficient
        # closed form 4 F_c / pi, i.e. a damping N(V) = 4 F_c / (pi V)
        assert first_harmonic == pytest.approx(4 * fc / math.pi, rel=1e-6)
        assert friction.describing_damping(v) * v == pytest.approx(first_harmonic, rel=1e-6)


@pytest.mark.parametrize("make, m_e, b_e", [(stage_x, M, B), (stage_y, 2 * M * L_POS / L_M, 2 * B)],
                         ids=["x", "y"])
def test_friction_response_solves_the_harmonic_balance(make, m_e, b_e):
    # Eq. 3.15 / 3.16 as K_t / (m_e s + b_e). With the describing function the velocity amplitude V
    # at current amplitude I solves |(b_e + j w m_e) V + 4 F / pi| = K_t I, a quadratic in V
    amp_a, fc = 0.5, 2.0
    g = (make(excitation_current_a=amp_a) * CoulombFriction(fc)).frd(W)
    v = np.abs(g) * amp_a
    assert np.allclose(np.abs((b_e + 1j * W * m_e) * v + 4 * fc / math.pi), KT * amp_a, rtol=1e-10)
    # the quadratic's positive root, written out
    c, f = 4 * fc / math.pi, KT * amp_a
    a2 = b_e**2 + (W * m_e) ** 2
    v_closed = (-b_e * c + np.sqrt((b_e * c) ** 2 - a2 * (c**2 - f**2))) / a2
    assert np.allclose(v, v_closed, rtol=1e-10)
    # the describing function is real: velocity in phase with the force on b_e + N(V) + j w m_e
    assert np.allclose(g, KT / (b_e + c / v + 1j * W * m_e), rtol=1e-10)


def test_friction_with_a_current_lag_sees_the_lagged_force():
    # the current loop scales the force amplitude: |(b + j w M) V + 4 F / pi| = K_t I |G_c(jw)|
    amp_a, fc, f_c = 0.5, 2.0, 40.0
    p = stage_x(excitation_current_a=amp_a) * CurrentLoop(f_c) * CoulombFriction(fc)
    v = np.abs(p.frd(W)) * amp_a
    lag = np.abs(CurrentLoop(f_c).frd(W))
    moving = v > 0
    assert np.allclose(np.abs((B + 1j * W * M) * v + 4 * fc / math.pi)[moving], (KT * amp_a * lag)[moving],
                       rtol=1e-10)
    # where the lagged force no longer exceeds 4 F / pi the describing function has no moving solution
    assert np.array_equal(moving, KT * amp_a * lag > 4 * fc / math.pi)


def test_friction_larger_than_the_drive_holds_the_stage():
    # drive K_t I = 2 N, friction 5 N: no moving solution at any frequency (V = 0)
    assert np.all((stage_x(excitation_current_a=0.1) * CoulombFriction(5.0)).frd(W) == 0)
    held = (stage_y(load_position_m=0.25, excitation_current_a=0.1) * TiltCoupling(40.0, 2e4)
            * CoulombFriction(5.0)).frd_outputs(W)
    assert np.all(held == 0)     # the tilt model's rails are held too


def test_friction_has_no_transfer_function_and_needs_an_amplitude():
    p = stage_x(excitation_current_a=0.5) * CoulombFriction(2.0)
    with pytest.raises(EffectError, match="no transfer function"):
        p.to_control()
    with pytest.raises(EffectError, match="excitation_current_a"):
        stage_x() * CoulombFriction(2.0)


# --- parameters: names, bounds, replacement ---------------------------------------------------------

def test_effect_parameters_are_named_effect_dot_parameter():
    p = stage_x() * Delay(0.001) * Resonance(120.0, 70.0, 0.03)
    names = set(p.parameters())
    assert {"mass_kg", "damping_n_s_per_m", "force_constant_n_per_a", "delay.seconds", "resonance.frequency_hz",
            "resonance.antiresonance_hz", "resonance.damping_ratio"} == names
    q = p.with_values({"delay.seconds": 0.002, "resonance.damping_ratio": 0.1})
    assert q.effect("delay") == Delay(0.002) and q.effect("resonance").damping_ratio == 0.1


# --- bad input names the parameter -----------------------------------------------------------------

@pytest.mark.parametrize("kwargs, words", [
    ({"mass_kg": -1.0}, "mass_kg must be positive"),
    ({"force_constant_n_per_a": 0.0}, "force_constant_n_per_a must be positive"),
    ({"damping_n_s_per_m": float("nan")}, "damping_n_s_per_m must be a finite number"),
    ({"mass_kg": float("inf")}, "mass_kg must be a finite number"),
])
def test_non_physical_plant_parameters(kwargs, words):
    with pytest.raises(ParameterError, match=words):
        Plant("x", **kwargs)
    with pytest.raises(ParameterError, match=words):
        stage_x().with_values(kwargs)


@pytest.mark.parametrize("build, words", [
    (lambda: make_effect("delay", seconds=-1e-3), "delay.seconds must be non-negative"),
    (lambda: make_effect("current_loop", bandwidth_hz=float("nan")), "current_loop.bandwidth_hz must be a finite"),
    (lambda: make_effect("sampling", rate_hz=0.0), "sampling.rate_hz must be positive"),
    (lambda: make_effect("resonance", frequency_hz=50.0, antiresonance_hz=60.0), "resonance.antiresonance_hz"),
    (lambda: make_effect("coulomb_friction", force_n=-1.0), "coulomb_friction.force_n must be non-negative"),
    (lambda: make_effect("tilt_coupling", stiffness_n_m_per_rad=0.0), "tilt_coupling.stiffness_n_m_per_rad"),
    (lambda: Resonance.from_two_mass(motor_mass_kg=5.0, load_mass_kg=-2.0, stiffness_n_per_m=1e5,
                                     damping_ratio=0.05), "resonance.load_mass_kg must be positive"),
])
def test_non_physical_effect_parameters(build, words):
    with pytest.raises(ParameterError, match=words):
        build()


@pytest.mark.parametrize("build, words", [
    (lambda: make_effect("backlash"), "unknown effect 'backlash'; known effects: delay, current_loop"),
    (lambda: make_effect("delay", tau=1e-3), "effect delay has no parameter 'tau'"),
    (lambda: stage_x() * Delay(0.001) * CurrentLoop() * Delay(0.002), "effect delay added twice"),
    (lambda: stage_x().with_values({"sampling.rate_hz": 1e3}), "sampling"),
    (lambda: stage_x() * TiltCoupling(), "tilt_coupling applies to Stage Y only"),
])
def test_bad_effects(build, words):
    with pytest.raises(EffectError, match=words):
        build()


@pytest.mark.parametrize("grid, words", [
    ([], "non-empty"),
    ([[1.0, 2.0]], "1-D"),
    ([1.0, 2.0, 2.0], r"strictly increasing: element 2 \(2\) <= element 1 \(2\)"),
    ([3.0, 2.0], "strictly increasing"),
    ([1.0, float("nan"), 3.0], "NaN"),
    ([0.0, 1.0], "positive"),
])
def test_bad_frequency_grids(grid, words):
    with pytest.raises(GridError, match=words):
        check_grid(grid)
    with pytest.raises(GridError, match=words):
        stage_x().frd(grid)


# --- the library's names, rational realisations, tilt -----------------------------------------------

def test_make_effect_builds_every_named_effect():
    # the names of docs/formats.md
    for name, cls in [("delay", Delay), ("current_loop", CurrentLoop), ("sampling", Sampling),
                      ("resonance", Resonance), ("coulomb_friction", CoulombFriction),
                      ("tilt_coupling", TiltCoupling)]:
        assert isinstance(make_effect(name), cls) and make_effect(name).name == name
    assert make_effect("delay", seconds=0.003) == Delay(0.003)


def test_plant_to_control_matches_frd_with_all_series_effects():
    p = stage_y() * Delay(0.0005) * CurrentLoop(300.0) * Sampling(5000.0) * Resonance(80.0, 50.0, 0.05)
    low = W < 200.0          # Pade 8 of 0.5 ms, Pade 3 (the sampling cap) of the 0.2 ms sample: exact to 1e-9 here
    assert np.allclose(p.to_control(pade_order=8)(S[low]), p.frd(W[low]), rtol=1e-8)


def test_tilt_coupling_parameters_and_centred_load():
    t = TiltCoupling(40.0, 2e4)
    assert t.inertia_kg_m2 == pytest.approx(2e4 / (2 * math.pi * 40.0) ** 2, rel=1e-14)   # J = K_a / w^2
    # a centred load with equal rail damping does not excite the tilt mode: Eq. 3.16 unchanged
    assert np.allclose((stage_y() * t).frd_outputs(W), stage_y().frd(W), rtol=1e-9)
    assert set(t.parameters()) == {"tilt_coupling.frequency_hz", "tilt_coupling.stiffness_n_m_per_rad",
                                   "tilt_coupling.offset_m"}
