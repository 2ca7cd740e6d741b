"""The PI controller object (``design.loop.controller.PI``) against references that share no code with it: the
closed form Kp + Ki / (jw), scipy's bilinear (Tustin) discretisation of (Kp s + Ki) / s, and the drive's own
recursion u[k] = kp e[k] + i[k], i[k] = i[k-1] + (ki T / 2)(e[k] + e[k-1]) run on a step."""

import math

import numpy as np
import pytest
from scipy.signal import cont2discrete, dlti, dstep

from design.loop.controller import PI
from plant.errors import GantryError


def test_its_response_is_the_closed_form_and_broadcasts_over_a_batch():
    w = np.geomspace(0.1, 1e4, 50)
    assert np.allclose(PI(236.0, 47.0).frd(w), 236.0 + 47.0 / (1j * w), rtol=1e-15)
    kp, ki = np.array([[1.0], [2.0], [3.0]]), np.array([[10.0], [20.0], [30.0]])
    batch = PI(kp, ki).frd(w)
    assert batch.shape == (3, 1, w.size) and np.allclose(batch[1, 0], 2.0 + 20.0 / (1j * w))


def test_its_transfer_function_is_python_controls_and_a_p_controller_has_no_integrator():
    import control

    w = np.geomspace(0.1, 1e4, 50)
    assert np.allclose(PI(236.0, 47.0).tf()(1j * w), 236.0 + 47.0 / (1j * w), rtol=1e-12)
    p_only = PI(150.0, 0.0).tf()
    assert control.poles(p_only).size == 0 and complex(p_only(1j)) == pytest.approx(150.0)


def test_its_discrete_form_is_scipys_tustin_and_the_drives_trapezoidal_recursion():
    kp, ki, T = 178.5, 1.915e4, 1.0 / 16000.0
    d = PI(kp, ki).discrete(T)
    num, den, _ = cont2discrete(([kp, ki], [1.0, 0.0]), T, method="bilinear")
    z = np.exp(1j * np.geomspace(1.0, math.pi / T * 0.99, 40) * T)
    reference = np.polyval(np.ravel(num), z) / np.polyval(den, z)
    assert np.allclose(d(z), reference, rtol=1e-12)
    # the drive's recursion on a unit step of the error
    e = np.ones(20)
    integral, prev, u = 0.0, 0.0, []
    for ek in e:
        integral += ki * T / 2 * (ek + prev)
        prev = ek
        u.append(kp * ek + integral)
    _, (step,) = dstep(dlti(np.ravel(d.num[0][0]), np.ravel(d.den[0][0]), dt=T), n=20)
    assert np.allclose(step.ravel(), u, rtol=1e-12)


def test_parameters_round_trip_and_the_spec_values_make_one():
    c = PI(209.9, 14.12)
    assert PI.of(c.parameters) == c and c.gains() == {"kp": 209.9, "ki": 14.12}

    class Value:
        def __init__(self, v):
            self.value = v

    class Bounds:
        kp, ki = Value(178.5), Value(None)

    assert PI.given(Bounds()) is None
    Bounds.ki = Value(19150.0)
    assert PI.given(Bounds()) == PI(178.5, 19150.0)


@pytest.mark.parametrize("kp", ["200", True, None, -1.0, math.nan, math.inf, [200.0]])
def test_a_bad_gain_is_named(kp):
    with pytest.raises(GantryError, match="kp"):
        PI(kp, 10.0)
    with pytest.raises(GantryError, match="batch of gains"):
        PI(np.array([1.0, -2.0]), np.array([1.0, 1.0]))


@pytest.mark.parametrize("name", ["per_motor", "common_differential", "master_slave"])
def test_a_two_motor_structure_realises_t_in_diag_pi_t_out(name):
    from design.loop.dual import BY_NAME

    cls = BY_NAME[name]
    gains = {"per_motor": (125.0, 1.78e4), "master_slave": (250.0, 3.0e4),
             "common_differential": (250.0, 3.0e4, 90.0, 5.0e3)}[name]
    c = cls(*gains)
    w = np.geomspace(1.0, 3e3, 30)
    pis = [gains[k] + gains[k + 1] / (1j * w) for k in range(0, len(gains), 2)]
    t_in = {"per_motor": np.eye(2), "master_slave": np.array([[0.5], [0.5]]),
            "common_differential": np.array([[0.5, -0.5], [0.5, 0.5]])}[name]
    t_out = {"per_motor": np.eye(2), "master_slave": np.array([[1.0, 0.0]]),
             "common_differential": np.array([[0.5, 0.5], [-0.5, 0.5]])}[name]
    if name == "per_motor":
        pis = pis * 2
    by_hand = np.stack([t_in @ np.diag([p[i] for p in pis]) @ t_out for i in range(w.size)], axis=-1)
    assert np.allclose(np.asarray(c.tf()(1j * w)), by_hand, rtol=1e-10)
    assert np.allclose(c.frd(w), by_hand, rtol=1e-12)
    assert c.parameters.tolist() == list(gains)


@pytest.mark.parametrize("rule", ["backward_euler", "forward_euler", "tustin", "zoh"])
def test_the_admittance_law_realises_its_rule_with_its_delay(rule):
    from design.admittance.rig import DiscreteAdmittance

    m_v, b_v, rate, d = 0.0414, 4.96, 100.0, 1
    law = DiscreteAdmittance.of(m_v, b_v, rate, d, rule=rule)
    T = 1.0 / rate
    w = np.geomspace(0.1, math.pi * rate * 0.99, 40)
    z = np.exp(1j * w * T)
    if rule == "tustin":
        num, den, _ = cont2discrete(([1.0], [m_v, b_v]), T, method="bilinear")
        y = np.polyval(np.ravel(num), z) / np.polyval(den, z)
    elif rule == "zoh":                     # scipy's hold carries one sample the law does not
        num, den, _ = cont2discrete(([1.0], [m_v, b_v]), T, method="zoh")
        y = z * np.polyval(np.ravel(num), z) / np.polyval(den, z)
    elif rule == "forward_euler":           # v[k] = v[k-1] + T (F[k] - b_v v[k-1]) / m_v
        y = (T / m_v) / (1 - (1 - b_v * T / m_v) / z)
    else:                                   # (m_v + b_v T) v[k] = m_v v[k-1] + T F[k]
        y = T / (m_v + b_v * T - m_v / z)
    y = y * z ** (-d)
    assert np.allclose(law.frd(w), y, rtol=1e-10)
    assert np.allclose(np.asarray(law.tf()(z)).ravel(), y, rtol=1e-10)
    assert law.parameters.tolist() == [m_v, b_v]
