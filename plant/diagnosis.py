"""Compare model and measurement, find the missing physical effect, add it, watch the error fall.

``diagnose`` fits the base model (thesis Eq. 3.15 / 3.16 with free mass and damping), shows
where it fails, tries every applicable effect of the library as an addition (refitting each),
ranks them by the drop of BIC, adds the best one only when the data justify it
(Delta BIC > ``ACCEPT_DELTA_BIC``), and repeats until the residuals are consistent with noise
(chi^2 within ``NOISE_Z`` standard deviations of its expectation N_data - n_params, the
expected minimum cost of a correct model) or no candidate is justified.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from plant.effects import make_effect
from plant.errors import DataError
from plant.fitting import FitResult, fit_plant
from plant.frequency_response import MeasuredResponse
from plant.models import Plant
from plant.residuals import ResidualSummary, merge_failing, residual_summary

#: an effect is added only when it lowers BIC by more than this ("very strong" evidence,
#: Kass & Raftery 1995)
ACCEPT_DELTA_BIC = 10.0
#: two candidates whose BIC differ by less than this are reported as not told apart
TIE_DELTA_BIC = 2.0
#: residuals are consistent with noise when chi2 <= dof + NOISE_Z * sqrt(2 dof)
NOISE_Z = 3.0
LINEAR_CANDIDATES = ("delay", "current_loop", "sampling", "resonance")
SIGNATURES = {
    "delay": "phase error growing linearly with frequency, magnitude unchanged",
    "current_loop": "phase lag with a small magnitude roll-off towards high frequency",
    "sampling": "phase lag linear in frequency (1.5 sample periods) with a slight sinc magnitude droop",
    "resonance": "a local peak/notch pair in magnitude with a phase swing around it",
    "coulomb_friction": "amplitude dependence and odd harmonics, strongest at low velocity",
    "tilt_coupling": "Y1 and Y2 disagreeing around a mode",
}
MAIN_PARAMETER = {
    "delay": "delay.seconds", "current_loop": "current_loop.bandwidth_hz", "sampling": "sampling.rate_hz",
    "resonance": "resonance.frequency_hz", "coulomb_friction": "coulomb_friction.force_n",
    "tilt_coupling": "tilt_coupling.frequency_hz",
}


@dataclass(frozen=True)
class Nonlinearity:
    """Evidence of a nonlinearity: odd harmonics and amplitude dependence."""

    detected: bool
    #: largest 3rd-harmonic ratio of the output, and the frequency where it occurs
    max_third_harmonic: float
    max_third_harmonic_f_hz: float
    #: 3rd-harmonic level above which it counts (noise floor or 0.5 %)
    threshold: float
    amplitude_dependent: bool | None
    description: str


@dataclass(frozen=True)
class Candidate:
    """One effect tried as an addition at one step."""

    effect: str
    delta_bic: float
    reduced_chi2: float
    fit: FitResult | None
    #: why it was not fitted (not applicable, not identifiable from these data), else ""
    skipped: str = ""


@dataclass(frozen=True)
class Step:
    """The model after a step: its effects, fit and error figures."""

    effects: tuple[str, ...]
    fit: FitResult
    residuals: ResidualSummary
    rms_magnitude_error_db: float
    rms_phase_error_deg: float
    #: the candidates tried from this model (ranked best first)
    ranking: tuple[Candidate, ...]
    #: why the next effect was added, or why the search stopped
    decision: str


@dataclass(frozen=True)
class Diagnosis:
    steps: tuple[Step, ...]
    final: FitResult
    nonlinearity: Nonlinearity
    #: notes on effects that cannot be told apart and data that cannot identify a candidate
    notes: tuple[str, ...]

    @property
    def final_effects(self) -> tuple[str, ...]:
        return self.final.plant.effect_names

    @property
    def added(self) -> tuple[str, ...]:
        return self.final_effects[len(self.steps[0].effects):]

    def story(self) -> str:
        """The diagnosis in words, step by step, with its numbers."""
        first = self.steps[0]
        lines = [f"1. Compare: base model ({', '.join(first.effects) or 'no effects'}), reduced chi-square "
                 f"{first.fit.reduced_chi2:.3g}, RMS error {first.rms_magnitude_error_db:.3f} dB / "
                 f"{first.rms_phase_error_deg:.2f} deg.",
                 f"2. Where it fails: {first.residuals.description}",
                 f"   Nonlinearity: {self.nonlinearity.description}"]
        for k, step in enumerate(self.steps):
            tried = ", ".join(f"{c.effect} (dBIC {c.delta_bic:+.1f})" for c in step.ranking if not c.skipped)
            if tried:
                lines.append(f"{k + 3}. Candidates from [{', '.join(step.effects) or 'base'}]: {tried}")
            lines.append(f"   -> {step.decision}")
        lines.append("Error by step:")
        for step in self.steps:
            lines.append(f"   {' + '.join(('base',) + step.effects[len(self.steps[0].effects):]):40s} "
                         f"reduced chi2 {step.fit.reduced_chi2:10.3g}  RMS {step.rms_magnitude_error_db:7.3f} dB "
                         f"{step.rms_phase_error_deg:7.2f} deg  BIC {step.fit.bic:12.1f}")
        lines += [f"Note: {n}" for n in self.notes]
        return "\n".join(lines)


def _noise_consistent(fit: FitResult) -> bool:
    return fit.dof > 0 and fit.chi2 <= fit.dof + NOISE_Z * math.sqrt(2 * fit.dof)


def _step(fit: FitResult, data: MeasuredResponse, ranking, decision) -> Step:
    res = residual_summary(data.f_hz, data.response, data.variance, fit.model_response)
    rms_mag = float(np.sqrt(np.mean(res.magnitude_error_db**2)))
    rms_ph = float(np.sqrt(np.mean(res.phase_error_deg**2)))
    return Step(fit.plant.effect_names, fit, res, rms_mag, rms_ph, tuple(ranking), decision)


def detect_nonlinearity(data: MeasuredResponse, *, amplitude_dependent: bool | None = None) -> Nonlinearity:
    """Odd-harmonic distortion above its noise floor, or amplitude dependence, means nonlinear."""
    hd3 = np.asarray(data.harmonic_distortion)[..., 1]
    # white noise puts about as much noise in the 3rd-harmonic bin as in the fundamental's, whose
    # relative standard deviation is sqrt(var)/|G|: count 4 sigma of it, and at least 0.5 %
    floor = np.maximum(4.0 * np.sqrt(np.asarray(data.variance)) / np.abs(data.response), 0.005)
    ratio = hd3 / floor
    k = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    detected = bool(ratio[k] > 1.0) or bool(amplitude_dependent)
    f_at = float(np.asarray(data.f_hz)[k[-1]])
    words = (f"3rd harmonic up to {100 * hd3[k]:.2f} % of the fundamental at {f_at:.3g} Hz "
             f"(threshold {100 * floor[k]:.2f} %)")
    if amplitude_dependent is not None:
        words += "; response depends on the excitation amplitude" if amplitude_dependent else \
            "; no amplitude dependence between the recordings"
    words = ("detected: " if detected else "none: ") + words
    return Nonlinearity(detected, float(hd3[k]), f_at, float(floor[k]), amplitude_dependent, words)


def with_distortion_variance(data: MeasuredResponse) -> MeasuredResponse:
    """Data whose variance also carries the describing function's own error.

    A describing function keeps only the fundamental; its error in the fundamental is of the
    order of the harmonics it neglects (harmonic balance), so each point's variance is augmented
    by (|G| * (HD2 + HD3))^2 with the measured harmonic ratios. Used once a nonlinearity is
    detected, for every candidate alike, so their BICs stay comparable.
    """
    hd = np.sum(np.asarray(data.harmonic_distortion), axis=-1)
    extra = (np.abs(data.response) * hd) ** 2
    return replace(data, variance=np.asarray(data.variance) + extra,
                   metadata={**data.metadata, "variance": "measurement + describing-function (harmonic) error"})


def _applicable(name: str, plant: Plant, data: MeasuredResponse, nonlinear: Nonlinearity) -> str:
    """Empty when ``name`` can be tried on ``plant`` with ``data``; else the reason it is skipped."""
    if name in plant.effect_names:
        return "already in the model"
    if name == "tilt_coupling":
        if plant.stage != "y" or len(data.output_names) < 2:
            return "needs Stage Y with both rails Y1 and Y2 recorded"
        if math.isclose(plant.load_position_m, plant.motor_length_m / 2):
            return "the load is centred (load_position_m = motor_length_m / 2): the tilt mode is not excited"
    if name == "coulomb_friction" and not nonlinear.detected:
        return "no harmonic distortion or amplitude dependence in the data"
    return ""


def _try(plant: Plant, name: str, data: MeasuredResponse, free_base: tuple[str, ...]) -> FitResult:
    if name == "coulomb_friction":
        plant = replace(plant, excitation_current_a=np.asarray(data.current_amplitude_a, dtype=float))
    candidate = plant * make_effect(name)
    free = free_base + tuple(p for p in candidate.parameters() if "." in p)
    if name != "coulomb_friction":
        return fit_plant(candidate, data, free=free)
    # friction: starts spread over 5-40 % of the excitation force (the default may stall the stage)
    force = float(np.mean(np.asarray(plant.force_constant_n_per_a) * np.asarray(data.current_amplitude_a)))
    own = {n: v for n, v in candidate.parameters().items() if n in free}
    fits = [fit_plant(candidate, data, free=free, start={**{n: p.value for n, p in own.items()},
                                                         "coulomb_friction.force_n": share * force})
            for share in (0.05, 0.15, 0.3)]
    return min(fits, key=lambda r: r.chi2)


def diagnose(plant: Plant, data: MeasuredResponse, *, candidates: tuple[str, ...] | None = None,
             free_base: tuple[str, ...] = ("mass_kg", "damping_n_s_per_m"),
             amplitude_dependent: bool | None = None, max_steps: int = 4) -> Diagnosis:
    """Diagnose which effects ``plant`` misses to explain ``data`` (see module doc).

    ``plant`` sets the stage, geometry and starting values (its effects, if any, are kept and
    refitted); ``free_base`` are the base parameters fitted at every step (add
    ``force_constant_n_per_a`` when asked). ``amplitude_dependent`` comes from comparing
    recordings at several amplitudes (``plant.frequency_response.amplitude_dependence``).
    """
    n_freq = len(data.f_hz)
    n_values = 2 * n_freq * len(data.output_names)
    if n_values <= len(free_base) + len(plant.parameters()) - 3:
        raise DataError(
            f"{data.source}: {n_freq} frequenc{'y' if n_freq == 1 else 'ies'} give {n_values} real values, which "
            f"exactly determine (or fewer than) the {len(free_base)} base parameters ({', '.join(free_base)}): "
            "nothing is left to test the model or a missing effect. Record more frequencies (the thesis used 1-75 Hz).")
    nonlinear = detect_nonlinearity(data, amplitude_dependent=amplitude_dependent)
    if nonlinear.detected:
        data = with_distortion_variance(data)
    pool = candidates if candidates is not None else LINEAR_CANDIDATES + ("coulomb_friction", "tilt_coupling")
    free_now = free_base + tuple(p for p in plant.parameters() if "." in p)
    fit = fit_plant(plant, data, free=free_now)
    steps: list[Step] = []
    notes: list[str] = []
    for _ in range(max_steps + 1):
        if _noise_consistent(fit):
            steps.append(_step(fit, data, (), f"residuals are consistent with noise (chi2 {fit.chi2:.1f} for "
                                              f"{fit.dof} degrees of freedom): nothing is missing"))
            break
        ranking = []
        for name in pool:
            reason = _applicable(name, fit.plant, data, nonlinear)
            n_new = len(make_effect(name).bounds)
            if not reason and n_values - fit.n_params - n_new < 1:
                reason = (f"not identifiable: {n_freq} frequencies give {n_values} real values for "
                          f"{fit.n_params + n_new} parameters")
            if reason:
                ranking.append(Candidate(name, float("nan"), float("nan"), None, reason))
                continue
            cand = _try(fit.plant, name, data, free_base)
            ranking.append(Candidate(name, fit.bic - cand.bic, cand.reduced_chi2, cand))
        ranking.sort(key=lambda c: -c.delta_bic if not c.skipped else math.inf)
        tried = [c for c in ranking if not c.skipped]
        if not tried or tried[0].delta_bic <= ACCEPT_DELTA_BIC:
            best = f" (best: {tried[0].effect}, dBIC {tried[0].delta_bic:+.1f})" if tried else ""
            steps.append(_step(fit, data, ranking, f"no candidate lowers BIC by more than {ACCEPT_DELTA_BIC:g}"
                                                   f"{best}: stop with reduced chi-square {fit.reduced_chi2:.3g}"))
            break
        best = tried[0]
        ties = [c.effect for c in tried[1:] if best.delta_bic - c.delta_bic < TIE_DELTA_BIC]
        decision = (f"add {best.effect} (dBIC {best.delta_bic:+.1f}; signature: {SIGNATURES[best.effect]})")
        if ties:
            note = (f"{best.effect} and {', '.join(ties)} explain these data equally well (BIC within "
                    f"{TIE_DELTA_BIC:g}); {best.effect} is reported, the data cannot tell them apart")
            notes.append(note)
            decision += f"; {note}"
        steps.append(_step(fit, data, ranking, decision))
        fit = best.fit
    else:
        steps.append(_step(fit, data, (), f"stopped after {max_steps} added effects"))
    for flag in fit.flags:
        if "cannot be told apart" in flag:
            notes.append(flag)
    return Diagnosis(tuple(steps), fit, nonlinear, tuple(dict.fromkeys(notes)))


def failing_bands(step: Step) -> list[dict]:
    """JSON rows of the merged failing bands of a step."""
    return [{"f_low_hz": lo, "f_high_hz": hi, "reduced_chi2": chi} for lo, hi, chi in merge_failing(step.residuals.bands)]


