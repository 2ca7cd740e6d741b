"""Every chain effect's state-space realisation (``ChainEffect.state_space``, what the time-domain simulators and
the sampled admittance loop are built from) has the effect's own frequency response: exactly for a rational
factor, to the Pade approximant's accuracy for a delay; a batch realises each plant's values; the batched matrix
exponential under the exact discretisation agrees with scipy's one matrix at a time."""

import numpy as np
import pytest
import scipy.linalg

from plant.physics.effect_base import ChainEffect, effects_state_space
from plant.physics.effects import EFFECTS, make_effect
from plant.physics.state_space import expm, hold_step


def frequency_response(sys, w_rad_s):
    """C (jw I - A)^-1 B + D of an unbatched single-input single-output model, by dense solves."""
    out = []
    for w in w_rad_s:
        x = np.linalg.solve(1j * w * np.eye(sys.order) - sys.A, sys.B) if sys.order else np.zeros((0, 1))
        out.append((sys.C @ x + sys.D)[0, 0])
    return np.array(out)


CHAIN = [name for name, cls in EFFECTS.items() if issubclass(cls, ChainEffect)]
W = np.geomspace(2 * np.pi * 0.1, 2 * np.pi * 300.0, 40)


@pytest.mark.parametrize("name", CHAIN)
def test_realisation_has_the_effects_frequency_response(name):
    effect = make_effect(name)
    sys = effect.state_space(1, pade_order=8).take(0)
    got = frequency_response(sys, W)
    # the realisation is the effect's rational model exactly (python-control evaluates that model) ...
    rational = np.array([complex(effect.to_tf(pade_order=8)(1j * w)) for w in W])
    assert np.max(np.abs(got - rational) / np.abs(rational)) < 1e-9, name
    # ... and that model the effect's frequency response: exactly for a rational factor, to the Pade
    # approximant's accuracy for a delay, a hold or an encoder's difference (order 3 for those two: 7e-6 at 300 Hz)
    expected = effect.frd(W)
    assert np.max(np.abs(got - expected) / np.abs(expected)) < 1e-5, name


def test_a_batch_realises_each_plants_values():
    delays = make_effect("delay", seconds=np.array([[0.0], [3e-4], [8e-4]]))
    loops = make_effect("current_loop", bandwidth_hz=np.array([[200.0], [500.0], [2000.0]]))
    batch = effects_state_space((delays, loops), "drive", 3, pade_order=8)
    for j, (tau, fc) in enumerate(zip((0.0, 3e-4, 8e-4), (200.0, 500.0, 2000.0))):
        expected = np.exp(-1j * W * tau) * (2 * np.pi * fc) / (1j * W + 2 * np.pi * fc)
        got = frequency_response(batch.take(j), W)
        assert np.max(np.abs(got - expected)) < 1e-8


def test_no_factor_is_a_unit_gain():
    sys = effects_state_space((), "sensor", 2).take(1)
    assert sys.order == 0 and sys.D[0, 0] == 1.0


@pytest.mark.parametrize("scale", [1e-8, 1e-2, 1.0, 30.0, 3e3])
def test_batched_expm_equals_scipys_matrix_by_matrix(scale):
    # stable and lightly damped batches over nine decades of norm: each scaled by its own power of two
    rng = np.random.default_rng(7)
    R = rng.normal(size=(20, 9, 9))
    A = np.concatenate([rng.normal(size=(20, 9, 9)) * scale - 4 * scale * np.eye(9),
                        (R - R.transpose(0, 2, 1) - 0.01 * np.eye(9)) * scale * rng.uniform(1e-3, 1, (20, 1, 1))])
    ref = np.stack([scipy.linalg.expm(a) for a in A])
    assert np.max(np.abs(expm(A) - ref) / np.maximum(np.abs(ref).max(axis=(-2, -1), keepdims=True), 1e-300)) < 1e-10


def test_hold_step_of_a_first_order_lag_is_its_closed_form():
    # x' = -a x + a u over h: Phi = e^(-a h), Gamma = 1 - e^(-a h); a batch of rates over the stiff range
    a = np.array([1e-3, 1.0, 2 * np.pi * 700, 2 * np.pi * 1.3e4])
    h = 0.01
    Phi, Gamma = hold_step(-a[:, None, None], a[:, None, None], h)
    assert np.allclose(Phi[:, 0, 0], np.exp(-a * h), rtol=1e-13, atol=1e-300)
    assert np.allclose(Gamma[:, 0, 0], -np.expm1(-a * h), rtol=1e-13)
