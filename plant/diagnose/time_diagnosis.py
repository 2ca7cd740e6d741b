"""Diagnosis on a time-domain recording: where the thesis's linear model (mass and rail damping)
fails, which force effects are missing, added one at a time while the error falls.

Candidates are the effects with a force model (``Effect.force_regressors``: ``coulomb_friction``,
``stribeck_friction``, ``offset``, ``current_limit``, and with the position recorded ``force_ripple`` and
``force_constant_profile``), the fields that shape their signals (a Stribeck velocity, a limit, a pitch, a
span) set from the recording and the residual of the model each is added to (``Effect.configured``). Every
combination of up to ``MAX_TIME_EFFECTS`` is fitted by the inverse model (``plant.identify.time_fit``; linear
least squares, so each fit is global and a model containing another never fits worse), except those of the largest
size, which are no other's parent, that the admission rule (``not_admitted``) would drop, in the model search of
``plant.diagnose.search``, which selects among them as for a frequency response: by BIC, with the
residual's own variance and one effective sample size for all (that of the model leaving the least
residual, the closest to the noise whose correlation the size describes; ``plant.identify.time_fit``
module doc), and with "consistent with the noise" meaning a residual without
structure (``TimeFitResult.explained``). The verdict is "explained" only when the selected model's is;
otherwise it says what is left and where.

The base model's residual is described by regime of motion and by direction: a force that
changes sign with the direction of motion is the signature of Coulomb friction; one of the same
sign both ways, of a constant force.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from plant.data.recordings import TimeRecording
from plant.diagnose.evidence import (
    ACCEPT_DELTA_BIC,
    addition_delta_bic,
    delta_bic_text,
    fitted_sentence,
    model_label,
    model_section,
    parameter_section,
    verdict,
)
from plant.diagnose.plausibility import implausible, warning
from plant.diagnose.search import compatible, fit_models, path_to, select_model
from plant.diagnose.two_rails import RailReading, at_one_scale
from plant.errors import EffectError, ParameterError
from plant.identify.compensation import CompensationTable, compensation_table
from plant.identify.inverse_model import InverseModelData, Preprocessing, inverse_model_data
from plant.identify.time_fit import STRUCTURE_SHARE, TimeFitResult, bic, fit_inverse_model, fit_samples
from plant.physics.effect_base import Effect
from plant.physics.effects import EFFECTS, make_effect
from plant.physics.models import Plant
from plant.story import Section, Story, Table

#: fraction of the 99th percentile of |v| above which a sample counts as moving in one direction
DIRECTION_FRACTION = 0.05
#: most effects in one model of the search
MAX_TIME_EFFECTS = 3
#: the dropped models with a lower BIC than the selected one that the story shows (the JSON has them all)
LEFT_OUT_SHOWN = 5
#: an effect that contains another (``Effect.contains``) is claimed only when the parameter that tells them apart
#: lies this many robust (Newey-West) standard errors from the value at which it is the other
NESTED_Z = 3.0


@dataclass(frozen=True)
class TimeCandidate:
    """One effect tried on the base model (``delta_bic`` as ``plant.diagnose.evidence`` has it: positive favours it)."""

    effect: str
    delta_bic: float
    rms_residual_n: float
    #: plain least squares' rms residual, which ``delta_bic`` compares (``TimeFitResult.ls_rms_residual``)
    ls_rms_residual_n: float


@dataclass(frozen=True)
class TimeStep:
    """One model on the path from the base to the selected model."""

    effects: tuple[str, ...]
    fit: TimeFitResult
    bic: float
    decision: str


@dataclass(frozen=True)
class DirectionalResidual:
    """Mean residual (N) while moving forward and backward, and what their signs suggest."""

    forward_n: float
    backward_n: float
    description: str


@dataclass(frozen=True)
class TimeAlternative:
    """A model the data cannot rule out beside the selected one: its effects, its BIC above the selected one's,
    its rms residual (N) and whether it is consistent with the noise."""

    effects: tuple[str, ...]
    delta_bic: float
    rms_residual_n: float
    consistent_with_noise: bool
    #: plain least squares' rms residual, which ``delta_bic`` compares
    ls_rms_residual_n: float


@dataclass(frozen=True)
class TimeLeftOut:
    """A model whose BIC lies within ``ACCEPT_DELTA_BIC`` of the selected one's, or below it, that the rule admitting
    a model drops (``not_admitted``): its effects, its BIC above the selected one's, plain least squares' rms
    residual (N, what the BIC compares) and why it is dropped."""

    effects: tuple[str, ...]
    delta_bic: float
    ls_rms_residual_n: float
    reason: str


@dataclass(frozen=True)
class TimeDiagnosis:
    """Result of ``diagnose_time``."""

    steps: tuple[TimeStep, ...]
    ranking: tuple[TimeCandidate, ...]
    models: dict[tuple[str, ...], TimeFitResult]
    selected: tuple[str, ...]
    verdict: str
    explanation: str
    where_it_fails: str
    direction: DirectionalResidual
    #: the effective sample size shared by the BIC of every model
    n_effective: float
    #: frequency (Hz) at which the selected model's residual has most power, and its share of it
    residual_peak_hz: float
    residual_peak_share: float
    notes: tuple[str, ...]
    #: position (m) at the fits' samples, None when the recording has velocity only
    position_m: np.ndarray | None = None
    #: the selected model's base parameters that are implausible (``plant.diagnose.plausibility``)
    implausible: tuple[str, ...] = ()
    #: both rails read jointly (Stage Y with two outputs, ``plant.diagnose.two_rails``), None for one output
    rails: RailReading | None = None
    #: the models within ``ACCEPT_DELTA_BIC`` of the selected one, or below it, that the admission rule drops
    left_out: tuple[TimeLeftOut, ...] = ()

    @property
    def final(self) -> TimeFitResult:
        return self.models[self.selected]

    def bic(self, combo: tuple[str, ...]) -> float:
        """The BIC of the model of ``combo`` with the effective sample size shared by all (``time_fit.bic``)."""
        return bic(self.models[combo], self.n_effective)

    @property
    def alternatives(self) -> tuple[TimeAlternative, ...]:
        """The other models the rule admits within ``ACCEPT_DELTA_BIC`` of the selected one (the data cannot rule
        them out; ``left_out`` has those it drops)."""
        chosen = self.bic(self.selected)
        dropped = {m.effects for m in self.left_out}
        return tuple(TimeAlternative(c, self.bic(c) - chosen, f.rms_residual, f.explained, f.ls_rms_residual)
                     for c, f in self.models.items()
                     if c != self.selected and c not in dropped and self.bic(c) - chosen < ACCEPT_DELTA_BIC)

    def compensation(self) -> CompensationTable:
        """The drive's compensation table of the selected model's position-dependent forces
        (``plant.identify.compensation``)."""
        if self.position_m is None:
            raise ParameterError("the recording has no position: there is no position-dependent force to compensate")
        return compensation_table(self.final, self.position_m)

    def story(self) -> Story:
        """The diagnosis as the reports tell it: the verdict first, the residual's size against the noise, where
        the base model fails and by direction of motion; then the candidates tried on the base model, the error
        step by step (by regime of motion) with each decision, the models the data cannot rule out, and the
        selected (or best) model's parameters."""
        base, final = self.steps[0].fit, self.final
        fitted = fitted_sentence(final)
        if self.rails is not None and self.rails.scale_claimed:
            fitted += (f", rail_scale.y2_scale = {self.rails.y2_scale:.5g} ± {self.rails.y2_scale_stderr:.2g} "
                       "(from both rails)")
        headline = (("Verdict", self.explanation),
                    ("Fitted", fitted),
                    ("The error", f"rms residual {base.rms_residual:.3g} N (base) → {final.rms_residual:.3g} N"
                                  + (f" (least squares, which the BIC compares: {base.ls_rms_residual:.3g} → "
                                     f"{final.ls_rms_residual:.3g} N)" if base.compensated or final.compensated
                                     else "") + f"; noise alone {final.noise_rms:.3g} N"),
                    ("Where the base model fails", self.where_it_fails),
                    ("By direction of motion", self.direction.description))
        regimes = [r.name for r in base.regimes]
        # where a fit took its columns' noise out, its residual lies above least squares' by construction, and the
        # BIC compares least squares': that one is shown beside it
        both = any(f.compensated for f in self.models.values())
        ls_head = ("least squares (N)",) if both else ()

        def ls(rms: float) -> tuple[str, ...]:
            return (f"{rms:.4g}",) if both else ()

        steps = []
        for s in self.steps:
            by = {r.name: f"{r.rms_residual:.3g}" for r in s.fit.regimes}
            steps.append((model_label(s.effects), f"{s.fit.rms_residual:.4g}", *ls(s.fit.ls_rms_residual),
                          f"{s.fit.noise_ratio:.3g}", *(by.get(n, "") for n in regimes), f"{s.bic:.1f}"))
        aside = ("(the fits take the columns' noise out; BIC compares plain least squares' residual on the recorded "
                 "columns)") if both else ""
        sections = [
            Section("Candidates tried on the base model",
                    table=Table(("effect", "ΔBIC", "rms residual (N)", *ls_head),
                                tuple((c.effect, delta_bic_text(c.delta_bic), f"{c.rms_residual_n:.4g}",
                                       *ls(c.ls_rms_residual_n)) for c in self.ranking)),
                    aside=aside),
            Section("The error, step by step", tuple(f"→ {s.decision}" for s in self.steps),
                    table=Table(("model", "rms residual (N)", *ls_head, "× noise", *(f"{n} (N)" for n in regimes),
                                 "BIC"), tuple(steps)),
                    aside="(rms residual overall and by regime of motion)")]
        if self.alternatives:
            sections.append(Section(
                f"Models within ΔBIC {ACCEPT_DELTA_BIC:g} of the selected one",
                table=Table(("model", "ΔBIC", "rms residual (N)", *ls_head, "consistent with noise"),
                            tuple((model_label(a.effects), f"{a.delta_bic:+.1f}", f"{a.rms_residual_n:.4g}",
                                   *ls(a.ls_rms_residual_n), "yes" if a.consistent_with_noise else "no")
                                  for a in self.alternatives),
                            frozenset({0, 3 + len(ls_head)}))))
        below = [m for m in self.left_out if m.delta_bic < 0]
        if below:
            shown = below[:LEFT_OUT_SHOWN]
            more = (f"and {len(below) - len(shown)} more with a lower BIC (the JSON's not_admitted lists them, and "
                    f"those within ΔBIC {ACCEPT_DELTA_BIC:g} above)",) if len(below) > len(shown) else ()
            sections.append(Section(
                "Models with a lower BIC that the admission rule drops", more,
                table=Table(("model", "ΔBIC", "least squares (N)", "why"),
                            tuple((model_label(m.effects), f"{m.delta_bic:+.1f}", f"{m.ls_rms_residual_n:.4g}",
                                   m.reason) for m in shown), frozenset({0, 3})),
                aside="(an effect enters where the model without it shows its pattern, not on a BIC gain alone)"))
        if self.rails is not None:
            sections.append(self.rails.section())
        sections.append(model_section(self.verdict, (f"effects: {', '.join(self.selected) or 'none'}",)))
        sections.append(parameter_section(final, ols=True))
        if self.notes:
            sections.append(Section("Notes", self.notes, kind="notes"))
        return Story(headline, tuple(sections))

    @property
    def final_effects(self) -> tuple[str, ...]:
        return self.selected

    @property
    def added(self) -> tuple[str, ...]:
        return self.selected


def time_candidates(position: bool = True, rails: bool = False) -> tuple[str, ...]:
    """Effects of the library with a force model (those that need the position only when it was recorded, those
    that follow the rails' difference only where both rails show the beam turning)."""
    return tuple(n for n, cls in EFFECTS.items() if cls.time_domain and (position or not cls.needs_position)
                 and (rails or not cls.needs_rails))


def _plant(base: Plant, effects: tuple[Effect, ...]) -> Plant:
    """The base plant with ``effects`` (a friction needs an excitation amplitude: the time domain does not use
    it)."""
    return dataclasses.replace(base, effects=effects, excitation_current_a=base.excitation_current_a or 1.0)


def _hidden_signature(combo: tuple[str, ...], models: dict[tuple[str, ...], TimeFitResult]) -> str | None:
    """Why ``combo`` is not admitted (``not_admitted``), or None: the first of its effects with a residual
    signature whose parent in ``models`` (``combo`` without it) is missing or does not show that signature."""
    for name in combo:
        signature = EFFECTS[name].residual_signature
        parent = models.get(tuple(n for n in combo if n != name))
        if signature is not None and not (parent is not None and any(
                st.significant for st in parent.structure if st.variable == signature)):
            return f"{name}: its pattern ({signature}) is not shown by the model without it"
    return None


def _small_beside_noise(combo: tuple[str, ...], models: dict[tuple[str, ...], TimeFitResult]) -> str | None:
    """Why ``combo`` is not admitted, or None: an effect of it without a residual signature added to an explained
    model (its residual the noise's) that takes less than ``STRUCTURE_SHARE`` of that residual away,
    sqrt(1 - RSS / RSS_parent) on the RSS the models are compared on (``TimeFitResult.ls_rss``)."""
    for name in combo:
        parent = models.get(tuple(n for n in combo if n != name))
        if EFFECTS[name].residual_signature is None and parent is not None and parent.explained:
            share = math.sqrt(max(0.0, 1.0 - models[combo].ls_rss / parent.ls_rss))
            if share < STRUCTURE_SHARE:
                return (f"{name}: it takes {100 * share:.0f} % of the residual of the model without it, which the "
                        f"noise explains, away (less than {100 * STRUCTURE_SHARE:.0f} %)")
    return None


def _nested_within(combo: tuple[str, ...], fit: TimeFitResult) -> str | None:
    """Why ``combo`` is not admitted, or None: one of its effects is, within ``NESTED_Z`` robust standard errors,
    an effect it contains (``Effect.contains``: a cable with no stiffness is an offset); there the model with the
    contained effect speaks for the data, whatever BIC gives the extra parameter."""
    for name in combo:
        for inner, field in EFFECTS[name].contains.items():
            key = f"{name}.{field}"
            se = fit.stderr.get(key, math.inf)
            neutral = EFFECTS[name].neutral[field]
            if not abs(fit.values[key] - neutral) > NESTED_Z * se:
                return (f"{key} = {fit.values[key]:.3g} lies within {NESTED_Z:g} robust standard errors of "
                        f"{neutral:g}, where {name} is {inner}")
    return None


def not_admitted(combo: tuple[str, ...], models: dict[tuple[str, ...], TimeFitResult]) -> str | None:
    """Why the rule that admits a model drops ``combo``, or None where each of its effects earns its place, not by a
    BIC gain alone, which a long record gives any small correlation: an effect with a residual signature
    (``Effect.residual_signature``: a structure test of ``plant.identify.time_fit``) is added to a model that shows it
    (p below the test level and a quarter of the residual or more, ``_hidden_signature``); one without a signature is
    added to a model the noise does not explain, or takes a quarter (``STRUCTURE_SHARE``) of that model's residual
    away (``_small_beside_noise``); and no effect is, within ``NESTED_Z`` robust standard errors, an effect it
    contains (``_nested_within``)."""
    return (_hidden_signature(combo, models) or _small_beside_noise(combo, models)
            or _nested_within(combo, models[combo]))


def _direction(fit: TimeFitResult) -> DirectionalResidual:
    v = fit.velocity_m_per_s
    scale = float(np.percentile(np.abs(v), 99)) or 1.0
    fwd = v > DIRECTION_FRACTION * scale
    bwd = v < -DIRECTION_FRACTION * scale
    f = float(np.mean(fit.residual[fwd])) if fwd.any() else math.nan
    b = float(np.mean(fit.residual[bwd])) if bwd.any() else math.nan
    noise = fit.noise_rms
    if not (math.isfinite(f) and math.isfinite(b)):
        text = "the recording moves in one direction only: friction and a constant force cannot be told apart"
    elif abs(f - b) / 2 > abs(f + b) / 2 and abs(f - b) / 2 > 3 * noise:
        text = (f"the residual force changes sign with the direction of motion ({f:+.3g} N forward, {b:+.3g} N "
                "backward): a friction that opposes the motion (coulomb_friction)")
    elif abs(f + b) / 2 > 3 * noise:
        text = (f"the residual force has the same sign in both directions ({f:+.3g} N forward, {b:+.3g} N "
                "backward): a constant force (offset)")
    else:
        text = f"no systematic force with the direction of motion ({f:+.3g} N forward, {b:+.3g} N backward)"
    return DirectionalResidual(f, b, text)


def _where(fit: TimeFitResult) -> str:
    worst = max(fit.regimes, key=lambda r: r.noise_ratio)
    parts = ", ".join(f"{r.name} {r.rms_residual:.3g} N rms ({100 * r.share:.1f} % of samples)" for r in fit.regimes)
    if not fit.explained:
        return (f"the model leaves {fit.rms_residual:.3g} N rms ({fit.noise_ratio:.3g} x the measurement noise); "
                f"largest at {worst.name}: {parts}")
    return f"the residual ({fit.rms_residual:.3g} N rms) is consistent with the measurement noise: {parts}"


def _residual_peak(fit: TimeFitResult) -> tuple[float, float]:
    """Frequency of the largest periodogram line of the residual and the power share within +-10 % of it."""
    e = fit.residual - fit.residual.mean()
    fs = 1.0 / float(np.median(np.diff(fit.time_s)))
    p = np.abs(np.fft.rfft(e * np.hanning(e.size))) ** 2
    f = np.fft.rfftfreq(e.size, 1 / fs)
    k = int(np.argmax(p[1:]) + 1)
    near = np.abs(f - f[k]) <= 0.1 * f[k]
    return float(f[k]), float(p[near].sum() / p[1:].sum())


def diagnose_time(plant: Plant, rec: TimeRecording, *, candidates: tuple[str, ...] | None = None,
                  prep: Preprocessing = Preprocessing(), progress=None, prune: bool = True) -> TimeDiagnosis:
    """Fit the base model and every combination of the candidate force effects; select and explain.
    ``progress(done, total)`` hears the models fitted (``search.fit_models``); ``prune=False`` fits the
    three-effect models the admission rule drops too (the full search, for checking the pruning)."""
    if plant.effects:
        raise EffectError("the diagnosis starts from the base model; give a plant without effects")
    data: InverseModelData = inverse_model_data(rec, float(plant.force_constant_n_per_a), prep)
    rails, _, data = at_one_scale(_plant(plant, ()), rec, data, prep)
    usable = time_candidates(position=data.position_m is not None, rails=rails is not None and rails.couples_the_mean)
    names = usable if candidates is None else tuple(candidates)
    notes = []
    for n in names:
        if n not in EFFECTS:
            raise EffectError(f"unknown effect {n!r}; known: {', '.join(EFFECTS)}")
    skipped = [n for n in names if n not in usable]
    if [n for n in skipped if not EFFECTS[n].time_domain]:
        notes.append(f"not tried on time-domain data (no force model; estimate a frequency response for them): "
                     f"{', '.join(n for n in skipped if not EFFECTS[n].time_domain)}")
    along = [n for n in skipped if EFFECTS[n].time_domain and EFFECTS[n].needs_position]
    if along:
        notes.append(f"not tried: {', '.join(along)} depend on the position, and the recording has velocity only")
    if [n for n in skipped if EFFECTS[n].needs_rails] and candidates is not None:
        notes.append("not tried: yaw_coupling follows the rails' difference, and the rails show no turn of the beam "
                     "but unequal motors'" if rails is not None else
                     "not tried: yaw_coupling needs both rails recorded")
    names = tuple(n for n in names if n in usable)
    samples = fit_samples(data)
    max_effects = min(len(names), MAX_TIME_EFFECTS)

    def fit(combo: tuple[str, ...], parents: list[TimeFitResult]) -> TimeFitResult | str:
        """The model of ``combo``: the effects of its best parent as that parent has them, the new one
        configured on that parent's residual (a ripple's pitch is seen once the friction is modelled). A model of
        the largest size, which is no other's parent, is not fitted where it would not be admitted
        (``not_admitted``: its parents are all fitted, so the rule reads as it would after the fit)."""
        if prune and 1 < len(combo) == max_effects:
            hidden = _hidden_signature(combo, {tuple(e.name for e in p.plant.effects): p for p in parents})
            if hidden is not None:
                return hidden
        best = min(parents, key=lambda r: r.ls_rss)
        effects = tuple(best.plant.effect(n) or make_effect(n, **{k: 0.0 for k in EFFECTS[n].neutral}).configured(
            samples, best.residual) for n in combo)
        return fit_inverse_model(_plant(plant, effects), data)

    models, pruned = fit_models((), fit_inverse_model(_plant(plant, ()), data), names, fit,
                                max_effects=max_effects, valid=compatible, progress=progress)
    if pruned:
        notes.append(f"{len(pruned)} models of {max_effects} effects not fitted: each adds an effect whose residual "
                     "pattern the model without it does not show, so the rule that admits a model would drop it")
    n_eff = min(models.values(), key=lambda f: f.ls_rss).n_effective
    bics = {c: bic(f, n_eff) for c, f in models.items()}
    reasons = {c: not_admitted(c, models) for c in models}
    admissible = {c: f for c, f in models.items() if reasons[c] is None}
    selected = select_model({c: bics[c] for c in admissible}, {c: f.explained for c, f in admissible.items()},
                            {c: f.n_params for c, f in admissible.items()})
    base = models[()]
    ranking = tuple(sorted((TimeCandidate(n, addition_delta_bic(bics[()], bics[(n,)]), models[(n,)].rms_residual,
                                          models[(n,)].ls_rms_residual)
                            for n in names if (n,) in models), key=lambda c: -c.delta_bic))
    steps = _path(models, bics, selected)
    final = models[selected]
    peak_hz, peak_share = _residual_peak(final)
    odd = implausible(final, plant)
    explanation = _explanation(final, selected, peak_hz, peak_share, rails) + warning(odd)
    explained = final.explained and (rails is None or rails.explained)
    left_out = tuple(sorted((TimeLeftOut(c, bics[c] - bics[selected], models[c].ls_rms_residual, why)
                             for c, why in reasons.items() if why is not None
                             and bics[c] - bics[selected] < ACCEPT_DELTA_BIC), key=lambda m: m.delta_bic))
    return TimeDiagnosis(steps, ranking, models, selected, verdict(explained), explanation, _where(base),
                         _direction(base), n_eff, peak_hz, peak_share, tuple(notes), samples.position_m, odd, rails,
                         left_out)


def _explanation(final: TimeFitResult, selected: tuple[str, ...], peak_hz: float, peak_share: float,
                 rails: RailReading | None) -> str:
    """The verdict's sentence; with both rails read, what their difference shows follows it (and a difference
    beyond the encoders' noise makes an explained mean "not explained")."""
    text = _force_explanation(final, selected, peak_hz, peak_share, rails)
    if rails is None:
        return text
    if final.explained and not rails.explained:
        text = "not explained: " + text
    return f"{text}. Both rails: {rails.clause()}"


def _force_explanation(final: TimeFitResult, selected: tuple[str, ...], peak_hz: float, peak_share: float,
                       rails: RailReading | None) -> str:
    model = "base" + "".join(f" + {n}" for n in selected)
    size = (f"{final.rms_residual:.3g} N rms ({final.relative_error_percent:.2g} % of the force), "
            f"{final.noise_ratio:.3g} x the noise predicted through the filters and differences")
    if final.explained:
        quiet = not selected and (rails is None or rails.agree)
        what = "recording" if rails is None else "force on the rails' mean"
        return (f"{model} explains the {what}: its residual ({size}) depends on neither velocity, acceleration, "
                "motor force nor position"
                + ("; nothing is missing" if quiet else ""))
    structured = [st for st in final.structure if st.significant]
    worst = max(final.regimes, key=lambda r: r.noise_ratio)
    if structured:
        what = "; ".join(f"it depends on {st.variable} ({st.summary}, p = {st.p_value:.1g})"
                         for st in structured)
        return (f"not explained: the best model ({model}) leaves {size}; {what}. Something outside the library "
                "remains (a velocity-dependent friction law other than Stribeck's, a position-dependent force such "
                "as a cable, dynamics above the rigid body)")
    return (f"not explained: the best model ({model}) leaves no significant dependence on velocity, acceleration, "
            f"motor force or position, but its residual is {size}, largest at {worst.name} "
            f"({worst.rms_residual:.3g} N rms); "
            f"{100 * peak_share:.0f} % of the residual power lies near {peak_hz:.3g} Hz. Variation that the force "
            "effects of the library do not describe remains (disturbances, the loop's own noise, dynamics above "
            "the decimation band)")


def _path(models, bics, selected) -> tuple[TimeStep, ...]:
    """From the base to ``selected`` (``plant.diagnose.search.path_to``), one effect added per step."""
    path = path_to(bics, (), selected)
    steps = [TimeStep((), models[()], bics[()], "base model: mass and rail damping (thesis Eq. 3.15 / 3.16)")]
    for current, nxt in zip(path, path[1:]):
        (added,) = set(nxt) - set(current)
        fit, before = models[nxt], models[current]
        compared = ("least-squares rms residual", before.ls_rms_residual, fit.ls_rms_residual) \
            if fit.compensated or before.compensated else ("rms residual", before.rms_residual, fit.rms_residual)
        steps.append(TimeStep(nxt, fit, bics[nxt],
                              f"add {added}: dBIC {addition_delta_bic(bics[current], bics[nxt]):+.1f}, {compared[0]} "
                              f"{compared[1]:.3g} -> {compared[2]:.3g} N"))
    return tuple(steps)
