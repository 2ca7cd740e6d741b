"""The batched matrix exponential under the exact discretisation, against scipy's one matrix at a time."""

import numpy as np
import pytest
import scipy.linalg

from plant.physics.state_space import expm, hold_step


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
