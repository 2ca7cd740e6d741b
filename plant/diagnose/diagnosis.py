"""Compare model and measurement, find the missing physical effects, add them, watch the error fall.

``diagnose`` fits the base model (thesis Eq. 3.15 / 3.16 with free mass and damping) and then
every combination of up to ``MAX_EFFECTS`` effects of the library by the model search of
``plant.diagnose.search``, which also selects: each model starts from the optimum of every model
it contains with the new effect at its neutral values, and from the effect's guesses on that
model's residual, so a nested model never fits worse than its parent and a wrong first step is
never locked in. Every model within ``ACCEPT_DELTA_BIC`` of the selected one is reported beside
it, with what makes it equivalent. The verdict is ``explained`` only when the selected model's chi^2 is consistent
with the noise (``chi2_is_noise``); otherwise it is ``not_explained`` and says so first,
describing the residual no effect of the library reproduces.

Coulomb friction on a rigid body is modelled exactly (the stick-slip first harmonic of
``plant.physics.coulomb_response``); in a chain of several bodies by its describing function, whose
error counts as misfit like any other, so such a model may be reported as not explaining the data.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace

import numpy as np
from scipy import special

from plant.data.frequency_response import MeasuredResponse
from plant.diagnose.drift import Drift, fit_drift
from plant.diagnose.evidence import (
    ACCEPT_DELTA_BIC,
    addition_delta_bic,
    delta_bic_text,
    fitted_sentence,
    model_label,
    model_section,
    parameter_section,
    rank_models,
    verdict,
)
from plant.diagnose.identifiability import Unidentified, unidentified
from plant.diagnose.plausibility import implausible, warning
from plant.diagnose.search import children, compatible, fit_models, path_to, select_model
from plant.errors import DataError
from plant.identify.fitting import FitResult, fit_plant
from plant.identify.residuals import ResidualSummary, residual_summary
from plant.physics.chain import EncoderVelocity
from plant.physics.effects import EFFECTS, make_effect
from plant.physics.models import Plant
from plant.story import Section, Story, Table

#: chi^2 is consistent with noise unless a correct model exceeds it with probability below the
#: one-sided normal tail at NOISE_Z (1.35e-3)
NOISE_Z = 3.0
#: bands of consecutive frequencies whose chi^2 is tested on its own for adequacy
ADEQUACY_BANDS = 6
#: draws of the reference distribution of chi^2 for the adequacy test
REFERENCE_DRAWS = 20000
#: most effects in one model of the search
MAX_EFFECTS = 3
#: force amplitudes (fractions of the excitation force K_t I) a friction fit starts from
FRICTION_SHARES = (0.05, 0.15, 0.3)
#: the best-ranked models a drift is tried on when none is consistent with the noise (beside every model of one
#: effect)
DRIFT_MODELS = 6
#: models whose BIC agree this closely are tied (their order would be the last bits of each fit)
TIED_BIC = 1e-6


@dataclass(frozen=True)
class Nonlinearity:
    """Evidence of a nonlinearity: harmonics (or output at a multisine's lines not excited) and amplitude
    dependence."""

    detected: bool
    #: largest 3rd-harmonic ratio of the output, and the frequency where it occurs (NaN: none measurable)
    max_third_harmonic: float
    max_third_harmonic_f_hz: float
    #: 3rd-harmonic level above which it counts (noise floor or 0.5 %)
    threshold: float
    amplitude_dependent: bool | None
    description: str
    #: distortion above the noise in the data themselves: harmonics of a stepped sine, output at a multisine's
    #: lines not excited (amplitude dependence alone is not distortion a model must reproduce)
    distortion: bool = False


@dataclass(frozen=True)
class Candidate:
    """One effect tried as an addition to a model (``delta_bic`` as ``plant.diagnose.evidence`` has it: positive favours
    the effect)."""

    effect: str
    delta_bic: float
    reduced_chi2: float
    fit: FitResult | None
    #: why it was not fitted (not applicable, not identifiable from these data), else ""
    skipped: str = ""


@dataclass(frozen=True)
class Step:
    """A model on the path from the base model to the selected one: its fit and error figures."""

    effects: tuple[str, ...]
    fit: FitResult
    residuals: ResidualSummary
    rms_magnitude_error_db: float
    rms_phase_error_deg: float
    #: the effects tried as additions to this model (ranked best first)
    ranking: tuple[Candidate, ...]
    #: why the next effect was added, or the verdict on the last step
    decision: str
    #: the model's score under the diagnosis's ranking (BIC, or QBIC: ``plant.diagnose.evidence.rank_models``)
    score: float = math.nan


@dataclass(frozen=True)
class Alternative:
    """A model within ``ACCEPT_DELTA_BIC`` of the selected one."""

    effects: tuple[str, ...]
    #: BIC of this model minus BIC of the selected one
    delta_bic: float
    reduced_chi2: float
    consistent_with_noise: bool
    note: str


@dataclass(frozen=True)
class LeftOut:
    """A model the selection would have reported but for effects the data do not identify
    (``plant.diagnose.identifiability``)."""

    effects: tuple[str, ...]
    #: its BIC minus the reported model's
    delta_bic: float
    reduced_chi2: float
    why: tuple[Unidentified, ...]

    #: the ranking's criterion the difference is in
    criterion: str = "BIC"

    def sentence(self, base: tuple[str, ...]) -> str:
        return (f"{model_label(self.effects, base)} fits better (Δ{self.criterion} {-self.delta_bic:+.1f}, reduced χ² "
                f"{self.reduced_chi2:.3g}) but the data do not identify "
                + "; ".join(u.text() for u in self.why) + ": left out")


@dataclass(frozen=True)
class Diagnosis:
    steps: tuple[Step, ...]
    final: FitResult
    nonlinearity: Nonlinearity
    notes: tuple[str, ...]
    #: "explained": the selected model is consistent with the noise; "not_explained": no model is
    verdict: str
    #: one sentence: what explains the data, or what no effect of the library reproduces
    explanation: str
    alternatives: tuple[Alternative, ...]
    #: every model of the search, by effect set
    models: dict[tuple[str, ...], FitResult]
    #: the model the selection would have reported had it not named effects the data do not identify
    left_out: LeftOut | None = None
    #: what ranks the models: "BIC", or "QBIC" when no model is consistent with the noise (module doc of
    #: ``plant.diagnose.evidence``), with its over-dispersion (1 for BIC)
    criterion: str = "BIC"
    overdispersion: float = 1.0
    #: the reported model's base parameters that are implausible (``plant.diagnose.plausibility``)
    implausible: tuple[str, ...] = ()
    #: the gain's drift over a stepped sine, when named (``plant.diagnose.drift``); ``final`` is then the model
    #: refitted with it when that explains the data
    drift: Drift | None = None

    @property
    def final_effects(self) -> tuple[str, ...]:
        return self.final.plant.effect_names

    @property
    def added(self) -> tuple[str, ...]:
        return self.final_effects[len(self.steps[0].effects):]

    def story(self) -> Story:
        """The diagnosis as the reports tell it: the verdict first, where the base model fails and the
        nonlinearity; then the candidates tried on the base model, the error step by step with each decision,
        the models the data cannot rule out, the selected (or best) model and its parameters, and the path to it
        in sentences (ΔBIC: BIC before minus after, positive favours the addition)."""
        first, final = self.steps[0], self.final
        base = first.effects
        headline = (("Verdict", self.explanation),
                    ("Fitted", fitted_sentence(final)),
                    ("Where the base model fails", first.residuals.description),
                    ("Nonlinearity", self.nonlinearity.description))
        delta = f"Δ{self.criterion}"
        candidates = Table(("effect", delta, "reduced χ²", "note"),
                           tuple((c.effect, "" if c.skipped else delta_bic_text(c.delta_bic),
                                  "" if c.skipped or math.isnan(c.reduced_chi2) else f"{c.reduced_chi2:.3g}",
                                  c.skipped) for c in first.ranking), frozenset({0, 3}))
        steps = Table(("model", "reduced χ²", "RMS mag (dB)", "RMS phase (deg)", self.criterion),
                      tuple((model_label(s.effects, base), f"{s.fit.reduced_chi2:.3g}",
                             f"{s.rms_magnitude_error_db:.3f}", f"{s.rms_phase_error_deg:.2f}", f"{s.score:.1f}")
                            for s in self.steps))
        sections = [Section("Candidates tried on the base model", table=candidates),
                    Section("The error, step by step", tuple(f"→ {s.decision}" for s in self.steps), table=steps)]
        if self.alternatives:
            sections.append(Section(
                f"Models within {delta} {ACCEPT_DELTA_BIC:g} of the selected one",
                table=Table(("model", delta, "reduced χ²", "consistent with noise", "relation"),
                            tuple((model_label(a.effects), f"{a.delta_bic:+.1f}", f"{a.reduced_chi2:.3g}",
                                   "yes" if a.consistent_with_noise else "no", a.note) for a in self.alternatives),
                            frozenset({0, 3, 4}))))
        modes = final.plant.modes_hz()
        sections.append(model_section(self.verdict, (f"effects: {', '.join(self.final_effects) or 'none'}",
                                                     *((f"mechanical modes: {', '.join(f'{m:.4g} Hz' for m in modes)}",)
                                                       if modes.size else ()))))
        sections.append(parameter_section(final))
        if self.left_out is not None:
            sections.append(Section("Not identified", (self.left_out.sentence(base),)))
        if self.drift is not None:
            words = self.drift.text()
            sections.append(Section("Drift over the record", (f"{words[0].upper()}{words[1:]}.",)))
        sections.append(Section("The path to the model", self._path(), kind="numbered"))
        if self.notes:
            sections.append(Section("Notes", self.notes, kind="notes"))
        return Story(headline, tuple(sections))

    def _path(self) -> tuple[str, ...]:
        """The base model, each effect added on the path to the selected model, and the verdict, in sentences."""
        first = self.steps[0]
        items = [f"The base model ({', '.join(first.effects) or 'no effects'}) fits with reduced χ² "
                 f"{first.fit.reduced_chi2:.3g}, RMS error {first.rms_magnitude_error_db:.3g} dB / "
                 f"{first.rms_phase_error_deg:.3g}°."]
        for before, step in zip(self.steps, self.steps[1:]):
            added = ", ".join(e for e in step.effects if e not in before.effects)
            items.append(f"Adding {added}: Δ{self.criterion} {before.score - step.score:+.1f}, reduced χ² "
                         f"{before.fit.reduced_chi2:.3g} → {step.fit.reduced_chi2:.3g}.")
        others = (f"; {len(self.alternatives)} other model(s) lie within Δ{self.criterion} {ACCEPT_DELTA_BIC:g} of "
                  "the selected one" if self.alternatives else "")
        if self.criterion != "BIC":
            others += (f"; no model is consistent with the noise, so they are ranked by QBIC (χ² over the best "
                       f"model's over-dispersion {self.overdispersion:.3g}, plus BIC's penalty)")
        items.append(f"{len(self.models)} models searched{others}. Verdict: {self.explanation.rstrip('.')}.")
        return tuple(items)


def chi2_is_noise(fit: FitResult) -> bool:
    """chi^2 no larger than a correct model's at the one-sided ``NOISE_Z`` sigma level, over all
    frequencies and in each of ``ADEQUACY_BANDS`` bands of consecutive frequencies (a misfit
    confined to one band, such as an unmodelled mode, must not hide in the total; Bonferroni over
    the bands).

    Per frequency and output, re^2 + im^2 of the normalised residual is 2 F(2, nu) when the variance
    comes from an estimate with nu degrees of freedom (chi^2_2 for nu = inf), scaled by
    1 - n_params / n_data for the fitted parameters. Sums of these are right-skewed (heavy F tails),
    so the tail probabilities come from ``REFERENCE_DRAWS`` seeded draws of the reference
    distribution rather than from a normal approximation.
    """
    if fit.dof <= 0:
        return False
    per_freq = fit.chi2_per_frequency
    groups = [np.arange(per_freq.size)] + (
        np.array_split(np.arange(per_freq.size), ADEQUACY_BANDS) if per_freq.size >= 2 * ADEQUACY_BANDS else [])
    sums = _reference_sums(tuple(np.asarray(fit.variance_dof, float)), fit.residuals.shape[0], len(groups))
    scale = 1 - fit.n_params / fit.n_data
    alpha = float(special.ndtr(-NOISE_Z))
    for g, idx in enumerate(groups):
        level = alpha if g == 0 else alpha / ADEQUACY_BANDS
        if np.mean(sums[g] * scale >= per_freq[idx].sum()) < level:
            return False
    return True


@functools.lru_cache(maxsize=32)
def _reference_sums(nu: tuple[float, ...], n_out: int, n_groups: int) -> np.ndarray:
    """``REFERENCE_DRAWS`` seeded draws of a correct model's chi^2 summed over all frequencies (row 0) and, when
    ``n_groups`` > 1, over each of the ``ADEQUACY_BANDS`` bands (rows 1...), shape (n_groups, draws)."""
    rng = np.random.default_rng(0)
    nu_arr = np.asarray(nu)
    terms = rng.chisquare(2, (REFERENCE_DRAWS, n_out, nu_arr.size))
    finite = np.isfinite(nu_arr)
    if finite.any():
        scale = rng.chisquare(nu_arr[finite], (REFERENCE_DRAWS, n_out, int(finite.sum()))) / nu_arr[finite]
        terms[:, :, finite] /= scale
    draws = terms.sum(axis=1)
    bands = np.array_split(np.arange(nu_arr.size), ADEQUACY_BANDS) if n_groups > 1 else []
    return np.stack([draws.sum(axis=1)] + [draws[:, idx].sum(axis=1) for idx in bands])


def _step(fit: FitResult, data: MeasuredResponse, ranking, decision, score: float) -> Step:
    res = residual_summary(data.f_hz, data.response, data.variance, fit.model_response)
    rms_mag = float(np.sqrt(np.mean(res.magnitude_error_db**2)))
    rms_ph = float(np.sqrt(np.mean(res.phase_error_deg**2)))
    return Step(fit.plant.effect_names, fit, res, rms_mag, rms_ph, tuple(ranking), decision, score)


def detect_nonlinearity(data: MeasuredResponse, *, amplitude_dependent: bool | None = None) -> Nonlinearity:
    """Odd-harmonic distortion above its noise floor, or amplitude dependence, means nonlinear.

    ``distortion`` (what a model must then reproduce to explain the data) is harmonics above that floor and
    above what an encoder's quantisation makes by itself (``_quantisation_floor``), or output at a
    multisine's lines not excited. Harmonics that could not be measured (NaN: at or above 0.45 x the sample
    rate) are left out; they never hide the others."""
    hd = np.asarray(data.harmonic_distortion, float)
    hd2, hd3 = hd[..., 0], hd[..., 1]
    # white noise puts about as much noise in a harmonic's bin as in the fundamental's, whose
    # relative standard deviation is sqrt(var)/|G|: count 4 sigma of it, and at least 0.5 %
    floor = np.maximum(4.0 * np.sqrt(np.asarray(data.variance)) / np.abs(data.response), 0.005)
    ratio = np.where(np.isfinite(hd3), hd3 / floor, -np.inf)
    extra = ("; response depends on the excitation amplitude" if amplitude_dependent else
             "; no amplitude dependence between the recordings") if amplitude_dependent is not None else ""
    lines = _multisine_distortion(data)
    if not np.any(np.isfinite(ratio)):
        words = lines or "no harmonic was measurable"
        detected = bool(lines) or bool(amplitude_dependent)
        return Nonlinearity(detected, float("nan"), float("nan"), float("nan"), amplitude_dependent,
                            ("detected: " if detected else "none: ") + words + extra, bool(lines))
    k = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    detected = bool(ratio[k] > 1.0) or bool(amplitude_dependent)
    harmonics = bool(np.any(np.isfinite(hd3) & (hd3 > np.maximum(floor, _quantisation_floor(data)))))
    f_at = float(np.asarray(data.f_hz)[k[-1]])
    words = (f"3rd harmonic up to {100 * hd3[k]:.2f} % of the fundamental at {f_at:.3g} Hz "
             f"(threshold {100 * floor[k]:.2f} %)")
    if detected and not harmonics and np.any(np.isfinite(hd3) & (hd3 > floor)):
        words += ", within what the encoder's quantisation makes"
    if harmonics:
        above = np.isfinite(hd3) & (hd3 > floor)
        even = np.where(np.isfinite(hd2), hd2 / floor, -np.inf)
        f = np.broadcast_to(np.asarray(data.f_hz, float), hd3.shape)
        words += (f", above the threshold at {int(above.sum())} of {int(np.isfinite(hd3).sum())} frequencies "
                  f"({f[above].min():.3g}..{f[above].max():.3g} Hz); 2nd harmonic up to "
                  f"{100 * float(np.nanmax(np.where(np.isfinite(hd2), hd2, np.nan))):.2f} %: "
                  + ("odd and even harmonics (an asymmetric nonlinearity)" if np.any(even > 1.0) else
                     "odd harmonics only (a symmetric nonlinearity: friction, saturation)"))
    return Nonlinearity(detected, float(hd3[k]), f_at, float(floor[k]), amplitude_dependent,
                        ("detected: " if detected else "none: ") + words + extra, harmonics)


def _quantisation_floor(data: MeasuredResponse) -> np.ndarray | float:
    """Harmonic ratio an encoder's quantisation can make by itself, per output and frequency (0 without an
    encoder): a position quantised in steps q is wrong by at most q / 2, whose harmonics in the differenced
    velocity stay below about q / X of the fundamental for a motion of amplitude X = |G| I / w."""
    quantum = data.metadata.get("encoder_velocity_quantum_m_per_s")
    rate = data.metadata.get("sample_rate_hz")
    if not quantum or not rate:
        return 0.0
    x = np.abs(data.response) * np.asarray(data.current_amplitude_a, float) / (2 * np.pi * np.asarray(data.f_hz))
    with np.errstate(divide="ignore"):
        return float(quantum) / float(rate) / x


def _multisine_distortion(data: MeasuredResponse) -> str:
    """The periodic estimator's finding of output at the lines not excited, in words ("" when none)."""
    significant = data.metadata.get("distortion_significant") or {}
    levels = data.metadata.get("distortion") or {}
    found = []
    for name, kinds in significant.items():
        for kind, hit in kinds.items():
            if hit:
                worst = max(levels[name][kind], key=lambda band: band["level_db"])
                found.append(f"output {name}: {worst['level_db']:.1f} dB above the noise at the {kind} lines not "
                             f"excited ({worst['f_lo_hz']:g}..{worst['f_hi_hz']:g} Hz)")
    return "; ".join(found)


def distortion_sources() -> tuple[str, ...]:
    """The effects of the library that make harmonics (nonlinear ones)."""
    return tuple(n for n, cls in EFFECTS.items() if not cls.linear)


def _pool(plant: Plant, data: MeasuredResponse, nonlinear: Nonlinearity,
          candidates: tuple[str, ...] | None) -> tuple[list[str], dict[str, str]]:
    """Effects the search may add, and why the others are left out."""
    skipped = {}
    pool = []
    for name in candidates if candidates is not None else tuple(EFFECTS):
        cls = EFFECTS[name]
        if name in plant.effect_names:
            skipped[name] = "already in the model"
        elif not cls.searched:
            skipped[name] = cls.not_searched
        elif plant.stage not in cls.stages:
            skipped[name] = f"applies to Stage {'/'.join(s.upper() for s in cls.stages)} only"
        elif len(data.output_names) < cls.min_outputs:
            skipped[name] = "needs Stage Y with both rails Y1 and Y2 recorded"
        elif not cls.linear and not nonlinear.detected:
            skipped[name] = "no harmonic distortion or amplitude dependence in the data"
        else:
            pool.append(name)
    return pool, skipped


def _fit_child(parents: list[FitResult], name: str, plant: Plant, data: MeasuredResponse,
               free_base: tuple[str, ...], fixed: tuple[str, ...]) -> FitResult:
    """Fit ``plant`` (a parent plus ``name``) from its parents' optima, the new effect neutral and at
    its guesses on the best parent's residual."""
    effect = plant.effect(name)
    free = free_base + tuple(p for p in plant.parameters() if "." in p and p not in fixed and
                             p.split(".", 1)[1] not in EFFECTS[p.split(".", 1)[0]].search_fixed)
    parents = sorted(parents, key=lambda r: r.chi2)
    neutral = {f"{name}.{k}": v for k, v in effect.neutral.items()}
    starts = [{**parents[0].values, **neutral}]
    model = parents[0].model_response
    # a parent held by its friction at a frequency (no motion) tells nothing about the new effect there
    ratio = np.divide(data.response, model, out=np.ones_like(data.response), where=model != 0)
    guesses = effect.guesses(data.w_rad_s, ratio)
    if not effect.linear:
        force = float(np.mean(np.asarray(plant.force_constant_n_per_a) * np.asarray(data.current_amplitude_a)))
        guesses = guesses + [{effect.main_parameter: share * force} for share in FRICTION_SHARES]
    starts += [{**parents[0].values, **{f"{name}.{k}": v for k, v in g.items()}} for g in guesses]
    for other in parents[1:2]:
        missing = [e for e in plant.effects if e.name not in other.plant.effect_names]
        starts.append({**other.values, **{f"{e.name}.{k}": v for e in missing for k, v in e.neutral.items()}})
    return fit_plant(plant, data, free=free, starts=starts)


def _relation(a: tuple[str, ...], b: tuple[str, ...], fits) -> str:
    """What makes two models of nearly equal BIC equivalent, in words."""
    only_a, only_b = set(a) - set(b), set(b) - set(a)
    if not only_a or not only_b:
        extra = only_a or only_b
        verb = "adds" if only_a else "lacks"
        return f"{verb} {', '.join(sorted(extra))}, which the data neither need nor rule out"
    delays = []
    for names, effs in ((only_a, a), (only_b, b)):
        plant = fits[effs].plant
        for n in sorted(names):
            tau = plant.effect(n).equivalent_delay_s()
            if tau is not None:
                delays.append(f"{n} = {1e3 * tau:.3g} ms")
    if len(delays) == len(only_a) + len(only_b):
        return ("drive/sensor lags the data cannot tell apart below their corners; equivalent delays: "
                + ", ".join(delays))
    return "fits as well with different effects"


def diagnose(plant: Plant, data: MeasuredResponse, *, candidates: tuple[str, ...] | None = None,
             free_base: tuple[str, ...] = ("mass_kg", "damping_n_s_per_m"),
             amplitude_dependent: bool | None = None, max_effects: int = MAX_EFFECTS,
             progress=None) -> Diagnosis:
    """Diagnose which effects ``plant`` misses to explain ``data`` (see module doc).

    ``plant`` sets the stage, geometry and starting values (its effects, if any, are kept and
    refitted); ``free_base`` are the base parameters fitted in every model (add
    ``force_constant_n_per_a`` when asked). ``amplitude_dependent`` comes from comparing
    recordings at several amplitudes (``plant.estimate.lockin.amplitude_dependence``). A recording whose
    velocity is an encoder position differenced at its sample rate (``data.metadata``) gets that
    sensor in every model. ``progress(done, total)`` hears the models fitted (``search.fit_models``).
    """
    if candidates is not None:
        candidates = tuple(dict.fromkeys(candidates))      # an effect named twice is one candidate
    n_freq = len(data.f_hz)
    n_values = 2 * n_freq * len(data.output_names)
    if n_values <= len(free_base) + len(plant.parameters()) - 3:
        raise DataError(
            f"{data.source}: {n_freq} frequenc{'y' if n_freq == 1 else 'ies'} give {n_values} real values, which "
            f"exactly determine (or fewer than) the {len(free_base)} base parameters ({', '.join(free_base)}): "
            "nothing is left to test the model or a missing effect. Record more frequencies (the thesis used 1-75 Hz).")
    notes = list(getattr(data, "notes", ()))
    fixed: tuple[str, ...] = ()
    quantum = data.metadata.get("encoder_velocity_quantum_m_per_s")
    rate = data.metadata.get("sample_rate_hz")
    if quantum and rate and "encoder_velocity" not in plant.effect_names:
        plant = plant * EncoderVelocity(float(rate))
        fixed = ("encoder_velocity.rate_hz",)
        notes.append(f"velocity is an encoder position differenced at {float(rate):g} Hz (steps of "
                     f"{float(quantum):.3g} m/s): every model includes its half-sample delay and sinc droop")
    nonlinear = detect_nonlinearity(data, amplitude_dependent=amplitude_dependent)
    pool, skipped = _pool(plant, data, nonlinear, candidates)
    own = tuple(p for p in plant.parameters() if "." in p and p not in fixed)
    base_fit = fit_plant(plant, data, free=free_base + own)
    base = plant.effect_names

    def fit(combo: tuple[str, ...], parents: list[FitResult]) -> FitResult | str:
        n_new = sum(len(EFFECTS[n].bounds) - len(EFFECTS[n].search_fixed) for n in combo)
        if n_values - len(free_base) - len(own) - n_new < 1:
            return (f"not identifiable: {n_freq} frequencies give {n_values} real values for "
                    f"{len(free_base) + len(own) + n_new} parameters")
        best = min(parents, key=lambda r: r.chi2)
        (name,) = [n for n in combo if n not in best.plant.effect_names]
        effect = make_effect(name)
        host = best.plant if effect.linear else replace(
            best.plant, excitation_current_a=np.asarray(data.current_amplitude_a, dtype=float))
        return _fit_child(parents, name, host * effect, data, free_base, fixed)

    fits, unidentifiable = fit_models(base, base_fit, pool, fit, max_effects=max_effects,
                                      valid=lambda combo: compatible(combo, base), progress=progress)
    adequate = {k: chi2_is_noise(f) for k, f in fits.items()}
    n_params = {k: f.n_params for k, f in fits.items()}
    band = (float(np.min(data.f_hz)), float(np.max(data.f_hz)))
    gaps = {k: unidentified(f, base, band) for k, f in fits.items()}
    identified = {k: f for k, f in fits.items() if not gaps[k]}
    rank = rank_models(fits, adequate)
    score = rank.score
    selected = select_model({k: score[k] for k in identified}, {k: adequate[k] for k in identified}, n_params)
    unchecked = select_model(score, adequate, n_params)
    final = fits[selected]
    left_out = None if unchecked == selected or not gaps[unchecked] else LeftOut(
        unchecked, score[unchecked] - score[selected], fits[unchecked].reduced_chi2, gaps[unchecked], rank.criterion)
    explained = adequate[selected]
    drift, drift_explains = None, False
    if not explained:
        ranked = _ranked({k: score[k] for k in identified})
        tried = [k for k in dict.fromkeys(ranked[:DRIFT_MODELS] + [k for k in ranked if len(k) <= len(base) + 1])
                 if fits[k].plant.linear]      # a friction model's refit at each rate costs seconds: not tried
        drifted = _drifted(tried, fits, data, lambda fit: not unidentified(fit, base, band))
        if drifted is not None:
            drift = drifted[1]
            drift_explains = chi2_is_noise(drift.fit)
            if drift_explains:
                selected = drifted[0]              # the model the drift explains the record with
                final = fits[selected]
    # a linear model makes no harmonics: with distortion in the data its fit is a describing function (the gain
    # of the fundamental at this amplitude), not the stage, however well it fits
    unexplained_distortion = nonlinear.distortion and all(EFFECTS[n].linear for n in selected)
    alternatives = tuple(
        Alternative(k, score[k] - score[selected], fits[k].reduced_chi2, adequate[k],
                    (f"lower {rank.criterion}, but its extra parameters fall short of very strong evidence; "
                     if score[k] < score[selected] else "") + _relation(k, selected, fits))
        for k in _ranked({k: score[k] for k in identified})
        if k != selected and score[k] - score[selected] < ACCEPT_DELTA_BIC)
    steps = _path(fits, score, rank.criterion, base, selected, data, skipped, unidentifiable, pool)
    final_res = steps[-1].residuals
    explained_by_drift = drift_explains and not unexplained_distortion
    if explained_by_drift:
        final, explained = drift.fit, True
        named = ", ".join(selected[len(base):]) or "the refitted base model"
        explanation = (f"explained by {named} with a gain drifting over the record (reduced chi-square "
                       f"{final.reduced_chi2:.3g}, expected {final.expected_reduced_chi2:.3g}: the residuals are "
                       f"consistent with the noise): {drift.text()}")
    elif explained and unexplained_distortion:
        explained = False
        named = " + ".join(("base",) + selected[len(base):])
        explanation = (f"not explained: {named} fits the fundamental within the noise (reduced chi-square "
                       f"{final.reduced_chi2:.3g}) but makes no harmonics, and the data hold distortion above the "
                       f"noise ({nonlinear.description.removeprefix('detected: ')}); its parameters are those of "
                       f"a describing function at this amplitude, not of the stage. {_sources(pool, skipped)}")
    elif explained:
        named = ", ".join(selected[len(base):]) or "no effect beyond the refitted base model"
        explanation = (f"explained by {named} (reduced chi-square {final.reduced_chi2:.3g}, expected "
                       f"{final.expected_reduced_chi2:.3g}: the residuals are consistent with the noise)")
    else:
        where = final_res.description
        peaks = _residual_peak(final_res)
        explanation = (f"not explained: no model of the library is consistent with the noise (best: "
                       f"{' + '.join(('base',) + selected[len(base):])}, reduced chi-square {final.reduced_chi2:.3g}); "
                       f"the residual {peaks}no effect of the library reproduces: {where}")
        if drift is not None:
            explanation += f"; and {drift.text()}"
        if unexplained_distortion:
            explanation += (f"; and the data hold distortion a linear model does not make "
                            f"({nonlinear.description.removeprefix('detected: ')}). {_sources(pool, skipped)}")
        elif nonlinear.distortion:
            explanation += (f"; and the data hold distortion the best model does not reproduce within the noise "
                            f"({nonlinear.description.removeprefix('detected: ')})")
    odd = implausible(final, plant)
    explanation += warning(odd)
    if left_out is not None and not explained_by_drift:       # (a drift that explains makes the ranking moot)
        explanation += f"; {left_out.sentence(base)}"
    last = steps[-1]
    steps[-1] = replace(last, decision=explanation if not last.decision else f"{last.decision}; {explanation}")
    for flag in final.flags:
        if "cannot be told apart" in flag:
            notes.append(flag)
    return Diagnosis(tuple(steps), final, nonlinear, tuple(dict.fromkeys(notes)),
                     verdict(explained), explanation, alternatives, fits, left_out, rank.criterion,
                     rank.overdispersion, odd, drift)


def _drifted(models: list[tuple[str, ...]], fits, data: MeasuredResponse,
             identified) -> tuple[tuple[str, ...], Drift] | None:
    """The model and drift (``plant.diagnose.drift``) named on the best of ``models`` (the ``DRIFT_MODELS`` best-ranked
    identified models and every identified model of one effect, when none is consistent with the noise; linear ones:
    a drift is not tried beside Coulomb friction, whose describing-function refit costs seconds per rate): among
    those on which it is significant and whose drift-corrected fit still names only identified effects
    (``identified(fit)``), the one the search's selection rule picks from their drift-corrected fits
    (``plant.diagnose.search.select_model``); None where none is. A
    drift confounds with the frequency in a sweep, so the model a drift-free ranking puts first need not be the
    one the drift completes (a lag may stand in for a delay until the gain's trend is taken out)."""
    found = {k: d for k, d in ((k, fit_drift(fits[k], data)) for k in models)
             if d is not None and d.significant and identified(d.fit)}
    if not found:
        return None
    chosen = select_model({k: d.fit.bic for k, d in found.items()}, {k: chi2_is_noise(d.fit) for k, d in found.items()},
                          {k: d.fit.n_params for k, d in found.items()})
    return chosen, found[chosen]


def _ranked(bic: dict[tuple[str, ...], float]) -> list[tuple[str, ...]]:
    """Models by rising BIC; a run of models each within ``TIED_BIC`` of the one before is a tie, listed in
    name order."""
    order = sorted(bic, key=bic.get)
    runs: list[list[tuple[str, ...]]] = []
    for k in order:
        if runs and bic[k] - bic[runs[-1][-1]] < TIED_BIC:
            runs[-1].append(k)
        else:
            runs.append([k])
    return [k for run in runs for k in sorted(run)]


def _sources(pool: list[str], skipped: dict[str, str]) -> str:
    """The library's effects that make harmonics, and whether the search tried them, in words."""
    tried = [n for n in distortion_sources() if n in pool]
    not_tried = [f"{n} ({skipped[n]})" for n in distortion_sources() if n in skipped]
    words = "Effects of the library that make harmonics: "
    words += f"{', '.join(tried)} tried, not selected" if tried else ""
    words += ("; " if tried and not_tried else "") + (f"not tried: {', '.join(not_tried)}" if not_tried else "")
    return words


def _residual_peak(res: ResidualSummary) -> str:
    """Where the normalised residual is largest, in words ("peaks near 59 Hz, where ")."""
    r = np.sum(np.abs(res.normalised) ** 2, axis=0)
    k = int(np.argmax(r))
    if np.isnan(res.magnitude_error_db[:, k]).any():
        return f"is largest near {res.f_hz[k]:.3g} Hz, where the model holds the stage still by its friction, which "
    return f"is largest near {res.f_hz[k]:.3g} Hz ({res.magnitude_error_db[:, k].mean():+.2f} dB, " \
           f"{res.phase_error_deg[:, k].mean():+.1f} deg), which "


def _path(fits, score, criterion, base, selected, data, skipped, unidentifiable, pool) -> list[Step]:
    """Steps from the base model to ``selected`` (``plant.diagnose.search.path_to`` on ``score``), each with the
    effects tried as additions to it, ranked."""
    models = path_to(score, base, selected)
    steps = []
    for current, nxt in zip(models, models[1:] + [None]):
        ranking = []
        for k in children(fits, current):
            (name,) = set(k) - set(current)
            ranking.append(Candidate(name, addition_delta_bic(score[current], score[k]), fits[k].reduced_chi2,
                                     fits[k]))
        ranking.sort(key=lambda c: -c.delta_bic)
        tried = {c.effect for c in ranking}
        for name in pool:
            combo = tuple(n for n in current[len(base):]) + (name,)
            if name not in tried and name not in current:
                reason = unidentifiable.get(tuple(sorted(combo, key=pool.index)), "") or \
                    ("" if compatible(combo, base) else "cannot be combined with the model's effects")
                if reason:
                    ranking.append(Candidate(name, float("nan"), float("nan"), None, reason))
        ranking += [Candidate(n, float("nan"), float("nan"), None, why) for n, why in skipped.items()
                    if current == base]
        if nxt is None:
            steps.append(_step(fits[current], data, ranking, "", score[current]))
            break
        (name,) = set(nxt) - set(current)
        steps.append(_step(fits[current], data, ranking,
                           f"add {name} (d{criterion} {score[current] - score[nxt]:+.1f}; signature: "
                           f"{EFFECTS[name].signature})", score[current]))
    return steps
