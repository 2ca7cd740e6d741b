"""Time-domain grey-box fit of the rigid stage with friction and a constant force:

    K_f u = m_e a + b_e v + F_c sign(v) + F_0 (+ any effect with ``force_regressors``),

with m_e, b_e the plant's effective mass and damping (Stage X: mass and rail damping, thesis
Eq. 3.15; Stage Y: Eq. 3.16's 2 m l_1 / L and 2 b), F_c ``coulomb_friction.force_n`` and F_0
``offset.force_n``. A describing function holds for one sine only; in the time domain the
friction is exact.

``fit_inverse_model`` is IDIM-LS (Janot, Gautier & Brunot 2019): linear least squares of the
filtered and decimated force on the filtered and decimated regressors (``plant.identify.inverse_model``),
within the parameters' physical bounds (``scipy.optimize.lsq_linear``), bias-compensated: the acceleration read
from a noisy position carries noise that pulls plain least squares' mass towards zero (by var(a) / (var(a) +
var(noise)): -10 % on a slow sweep with 10 um of position noise, and on a chirp, whose acceleration grows over the
record, onto a drift's pattern), so the noise's Gram matrix, from the chain's own noise
(``InverseModelData.noise_acceleration_m_per_s2``), is taken from X^T X (``_bias_compensated``). ``fit_output_error``
fits the same parameters by simulating the velocity from the measured force
(``simulate_velocity``: exact exponential step of the linear part, stick and slip of the
Coulomb friction) and minimising the velocity error, from the inverse model's estimate and
perturbed starts: unbiased where the inverse model's regressors carry noise.

Standard errors. The residual of a filtered and decimated regression is autocorrelated, so
the ordinary (X^T X)^-1 s^2 (what the reference script prints, ``stderr_ols``) understates
the uncertainty; ``stderr`` is the Newey-West (1987) heteroscedasticity and autocorrelation
consistent estimate with Bartlett weights, its lag the first at which the residual's
autocorrelation falls below 2 / sqrt(n). Model selection uses the Gaussian likelihood with
the residual's own variance and the effective sample size n_eff = n (1 - rho_1) / (1 + rho_1)
of an AR(1) residual (Bayley & Hammersley 1946): ``bic(fit, n_eff)`` = n_eff ln(RSS_LS / n) + k ln n_eff, with
one n_eff for all the models compared. RSS_LS is plain (bounded) least squares' residual on the model's columns as
recorded: the Gaussian likelihood of the force given those columns, which plain least squares maximises and for
which BIC's penalty is made. The parameters reported are the bias-compensated ones; their fit's own residual lies
above RSS_LS by construction (it does not minimise the RSS), and ranking on it charged a model for taking its
noisy column's bias out: ``yaw_coupling``'s column (the rails' difference differentiated twice) is as noisy as its
signal on a stepped sine of positions, and an off-centre load there was named a force-constant drift.

Samples at rest (``InverseModelData.at_rest``) are left out of every fit: there the friction
force is static, anywhere between -F_c and F_c, and no function of the velocity.

A model explains the data when its residual has no structure: the residual's mean in
``STRUCTURE_BINS`` quantile bins of velocity, of acceleration, of the motor force (an amplifier's current
limit bends the force at large currents) and (encoder data) of position is
zero within its Newey-West uncertainty (a chi^2 test of the bin means at ``TEST_P``, per
variable; ``Structure``) and large enough to matter (``STRUCTURE_SHARE``: numerical and
preprocessing approximations leave a structure of about 0.1 % of the force that a long record
resolves). With the position recorded, two dependences that bins of one variable cannot see are tested the
same way (``_interactions``): on current x position (a force constant varying along the track) and on a
periodic function of position (cogging, force ripple; its pitch found from the residual's spectrum over
position); on current x time and velocity x time (a force constant or a damping drifting over the record,
``_drifts``); and the residual's mean
against its own Newey-West error (``_constant``), which a slow variation
along the travel inflates, so the mean of a cable's force is not taken for a constant one. A missing Coulomb
friction leaves a step at v = 0, an offset a shift in every bin, a Stribeck curve a bump at low velocity, a
position-dependent force (cogging, a cable) a pattern along the travel, a wrong mass a slope in acceleration.
The test needs no noise model.
Its size must also be that of the measurement noise: the residual's rms at most ``NOISE_RATIO_LIMIT``
times the prediction, the white noise of the raw signals passed through the chain
(``InverseModelData.residual_noise_std_n``) combined with the chain's own precision (``CHAIN_PRECISION`` of the
force's rms); in a closed loop the force noise is zero (the command is exact, ``inverse_model_data``), and the
encoder's noise, differentiated and filtered, is what is left: on the independent closed-loop axis with nothing
missing the ratio is 0.9 to 1.1 with 1 and 10 um encoders and below 1 where a 0.1 um encoder leaves the chain's
precision as the floor. The tests (size and structure) leave out the samples at a reversal
(``InverseModelData.at_reversal``), where the sampled sign(v) cannot place the friction's turn or a stick within
the decimated sample (they are fitted, as the reference script fits every sample). The residual by regime of
motion (``regimes``) says where it is largest.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.optimize
import scipy.special

from plant.data.recordings import TimeRecording
from plant.errors import DataError, EffectError, ParameterError
from plant.estimate.lockin import TEST_P
from plant.identify.fit_result import PlantFit
from plant.identify.inverse_model import EDGE_SAMPLES, FILTER_ORDER, InverseModelData, Preprocessing, inverse_model_data
from plant.physics.effect_base import FitSamples
from plant.physics.models import Plant
from plant.physics.motor_forces import periodic_pitch
from plant.story import Section

#: velocity below this fraction of the 99th percentile of |v| is "low velocity"
LOW_VELOCITY_FRACTION = 0.05
#: seconds either side of a change of direction that count as "reversal"
REVERSAL_S = 0.05
#: largest residual rms / predicted noise rms of a model that explains the data (module doc): correct models of
#: the independent open-loop linear motor leave 0.6 to 1.0, of the closed-loop friction axis 0.3 to 1.1
NOISE_RATIO_LIMIT = 1.5
#: the bias compensation needs the noisy columns' signal-to-noise ratio above this many of their Gram's sampling
#: spreads (``_bias_compensated``)
COMPENSATION_SIGMAS = 3.0
#: relative precision of the inverse model's chain: its residual on a noise-free recording of the truth, as a
#: fraction of the force's rms (the independent closed-loop axis leaves 0.05 %: its controller's 1 ms steps against
#: the filters' transition bands)
CHAIN_PRECISION = 1e-3
#: quantile bins of each variable in the structure test
STRUCTURE_BINS = 16
#: smallest share of the residual (rms of the bin means / rms) that counts as structure: a systematic
#: part of a quarter of the residual's rms (6 % of its variance); pure noise gives about
#: sqrt(STRUCTURE_BINS / n_eff), 0.13 for 1000 effective samples
STRUCTURE_SHARE = 0.25
#: a pattern whose columns keep less than this fraction of their norm once made orthogonal to the model's is
#: in the model already (its own columns, formed before the decimation, keep ~0.002; any other pattern > 0.5)
IN_MODEL_NORM = 0.01
#: perturbations of the inverse model's mass and damping used as further output-error starts
OE_START_FACTORS = ((1.0, 1.0), (0.7, 1.4), (1.4, 0.7))
#: highest rate (Hz) of the output-error simulation (the force is filtered below it first)
OE_RATE_HZ = 250.0


@dataclass(frozen=True)
class Regime:
    """The residual in one regime of motion."""

    name: str
    #: share of the samples in the regime
    share: float
    rms_residual: float
    #: rms residual / the noise's rms (1 when the model is right)
    noise_ratio: float
    significant: bool


@dataclass(frozen=True)
class Structure:
    """Whether the residual's mean depends on one variable (module doc)."""

    variable: str
    chi2: float
    dof: int
    p_value: float
    significant: bool
    #: the bin with the largest mean residual in standard errors: its range and mean; for an interaction, the
    #: pattern found and its size
    worst_bin: str
    #: rms over the samples of their bin's mean residual (of the fitted pattern), over the residual's rms
    #: (0: no structure)
    share: float
    #: what the residual does, in words
    summary: str = ""


@dataclass(frozen=True, kw_only=True)
class TimeFitResult(PlantFit):
    """Result of ``fit_inverse_model`` or ``fit_output_error``. Residuals are in the unit of
    ``quantity``: force in N (inverse model) or velocity in m/s (output error); ``stderr`` are the
    Newey-West standard errors (module doc)."""

    method: str
    #: the ordinary least-squares standard errors
    stderr_ols: dict[str, float]
    quantity: str
    time_s: np.ndarray
    #: the (filtered) velocity at each residual's sample, m/s
    velocity_m_per_s: np.ndarray
    measured: np.ndarray
    model: np.ndarray
    residual: np.ndarray
    rss: float
    #: effective sample size of the autocorrelated residual
    n_effective: float
    lag1_autocorrelation: float
    relative_error_percent: float
    #: rms residual expected from measurement noise alone, and the rms residual over it
    noise_rms: float
    noise_ratio: float
    #: no structure test finds a dependence of the residual on velocity, acceleration or position, and
    #: the residual is no larger than ``NOISE_RATIO_LIMIT`` times the predicted noise
    explained: bool
    regimes: tuple[Regime, ...]
    structure: tuple[Structure, ...]
    #: samples left out because the axis was at rest
    n_at_rest: int
    condition_number: float
    elapsed_s: float
    #: the residual sum of squares of plain (bounded) least squares on the same columns, which models are compared
    #: on (``bic``; ``rss`` where the fit took no noise out)
    ls_rss: float = math.nan

    @property
    def rms_residual(self) -> float:
        return float(np.sqrt(self.rss / self.n_data))

    @property
    def ls_rms_residual(self) -> float:
        """Plain least squares' rms residual (``ls_rss``): the one the models' BIC compares."""
        return float(np.sqrt(self.ls_rss / self.n_data))

    @property
    def compensated(self) -> bool:
        """Whether the fit took the columns' noise out (its residual then lies above least squares' by
        construction)."""
        return self.ls_rss != self.rss

    @property
    def _unit(self) -> str:
        return "N" if self.quantity == "force_n" else "m/s"

    def _model_lines(self) -> list[str]:
        return [f"stage {self.plant.stage.upper()}, effects: {', '.join(self.effect_names) or 'none'}, "
                f"{self.method} fit of the {'force' if self._unit == 'N' else 'velocity'}"]

    def _statistics_lines(self) -> list[str]:
        unit = self._unit
        return [
            f"# data points      = {self.n_data} (effective {self.n_effective:.0f}: residual lag-1 "
            f"autocorrelation {self.lag1_autocorrelation:.3f}; {self.n_at_rest} at rest left out)",
            f"# variables        = {self.n_params}",
            f"rms residual       = {self.rms_residual:.4g} {unit} ({self.relative_error_percent:.2f} % of the "
            "measured signal)",
            f"noise alone        = {self.noise_rms:.4g} {unit} rms (residual / noise {self.noise_ratio:.3g})",
            f"condition number   = {self.condition_number:.3g}",
        ]

    def _variables_aside(self) -> str:
        return "(+/- Newey-West standard error; ordinary least squares in brackets)"

    def _variable_notes(self) -> dict[str, str]:
        return {n: f" [{self.stderr_ols[n]:.3g}]" for n in self.stderr}

    def _sections(self) -> list[Section]:
        unit = self._unit
        structure = tuple(f"{st.variable:14s} chi2 {st.chi2:.4g} for {st.dof} bins, p = {st.p_value:.2g}"
                          f"{' (significant)' if st.significant else ''}; largest: {st.worst_bin}"
                          for st in self.structure)
        regimes = tuple(f"{r.name:14s} {100 * r.share:5.1f} % of samples: rms {r.rms_residual:.4g} {unit}, "
                        f"{r.noise_ratio:.3g} x noise{' (significant)' if r.significant else ''}"
                        for r in self.regimes)
        return [*super()._sections(),
                Section("Structure of the residual", structure,
                        aside="(mean in quantile bins, chi-square against Newey-West errors)"),
                Section("Residual by regime of motion", regimes)]


def time_domain_effects(plant: Plant) -> None:
    """Refuse effects the time-domain model cannot represent, naming them."""
    for e in plant.effects:
        if not e.time_domain:
            raise EffectError(f"{e.name} has no time-domain force model (it acts on the dynamics, not on the force "
                              "balance); estimate a frequency response from the recording to fit it")


def fit_samples(data: InverseModelData) -> FitSamples:
    """The samples every fit uses (decimated, moving), for ``Effect.configured``."""
    moving = ~data.at_rest
    return FitSamples(data.velocity_m_per_s[moving], data.acceleration_m_per_s2[moving], data.force_n[moving],
                      None if data.position_m is None else data.position_m[moving], data.time_s[moving])


def configure_from_recording(plant: Plant, data: InverseModelData, given: Sequence[str] = ()) -> Plant:
    """``plant`` with the fields that shape its effects' signals (``search_fixed``: a limit, a pitch, a span, a
    Stribeck velocity) set from the recording, each effect in turn on the residual of the plant with the effects
    before it (``Effect.configured``), except the fields named in ``given`` (``effect.field``), which are kept (a
    profiled field is then refined from there by ``fit_inverse_model``)."""
    samples = fit_samples(data)
    done: list = []
    for effect in plant.effects:
        if effect.search_fixed and not any(f"{effect.name}.{k}" in given for k in effect.search_fixed):
            residual = fit_inverse_model(plant.with_effects(*done), data).residual
            effect = effect.configured(samples, residual)
        done.append(effect)
    return plant.with_effects(*done)


def default_free_time(plant: Plant) -> tuple[str, ...]:
    """Mass, damping and every effect parameter of the time-domain model but those that shape its signals
    (``search_fixed``: a ripple's pitch)."""
    return ("mass_kg", "damping_n_s_per_m") + tuple(f"{e.name}.{k}" for e in plant.effects for k in e.bounds
                                                    if k not in e.search_fixed)


def _check_free(plant: Plant, free: Sequence[str]) -> tuple[str, ...]:
    params = plant.parameters()
    for name in free:
        if name == "force_constant_n_per_a":
            raise ParameterError("force_constant_n_per_a scales every force of a time-domain fit, so it trades off "
                                 "exactly against mass, damping and friction; set it (--set "
                                 "force_constant_n_per_a=...) instead of fitting it")
        if name not in params:
            raise ParameterError(f"unknown parameter {name!r} to fit; parameters: {', '.join(params)}")
    return tuple(free)


def effective_factors(plant: Plant) -> tuple[float, float]:
    """Effective mass per kg of ``mass_kg`` and damping per N*s/m of ``damping_n_s_per_m`` (1 on Stage X)."""
    m_e, b_e = (float(np.mean(x)) for x in plant._effective_mass_damping())
    return m_e / float(plant.mass_kg), b_e / float(plant.damping_n_s_per_m)


def _regressors(plant: Plant, data: InverseModelData) -> dict[str, np.ndarray]:
    """Force per unit of each parameter (module doc's model), at the decimated samples."""
    m_per, b_per = effective_factors(plant)
    cols = {"mass_kg": m_per * data.acceleration_m_per_s2, "damping_n_s_per_m": b_per * data.velocity_m_per_s}
    for e in plant.effects:
        if e.needs_position and data.position_m is None:
            raise DataError(f"{data.source}: {e.name} depends on the position; the recording has velocity only")
        cols.update({f"{e.name}.{field}": col for field, col in data.effect_columns(e).items()})
    return cols


def _plant_with(plant: Plant, values: dict[str, float], excitation_a: float) -> Plant:
    import dataclasses

    out = plant.with_values(values)
    return dataclasses.replace(out, excitation_current_a=excitation_a) if not out.linear else out


def newey_west(X: np.ndarray, e: np.ndarray, gram: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """HAC covariance (X^T X)^-1 S (X^T X)^-1 with Bartlett weights; the lag as the module doc says. With the
    columns' noise ``gram`` (the bias-compensated fit, ``_bias_compensated``) the bread is (X^T X - gram)^-1 and the
    scores x_t e_t are centred (their sum is gram beta there, not 0)."""
    n = e.size
    ec = e - e.mean()
    acf = np.correlate(ec[: min(n, 4096)], ec[: min(n, 4096)], "full")[min(n, 4096) - 1:]
    acf = acf / acf[0] if acf[0] > 0 else acf
    below = np.flatnonzero(np.abs(acf) < 2 / np.sqrt(n))
    lag = int(min(below[0] if below.size else n // 10, n // 10))
    # S = sum over |k| <= lag of (1 - |k| / (lag + 1)) sum_t xe_t xe_(t+k)^T: each column convolved once with the
    # Bartlett window (every lag in one pass), symmetrised against round-off
    xe = X * e[:, None]
    if gram is not None:
        xe = xe - xe.mean(axis=0)
    bartlett = 1 - np.abs(np.arange(-lag, lag + 1)) / (lag + 1)
    S = xe.T @ np.column_stack([np.convolve(c, bartlett, "same") for c in xe.T])
    S = (S + S.T) / 2
    inv = np.linalg.pinv(X.T @ X - (0.0 if gram is None else gram))
    return inv @ S @ inv, lag


def _lag1(e: np.ndarray) -> float:
    ec = e - e.mean()
    den = float(ec @ ec)
    return float(ec[1:] @ ec[:-1] / den) if den > 0 else 0.0


def _regimes(v: np.ndarray, t: np.ndarray, e: np.ndarray, noise_rms: float,
             n_eff_per_sample: float) -> tuple[Regime, ...]:
    """Residual at reversals, at low velocity (elsewhere) and while moving."""
    speed = np.abs(v)
    scale = float(np.percentile(speed, 99)) or 1.0
    moving = speed > LOW_VELOCITY_FRACTION * scale
    # direction changes between samples that are moving, ignoring chatter at rest
    direction = np.sign(v)
    idx = np.flatnonzero(moving)
    flips = idx[1:][direction[idx[1:]] != direction[idx[:-1]]]
    flip_t = t[flips]
    nearest = np.clip(np.searchsorted(flip_t, t), 1, max(flip_t.size - 1, 1))
    reversal = np.zeros(v.size, bool) if flip_t.size == 0 else \
        np.minimum(np.abs(t - flip_t[nearest - 1]), np.abs(t - flip_t[np.minimum(nearest, flip_t.size - 1)])) \
        <= REVERSAL_S
    groups = (("reversals", reversal), ("low velocity", ~moving & ~reversal), ("moving", moving & ~reversal))
    out = []
    for name, mask in groups:
        if not mask.any():
            continue
        rms = float(np.sqrt(np.mean(e[mask] ** 2)))
        ratio = rms / noise_rms if noise_rms > 0 else math.inf
        dof = max(mask.sum() * n_eff_per_sample, 1.0)
        limit = scipy.special.chdtri(dof, TEST_P) / dof
        out.append(Regime(name, float(mask.mean()), rms, ratio, bool(ratio**2 > limit)))
    return tuple(out)


def _structure(e: np.ndarray, variables: dict[str, np.ndarray], unit: str, floor: float) -> tuple[Structure, ...]:
    """Chi-square test of the residual's bin means per variable (module doc); a structure whose bin means' rms is
    below ``floor`` (the chain's precision, ``CHAIN_PRECISION``) is not significant."""
    out = []
    for name, z in variables.items():
        edges = np.unique(np.quantile(z, np.linspace(0, 1, STRUCTURE_BINS + 1)))
        idx = np.clip(np.searchsorted(edges, z, side="right") - 1, 0, edges.size - 2)
        k = edges.size - 1
        if k < 2:
            continue
        B = np.zeros((z.size, k))
        B[np.arange(z.size), idx] = 1.0
        counts = B.sum(axis=0)
        B, edges_used = B[:, counts > 0], [(edges[j], edges[j + 1]) for j in range(k) if counts[j] > 0]
        means = (B.T @ e) / B.sum(axis=0)
        cov, _ = newey_west(B, e)
        se = np.sqrt(np.maximum(np.diag(cov), 1e-300))
        chi2 = float(means @ np.linalg.pinv(cov) @ means)
        dof = int(means.size)
        p = float(scipy.special.chdtrc(dof, chi2))
        j = int(np.argmax(np.abs(means) / se))
        lo, hi = edges_used[j]
        worst = f"{name} {lo:.3g} to {hi:.3g}: mean {means[j]:+.3g} {unit} ({means[j] / se[j]:+.1f} se)"
        size = float(np.sqrt(np.sum(B.sum(axis=0) * means**2) / e.size))
        share = size / max(float(np.sqrt(e @ e / e.size)), 1e-300)
        out.append(Structure(name, chi2, dof, p, p < TEST_P and share >= STRUCTURE_SHARE and size > floor, worst, share,
                             f"largest bin {worst}"))
    return tuple(out)


@dataclass(frozen=True)
class ColumnNoise:
    """The noise the measurement puts into the first columns of a regression (``_noise_gram``): its covariance per
    sample and those columns' fitted coefficients."""

    covariance: np.ndarray
    beta: np.ndarray


def _pattern(name: str, e: np.ndarray, B: np.ndarray, tests: int, words, X: np.ndarray | None = None,
             noise: ColumnNoise | None = None) -> Structure:
    """Wald test (Newey-West covariance) of the residual's regression on the pattern columns ``B``, its p-value
    times ``tests`` (Bonferroni over the patterns searched); ``words(coefficients)`` describes the fit. With the
    model's own columns ``X``, ``B`` is first made orthogonal to them (the omitted-variable test of a pattern
    that the fitted mass and damping partly absorbed) and the covariance is taken on the residual left by the
    pattern (a Wald test: a residual that is mostly the pattern no longer inflates its own error). Without
    ``X`` the covariance is the residual's own (a score test), which a smooth residual inflates: a periodic
    pattern is then claimed only where it stands out of any slow variation along the travel. With the ``noise``
    of ``X``'s first columns, the projection's share of that noise (B - X g carries -N g, the residual -N beta) is
    taken out of B^T e and B^T B as the fit's least squares takes it out of X^T X (``_bias_compensated``): a pattern
    that the acceleration's noise correlates with through the projection (a chirp's F u on the noisy acceleration)
    is not claimed for that."""
    if X is not None:
        g = np.linalg.lstsq(X, B, rcond=None)[0]
        kept = B - X @ g
        if np.min(np.linalg.norm(kept, axis=0) / np.maximum(np.linalg.norm(B, axis=0), 1e-300)) < IN_MODEL_NORM:
            return Structure(name, 0.0, B.shape[1], 1.0, False, "in the model", 0.0, "in the model")
        B = kept
    coef = None
    if X is not None and noise is not None:
        gk = g[:noise.covariance.shape[0]]
        try:
            coef = np.linalg.solve(B.T @ B - e.size * gk.T @ noise.covariance @ gk,
                                   B.T @ e - e.size * gk.T @ noise.covariance @ noise.beta)
        except np.linalg.LinAlgError:
            pass
    if coef is None:
        coef, *_ = np.linalg.lstsq(B, e, rcond=None)
    cov, _ = newey_west(B, e if X is None else e - B @ coef)
    chi2 = float(coef @ np.linalg.pinv(cov) @ coef)
    p = min(1.0, tests * float(scipy.special.chdtrc(coef.size, chi2)))
    share = float(np.linalg.norm(B @ coef) / max(float(np.linalg.norm(e)), 1e-300))
    text = words(coef)
    return Structure(name, chi2, int(coef.size), p, p < TEST_P and share >= STRUCTURE_SHARE, text, share, text)


def _constant(e: np.ndarray) -> Structure:
    """constant: the residual's mean against its own Newey-West error (``_pattern``'s score form), the pattern of
    a constant force (``offset``); a slow variation the model lacks (a cable's force along the travel) inflates
    that error, so its mean over the recording is not taken for a constant force."""
    return _pattern("constant", e, np.ones((e.size, 1)), 1, lambda c: f"a constant force {c[0]:+.3g} N")


#: what a drift's pattern says when it stands out alone but not beside the other drift's
CONFOUNDED = (" (beside the other drift's pattern it does not stand out: the force follows the velocity, and the "
              "fits of both drifts tell them apart)")


def _drifts(e: np.ndarray, force: np.ndarray, velocity: np.ndarray, t: np.ndarray, X: np.ndarray,
            damping: float, noise: ColumnNoise | None = None) -> tuple[Structure, Structure]:
    """current x time and velocity x time: e on F u and on v u, u = (t - mid) / half over the record, each against
    the model's columns, u itself (a force that changes in time alone is not an interaction) and the other's pattern
    (where the force follows the velocity, F ~ b v, the two drifts leave nearly the same residual). A force constant
    drifting over the record (a coil warming), K(t) = K(mid) (1 + d u), leaves -d u F; a damping drifting (a
    lubricant warming), b(t) = b(mid) (1 + d u), leaves d u b v; each mean in any bin of time is zero where the
    current or the velocity averages out. Where neither stands out beside the other but the two together carry the
    residual (a joint test), each that stands out alone, against the model's columns and u, is shown (``CONFOUNDED``):
    both drifts are then fitted and the fits tell them apart."""
    lo, hi = float(t.min()), float(t.max())
    still = Structure("current x time", 0.0, 1, 1.0, False, "one instant", 0.0, "one instant")
    if not hi > lo:
        return still, dataclasses.replace(still, variable="velocity x time")
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    u = (t - mid) / half
    span = f"u = (t - {mid:.3g} s) / {half:.3g} s"

    def force_constant(c):
        return (f"a force constant drifting over the record, to first order K(t) / K = 1 {-c[0]:+.3g} u with "
                f"{span}: {100 * -2 * c[0]:+.2g} % from the first sample to the last")

    def damping_words(c):
        d = c[0] / damping
        return (f"a damping drifting over the record, to first order b(t) / b = 1 {d:+.3g} u with "
                f"{span}: {100 * 2 * d:+.2g} % from the first sample to the last")

    fu, vu = force * u, velocity * u
    current = _pattern("current x time", e, fu[:, None], 1, force_constant, np.column_stack([X, vu, u]), noise)
    if not damping > 0:
        return current, dataclasses.replace(still, variable="velocity x time")
    damp = _pattern("velocity x time", e, vu[:, None], 1, damping_words, np.column_stack([X, fu, u]), noise)
    if current.significant or damp.significant:
        return current, damp
    # where the force follows the velocity the two patterns are nearly one, and neither stands out beside the other
    # even when together they carry the residual: then each that stands out alone is shown, and the fits decide
    joint = _pattern("drift", e, np.column_stack([fu, vu]), 1, lambda c: "", np.column_stack([X, u]), noise)
    if not joint.significant:
        return current, damp
    alone = (_pattern("current x time", e, fu[:, None], 1, force_constant, np.column_stack([X, u]), noise),
             _pattern("velocity x time", e, vu[:, None], 1, damping_words, np.column_stack([X, u]), noise))
    return tuple(dataclasses.replace(a, summary=a.summary + CONFOUNDED, worst_bin=a.worst_bin + CONFOUNDED)
                 if a.significant else s for s, a in zip((current, damp), alone))


def _interactions(e: np.ndarray, force: np.ndarray, position: np.ndarray, X: np.ndarray,
                  noise: ColumnNoise | None = None) -> tuple[Structure, ...]:
    """Residual dependences that bins of one variable cannot see (module doc).

    * current x position: e on F x and F x^2 (x scaled to -1 .. 1 over the travel covered): a force constant
      K(x) = K(mid) (1 + c1 x + c2 x^2) leaves exactly this residual, whose mean in any bin of position is
      zero where the current averages out; tested against the model's columns ``X`` (``_pattern``), since
      the fitted mass and damping, whose force the current carries, absorb part of it, and against x and x^2,
      its main effect (a force of the position alone, a cable, is not an interaction);
    * position, periodic: e on sin and cos of 2 pi x / pitch at the pitch of the largest peak of the
      residual's spectrum over position (``plant.physics.motor_forces.periodic_pitch``), a cogging or
      force-ripple pattern; Bonferroni over the pitches searched."""
    lo, hi = float(position.min()), float(position.max())
    if not hi > lo:
        return ()
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    x = (position - mid) / half

    def kt_words(c):      # e = F - K_fit (1 + d(u)) F / K: the residual is -d(u) F to first order
        d1, d2 = -c[0], -c[1]
        return (f"a force constant that varies along the travel, to first order K(x) / K = 1 {d1:+.3g} u {d2:+.3g} u^2 "
                f"with u = (x - {mid:.3g} m) / {half:.3g} m: {100 * (d1 + d2):+.2g} % at {hi:.3g} m, "
                f"{100 * (d2 - d1):+.2g} % at {lo:.3g} m")

    # an interaction is tested beside its main effect: a force that depends on the position alone (a cable)
    # correlates with current x position wherever the current follows the position
    main = np.column_stack([X, x, x**2])
    out = [_pattern("current x position", e, np.column_stack([force * x, force * x**2]), 1, kt_words, main, noise)]
    pitch, searched = periodic_pitch(position, e)
    if searched:
        phase = 2 * np.pi * (position - lo) / pitch

        def ripple_words(c):
            return (f"a force periodic in position, pitch {1e3 * pitch:.3g} mm, amplitude {np.hypot(*c):.3g} N "
                    "(cogging or force ripple)")

        out.append(_pattern("position, periodic", e, np.column_stack([np.sin(phase), np.cos(phase)]), searched,
                            ripple_words))
    return tuple(out)


def _summarise(plant, method, values, free, X, e, measured, model, quantity, t, v, noise_rms, flags, n_starts,
               elapsed, excitation_a, variables=None, n_at_rest=0, interactions=(),
               judged=None, gram=None, ls_rss=None) -> TimeFitResult:
    n, k = X.shape
    floor = CHAIN_PRECISION * float(np.sqrt(np.mean(measured**2))) if quantity == "force_n" else 0.0
    noise_rms = math.hypot(noise_rms, floor)
    rss = float(e @ e)
    s2 = rss / max(n - k, 1)
    inv = np.linalg.pinv(X.T @ X - (0.0 if gram is None else gram))
    cov_ols = inv * s2
    cov, _ = newey_west(X, e, gram)
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    d = np.where(se > 0, se, np.inf)
    corr = cov / np.outer(d, d)
    np.fill_diagonal(corr, 1.0)
    rho = _lag1(e)
    n_eff = float(np.clip(n * (1 - rho) / (1 + rho), k + 2, n)) if rho > 0 else float(n)
    j = np.ones(n, bool) if judged is None or not judged.any() else judged
    ratio = math.sqrt(float(np.mean(e[j] ** 2))) / noise_rms if noise_rms > 0 else math.inf
    regimes = _regimes(v[j], t[j], e[j], noise_rms, n_eff / n)
    structure = _structure(e[j], {k: z[j] for k, z in (variables or {"velocity": v}).items()},
                           "N" if quantity == "force_n" else "m/s", floor) + interactions
    explained = not any(st.significant for st in structure) and ratio <= NOISE_RATIO_LIMIT
    cond = float(np.linalg.cond(X / np.maximum(np.linalg.norm(X, axis=0), 1e-300)))
    return TimeFitResult(
        plant=_plant_with(plant, values, excitation_a), method=method, values=dict(values), free=tuple(free),
        stderr={p: float(s) for p, s in zip(free, se)},
        stderr_ols={p: float(s) for p, s in zip(free, np.sqrt(np.maximum(np.diag(cov_ols), 0.0)))},
        covariance=cov, correlation=corr, quantity=quantity, time_s=t, velocity_m_per_s=v, measured=measured,
        model=model, residual=e,
        rss=rss, n_data=n, n_params=k, n_effective=n_eff, lag1_autocorrelation=rho,
        relative_error_percent=float(100 * math.sqrt(rss) / max(np.linalg.norm(measured), 1e-300)),
        noise_rms=noise_rms, noise_ratio=ratio, explained=explained, regimes=regimes,
        structure=structure, n_at_rest=int(n_at_rest),
        condition_number=cond, flags=tuple(flags),
        n_starts=n_starts, elapsed_s=elapsed, ls_rss=rss if ls_rss is None else ls_rss)


def fit_inverse_model(plant: Plant, rec: TimeRecording | InverseModelData, *, free: Sequence[str] | None = None,
                      prep: Preprocessing = Preprocessing()) -> TimeFitResult:
    """IDIM-LS of ``plant``'s time-domain model (module doc) on ``rec`` (or its prepared signals)."""
    t0 = time.perf_counter()
    time_domain_effects(plant)
    free = _check_free(plant, free if free is not None else default_free_time(plant))
    data = rec if isinstance(rec, InverseModelData) else \
        inverse_model_data(rec, float(plant.force_constant_n_per_a), prep)
    moving = ~data.at_rest
    plant = _profiled(plant, data, free)
    cols = {name: col[moving] for name, col in _regressors(plant, data).items()}
    params = plant.parameters()
    force = data.force_n[moving]
    y = force.copy()
    for name, col in cols.items():
        if name not in free:
            y -= params[name].value * col
    X = np.column_stack([cols[p] for p in free])
    lo = np.array([params[p].lower for p in free])
    hi = np.array([params[p].upper for p in free])
    where = getattr(rec, "source", None) or "recording"
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(y))):
        raise DataError(f"{where}: the model's signals (filtered velocity, acceleration, force) overflow: a value "
                        "in the recording is far out of range")
    try:
        A, target, gram = _bias_compensated(X, y, _noise_gram(plant, data, free, int(moving.sum())),
                                            data.noise_lag_factor)
        sol = scipy.optimize.lsq_linear(A, target, bounds=(lo, hi), method="bvls")
        # the likelihood the models are ranked by (module doc): plain least squares' residual
        ls_rss = None if gram is None else \
            float(np.sum((y - X @ scipy.optimize.lsq_linear(X, y, bounds=(lo, hi), method="bvls").x) ** 2))
    except np.linalg.LinAlgError:
        raise DataError(f"{where}: the least-squares problem of the model cannot be solved on this recording (its "
                        "values span too many orders of magnitude)") from None
    beta = np.clip(sol.x, lo, hi)           # BVLS may leave a bound by a rounding error (-8e-17 seen)
    values = {name: p.value for name, p in params.items()}
    values.update(dict(zip(free, map(float, beta))))
    flags = [f"{p} = {b:.4g} {params[p].unit} is at its bound [{lo[i]:g}, {hi[i]:g}]: the data ask for a value "
             "outside the physical range" for i, (p, b) in enumerate(zip(free, beta))
             if np.isclose(b, lo[i]) or np.isclose(b, hi[i])]
    model = X @ beta + (force - y)
    e = force - model
    m_per, b_per = effective_factors(plant)
    noise = data.residual_noise_std_n(m_per * values["mass_kg"], b_per * values["damping_n_s_per_m"],
                                      (values.get("yaw_coupling.inertia_kg", 0.0),
                                       values.get("yaw_coupling.damping_n_s_per_m", 0.0)))
    variables = {"velocity": data.velocity_m_per_s[moving], "acceleration": data.acceleration_m_per_s2[moving],
                 "motor force": force}
    j = ~data.at_reversal[moving]
    # the pattern tests take the noise out as the fit did (not where the fit fell back to plain least squares)
    column_noise = None if gram is None else ColumnNoise(gram / max(int(moving.sum()), 1), beta)
    interactions = (_constant(e[j]), *_drifts(e[j], force[j], data.velocity_m_per_s[moving][j],
                                               data.time_s[moving][j], X[j], b_per * values["damping_n_s_per_m"],
                                               column_noise))
    if data.position_m is not None:
        variables["position"] = data.position_m[moving]
        interactions += _interactions(e[j], force[j], data.position_m[moving][j], X[j], column_noise)
    return _summarise(plant, "inverse-model", values, free, X, e, force, model, "force_n", data.time_s[moving],
                      data.velocity_m_per_s[moving], noise, flags, 1, time.perf_counter() - t0,
                      _peak_input(plant, data), variables, int(data.at_rest.sum()), interactions, judged=j,
                      gram=gram, ls_rss=ls_rss)


def _noise_gram(plant: Plant, data: InverseModelData, free: Sequence[str], n: int) -> np.ndarray:
    """E[N^T N] of the noise N that the measurement puts into the columns of ``free`` over ``n`` samples: the mass's
    column (the acceleration differentiated twice from the noisy position) and the damping's (once), from the
    chain's own noise moments (``InverseModelData.noise_moments``, exact expectations), and
    ``yaw_coupling``'s (the rails' difference differentiated: twice that noise, independent of the mean's); the
    other effects' columns carry none that matters (a product with u, x or sign(v), or the force's noise, which is
    small beside its signal)."""
    m_per, b_per = effective_factors(plant)
    moments = data.noise_moments                 # (velocity, acceleration)
    # (factor, signal, source): the rails' difference carries twice the mean's noise, independent of it
    noise = {"mass_kg": (m_per, 1, "mean"), "damping_n_s_per_m": (b_per, 0, "mean"),
             "yaw_coupling.inertia_kg": (2.0, 1, "difference"),
             "yaw_coupling.damping_n_s_per_m": (2.0, 0, "difference")}
    out = np.zeros((len(free), len(free)))
    for i, p in enumerate(free):
        for j, q in enumerate(free):
            if p in noise and q in noise and noise[p][2] == noise[q][2]:
                out[i, j] = n * float(noise[p][0] * noise[q][0] * moments[noise[p][1], noise[q][1]])
    return out


def _bias_compensated(X: np.ndarray, y: np.ndarray, gram: np.ndarray,
                      lag_factor: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(A, target, G) whose least squares ||A beta - target||^2 = beta^T (X^T X - G) beta - 2 beta^T X^T y + const is
    the bias-compensated least squares (Stoica & Soderstrom 1982): noise in the columns (the acceleration read from a
    noisy position) adds its Gram matrix G to X^T X and pulls the mass towards zero by var(a) / (var(a) + var(noise))
    (-10 % on a slow sweep with a 10 um position noise); subtracting it removes that.

    G is an expectation: the recording's own noise Gram departs from it by about sqrt(2 F / n) of it (a chi^2 of
    n / F effective samples, F = ``lag_factor``, the noise's sum of squared autocorrelations at the samples' lags).
    The noisy columns' signal, once the noise-free columns are projected out, must stand above their noise by
    ``COMPENSATION_SIGMAS`` times that in every direction (the least generalised eigenvalue of (S - G, G), S their
    Schur complement: a signal-to-noise ratio, free of the columns' scales and of collinearity among the noise-free
    ones); where it does not (a column as noisy as its signal in a closed loop, whose compensation would blow up),
    the plain least squares (X, y, None): G is the Gram matrix the fit took out, None where it took none."""
    noisy = np.flatnonzero(np.diag(gram) > 0)
    if not noisy.size:
        return X, y, None
    clean = np.setdiff1d(np.arange(X.shape[1]), noisy)
    signal = X[:, noisy]
    if clean.size:
        signal = signal - X[:, clean] @ np.linalg.lstsq(X[:, clean], signal, rcond=None)[0]
    noise = gram[np.ix_(noisy, noisy)]
    snr = scipy.linalg.eigh(signal.T @ signal - noise, noise, eigvals_only=True)[0]
    if not snr > COMPENSATION_SIGMAS * math.sqrt(2.0 * lag_factor / X.shape[0]):
        return X, y, None
    try:
        L = np.linalg.cholesky(X.T @ X - gram)
    except np.linalg.LinAlgError:
        return X, y, None
    return L.T, scipy.linalg.solve_triangular(L, X.T @ y, lower=True), gram


def _profiled(plant: Plant, data: InverseModelData, free: Sequence[str]) -> Plant:
    """``plant`` with each effect's ``profiled`` field (a ripple's pitch) set to the value, within its span of
    its own either way, that leaves the least squares of the fit of ``free`` smallest (profile least squares:
    the other parameters enter linearly; only the effect's own columns change)."""
    moving = ~data.at_rest
    force = data.force_n[moving]
    cols = {name: col[moving] for name, col in _regressors(plant, data).items()}
    for i, effect in enumerate(plant.effects):
        for field, span in effect.profiled.items():
            start = float(getattr(effect, field))
            own_names = [p for p in free if p.startswith(f"{effect.name}.")]
            # the other columns do not change: project them out once (Frisch-Waugh-Lovell), an orthonormal
            # basis of their span from the SVD
            fixed = np.column_stack([cols[p] for p in free if p not in own_names] or [np.zeros_like(force)])
            U, sv, _ = np.linalg.svd(fixed, full_matrices=False)
            U = U[:, sv > sv[0] * 1e-12] if sv[0] > 0 else U[:, :0]
            force_left = force - U @ (U.T @ force)

            def rss(value, effect=effect, field=field, own_names=own_names, U=U, force_left=force_left):
                regressors = data.effect_columns(dataclasses.replace(effect, **{field: value}))
                O = np.stack([regressors[p.split(".", 1)[1]] for p in own_names])[:, moving].T
                O = O - U @ (U.T @ O)
                return float(np.sum((force_left - O @ np.linalg.lstsq(O, force_left, rcond=None)[0]) ** 2))

            best = scipy.optimize.minimize_scalar(rss, bounds=(start * (1 - span), start * (1 + span)),
                                                  method="bounded", options={"xatol": 1e-6 * start})
            if best.fun < rss(start):
                effect = dataclasses.replace(effect, **{field: float(best.x)})
                plant = plant.with_effects(*plant.effects[:i], effect, *plant.effects[i + 1:])
    return plant


def _peak_input(plant: Plant, data: InverseModelData) -> float:
    """Peak drive input (A): the amplitude a describing function of the fitted plant refers to."""
    return float(np.max(np.abs(data.force_n)) / float(plant.force_constant_n_per_a)) or 1.0


def bic(fit: TimeFitResult, n_effective: float) -> float:
    """Bayesian information criterion on plain least squares' residual (``TimeFitResult.ls_rss``, module doc) with
    a shared effective size."""
    return n_effective * math.log(max(fit.ls_rss / fit.n_data, 1e-300)) + fit.n_params * math.log(n_effective)


# --- output error -------------------------------------------------------------------------
@dataclass(frozen=True)
class _OeData:
    """Force and velocity low-passed at the filter corner and taken at the simulation rate."""

    time_s: np.ndarray
    force_n: np.ndarray
    velocity_m_per_s: np.ndarray
    step_s: float


def _oe_data(rec: TimeRecording, data: InverseModelData, force_constant: float) -> _OeData:
    import scipy.signal  # here: a stepped-sine fit imports this module and needs none of it (0.5 s)

    fs = rec.sample_rate_hz
    q = max(1, int(fs // max(OE_RATE_HZ, 2.5 * data.filter_hz)))
    b, a = scipy.signal.butter(FILTER_ORDER, data.filter_hz / (fs / 2))
    force = scipy.signal.filtfilt(b, a, force_constant * rec.current_a)
    cut = slice(EDGE_SAMPLES, rec.n_samples - EDGE_SAMPLES, q)
    return _OeData(rec.time_s[cut], force[cut], data.full_rate_velocity_m_per_s[::q], q / fs)


def simulate_velocity(force_n: np.ndarray, step_s: float, *, mass_kg: float, damping_n_s_per_m: float,
                      coulomb_n: float = 0.0, offset_n: float = 0.0, v0_m_per_s: float = 0.0) -> np.ndarray:
    """Velocity (m/s) of m dv/dt = F - F_0 - b v - F_c sign(v) from rest or ``v0``, the force held at the
    mean of consecutive samples over each step: exact exponential step of the linear part; a step in
    which the velocity would change sign ends at rest, and the body stays at rest while
    |F - F_0| <= F_c (stick), then slides off in the direction of the net force (Karnopp 1985)."""
    alpha = math.exp(-damping_n_s_per_m * step_s / mass_kg)
    gain = (1.0 - alpha) / damping_n_s_per_m
    f = np.asarray(force_n, dtype=float)
    drive = ((f[:-1] + f[1:]) / 2 - offset_n).tolist()
    out = [float(v0_m_per_s)]
    v = float(v0_m_per_s)
    for net in drive:
        if v == 0.0:
            if abs(net) <= coulomb_n:
                out.append(0.0)
                continue
            sign = 1.0 if net > 0 else -1.0
        else:
            sign = 1.0 if v > 0 else -1.0
        nxt = alpha * v + gain * (net - sign * coulomb_n)
        v = 0.0 if nxt * sign < 0 else nxt
        out.append(v)
    return np.asarray(out)


def fit_output_error(plant: Plant, rec: TimeRecording, *, start: TimeFitResult | None = None,
                     prep: Preprocessing = Preprocessing()) -> TimeFitResult:
    """Output-error fit of the time-domain model (module doc): the simulated velocity against the measured
    one, from the inverse model's estimate (``start``, fitted when None) and ``OE_START_FACTORS``
    perturbations of its mass and damping; the best start wins, and a start that ends elsewhere with
    a cost within 1e-6 is reported as a flag."""
    t0 = time.perf_counter()
    data = inverse_model_data(rec, float(plant.force_constant_n_per_a), prep)
    start = start or fit_inverse_model(plant, data)
    plant = start.plant
    free = start.free
    if any(n not in ("mass_kg", "damping_n_s_per_m", "coulomb_friction.force_n", "offset.force_n") for n in free):
        raise EffectError("the output-error fit simulates mass, damping, coulomb_friction and offset; "
                          f"free parameters were {', '.join(free)}")
    oe = _oe_data(rec, data, float(plant.force_constant_n_per_a))
    m_per, b_per = effective_factors(plant)
    params = plant.parameters()
    scale = np.array([max(abs(start.values[p]), 1.0) for p in free])
    lo = np.array([params[p].lower for p in free]) / scale
    hi = np.array([params[p].upper for p in free]) / scale

    def simulate(x):
        v = dict(start.values)
        v.update(zip(free, x * scale))
        return simulate_velocity(oe.force_n, oe.step_s, mass_kg=m_per * v["mass_kg"],
                                 damping_n_s_per_m=b_per * v["damping_n_s_per_m"],
                                 coulomb_n=v.get("coulomb_friction.force_n", 0.0),
                                 offset_n=v.get("offset.force_n", 0.0),
                                 v0_m_per_s=oe.velocity_m_per_s[0])

    def residual(x):
        return oe.velocity_m_per_s - simulate(x)

    x_idim = np.array([start.values[p] for p in free]) / scale
    runs = []
    for fm, fb in OE_START_FACTORS:
        x0 = x_idim.copy()
        for name, factor in (("mass_kg", fm), ("damping_n_s_per_m", fb)):
            if name in free:
                x0[free.index(name)] *= factor
        runs.append(scipy.optimize.least_squares(residual, np.clip(x0, lo, hi), bounds=(lo, hi), x_scale="jac"))
    best = min(runs, key=lambda r: r.cost)
    flags = []
    for r in runs:
        if r.cost > best.cost * (1 + 1e-6) and np.max(np.abs(r.x - best.x)) > 1e-3:
            flags.append(f"a start ended at a worse local minimum (cost {r.cost:.4g} vs {best.cost:.4g})")
    values = dict(start.values)
    values.update(zip(free, map(float, best.x * scale)))
    J = -best.jac / scale
    e = residual(best.x)
    model = oe.velocity_m_per_s - e
    noise_rms = float(np.std(data.noise_velocity_m_per_s))
    return _summarise(plant, "output-error", values, free, J, e, oe.velocity_m_per_s, model, "velocity_m_per_s",
                      oe.time_s, oe.velocity_m_per_s, noise_rms, flags, len(runs), time.perf_counter() - t0,
                      _peak_input(plant, data))
