"""Effects of plant.effects against their closed forms, their rational (Pade) models and bad input.

Every reference is a closed form written out here (the effect's defining formula, a property
of it that the code does not use, or an independent realisation) or python-control 0.10.2.
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
from plant.errors import EffectError, GridError, ParameterError

W = np.geomspace(0.1, 5000.0, 400)
S = 1j * W
# thesis section 3.1 / Appendix A values
KT, B, M, L_M, L_POS = 20.0, 440.0, 35.0, 0.8, 0.4


# --- series effects: frd against closed forms ----------------------------------------------

def test_delay_is_a_pure_phase_lag():
    tau = 0.002
    g = Delay(tau).frd(W)
    assert np.allclose(g, np.exp(-S * tau), rtol=1e-14)          # closed form e^(-s tau)
    assert np.allclose(np.abs(g), 1.0, rtol=1e-14)
    assert Delay(0.0).frd(W) == pytest.approx(np.ones(W.size))     # zero delay is the identity


def test_current_loop_is_a_first_order_lag_with_its_corner_at_the_bandwidth():
    f_bw = 150.0
    wc = 2 * math.pi * f_bw
    assert np.allclose(CurrentLoop(f_bw).frd(W), 1 / (1 + S / wc), rtol=1e-14)   # closed form
    at_corner = CurrentLoop(f_bw).frd(np.array([wc]))[0]
    assert abs(at_corner) == pytest.approx(1 / math.sqrt(2), rel=1e-14)          # -3 dB at bandwidth_hz
    assert math.degrees(np.angle(at_corner)) == pytest.approx(-45.0, rel=1e-14)


def test_sampling_is_zero_order_hold_plus_one_sample():
    rate = 4000.0
    T = 1 / rate
    g = Sampling(rate).frd(W)
    assert np.allclose(g, (1 - np.exp(-S * T)) / (S * T) * np.exp(-S * T), rtol=1e-12)   # closed form
    # equivalent closed form: |sinc(wT/2)| magnitude and a linear phase of 1.5 samples
    below_nyquist = W < math.pi / T
    x = W[below_nyquist] * T / 2
    assert np.allclose(np.abs(g[below_nyquist]), np.sin(x) / x, rtol=1e-12)
    assert np.allclose(np.angle(g[below_nyquist]), -1.5 * W[below_nyquist] * T, rtol=1e-12)
    assert abs(Sampling(rate).frd(np.array([2 * math.pi * rate]))[0]) < 1e-12     # ZOH zero at the rate


# --- rational models -----------------------------------------------------------------------------

@pytest.mark.parametrize("effect", [CurrentLoop(150.0)])
def test_rational_effects_to_tf_is_exact(effect):
    assert np.allclose(effect.to_tf()(S), effect.frd(W), rtol=1e-10)


@pytest.mark.parametrize("order", [4, 6, 10])
def test_delay_pade_matches_at_low_frequency(order):
    tau = 0.001
    pade = Delay(tau).to_tf(pade_order=order)
    assert np.allclose(np.abs(pade(S)), 1.0, rtol=1e-9)         # a Pade delay is all-pass
    low = W * tau < 1.0
    # Pade (n, n) phase error is O((w tau)^(2n+1)); at w tau <= 1 it is below 1e-6 from order 4 on
    assert np.allclose(pade(S[low]), Delay(tau).frd(W[low]), rtol=1e-6)
    high = W * tau > 2 * order     # far above its range the approximation is not a delay any more
    if high.any():
        assert not np.allclose(pade(S[high]), Delay(tau).frd(W[high]), rtol=1e-2)


def test_sampling_rational_model_keeps_the_hold_droop():
    # to_tf is the hold and one-sample delay with a Pade for e^{-sT}: at low frequency it equals the
    # exact frd, whose magnitude is the ZOH droop sinc(wT/2) (closed form), not 1 as for a pure delay
    rate = 2000.0
    T = 1 / rate
    low = W * T < 0.5                               # Pade(3) error ~1e-5 (wT)^7
    x = W[low] * T / 2
    e = Sampling(rate)
    assert np.allclose(np.abs(e.to_tf()(S[low])), np.sin(x) / x, rtol=1e-6)
    assert np.allclose(e.to_tf()(S[low]), e.frd(W[low]), rtol=1e-6)


def test_plant_to_control_matches_frd_with_all_series_effects():
    p = stage_y() * Delay(0.0005) * CurrentLoop(300.0) * Sampling(5000.0) * Resonance(80.0, 50.0, 0.05)
    low = W < 200.0          # Pade 8 of 0.5 ms, Pade 3 (the sampling cap) of the 0.2 ms sample: exact to 1e-9 here
    assert np.allclose(p.to_control(pade_order=8)(S[low]), p.frd(W[low]), rtol=1e-8)


# --- mechanical effects ---------------------------------------------------------------------------

def test_coulomb_sign_nonlinearity_has_the_describing_function_4F_over_pi():
    fc = 3.0
    friction = CoulombFriction(fc)
    # first harmonic of F sign(V sin theta), computed by quadrature of the exact force (time domain)
    theta = np.linspace(0, 2 * math.pi, 200001)[:-1]
    for v in (0.01, 0.2, 5.0):
        force = friction.force(v * np.sin(theta))
        first_harmonic = 2 * np.mean(force * np.sin(theta))
        assert friction.describing_damping(v) * v == pytest.approx(first_harmonic, rel=1e-5)
        assert friction.describing_damping(v) == pytest.approx(4 * fc / (math.pi * v), rel=1e-14)
    assert np.isinf(friction.describing_damping(0.0))             # a velocity of zero: stuck


@pytest.mark.parametrize("make, m_e, b_e", [(stage_x, M, B), (stage_y, 2 * M * L_POS / L_M, 2 * B)])
def test_coulomb_describing_function_solves_the_amplitude_balance(make, m_e, b_e):
    # Eq. 3.15 / 3.16 as K_t / (m_e s + b_e); with the describing function the velocity amplitude V
    # satisfies |(b_e + j w m_e) V + 4 F_c / pi| = K_t I (closed form of the harmonic balance)
    amp_a, fc = 0.5, 2.0
    p = make(excitation_current_a=amp_a) * CoulombFriction(fc)
    g = p.frd(W)
    v = np.abs(g) * amp_a
    assert np.allclose(np.abs((b_e + S * m_e) * v + 4 * fc / np.pi), KT * amp_a, rtol=1e-9)
    # the velocity stays in phase with the force on the impedance b_e + N(V) + j w m_e
    n = 4 * fc / (np.pi * v)
    assert np.allclose(np.angle(g), -np.arctan2(W * m_e, b_e + n), rtol=1e-9, atol=1e-12)
    # friction only lowers the response, most at low frequency where the velocity is largest
    linear = make().frd(W)
    assert np.all(np.abs(g) < np.abs(linear))
    with pytest.raises(EffectError, match="no transfer function"):
        p.to_control()


def test_coulomb_friction_above_the_drive_force_holds_the_stage():
    # drive K_t I = 2 N against 5 N of friction: the stage never breaks loose (closed form: V = 0)
    p = stage_x(excitation_current_a=0.1) * CoulombFriction(5.0)
    assert np.all(p.frd(W) == 0)


def test_tilt_coupling_parameters_and_centred_load():
    t = TiltCoupling(40.0, 2e4)
    assert t.inertia_kg_m2 == pytest.approx(2e4 / (2 * math.pi * 40.0) ** 2, rel=1e-14)   # J = K_a / w^2
    # a centred load with equal rail damping does not excite the tilt mode: Eq. 3.16 unchanged
    assert np.allclose((stage_y() * t).frd_outputs(W), stage_y().frd(W), rtol=1e-9)
    assert set(t.parameters()) == {"tilt_coupling.frequency_hz", "tilt_coupling.stiffness_n_m_per_rad",
                                   "tilt_coupling.offset_m"}


def test_parameters_are_named_effect_dot_parameter_and_replaceable():
    p = stage_x() * Delay(0.001) * CurrentLoop(300.0)
    params = p.parameters()
    assert {"mass_kg", "damping_n_s_per_m", "force_constant_n_per_a", "delay.seconds",
            "current_loop.bandwidth_hz"} <= set(params)
    assert params["delay.seconds"].value == 0.001 and params["delay.seconds"].unit == "s"
    q = p.with_values({"delay.seconds": 0.002, "mass_kg": 20.0})
    assert np.allclose(q.frd(W), KT / (B + 20.0 * S) * np.exp(-0.002 * S) * CurrentLoop(300.0).frd(W))
    with pytest.raises(EffectError, match="resonance"):
        p.with_values({"resonance.frequency_hz": 50.0})
    with pytest.raises(ParameterError, match="masskg"):
        p.with_values({"masskg": 20.0})


def test_make_effect_builds_every_named_effect():
    # the names of shared/ARCHITECTURE.md
    for name, cls in [("delay", Delay), ("current_loop", CurrentLoop), ("sampling", Sampling),
                      ("resonance", Resonance), ("coulomb_friction", CoulombFriction),
                      ("tilt_coupling", TiltCoupling)]:
        assert isinstance(make_effect(name), cls) and make_effect(name).name == name
    assert make_effect("delay", seconds=0.003) == Delay(0.003)


# --- bad input: errors name the parameter ---------------------------------------------------------

@pytest.mark.parametrize("kwargs, words", [
    ({"mass_kg": -1.0}, "mass_kg must be positive"),
    ({"mass_kg": 0.0}, "mass_kg must be positive"),
    ({"force_constant_n_per_a": 0.0}, "force_constant_n_per_a must be positive"),
    ({"damping_n_s_per_m": float("nan")}, "damping_n_s_per_m must be a finite number"),
    ({"mass_kg": np.array([10.0, np.nan])}, "mass_kg must be a finite number"),
    ({"load_position_m": 0.9}, "load_position_m"),
])
def test_non_physical_plant_parameters_are_named(kwargs, words):
    with pytest.raises(ParameterError, match=words):
        Plant("x", **kwargs)


@pytest.mark.parametrize("build, words", [
    (lambda: Delay(-1e-3), "delay.seconds must be non-negative"),
    (lambda: Delay(float("nan")), "delay.seconds must be a finite number"),
    (lambda: CurrentLoop(0.0), "current_loop.bandwidth_hz must be positive"),
    (lambda: Sampling(-5.0), "sampling.rate_hz must be positive"),
    (lambda: Resonance(50.0, 80.0, 0.05), "resonance.antiresonance_hz must lie below resonance.frequency_hz"),
    (lambda: Resonance.from_two_mass(motor_mass_kg=-1.0, load_mass_kg=2.0, stiffness_n_per_m=1e5,
                                     damping_ratio=0.05), "resonance.motor_mass_kg must be positive"),
    (lambda: CoulombFriction(-2.0), "coulomb_friction.force_n must be non-negative"),
    (lambda: TiltCoupling(40.0, float("inf")), "tilt_coupling.stiffness_n_m_per_rad must be a finite number"),
    (lambda: make_effect("delay", seconds=float("nan")), "delay.seconds"),
])
def test_non_physical_effect_parameters_are_named(build, words):
    with pytest.raises(ParameterError, match=words):
        build()


@pytest.mark.parametrize("build, words", [
    (lambda: make_effect("dealy"), "unknown effect 'dealy'"),
    (lambda: make_effect("delay", second=0.001), "no parameter 'second'"),
    (lambda: stage_x() * Delay() * Delay(0.002), "effect delay added twice"),
    (lambda: stage_x() * TiltCoupling(), "tilt_coupling applies to Stage Y only"),
    (lambda: stage_x() * CoulombFriction(), "coulomb_friction needs excitation_current_a"),
    (lambda: Delay().with_values(secs=1.0), "effect delay has no parameter 'secs'"),
])
def test_bad_effects_are_named(build, words):
    with pytest.raises(EffectError, match=words):
        build()


@pytest.mark.parametrize("grid, words", [
    ([], "non-empty"),
    (np.zeros((2, 3)) + 1.0, "non-empty 1-D"),
    ([1.0, 3.0, 2.0], r"strictly increasing: element 2 \(2\) <= element 1 \(3\)"),
    ([1.0, 1.0], "strictly increasing"),
    ([1.0, float("nan")], "NaN"),
    ([-1.0, 2.0], "positive"),
])
def test_bad_frequency_grids_are_named(grid, words):
    with pytest.raises(GridError, match=words):
        stage_x().frd(grid)
