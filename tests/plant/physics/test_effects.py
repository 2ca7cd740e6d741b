"""Effects of plant.effects: frequency responses against closed forms, rational (Pade) models,
the Coulomb describing function and exact first harmonic, and bad input that names the parameter.

Every reference is a closed form written out here, python-control 0.10.2, or (friction with
stick-slip) the SciPy event-located integration of ``independent_stick_slip``.
"""

import math

import numpy as np
import pytest
from independent_stick_slip import velocity

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
from plant.errors import EffectError, GridError, ParameterError
from plant.grid import check_grid
from plant.physics.effects import SensorFilter

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


def test_delay_off_the_imaginary_axis_and_batched():
    tau = np.array([[0.0], [0.0004], [0.0013]])
    s = 3.0 + 1j * W                     # the exponentially windowed FFT's points (Re s > 0)
    assert np.allclose(Delay(tau).response(s), np.exp(-s * tau), rtol=1e-13, atol=0)


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


def _first_harmonic_by_integration(m, b, fc, force_n, w) -> complex:
    """Velocity per force of the fundamental of m v' + b v + F_c sgn(v) = F sin(w t) from rest, integrated
    by ``independent_stick_slip`` (SciPy, event-located stops) until periodic, then Fourier-integrated over
    the last period. Shares no code with plant.physics.coulomb_response."""
    period = 2 * math.pi / w
    t_end = period * (3 + math.ceil(12 * (m / b) / period))
    grid = np.linspace(t_end - period, t_end, 40001)[:-1]
    v = velocity(np.r_[0.0, grid], mass_kg=m, damping_n_s_per_m=b, friction_n=fc, force_n=force_n,
                 f_hz=w / (2 * math.pi))[1:]
    return 2 * np.mean(v * np.exp(-1j * w * grid)) / (-1j * force_n)


@pytest.mark.parametrize("make, m_e, b_e", [(stage_x, M, B), (stage_y, 2 * M * L_POS / L_M, 2 * B)],
                         ids=["x", "y"])
@pytest.mark.parametrize("fc", [1.0, 5.0, 8.5])
def test_friction_response_is_the_exact_first_harmonic_with_stick_slip(make, m_e, b_e, fc):
    # drive force K_t I = 10 N against 1 N (sliding throughout), 5 N and 8.5 N (stick-slip; above 4 F_c / pi
    # = 7.85 N the describing function has no motion at all), at 1, 4 and 25 Hz
    amp_a, w = 0.5, 2 * math.pi * np.array([1.0, 4.0, 25.0])
    g = (make(excitation_current_a=amp_a) * CoulombFriction(fc)).frd(w)
    ref = np.array([KT * _first_harmonic_by_integration(m_e, b_e, fc, KT * amp_a, wk) for wk in w])
    assert np.allclose(g, ref, rtol=1e-6), np.abs(g / ref - 1)


def test_friction_response_tends_to_the_linear_plant_and_to_rest():
    w = W[::20]
    slight = (stage_x(excitation_current_a=0.5) * CoulombFriction(1e-9)).frd(w)
    assert np.allclose(slight, KT / (B + 1j * w * M), rtol=1e-8)          # Eq. 3.15
    near = (stage_x(excitation_current_a=0.5) * CoulombFriction(KT * 0.5 * (1 - 1e-6))).frd(w)
    assert np.all(np.abs(near) < 1e-3 * np.abs(KT / (B + 1j * w * M)))


def test_friction_with_a_current_lag_sees_the_lagged_force():
    # the current loop scales the force amplitude to K_t I |G_c(jw)| and turns its phase
    amp_a, fc, f_c = 0.5, 2.0, 40.0
    g = (stage_x(excitation_current_a=amp_a) * CurrentLoop(f_c) * CoulombFriction(fc)).frd(W)
    lag = CurrentLoop(f_c).frd(W)
    alone = np.array([(stage_x(excitation_current_a=amp_a * abs(gk)) * CoulombFriction(fc)).frd(np.array([wk]))[0]
                      if KT * amp_a * abs(gk) > fc else 0.0 for wk, gk in zip(W[::25], lag[::25])])
    assert np.allclose(g[::25], lag[::25] * alone, rtol=1e-10, atol=0)
    assert np.array_equal(g != 0, KT * amp_a * np.abs(lag) > fc)


def test_friction_on_a_chain_balances_the_rail_impedance():
    # describing function on a two-mass chain (a motor-sensed mode): the rail's velocity amplitude V solves
    # |Z V + 4 F_c / pi| = K_t I with the chain's driving-point impedance, written out here from the split
    # masses, spring and coupling damping: Z = m1 s + b + (k/s + c) m2 s / (k/s + c + m2 s)
    amp_a, fc = 0.5, 2.0
    p = stage_x(excitation_current_a=amp_a) * Resonance(45.0, 35.0, 0.05) * CoulombFriction(fc)
    chain = p.mechanics()
    (m1, m2), (k,), (c,) = chain.masses_kg, chain.stiffness_n_per_m, chain.damping_n_s_per_m
    s = 1j * W
    coupling = k / s + c
    z = m1 * s + B + coupling * m2 * s / (coupling + m2 * s)
    v = np.abs(p.frd(W)) * amp_a                       # motor-sensed: the rail velocity amplitude
    moving = v > 0
    assert moving.sum() > 0.9 * W.size
    assert np.allclose(np.abs(z * v + 4 * fc / math.pi)[moving], KT * amp_a, rtol=1e-9)


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


def test_series_tf_is_python_controls_product():
    import control

    from plant.physics.effect_base import series_tf

    parts = [control.tf([2.0, 3.0], [1.0, 4.0, 5.0]), control.tf(*control.pade(1e-3, 4)),
             control.tf([7.0], [1e-4, 1.0]), control.tf([1.0, 0.5], [1.0, 0.0])]
    ours, theirs = series_tf(*parts), parts[0] * parts[1] * parts[2] * parts[3]
    assert np.array_equal(ours.num[0][0], theirs.num[0][0])
    assert np.array_equal(ours.den[0][0], theirs.den[0][0])
