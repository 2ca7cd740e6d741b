"""Encoder lattices: velocities that are an encoder position differenced at the logging rate lie on
the lattice n q fs (quantum q, m; rate fs, Hz); the lock-in models that sensor when it finds one."""

from __future__ import annotations

import numpy as np

#: fewest distinct levels for values to be taken as lying on a lattice
MIN_LATTICE_LEVELS = 20
#: share of the values that must lie on the lattice
LATTICE_SHARE = 0.999
#: values screened before a large input is checked whole
LATTICE_SCREEN = 4096


def lattice_step(values: np.ndarray) -> float | None:
    """The step s when (almost) every value is an integer multiple n s of it, else None.

    An encoder position (quantum q, m) differenced at the logging rate fs gives velocities on
    the lattice n q fs. The step is first the smallest difference between sorted distinct values
    (differences below 1e-6 of the largest value are rounding of one level and skipped), then
    refined by least squares over all values, sum(n v) / sum(n^2), so that values written with
    9 or 10 significant digits still fit. Accepted when more than ``LATTICE_SHARE`` of the
    values are within 1e-6 + 1e-8 |n| of n s (the relative term: the printing precision of
    large counts) and at least ``MIN_LATTICE_LEVELS`` distinct levels occur (a few levels are
    also what a coarse but continuous signal shows). Continuous data has a smallest difference
    near 1e-6 of its range, so its values lie at random between lattice points: rejected.
    Large inputs are screened on every m-th value first (``LATTICE_SCREEN`` of them), so that
    continuous data is rejected without sorting all of it.
    """
    v = np.asarray(values, dtype=float).ravel()
    if v.size > 4 * LATTICE_SCREEN and _lattice_step(v[:: v.size // LATTICE_SCREEN]) is None:
        return None
    return _lattice_step(v)


def _lattice_step(v: np.ndarray) -> float | None:
    """``lattice_step`` of the 1-d array ``v``, without screening."""
    scale = float(np.max(np.abs(v), initial=0.0))
    if not scale > 0:
        return None
    levels = np.unique(v)
    steps = np.diff(levels)
    steps = steps[steps > 1e-6 * scale]
    if levels.size < MIN_LATTICE_LEVELS or steps.size == 0:
        return None
    n = np.round(v / steps.min())
    step = float(np.dot(n, v) / np.dot(n, n))
    n = np.round(v / step)
    on = np.abs(v / step - n) <= 1e-6 + 1e-8 * np.abs(n)
    if np.mean(on) <= LATTICE_SHARE or np.unique(n).size < MIN_LATTICE_LEVELS:
        return None
    return step
