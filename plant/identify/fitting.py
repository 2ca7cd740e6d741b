"""Maximum-likelihood fit of a physical plant (with effects) to a measured frequency response.

The measured G_k of every output has circular complex noise of variance var_k
(``MeasuredResponse.variance``: real and imaginary parts each var_k / 2), so the negative
log-likelihood is, up to a constant, chi^2 / 2 with

    chi^2 = sum_k |G_model(jw_k) - G_k|^2 / var_k
          = sum over [Re; Im] of ((G_model - G) / sqrt(var / 2))^2,

the real and imaginary parts split explicitly. ``fit_plant`` minimises it over the named
bounded parameters of ``Plant.parameters()`` with ``scipy.optimize.least_squares``,
optimising log(p) for parameters with a positive lower bound and p / scale otherwise, so a
1 ms delay and a 40 kg mass are equally well conditioned. Standard errors come from the
Jacobian J of the normalised residuals at the optimum: cov = (J^T J)^-1, the Cramer-Rao bound
when the variances are known. Measured variances are themselves estimates (the lock-in's k
sub-blocks give each about nu = 2 (k - 1) real degrees of freedom); weighting by them makes
the estimate noisier than (J^T J)^-1 says, by E[sigma^2/s^4] / E[1/s^2] = nu / (nu - 4) per
point for s^2 ~ sigma^2 chi^2_nu / nu, so the covariance is the sandwich
(J^T J)^-1 J^T diag(nu/(nu-4)) J (J^T J)^-1, and a correct model's chi^2 has expectation
nu / (nu - 2) per residual instead of 1 (``expected_reduced_chi2``). ``stderr_scaled`` is
lmfit's ``scale_covar``: sqrt(diag((J^T J)^-1) * reduced chi-square).

Refitting with one more effect is one call: ``fit_plant(result.plant * Delay(), data)``;
the previous values are one of the starting points.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import special
from scipy.optimize import least_squares

from plant.data.frequency_response import MeasuredResponse
from plant.errors import DataError, EffectError, ParameterError
from plant.identify.fit_result import PlantFit
from plant.physics.models import BASE_BOUNDS, Plant
from plant.physics.parameters import Parameter, check_finite

#: |correlation| above which two parameters are flagged as not separable by the data
CORRELATION_FLAG = 0.95
#: a fit is flagged as not explaining the data when P(chi^2 >= observed) is below this
CHI2_P_FLAG = 1e-3
#: ratio bounds antiresonance / resonance frequency when both are free
_RATIO_BOUNDS = (1e-3, 0.999)
#: starts polished by least squares after the projected scan (the best few of the candidates)
N_POLISH = 3
#: most candidate starts scanned per fit (a product of the effects' guesses is thinned to this)
MAX_CANDIDATES = 4096


@dataclass(frozen=True, kw_only=True)
class FitResult(PlantFit):
    """Immutable result of ``fit_plant``. Arrays of responses are shaped (n_outputs, n_freq); ``stderr`` is
    (J^T J)^-1 corrected for the variances' degrees of freedom (module doc); inf: not determined by the data."""

    #: sqrt(diag((J^T J)^-1) * reduced_chi2) (lmfit's scale_covar)
    stderr_scaled: dict[str, float]
    #: starting values of the winning start
    initial: dict[str, float]
    f_hz: np.ndarray
    output_names: tuple[str, ...]
    #: fitted model response at the data's outputs and frequencies (m/s per A)
    model_response: np.ndarray
    #: normalised complex residuals (G - G_model) / sqrt(var / 2): real and imag each ~ N(0, 1)
    residuals: np.ndarray
    chi2: float
    dof: int
    reduced_chi2: float
    #: expectation of reduced_chi2 for a correct model: mean nu / (nu - 2) over the residuals
    #: (1 when the variances are known exactly)
    expected_reduced_chi2: float
    #: real degrees of freedom of each frequency's variance estimate (inf: known exactly)
    variance_dof: np.ndarray
    #: -2 ln L + 2 k and -2 ln L + k ln n (``minus_two_log_likelihood``)
    aic: float
    bic: float
    success: bool
    message: str
    n_evaluations: int
    elapsed_s: float

    @property
    def chi2_per_frequency(self) -> np.ndarray:
        """Contribution of each frequency to chi^2 (summed over outputs), shape (n_freq,)."""
        return np.sum(np.abs(self.residuals) ** 2, axis=0)

    def _model_lines(self) -> list[str]:
        return [f"stage {self.plant.stage.upper()}, effects: {', '.join(self.effect_names) or 'none'}"]

    def _statistics_lines(self) -> list[str]:
        n_out, n_f = self.residuals.shape
        return [
            f"# data points      = {self.n_data} ({n_f} frequencies x {n_out} output(s) x re/im)",
            f"# variables        = {self.n_params}",
            f"chi-square         = {self.chi2:.6g}",
            f"reduced chi-square = {self.reduced_chi2:.6g} (expected {self.expected_reduced_chi2:.4g} for a "
            "correct model)",
            f"Akaike info crit   = {self.aic:.6g}",
            f"Bayesian info crit = {self.bic:.6g}",
            f"starts, evaluations = {self.n_starts}, {self.n_evaluations}",
            f"success            = {self.success} ({self.message})",
        ]

    def _variable_notes(self) -> dict[str, str]:
        return {n: f" (init = {self.initial[n]:.6g})" for n in self.stderr}


# --- data <-> model outputs -----------------------------------------------------------------
def _normalise_output_name(name: str) -> str:
    n = name.strip().lower()
    for suffix in ("_m_per_s", "_mps", "_m_s"):
        if n.endswith(suffix):
            n = n[: -len(suffix)]
    return n


def output_map(plant: Plant, output_names: Sequence[str]) -> tuple[int, ...]:
    """Model row compared with each data output: index into ``plant.output_names``, or -1 for the
    mean of the outputs (a single-output Stage Y recording). Matched by name (unit suffix
    ignored), else by position when the counts agree."""
    model = plant.output_names
    data = [_normalise_output_name(n) for n in output_names]
    if all(d in model for d in data):
        return tuple(model.index(d) for d in data)
    if len(data) == len(model):
        return tuple(range(len(model)))
    if len(model) == 1:
        return (0,) * len(data)
    if len(data) == 1:
        return (-1,)
    raise DataError(f"cannot match data outputs {list(output_names)} to the Stage {plant.stage.upper()} "
                    f"outputs {list(model)}")


def at_outputs(out: np.ndarray, rows: Sequence[int]) -> np.ndarray:
    """The plant's outputs (..., n_outputs, n_freq) at the data's (``output_map``: -1 is their mean)."""
    return np.stack([out.mean(axis=-2) if r < 0 else out[..., r, :] for r in rows], axis=-2)


def _check_data(data: MeasuredResponse) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    f = np.asarray(data.f_hz, dtype=float)
    g = np.atleast_2d(np.asarray(data.response))
    var = np.atleast_2d(np.asarray(data.variance, dtype=float))
    where = f"measured response {data.source}"
    if f.ndim != 1 or f.size == 0:
        raise DataError(f"{where}: f_hz must be a non-empty 1-D array")
    if g.shape != (len(data.output_names), f.size) or var.shape != g.shape:
        raise DataError(f"{where}: response and variance must be shaped (n_outputs={len(data.output_names)}, "
                        f"n_freq={f.size}), got {g.shape} and {var.shape}")
    if not np.all(np.isfinite(f)) or np.any(f <= 0) or np.any(np.diff(f) <= 0):
        raise DataError(f"{where}: f_hz must be positive, finite and strictly increasing")
    for k, name in enumerate(data.output_names):
        bad = ~np.isfinite(g[k])
        if bad.any():
            raise DataError(f"{where}: output {name} has a non-finite response at {f[bad.argmax()]:g} Hz")
        bad = ~(np.isfinite(var[k]) & (var[k] > 0))
        if bad.any():
            raise DataError(f"{where}: output {name} has variance {float(var[k][bad.argmax()])!r} at "
                            f"{f[bad.argmax()]:g} Hz; fitting needs positive finite variances")
    return f, g.astype(complex), var


# --- coordinates: physical values <-> well-conditioned optimiser variables --------------------
def _ratio_reference(name: str, names) -> str | None:
    """The resonance of the same effect when ``name`` is an antiresonance whose resonance is in ``names``."""
    effect, _, field = name.rpartition(".")
    ref = f"{effect}.frequency_hz"
    return ref if field == "antiresonance_hz" and ref in names else None


@dataclass(frozen=True)
class _Coordinates:
    """Maps optimiser variables x to physical values: log(p) when the lower bound is positive,
    p / scale otherwise; an antiresonance as log(ratio to its resonance) when both are free
    (keeps the notch below the peak)."""

    names: tuple[str, ...]
    kinds: tuple[str, ...]          # "log" | "lin" | "ratio"
    scales: tuple[float, ...]
    lower: np.ndarray
    upper: np.ndarray

    def to_values(self, x: np.ndarray) -> dict[str, float]:
        out = {}
        for name, kind, scale, xi in zip(self.names, self.kinds, self.scales, x):
            if kind == "lin":
                out[name] = float(xi * scale)
            elif kind == "log":
                out[name] = float(math.exp(xi))
        for name, kind, xi in zip(self.names, self.kinds, x):
            if kind == "ratio":
                out[name] = out[_ratio_reference(name, self.names)] * math.exp(xi)
        return out

    def to_x(self, values: Mapping[str, float]) -> np.ndarray:
        x = []
        for name, kind, scale in zip(self.names, self.kinds, self.scales):
            v = values[name]
            if kind == "lin":
                x.append(v / scale)
            elif kind == "log":
                x.append(math.log(v))
            else:
                x.append(math.log(v / values[_ratio_reference(name, self.names)]))
        return np.clip(np.array(x), self.lower, self.upper)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """d values / d x, shape (n, n) (rows: values, columns: x)."""
        vals = self.to_values(x)
        n = len(self.names)
        D = np.zeros((n, n))
        for i, (name, kind, scale) in enumerate(zip(self.names, self.kinds, self.scales)):
            if kind == "lin":
                D[i, i] = scale
            elif kind == "log":
                D[i, i] = vals[name]
            else:
                D[i, i] = vals[name]
                D[i, self.names.index(_ratio_reference(name, self.names))] = vals[name]
        return D


def _bounds_of(name: str, params: Mapping[str, Parameter], free: Sequence[str]) -> tuple[float, float]:
    """Bounds of ``name``, an antiresonance kept below its fixed resonance (and the reverse)."""
    p = params[name]
    lower, upper = p.lower, p.upper
    effect, _, field = name.rpartition(".")
    if field == "antiresonance_hz" and f"{effect}.frequency_hz" in params:
        upper = min(upper, params[f"{effect}.frequency_hz"].value * _RATIO_BOUNDS[1])
    if field == "frequency_hz" and f"{effect}.antiresonance_hz" in params and \
            f"{effect}.antiresonance_hz" not in free:
        lower = max(lower, params[f"{effect}.antiresonance_hz"].value / _RATIO_BOUNDS[1])
    return lower, upper


def _coordinates(free: Sequence[str], params: Mapping[str, Parameter], start: Mapping[str, float]) -> _Coordinates:
    kinds, scales, lo, hi = [], [], [], []
    for name in free:
        if _ratio_reference(name, free):
            kinds.append("ratio")
            scales.append(1.0)
            lo.append(math.log(_RATIO_BOUNDS[0]))
            hi.append(math.log(_RATIO_BOUNDS[1]))
            continue
        lower, upper = _bounds_of(name, params, free)
        if lower > 0:
            kinds.append("log")
            scales.append(1.0)
            lo.append(math.log(lower))
            hi.append(math.log(upper) if math.isfinite(upper) else np.inf)
        else:
            v = abs(start[name])
            scale = v if v > 0 else ((upper - lower) / 20 if math.isfinite(upper - lower) else 1.0)
            kinds.append("lin")
            scales.append(scale)
            lo.append(lower / scale)
            hi.append(upper / scale)
    return _Coordinates(tuple(free), tuple(kinds), tuple(scales), np.array(lo), np.array(hi))


# --- starting values ----------------------------------------------------------------------
def _first_order(w: np.ndarray, g: np.ndarray, var: np.ndarray, tau: float) -> tuple[float, float]:
    """Levy's linear fit of g e^(jw tau) ~ 1 / (m s + b) (weighted by |g|^2 / sd): returns (m, b)."""
    z = np.exp(-1j * w * tau) / g
    wt = np.abs(g) ** 2 / np.sqrt(var)
    A = np.vstack([np.column_stack([wt, np.zeros_like(w)]), np.column_stack([np.zeros_like(w), w * wt])])
    b, m = np.linalg.lstsq(A, np.concatenate([z.real * wt, z.imag * wt]), rcond=None)[0]
    return abs(float(m)), abs(float(b))


def _phase_delay(w: np.ndarray, g: np.ndarray, var: np.ndarray, m: float, b: float) -> float:
    """Delay (>= 0) from the phase slope of g (m s + b) through the origin, weighted by |g|^2 / var."""
    phase = np.unwrap(np.angle(g * (1j * w * m + b)))
    pw = np.abs(g) ** 2 / var
    return max(-float(np.sum(pw * w * phase) / np.sum(pw * w * w)), 0.0)


def _clip(params: Mapping[str, Parameter], name: str, value: float, free: Sequence[str] = ()) -> float:
    lo, hi = _bounds_of(name, params, free)
    return float(min(max(value, lo), hi))


def rigid_start(plant: Plant, w: np.ndarray, g_mean: np.ndarray, var_mean: np.ndarray) -> dict[str, float]:
    """Mass and damping of the rigid body from the data: a first-order fit of the lowest third of
    the frequencies alternating with the delay seen in the phase of all of them (three rounds)."""
    params = plant.parameters()
    unit = dataclasses.replace(plant, mass_kg=1.0, damping_n_s_per_m=1.0, force_constant_n_per_a=1.0, effects=())
    z1 = 1.0 / unit.frd(w[:1])[0]
    c_b, c_m = float(z1.real), float(z1.imag / w[0])
    kt = params["force_constant_n_per_a"].value
    low = slice(0, max(3, len(w) // 3))
    gn, vn, tau = g_mean / kt, var_mean / kt**2, 0.0
    for _ in range(3):
        m_e, b_e = _first_order(w[low], gn[low], vn[low], tau)
        tau = _phase_delay(w, gn, vn, m_e, b_e)
    return {"mass_kg": _clip(params, "mass_kg", m_e / c_m), "damping_n_s_per_m": _clip(params, "damping_n_s_per_m",
                                                                                       b_e / c_b)}


def effect_candidates(plant: Plant, free: Sequence[str], w: np.ndarray, g: np.ndarray,
                      model: np.ndarray) -> list[dict[str, float]]:
    """Candidate values of the free effect parameters: the product of each effect's ``guesses`` from
    the data divided by ``model`` (and its neutral values), thinned to ``MAX_CANDIDATES``."""
    ratio = g / model
    per_effect = []
    for e in plant.effects:
        names = [n for n in e.bounds if f"{e.name}.{n}" in free]
        if not names:
            continue
        options = [dict(e.neutral)] + e.guesses(w, ratio)
        opts = [{f"{e.name}.{k}": v for k, v in o.items() if k in names} for o in options]
        per_effect.append([o for o in opts if o])
    out: list[dict[str, float]] = [{}]
    for opts in per_effect:
        out = [{**a, **b} for a in out for b in opts]
    if len(out) > MAX_CANDIDATES:
        out = out[:: math.ceil(len(out) / MAX_CANDIDATES)]
    return out


# --- the fit ------------------------------------------------------------------------------
def default_free(plant: Plant) -> tuple[str, ...]:
    """Mass, damping and every effect parameter (the force constant stays fixed)."""
    return ("mass_kg", "damping_n_s_per_m") + tuple(n for n in plant.parameters()
                                                    if n not in ("mass_kg", "damping_n_s_per_m",
                                                                 "force_constant_n_per_a"))


def _check_arguments(plant, data, start, starts) -> None:
    """``fit_plant``'s arguments: a ``Plant``, a complex ``MeasuredResponse``, finite numeric starts."""
    if not isinstance(plant, Plant):
        raise ParameterError(f"fit_plant: plant must be a Plant (e.g. plant.stage_x()), got {type(plant).__name__}")
    if not isinstance(data, MeasuredResponse):
        raise DataError(f"fit_plant: data must be a MeasuredResponse (plant.estimate.estimate_response), got "
                        f"{type(data).__name__}")
    if data.method == "rms" or not np.iscomplexobj(data.response) or np.all(np.imag(data.response) == 0):
        raise DataError(f"measured response {data.source}: holds magnitudes only (no phase; method "
                        f"{data.method!r}); a fit needs the complex response G = V/I of the lock-in estimate, "
                        "whose phase carries the mass, the delay and the lags")
    for k, candidate in enumerate([start] if start is not None else list(starts or [])):
        if not isinstance(candidate, Mapping):
            raise ParameterError(f"fit_plant: a start must map parameter names to values, got "
                                 f"{type(candidate).__name__}")
        for name, value in candidate.items():
            check_finite(f"{name} (start{'' if start is not None else f' {k + 1}'})", value)


def fit_plant(plant: Plant, data: MeasuredResponse, *, free: Sequence[str] | None = None,
              start: Mapping[str, float] | None = None, starts: Sequence[Mapping[str, float]] | None = None,
              multistart: bool = True, variance_dof=None) -> FitResult:
    """Maximum-likelihood fit of ``plant``'s ``free`` parameters to ``data`` (see module doc).

    ``free`` defaults to ``default_free(plant)``. Starting values, global first:

    * ``start``: exactly one start, polished as given;
    * ``starts``: candidate starts (missing names take the plant's values), e.g. a parent model's
      optimum with the new effect at its neutral values and at its guesses. The first is always
      polished, so a model that contains another and starts from its optimum never ends worse;
    * neither: the plant's own values, and the rigid body from the data (``rigid_start``) with
      every combination of the effects' guesses (``effect_candidates``).

    Candidates are scanned with the mass and damping projected out (1/P is affine in them for a
    chain of bodies: variable projection by reweighted linear least squares), and the best
    ``N_POLISH`` are polished by ``least_squares`` over all free parameters; the lowest chi^2 wins.
    ``multistart=False``: only the plant's own values. A nonlinear plant (``coulomb_friction``)
    gets ``excitation_current_a`` from the data per frequency; that amplitude is itself measured, so
    once fitted, each point's variance also carries its error (``with_current_noise``) and the fit is
    polished again from its optimum. ``variance_dof``: real degrees of
    freedom of each frequency's variance (scalar or per frequency; inf = known exactly); default
    ``data.metadata["variance_dof"]`` from the estimator (else 2 (k - 1) from its sub-block counts
    ``data.metadata["subblocks"]``), else inf.
    """
    _check_arguments(plant, data, start, starts)
    result = _fit(plant, data, free=free, start=start, starts=starts, multistart=multistart,
                  variance_dof=variance_dof)
    if result.plant.linear or not np.all(np.isfinite(np.asarray(data.current_amplitude_variance, float))):
        return result
    again = _fit(result.plant, with_current_noise(result.plant, data), free=result.free,
                 start={n: result.values[n] for n in result.free}, starts=None, multistart=False,
                 variance_dof=variance_dof)
    return dataclasses.replace(again, initial=result.initial, n_starts=result.n_starts,
                               n_evaluations=result.n_evaluations + again.n_evaluations,
                               elapsed_s=result.elapsed_s + again.elapsed_s)


def with_current_noise(plant: Plant, data: MeasuredResponse) -> MeasuredResponse:
    """``data`` whose variance also carries the error of the measured current amplitude I, on which the
    response of a nonlinear ``plant`` depends (errors in variables, to first order). A radial error dI
    moves the residual G - G_model by -(G / I + dG_model/dI) dI; the ratio's part |G / I|^2 var(I) is
    already in the measured variance, so each point gains (|G / I + dG_model/dI|^2 - |G / I|^2) var(I)
    (never less than nothing)."""
    amp = np.asarray(data.current_amplitude_a, float)
    step = 1e-6 * amp
    rows = output_map(plant, data.output_names)

    def model(a):
        return at_outputs(dataclasses.replace(plant, excitation_current_a=a).frd_outputs(data.w_rad_s), rows)

    slope = (model(amp + step) - model(amp - step)) / (2 * step)
    ratio = np.asarray(data.response) / amp
    extra = np.maximum(np.abs(ratio + slope) ** 2 - np.abs(ratio) ** 2, 0.0) * data.current_amplitude_variance
    return dataclasses.replace(data, variance=np.asarray(data.variance) + extra,
                               metadata={**data.metadata, "variance": "measurement + current amplitude"})


def _fit(plant: Plant, data: MeasuredResponse, *, free, start, starts, multistart, variance_dof) -> FitResult:
    """``fit_plant`` on the data's own variances."""
    t0 = time.perf_counter()
    f, g, var = _check_data(data)
    nu = _variance_dof(data, f.size, variance_dof)
    w = 2 * np.pi * f
    if not plant.linear:
        plant = dataclasses.replace(plant, excitation_current_a=np.asarray(data.current_amplitude_a, dtype=float))
    params = plant.parameters()
    free = tuple(default_free(plant) if free is None else free)
    for name in free:
        if name not in params:
            kind = EffectError if "." in name and name.split(".", 1)[0] not in plant.effect_names else ParameterError
            raise kind(f"cannot fit {name!r}: the plant's parameters are {', '.join(params)}")
    if len(set(free)) != len(free) or not free:
        raise ParameterError(f"free parameters must be distinct and at least one, got {list(free)}")
    n_data = 2 * g.size
    if n_data <= len(free):
        raise DataError(f"{g.size} frequenc{'y gives' if g.size == 1 else 'ies give'} {n_data} real values, too few "
                        f"to determine the {len(free)} free parameters ({', '.join(free)}); record more frequencies")
    rows = output_map(plant, data.output_names)
    sigma = np.sqrt(var / 2)
    own = {n: params[n].value for n in free}

    if start is not None:
        unknown = set(start) - set(free)
        if unknown:
            raise ParameterError(f"start value for {sorted(unknown)[0]!r}, which is not free ({', '.join(free)})")
        chosen = [{**own, **{k: float(v) for k, v in start.items()}}]
        n_candidates = 1
    else:
        if starts is not None:
            candidates = [{**own, **{k: float(v) for k, v in c.items() if k in own}} for c in starts]
        else:
            rigid = {k: v for k, v in rigid_start(plant, w, g.mean(axis=0), var.mean(axis=0) / g.shape[0]).items()
                     if k in own}
            rigid_model = dataclasses.replace(plant.with_values(rigid), effects=()).frd(w)
            candidates = [own] + [{**own, **rigid, **c} for c in effect_candidates(plant, free, w, g, rigid_model)]
            if not multistart:
                candidates = candidates[:1]
        candidates = [{n: _clip(params, n, v, free) for n, v in c.items()} for c in candidates]
        n_candidates = len(candidates)
        chosen = _scan(plant, w, g, sigma, rows, free, candidates, keep_first=starts is not None)

    # a short least-squares run from every chosen start, then the best one to convergence
    best = None
    n_eval = 0
    for s in chosen:
        s = {n: _clip(params, n, v, free) for n, v in s.items()}
        problem = _Problem(plant, w, g, sigma, rows, _coordinates(free, params, s))
        sol = _least_squares(problem, problem.coords.to_x(s), short=len(chosen) > 1)
        n_eval += problem.n_evaluations
        if best is None or sol.cost < best[0].cost:
            best = (sol, problem, s)
    sol, problem, s0 = best
    if len(chosen) > 1:
        problem.n_evaluations = 0
        sol = _least_squares(problem, sol.x, short=False)
        n_eval += problem.n_evaluations
    problem.n_evaluations = 0
    sol = _off_lower_bounds(problem, sol)
    n_eval += problem.n_evaluations
    return _result(problem, params, sol, s0, data, nu, n_starts=n_candidates, n_eval=n_eval,
                   elapsed=time.perf_counter() - t0)


#: a log coordinate this close to its lower bound is moved off it (by _REPOLISH_STEP above the bound) and
#: polished again
_NEAR_BOUND = math.log(2)
_REPOLISH_STEP = math.log(10)
#: a polish's evaluations per free parameter + 1: at first, then per further stretch, and in all; it goes on past the
#: first only while a stretch lowers the cost by more than ``CRAWL`` of it
POLISH_FIRST, POLISH_STRETCH, POLISH_MAX = 40, 10, 100
CRAWL = 1e-4
#: the first stretch of a re-polish off a bound (``_off_lower_bounds``)
REPOLISH_FIRST = 15


def _off_lower_bounds(problem: _Problem, sol):
    """``sol``, or a polish from it with every log coordinate within ln 2 of its lower bound moved to the
    bound + ln 10, whichever costs less. In a flat direction of near +-1 correlations (e.g. a lightly damped
    resonance traded against others) the polish can stop with a damping pinned at its bound, in a worse
    basin than one it reaches from off the bound. The move is a start like the others: a polish that has not
    converged after ``REPOLISH_FIRST`` (n + 1) evaluations goes on only when it already costs less than ``sol``
    (a model the data reject crawled 1,000 evaluations along its valley for nothing; the basins ``diagnose_x``
    leaves are found alike)."""
    coords = problem.coords
    near = np.array([kind == "log" and np.isfinite(lo) and x - lo < _NEAR_BOUND
                     for kind, lo, x in zip(coords.kinds, coords.lower, sol.x)], dtype=bool)
    if not near.any():
        return sol
    x0 = sol.x.copy()
    x0[near] = np.minimum(coords.lower[near] + _REPOLISH_STEP, coords.upper[near])
    again = _least_squares(problem, x0, short=False, first=REPOLISH_FIRST, overtake=sol.cost)
    return again if again.cost < sol.cost else sol


def _least_squares(problem: _Problem, x0: np.ndarray, *, short: bool, first: int = POLISH_FIRST,
                   overtake: float | None = None):
    """scipy's trust-region reflective least squares in the problem's coordinates; ``short``: a
    few iterations to rank starts.

    A polish that has not converged after its first ``POLISH_FIRST`` (n + 1) evaluations goes on in stretches
    while each lowers the cost by more than ``CRAWL`` of it: a model the data reject (two resonances standing in
    for Stage Y's yaw mode, reduced chi^2 1e5) otherwise crawled along a flat valley to the limit, 0.02 % lower
    after 1,000 evaluations, a change no ranking can see (BIC when an adequate model exists; QBIC's unit is the
    misfit itself). ``first``: the first stretch; ``overtake``: a cost the polish must be below after it to go
    on."""
    n = x0.size
    tol = 1e-6 if short else 1e-9

    def run(x, evaluations):
        return least_squares(problem.residuals, x, jac=problem.jacobian,
                             bounds=(problem.coords.lower, problem.coords.upper), method="trf", x_scale="jac",
                             xtol=tol, ftol=tol, gtol=tol, max_nfev=evaluations * (n + 1))

    if short:
        return run(x0, 15)
    sol = run(x0, first)
    used = first
    if overtake is not None and sol.cost >= overtake:
        return sol
    while sol.status == 0 and used < POLISH_MAX:
        step = min(POLISH_STRETCH, POLISH_MAX - used)
        again = run(sol.x, step)
        used += step
        crawled = sol.cost - again.cost < CRAWL * sol.cost
        sol = again if again.cost <= sol.cost else sol
        if crawled:
            break
    return sol


#: candidates evaluated per batched model call of the scan
_SCAN_CHUNK = 256
_PROJECTED = ("mass_kg", "damping_n_s_per_m")


def _scan(plant: Plant, w, g, sigma, rows, free, candidates: list[dict[str, float]], *,
          keep_first: bool) -> list[dict[str, float]]:
    """The ``N_POLISH`` candidates of lowest chi^2 (the first one too when ``keep_first``), each
    with the mass and damping that fit it best when they are free and 1/P is affine in them."""
    if len(candidates) <= N_POLISH:
        return candidates
    project = all(n in free for n in _PROJECTED) and plant.affine_in_mass_damping
    problem = _Problem(plant, w, g, sigma, rows, None)
    chi2, scanned = [], []
    for i in range(0, len(candidates), _SCAN_CHUNK):
        chunk = candidates[i:i + _SCAN_CHUNK]
        batch = {n: np.array([c[n] for c in chunk]).reshape(-1, 1) for n in free}
        if project:
            batch.update(_project_mass_damping(problem, batch, g, sigma))
        model = problem.model(batch)
        chi2.append(np.sum(np.abs((model - g) / sigma) ** 2, axis=(-2, -1)))
        scanned += [{n: float(np.asarray(batch[n]).reshape(-1)[k]) for n in free} for k in range(len(chunk))]
    order = np.argsort(np.concatenate(chi2), kind="stable")
    chosen = [scanned[0]] if keep_first else []
    for k in order:
        if len(chosen) >= N_POLISH + keep_first:
            break
        if not any(all(math.isclose(scanned[k][n], c[n], rel_tol=1e-6) for n in free) for c in chosen):
            chosen.append(scanned[k])
    return chosen


def _project_mass_damping(problem: _Problem, batch: dict, g: np.ndarray, sigma: np.ndarray) -> dict:
    """Mass and damping minimising chi^2 for every candidate of ``batch`` with the others fixed.

    1/P = m a(s) + b beta(s) for a chain of bodies (the ladder impedance scales with the mass, the
    rail damping adds), so a and beta follow from three model evaluations. The weighted misfit
    (G (m a + b beta) - 1) / ((m a + b beta) sigma) is linear in (m, b) for fixed weights: three
    reweighted linear least-squares rounds (Steiglitz-McBride) from weights |G| / sigma."""
    k = len(next(iter(batch.values())))
    one, two = np.ones((k, 1)), np.full((k, 1), 2.0)
    u11 = 1.0 / problem.model({**batch, "mass_kg": one, "damping_n_s_per_m": one})
    a = 1.0 / problem.model({**batch, "mass_kg": two, "damping_n_s_per_m": one}) - u11
    beta = 1.0 / problem.model({**batch, "mass_kg": one, "damping_n_s_per_m": two}) - u11
    z = 1.0 / g
    lo = np.array([BASE_BOUNDS["mass_kg"][0], BASE_BOUNDS["damping_n_s_per_m"][0]])
    hi = np.array([BASE_BOUNDS["mass_kg"][1], BASE_BOUNDS["damping_n_s_per_m"][1]])
    for _ in range(3):
        wt = np.broadcast_to(1.0 / (np.abs(z) * sigma), a.shape)
        A = np.stack([g * a * wt, g * beta * wt], axis=-1).reshape(k, -1, 2)
        A = np.concatenate([A.real, A.imag], axis=1)
        rhs = np.concatenate([wt.reshape(k, -1), np.zeros((k, wt[0].size))], axis=1)
        ata = np.einsum("kni,knj->kij", A, A)
        atb = np.einsum("kni,kn->ki", A, rhs)
        mb = np.clip(np.linalg.solve(ata, atb[..., None])[..., 0], lo, hi)
        z = mb[:, 0, None, None] * a + mb[:, 1, None, None] * beta
    return {"mass_kg": mb[:, :1], "damping_n_s_per_m": mb[:, 1:]}


def _variance_dof(data: MeasuredResponse, n_freq: int, variance_dof) -> np.ndarray:
    if variance_dof is None:
        meta = data.metadata if isinstance(data.metadata, Mapping) else {}
        if np.shape(meta.get("variance_dof")) == (n_freq,):
            variance_dof = np.asarray(meta["variance_dof"], dtype=float)
        elif np.shape(meta.get("subblocks")) == (n_freq,):
            variance_dof = 2.0 * (np.asarray(meta["subblocks"], dtype=float) - 1)
        else:
            return np.full(n_freq, np.inf)
    nu = np.broadcast_to(np.asarray(variance_dof, dtype=float), (n_freq,)) if np.ndim(variance_dof) == 0 \
        else np.asarray(variance_dof, dtype=float)
    if nu.shape != (n_freq,) or np.any(np.isnan(nu)) or np.any(nu <= 0):
        raise DataError(f"variance_dof must be positive, one value or one per frequency ({n_freq}), "
                        f"got {variance_dof!r}")
    return nu.copy()


class _Problem:
    """Normalised residuals of one start's coordinates, and their Jacobian by finite differences
    evaluated as one batched plant (parameters shaped (k, 1) broadcast against frequency)."""

    def __init__(self, plant: Plant, w, g, sigma, rows, coords: _Coordinates) -> None:
        self.plant, self.w, self.g, self.sigma, self.rows, self.coords = plant, w, g, sigma, rows, coords
        self.n_evaluations = 0

    def model(self, values: Mapping[str, float | np.ndarray]) -> np.ndarray:
        """Model at the data outputs, shape (..., n_data_outputs, n_freq)."""
        self.n_evaluations += 1
        return at_outputs(self.plant.with_values(dict(values), checked=False).frd_outputs(self.w, checked=False),
                          self.rows)

    def _split(self, model: np.ndarray) -> np.ndarray:
        r = (model - self.g) / self.sigma
        return np.concatenate([r.real.reshape(*r.shape[:-2], -1), r.imag.reshape(*r.shape[:-2], -1)], axis=-1)

    def residuals(self, x: np.ndarray) -> np.ndarray:
        return self._split(self.model(self.coords.to_values(x)))

    def _batch(self, xs: np.ndarray) -> np.ndarray:
        vals = [self.coords.to_values(x) for x in xs]
        batch = {n: np.array([v[n] for v in vals]).reshape(-1, 1) for n in self.coords.names}
        return self._split(self.model(batch))

    def jacobian(self, x: np.ndarray, *, central: bool = False) -> np.ndarray:
        """d residuals / d x; forward differences (central when asked), steps as scipy's '2-point'."""
        n = x.size
        h = np.sqrt(np.finfo(float).eps) * np.maximum(1.0, np.abs(x))
        if central:
            h = np.cbrt(np.finfo(float).eps) * np.maximum(1.0, np.abs(x))
            lo = np.maximum(x - h, self.coords.lower)
            hi = np.minimum(x + h, self.coords.upper)
            r = self._batch(np.vstack([x + np.diag(hi - x), x + np.diag(lo - x)]))
            return ((r[:n] - r[n:]) / (hi - lo)[:, None]).T
        h = np.where(x + h > self.coords.upper, -h, h)
        r = self._batch(np.vstack([x, x + np.diag(h)]))
        return ((r[1:] - r[0]) / h[:, None]).T


def minus_two_log_likelihood(residuals: np.ndarray, nu: np.ndarray) -> float:
    """-2 ln L of normalised complex residuals (n_out, n_freq) whose variances were estimated with nu real
    degrees of freedom, constants dropped: |r|^2 / 2 is then F(2, nu) distributed, whose density
    (1 + |r|^2 / nu)^(-(nu + 2) / 2) gives sum (nu + 2) ln(1 + |r|^2 / nu); with known variances
    (nu = inf) it is chi^2. The heavy tail keeps one point whose variance happens to be
    underestimated from buying an extra effect in a model comparison."""
    r2 = np.abs(residuals) ** 2
    nu = np.broadcast_to(np.asarray(nu, dtype=float), r2.shape[-1:])
    finite = np.isfinite(nu)
    return float(np.sum(r2[:, ~finite]) + np.sum((nu[finite] + 2) * np.log1p(r2[:, finite] / nu[finite])))


def _split_abs2(r: np.ndarray) -> np.ndarray:
    """Squares of the real parts (all outputs) then the imaginary parts, in residual-row order."""
    return np.concatenate([r.real.ravel() ** 2, r.imag.ravel() ** 2])


def _result(problem: _Problem, params, sol, s0, data, nu, *, n_starts, n_eval, elapsed) -> FitResult:
    coords, free = problem.coords, problem.coords.names
    fitted = coords.to_values(sol.x)
    flags = []
    for name in free:   # the ratio coordinate may leave the notch's own bounds
        p = params[name]
        if not p.lower <= fitted[name] <= p.upper:
            fitted[name] = min(max(fitted[name], p.lower), p.upper)
            flags.append(f"parameter {name} was clipped to its bound {fitted[name]:g} {p.unit}")
    fitted_plant = problem.plant.with_values(fitted)
    model_resp = problem.model(fitted)
    residuals = (problem.g - model_resp) / problem.sigma
    chi2 = float(np.sum(np.abs(residuals) ** 2))
    n_data, k = 2 * problem.g.size, len(free)
    dof = n_data - k

    # covariance from the Jacobian in optimiser coordinates, mapped to physical values
    J = problem.jacobian(sol.x, central=True)
    _, sv, vt = np.linalg.svd(J, full_matrices=False)
    good = sv > sv.max() * 1e-10
    cov_x = (vt[good].T / sv[good] ** 2) @ vt[good]            # (J^T J)^+
    # per residual row (real parts of every output, then imaginary): nu/(nu-4) and nu/(nu-2)
    n_rows = 2 * problem.g.shape[0]
    few = nu < 6
    with np.errstate(divide="ignore", invalid="ignore"):
        inflate = np.tile(np.where(np.isinf(nu), 1.0, nu / (np.maximum(nu, 6.0) - 4)), n_rows)
        mean_chi2 = np.tile(np.where(np.isinf(nu), 1.0, nu / (np.maximum(nu, 6.0) - 2)), n_rows)
    D = coords.jacobian(sol.x)
    cov = D @ cov_x @ (J.T * inflate) @ J @ cov_x @ D.T
    raw_err = np.sqrt(np.clip(np.diag(D @ cov_x @ D.T), 0, None))
    undetermined = {name for i, name in enumerate(free) if np.any(np.abs(vt[~good][:, i]) > 0.1)}
    err = np.sqrt(np.clip(np.diag(cov), 0, None))
    for i, name in enumerate(free):
        if name in undetermined:
            err[i] = np.inf
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(err, err)
    for i, name in enumerate(free):
        if name in undetermined:
            corr[i, :] = corr[:, i] = np.nan
        corr[i, i] = 1.0
    reduced = chi2 / dof if dof > 0 else float("nan")
    scale = math.sqrt(reduced) if math.isfinite(reduced) else float("nan")
    expected = float(np.mean(mean_chi2))

    if few.any():
        flags.append(f"{int(few.sum())} frequencies have variances from fewer than 4 sub-blocks (nu < 6): "
                     "their weights are unreliable and the standard errors optimistic")
    for name in sorted(undetermined):
        flags.append(f"parameter {name} is not determined by the data (singular Jacobian): "
                     "fix it or fix a parameter it trades off against")
    for i, name in enumerate(free):
        lo, hi = coords.lower[i], coords.upper[i]
        tol = 1e-6 * max(hi - lo if np.isfinite(hi - lo) else 1.0, 1.0)
        for side, bound in (("lower", lo), ("upper", hi)):
            if np.isfinite(bound) and abs(sol.x[i] - bound) <= tol:
                flags.append(f"parameter {name} is at its {side} bound ({fitted[name]:g} {params[name].unit}); "
                             "its standard error is not meaningful")
    for i in range(k):
        for j in range(i + 1, k):
            c = corr[i, j]
            if np.isfinite(c) and abs(c) > CORRELATION_FLAG:
                flags.append(f"parameters {free[i]} and {free[j]} cannot be told apart (correlation {c:+.3f})")
    if dof > 0:
        # chi^2 with each residual divided by its expectation nu/(nu-2) against chi^2(dof)
        p = float(special.chdtrc(dof, float(np.sum(_split_abs2(residuals) / mean_chi2))))
        if p < CHI2_P_FLAG:
            flags.append(f"reduced chi-square {reduced:.3g}, expected {expected:.3g} (P = {p:.1e} for {dof} "
                         "degrees of freedom): the model "
                         "does not explain the data within its uncertainty (missing effect, or variance "
                         "underestimated)")
    if not sol.success:
        flags.append(f"optimiser did not converge: {sol.message}")

    values = {n: float(fitted.get(n, p.value)) for n, p in fitted_plant.parameters().items()}
    m2ll = minus_two_log_likelihood(residuals, nu)
    return FitResult(
        plant=fitted_plant, values=values, free=tuple(free),
        stderr={n: float(e) for n, e in zip(free, err)},
        stderr_scaled={n: float(np.inf if n in undetermined else e * scale) for n, e in zip(free, raw_err)},
        covariance=cov, correlation=corr, initial={n: float(s0[n]) for n in free},
        f_hz=problem.w / (2 * np.pi), output_names=tuple(data.output_names), model_response=model_resp,
        residuals=residuals, chi2=chi2, dof=dof, reduced_chi2=reduced, expected_reduced_chi2=expected,
        variance_dof=nu, aic=m2ll + 2 * k,
        bic=m2ll + k * math.log(n_data), n_data=n_data, n_params=k, flags=tuple(flags),
        success=bool(sol.success), message=str(sol.message), n_starts=n_starts, n_evaluations=int(n_eval),
        elapsed_s=float(elapsed),
    )
