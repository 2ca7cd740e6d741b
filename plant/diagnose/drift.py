"""A gain that drifts over a stepped-sine recording: a force constant falling as the coil warms (or a sensor's scale
creeping), which no effect of the library makes because it is a change in time, not in frequency.

A stepped sine records its frequencies one after the other (``block_time_s`` of the estimator: each block's middle,
seconds from the start), so a drift puts on the model a factor 1 + r (t_k - t_mid) per block: the magnitude moves
with block order and the phase does not (every causal effect that changes a magnitude changes its phase). The rate
r (fraction per second) is fitted by profile likelihood: for each r the model is refitted to the data divided by the
factor (variances by its square), which is the model times the factor against the data as measured; r's standard
error is the profile's curvature (-2 ln L rises by 1 at ±1σ). The drift counts as one parameter more in BIC.
When the model with the drift still leaves more than noise, its misfit is taken as over-dispersion c (its reduced
chi^2 over the expected, as QAIC takes the global model's: ``plant.diagnose.evidence``): the evidence is then the
chi^2 gain over c minus ln n and the standard error grows by sqrt(c), so a gain trend that merely absorbs part of
a misfit of another kind (a mode outside the library) is not named.

A diagnosis tries it on the model it reports when that model leaves more than noise (``plant.diagnose.diagnosis``):
the drift is named when it improves BIC by ``ACCEPT_DELTA_BIC`` (very strong evidence) with its rate ``DRIFT_Z``
standard errors from zero; it explains the recording when the drift-corrected fit is then consistent with the noise.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from plant.data.frequency_response import MeasuredResponse
from plant.diagnose.evidence import ACCEPT_DELTA_BIC
from plant.identify.fitting import FitResult, fit_plant

#: fewest blocks with times for a drift to be fitted
MIN_BLOCKS = 6
#: a drift is named only this many standard errors from zero
DRIFT_Z = 3.0
#: the largest change of the gain over the record that the fit considers (fraction)
MAX_CHANGE = 0.5


@dataclass(frozen=True)
class Drift:
    """The gain's drift over the record and the model refitted with it."""

    #: fractional change of the gain per second, and its standard error
    rate_per_s: float
    stderr_per_s: float
    #: seconds from the first block's middle to the last's
    span_s: float
    #: the model refitted on the drift-corrected data (its BIC, dof and reduced chi^2 count the rate)
    fit: FitResult
    #: BIC of the model without the drift minus with it (positive favours the drift); QBIC's with ``overdispersion``
    delta_bic: float
    #: the drift model's misfit taken as over-dispersion (1 when it is consistent with the noise)
    overdispersion: float = 1.0

    @property
    def change(self) -> float:
        """Fractional change of the gain from the first block to the last."""
        return self.rate_per_s * self.span_s

    @property
    def significant(self) -> bool:
        return self.delta_bic >= ACCEPT_DELTA_BIC and abs(self.rate_per_s) > DRIFT_Z * self.stderr_per_s

    def text(self) -> str:
        """'the gain falls 3.3 % (-0.29 dB) over the 240 s between the first and last block (block order; the phase
        unchanged), ±0.1 %'."""
        c, dc = self.change, self.stderr_per_s * self.span_s
        db = 20 * math.log10(max(1 + c, 1e-12))
        verb = "falls" if c < 0 else "rises"
        return (f"the gain {verb} {100 * abs(c):.2g} ± {100 * dc:.2g} % ({db:+.2f} dB) over the {self.span_s:.3g} s "
                "between the first block and the last, with the phase unchanged: a parameter drifting in time (a "
                "force constant as the coil warms, a sensor's scale), not an effect of frequency ("
                + ("ΔBIC" if self.overdispersion == 1.0 else "ΔQBIC") + f" {self.delta_bic:+.1f})")


def block_times(data: MeasuredResponse) -> np.ndarray | None:
    """Each frequency's block middle (s from the recording's start), None when the data have none (an estimate from
    broadband data) or too few blocks."""
    t = data.metadata.get("block_time_s")
    if t is None or len(t) != len(data.f_hz) or len(t) < MIN_BLOCKS:
        return None
    t = np.asarray(t, float)
    return t if np.all(np.isfinite(t)) and np.ptp(t) > 0 else None


def fit_drift(fit: FitResult, data: MeasuredResponse) -> Drift | None:
    """``fit``'s model with a gain drifting linearly in block time (module doc), None when ``data`` have no block
    times."""
    t = block_times(data)
    if t is None:
        return None
    tau = t - 0.5 * (t.min() + t.max())
    span = float(np.ptp(t))
    k_log_n = math.log(fit.n_data)
    start = {n: fit.values[n] for n in fit.free}
    cache: dict[float, FitResult] = {}

    def refit(r: float) -> FitResult:
        if r not in cache:
            scale = 1.0 + r * tau
            scaled = dataclasses.replace(data, response=data.response / scale, variance=data.variance / scale**2)
            near = min(cache, key=lambda q: abs(q - r)) if cache else None
            begin = start if near is None else {n: cache[near].values[n] for n in fit.free}
            cache[r] = fit_plant(fit.plant, scaled, free=fit.free, start=begin)
        return cache[r]

    def m2ll(r: float) -> float:
        return refit(r).bic - fit.n_params * k_log_n

    limit = MAX_CHANGE / span
    best, curvature = _parabola(m2ll, 0.0, 0.01 / span, limit)
    if best is None:         # not a bowl near zero: the bounded search
        best = optimize.minimize_scalar(m2ll, bounds=(-limit, limit), method="bounded",
                                        options={"xatol": 1e-4 / span}).x
        curvature = math.nan
    # the error where it is defined, -2 ln L rising by 1 at ±1σ: the curvature over ±1σ of the estimate
    h = math.sqrt(2.0 / curvature) if curvature > 0 else max(abs(best), 1e-3 / span) * 0.05
    curvature = (m2ll(best + h) - 2 * m2ll(best) + m2ll(best - h)) / h**2
    stderr = math.sqrt(2.0 / curvature) if curvature > 0 else math.inf
    drifted = refit(best)
    k, dof = drifted.n_params + 1, drifted.dof - 1
    counted = dataclasses.replace(drifted, n_params=k, dof=dof, bic=drifted.bic + k_log_n,
                                  aic=drifted.aic + 2.0, reduced_chi2=drifted.chi2 / dof if dof > 0 else math.nan)
    c = max(1.0, counted.reduced_chi2 / counted.expected_reduced_chi2) if dof > 0 else math.inf
    if c == 1.0:
        return Drift(float(best), stderr, span, counted, fit.bic - counted.bic, 1.0)
    gain = (fit.chi2 - counted.chi2) / (c * counted.expected_reduced_chi2) - k_log_n
    return Drift(float(best), stderr * math.sqrt(c), span, counted, gain, c)


def _parabola(f, x0: float, h: float, limit: float, steps: int = 3) -> tuple[float | None, float]:
    """Newton steps on the profile -2 ln L(r), nearly a parabola in the rate: the vertex of the parabola through
    f(x - h), f(x), f(x + h), moved to and re-fitted there until it stays within a tenth of h (a few refits where a
    bounded search takes twenty); (None, nan) when the three points are not a bowl or the vertex leaves the range."""
    x = x0
    for _ in range(steps):
        lo, mid, hi = f(x - h), f(x), f(x + h)
        curvature = (hi - 2 * mid + lo) / h**2
        if not curvature > 0:
            return None, math.nan
        step = -(hi - lo) / (2 * h * curvature)
        if abs(x + step) > limit:
            return None, math.nan
        x += step
        if abs(step) < 0.1 * h:
            return x, curvature
        h = max(min(h, abs(step)), 1e-6 * limit)
    return x, curvature
