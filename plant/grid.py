"""Frequency grids: validation and the default log-spaced grids (rad/s inside the library).

May import: ``plant.errors``."""

from __future__ import annotations

import numpy as np

from plant.errors import GridError


def check_grid(w_rad_s, *, name: str = "frequency grid") -> np.ndarray:
    """Return ``w_rad_s`` as a 1-D float array; raise ``GridError`` unless it is non-empty,
    finite, positive and strictly increasing."""
    if isinstance(w_rad_s, str | bytes) or np.asarray(w_rad_s).dtype.kind not in "iuf":
        raise GridError(f"{name} must be an array of numbers (rad/s), got {type(w_rad_s).__name__} {w_rad_s!r}"[:300])
    w = np.asarray(w_rad_s, dtype=float)
    if w.ndim != 1 or w.size == 0:
        raise GridError(f"{name} must be a non-empty 1-D array of frequencies, got shape {w.shape}")
    if not np.all(np.isfinite(w)):
        raise GridError(f"{name} contains NaN or infinite frequencies")
    if np.any(w <= 0):
        raise GridError(f"{name} must be positive (rad/s), got minimum {w.min():g}")
    if w.size > 1 and np.any(np.diff(w) <= 0):
        i = int(np.argmax(np.diff(w) <= 0))
        raise GridError(f"{name} must be strictly increasing: element {i + 1} ({w[i + 1]:g}) <= element {i} ({w[i]:g})")
    return w


def log_grid_rad_s(f_low_hz: float = 0.01, f_high_hz: float = 1.0e4, points: int = 4000) -> np.ndarray:
    """Log-spaced grid in rad/s between two frequencies given in Hz."""
    if not (0 < f_low_hz < f_high_hz) or points < 2:
        raise GridError(f"need 0 < f_low_hz < f_high_hz and points >= 2, got {f_low_hz}, {f_high_hz}, {points}")
    return 2 * np.pi * np.logspace(np.log10(f_low_hz), np.log10(f_high_hz), int(points))
