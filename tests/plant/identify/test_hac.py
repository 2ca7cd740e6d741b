"""The time-domain fits' Newey-West (HAC) covariance against its definition (Newey & West 1987): the lag sum of
Bartlett-weighted cross products of the scores, written out term by term."""

from __future__ import annotations

import numpy as np
import pytest

from plant.identify.time_fit import newey_west


def _by_definition(X: np.ndarray, e: np.ndarray, lag: int) -> np.ndarray:
    xe = X * e[:, None]
    S = xe.T @ xe
    for k in range(1, lag + 1):
        G = xe[k:].T @ xe[:-k]
        S = S + (1 - k / (lag + 1)) * (G + G.T)
    inv = np.linalg.pinv(X.T @ X)
    return inv @ S @ inv


@pytest.mark.parametrize("seed", range(6))
def test_covariance_is_the_bartlett_weighted_lag_sum(seed):
    rng = np.random.default_rng(seed)
    n, p, smooth = int(rng.integers(3, 2500)), int(rng.integers(1, 10)), int(rng.integers(1, 40))
    e = np.convolve(rng.normal(size=n + smooth), np.ones(smooth), "valid")[:n]     # correlated residual
    X = np.column_stack([rng.normal(size=n), (rng.random((n, p - 1)) < 0.3).astype(float)])
    cov, lag = newey_west(X, e)
    assert 0 <= lag <= n // 10
    ref = _by_definition(X, e, lag)
    assert np.max(np.abs(cov - ref)) <= 1e-12 * np.max(np.abs(ref))
