"""The one shape of a fit result, whatever was fitted (lmfit's one ``ModelResult`` in spirit).

``Fit`` holds what every fit reports (data points, estimated parameters, starts, flags) and tells it as a
story (``plant.story``): Model, Fit Statistics, the kind's own sections, Flags; ``report`` is its plain text.
``PlantFit`` adds the physical parameters of a fitted ``Plant`` (values, standard errors,
covariance, correlation) and their ``[[Variables]]`` and ``[[Correlations]]`` sections. The
frequency-domain (``plant.identify.fitting.FitResult``), time-domain
(``plant.identify.time_fit.TimeFitResult``) and rational (``plant.identify.rational_fit.RationalFit``)
results extend them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from plant.physics.models import Plant
from plant.story import Section, Story, unit_text


@dataclass(frozen=True, kw_only=True)
class Fit:
    """What every fit reports."""

    #: real data values the fit used, and the parameters it estimated
    n_data: int
    n_params: int
    #: what makes the fit doubtful, one sentence each; empty for a clean fit
    flags: tuple[str, ...]
    #: starts refined (the best kept)
    n_starts: int

    def story(self) -> Story:
        """The fit's report: the model, its statistics, the kind's own sections and the flags."""
        flags = (Section("Flags", self.flags, kind="notes"),) if self.flags else ()
        return Story(sections=(Section("Model", tuple(self._model_lines())),
                               Section("Fit Statistics", tuple(self._statistics_lines())),
                               *self._sections(), *flags))

    def report(self) -> str:
        """Text report in the spirit of lmfit's ``fit_report`` (``story`` as plain text)."""
        return self.story().text()

    def _model_lines(self) -> list[str]:
        raise NotImplementedError

    def _statistics_lines(self) -> list[str]:
        raise NotImplementedError

    def _sections(self) -> list[Section]:
        return []


@dataclass(frozen=True, kw_only=True)
class PlantFit(Fit):
    """A fit of a physical ``Plant``: every parameter's value (SI), the free ones' standard errors,
    covariance and correlation (rows and columns in ``free`` order)."""

    plant: Plant
    values: dict[str, float]
    free: tuple[str, ...]
    stderr: dict[str, float]
    covariance: np.ndarray
    correlation: np.ndarray

    @property
    def effect_names(self) -> tuple[str, ...]:
        return self.plant.effect_names

    def correlation_of(self, a: str, b: str) -> float:
        i, j = self.free.index(a), self.free.index(b)
        return float(self.correlation[i, j])

    def _variables_aside(self) -> str:
        """The rest of the Variables section's title line (what the errors are)."""
        return ""

    def _variable_notes(self) -> Mapping[str, str]:
        """A note after each free parameter's line (its start, another standard error)."""
        return {}

    def _sections(self) -> list[Section]:
        units = {n: p.unit for n, p in self.plant.parameters().items()}
        variables = Section("Variables", tuple(variable_lines(self.values, units, self.stderr, self._variable_notes())),
                            aside=self._variables_aside())
        correlations = correlation_section(self.free, self.correlation)
        return [variables] + ([correlations] if correlations is not None else [])


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
            lines.append(f"{name + ':':<{width + 1}} {value:.6g} +/- {err:.3g}{rel} {unit_text(units[name])}{note}")
        else:
            lines.append(f"{name + ':':<{width + 1}} {value:.6g} {unit_text(units[name])} (fixed)")
    return lines


def correlation_section(free: Sequence[str], correlation: np.ndarray,
                        min_correlation: float = 0.1) -> Section | None:
    """The correlations above ``min_correlation`` in magnitude, largest first (None: none is)."""
    pairs = [(abs(correlation[i, j]), free[i], free[j], correlation[i, j])
             for i in range(len(free)) for j in range(i + 1, len(free))
             if np.isfinite(correlation[i, j]) and abs(correlation[i, j]) > min_correlation]
    if not pairs:
        return None
    return Section("Correlations", tuple(f"C({a}, {b}) = {c:+.4f}" for _, a, b, c in sorted(pairs, reverse=True)),
                   aside=f"(unreported correlations are < {min_correlation:.3f})")
