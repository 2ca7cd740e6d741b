"""Text blocks shared by the fit reports (in the spirit of lmfit's ``fit_report``)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np


def variable_lines(values: Mapping[str, float], units: Mapping[str, str], stderr: Mapping[str, float],
                   notes: Mapping[str, str]) -> list[str]:
    """One line per parameter: value +/- standard error (relative), unit, and its note; "(fixed)" for
    parameters without a standard error."""
    width = max(len(n) for n in values)
    lines = []
    for name, value in values.items():
        if name in stderr:
            err = stderr[name]
            rel = f" ({100 * err / abs(value):.2f}%)" if math.isfinite(err) and value != 0 else ""
            note = notes.get(name, "")
            lines.append(f"    {name + ':':<{width + 1}} {value:.6g} +/- {err:.3g}{rel} {units[name]}{note}")
        else:
            lines.append(f"    {name + ':':<{width + 1}} {value:.6g} {units[name]} (fixed)")
    return lines


def correlation_lines(free: Sequence[str], correlation: np.ndarray, min_correlation: float = 0.1) -> list[str]:
    """The correlations above ``min_correlation`` in magnitude, largest first."""
    pairs = [(abs(correlation[i, j]), free[i], free[j], correlation[i, j])
             for i in range(len(free)) for j in range(i + 1, len(free))
             if np.isfinite(correlation[i, j]) and abs(correlation[i, j]) > min_correlation]
    if not pairs:
        return []
    return [f"[[Correlations]] (unreported correlations are < {min_correlation:.3f})"] + \
        [f"    C({a}, {b}) = {c:+.4f}" for _, a, b, c in sorted(pairs, reverse=True)]
