"""The one place results become JSON: strict (no NaN or Infinity) dicts of the fit, diagnosis and time-domain
results, the ``--json`` contract of the commands (``docs/formats.md``); and a design read back from it
(``synthesis_from_json``) for the commands that take one (``sweep``, ``mouse-run``)."""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from design.admittance.between import worst_by_legs
from design.admittance.model import admittance_problem
from design.admittance.recorded import FINE_STEP_S
from design.admittance.verify import PADE_ORDER
from design.loop.controller import PI
from design.results import FittedParameters
from design.synth.scenarios import coverage
from design.synth.solver_record import ChosenFilter
from plant.data.writers import csv_rows
from plant.errors import ParameterError, SpecError
from plant.experiment.simulate_time import travel_notes
from plant.identify.time_fit import TimeFitResult

if TYPE_CHECKING:
    from design.admittance.between import BetweenCheck, HeldBetween
    from design.admittance.dual import DualAdmittanceResult
    from design.admittance.dual_codesign_record import DualCodesignRecord
    from design.admittance.monte_carlo import AdmittanceMonteCarlo
    from design.admittance.mouse import MouseModel
    from design.admittance.synthesis import AdmittanceResult, AdmittanceSolverRecord
    from design.admittance.verify import AdmittanceVerification
    from design.loop.analysis import PayloadSweep
    from design.loop.discrete import DiscreteCheck, DiscreteDesign
    from design.loop.requirement import Binding
    from design.loop.sweep import SweepResult
    from design.problem import LoopProblem
    from design.results import DesignOutcome, DiagnosisOutcome, FitOutcome
    from design.synth.between import PiBetween
    from design.synth.dual_design import DualDesign
    from design.synth.evaluation import Evaluation
    from design.synth.measured import MeasuredDesign
    from design.synth.monte_carlo import MonteCarloCheck
    from design.synth.pi import SynthesisResult
    from design.synth.scan import ScanDiagnosis
    from design.synth.schedule import SchedulePoint
    from design.synth.solver_record import SolverRecord
    from design.synth.verify import Verification
    from plant.data.recordings import Recording
    from plant.diagnose.diagnosis import Diagnosis
    from plant.diagnose.time_diagnosis import TimeDiagnosis
    from plant.experiment.excitation import Multisine, SteppedSine, VariancePrediction
    from plant.identify.fitting import FitResult
    from plant.identify.rational_fit import RationalFit

#: the closed-loop bandwidth definitions (``requirements.bandwidth_definition``)
BANDWIDTH_DEFINITIONS = {
    "half_power": "first frequency where |T| = |L/(1 + L)| falls to 1/sqrt 2 of the reference, |T| = 1 (half "
                  "power, -3.01 dB; T(0) = 1 with integral action, and a loop without it starts below 1)",
    "minus_3_db": "first frequency where |T| = |L/(1 + L)| falls 3 dB below the reference, |T| = 1 (MATLAB's "
                  "bandwidth, taken against 1 rather than |T(0)|)"}


def finite_or_none(x) -> float | None:
    """JSON helper: a float, or None for nan/inf (strict JSON has no NaN or Infinity)."""
    x = float(x)
    return x if math.isfinite(x) else None


def print_json(obj) -> None:
    """Strict JSON on stdout: NaN and infinities anywhere in ``obj`` become null (see ``_strict``)."""
    print(json_text(obj))


def json_text(obj) -> str:
    """The strict JSON ``print_json`` prints."""
    return json.dumps(_strict(obj), indent=2, allow_nan=False)


def _strict(obj):
    """``obj`` with NumPy scalars and arrays as Python values, tuples as lists, and every
    non-finite float as None, through nested dicts, lists and tuples."""
    if isinstance(obj, dict):
        return {key: _strict(value) for key, value in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_strict(value) for value in obj]
    if isinstance(obj, np.ndarray):
        return _strict(obj.tolist())
    if isinstance(obj, np.generic):
        return _strict(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def fit_outcome_to_dict(outcome: FitOutcome) -> dict:
    """``gantry fit --json``: a frequency-domain fit (with its rational fit) or a time-domain one."""

    if isinstance(outcome.result, TimeFitResult):
        return {**time_fit_to_dict(outcome.result), "rails": rails_to_dict(outcome.rails)}
    out = fit_to_dict(outcome.result, outcome.rational)
    if outcome.measured is not None:
        out["notes"] = list(outcome.measured.notes)
    return out


def diagnosis_outcome_to_dict(outcome: DiagnosisOutcome) -> dict:
    """``gantry diagnose --json`` on a frequency response or a time-domain recording."""
    if outcome.time_domain:
        return time_diagnosis_to_dict(outcome.diagnosis)
    return diagnosis_to_dict(outcome.diagnosis)


def fit_to_dict(result: FitResult, rat: RationalFit | None = None) -> dict:
    """``gantry fit --json`` on a stepped sine or an estimated frequency response (with the rational fit)."""
    units = {n: p.unit for n, p in result.plant.parameters().items()}
    out = {"parameters": {n: {"value": result.values[n], "stderr": finite_or_none(result.stderr[n]),
                              "stderr_scaled": finite_or_none(result.stderr_scaled[n]), "unit": units[n]}
                          for n in result.free},
           "fixed": {n: v for n, v in result.values.items() if n not in result.free},
           "reduced_chi2": finite_or_none(result.reduced_chi2), "aic": result.aic, "bic": result.bic,
           "expected_reduced_chi2": result.expected_reduced_chi2,
           "chi2": result.chi2, "dof": result.dof, "n_data": result.n_data,
           "correlation": {"names": list(result.free),
                           "matrix": [[finite_or_none(c) for c in row] for row in result.correlation]},
           "flags": list(result.flags), "effects": list(result.plant.effect_names)}
    if rat is not None:
        out["rational"] = {"num": rat.num.tolist(), "den": rat.den.tolist(),
                           "fit_percent": finite_or_none(rat.fit_percent), "flags": list(rat.flags),
                           "success": rat.success, "weighting": rat.weighting,
                           "chi2": finite_or_none(rat.chi2), "dof": rat.dof, "chi2_p": finite_or_none(rat.chi2_p),
                           "stable": rat.stable, "start": rat.start}
    return out


def time_fit_to_dict(result: TimeFitResult) -> dict:
    """Strict-JSON-ready dict of a ``TimeFitResult`` (``gantry fit --json`` on a time-domain recording)."""
    units = {n: p.unit for n, p in result.plant.parameters().items()}
    return {"domain": "time", "method": result.method,
            "parameters": {n: {"value": result.values[n], "stderr": result.stderr[n],
                               "stderr_ols": result.stderr_ols[n], "unit": units[n]} for n in result.free},
            "fixed": {n: v for n, v in result.values.items() if n not in result.free},
            "fitted_quantity": result.quantity, "rms_residual": result.rms_residual,
            "relative_error_percent": result.relative_error_percent, "noise_rms": result.noise_rms,
            "noise_ratio": result.noise_ratio, "explained": result.explained,
            "n_data": result.n_data, "n_effective": result.n_effective,
            "lag1_autocorrelation": result.lag1_autocorrelation, "condition_number": result.condition_number,
            "correlation": {"names": list(result.free), "matrix": result.correlation},
            "regimes": [{"name": r.name, "share": r.share, "rms_residual": r.rms_residual,
                         "noise_ratio": r.noise_ratio, "significant": r.significant} for r in result.regimes],
            "flags": list(result.flags), "effects": list(result.effect_names), "starts": result.n_starts}


def diagnosis_to_dict(diag: Diagnosis) -> dict:
    """Strict-JSON-ready dict: the ``gantry diagnose --json`` contract."""

    first = diag.steps[0]
    final = diag.final
    return {
        "domain": "frequency",
        "steps": [{"effects": list(s.effects), "reduced_chi2": finite_or_none(s.fit.reduced_chi2),
                   "rms_magnitude_error_db": s.rms_magnitude_error_db, "rms_phase_error_deg": s.rms_phase_error_deg,
                   "bic": s.fit.bic, "decision": s.decision} for s in diag.steps],
        "ranking": [{"effect": c.effect, "delta_bic": finite_or_none(c.delta_bic),
                     "reduced_chi2": finite_or_none(c.reduced_chi2), "skipped": c.skipped or None}
                    for c in first.ranking],
        "final_effects": list(diag.final_effects),
        "added_effects": list(diag.added),
        "parameters": {name: {"value": final.values[name],
                              "stderr": finite_or_none(final.stderr[name]) if name in final.stderr else None,
                              "fixed": name not in final.stderr}
                       for name in final.values},
        "failing_bands": _bands(first.residuals.failing_merged),
        "failing_bands_final": _bands(diag.steps[-1].residuals.failing_merged),
        "where_it_fails": first.residuals.description,
        "nonlinearity": {"detected": diag.nonlinearity.detected,
                         "max_third_harmonic": diag.nonlinearity.max_third_harmonic,
                         "max_third_harmonic_f_hz": diag.nonlinearity.max_third_harmonic_f_hz,
                         "threshold": diag.nonlinearity.threshold,
                         "amplitude_dependent": diag.nonlinearity.amplitude_dependent,
                         "distortion": diag.nonlinearity.distortion,
                         "description": diag.nonlinearity.description},
        "notes": list(diag.notes),
        "flags": list(final.flags),
        "verdict": diag.verdict,
        "explanation": diag.explanation,
        "final_reduced_chi2": finite_or_none(final.reduced_chi2),
        "expected_reduced_chi2": finite_or_none(final.expected_reduced_chi2),
        "criterion": diag.criterion,
        "overdispersion": diag.overdispersion,
        "implausible": list(diag.implausible),
        "drift": None if diag.drift is None else {
            "rate_per_s": diag.drift.rate_per_s, "stderr_per_s": finite_or_none(diag.drift.stderr_per_s),
            "span_s": diag.drift.span_s, "change": diag.drift.change, "delta_bic": diag.drift.delta_bic},
        "models_evaluated": len(diag.models),
        "alternatives": [{"effects": list(a.effects), "delta_bic": finite_or_none(a.delta_bic),
                          "reduced_chi2": finite_or_none(a.reduced_chi2),
                          "consistent_with_noise": a.consistent_with_noise, "note": a.note}
                         for a in diag.alternatives],
        "left_out": None if diag.left_out is None else {
            "effects": list(diag.left_out.effects), "delta_bic": diag.left_out.delta_bic,
            "reduced_chi2": finite_or_none(diag.left_out.reduced_chi2),
            "not_identified": [{"effect": u.effect, "reason": u.reason} for u in diag.left_out.why]},
        "main_parameters": {e.name: {"name": f"{e.name}.{e.main_parameter}",
                                     "value": final.values[f"{e.name}.{e.main_parameter}"]}
                            for e in final.plant.effects},
        "modes_hz": [float(f) for f in final.plant.modes_hz()],
        "antiresonances_hz": [float(f) for f in final.plant.antiresonances_hz()],
    }


def _bands(merged) -> list[dict]:
    return [{"f_low_hz": lo, "f_high_hz": hi, "reduced_chi2": chi} for lo, hi, chi in merged]


def time_diagnosis_to_dict(diag: TimeDiagnosis) -> dict:
    """Strict-JSON-ready dict with the keys of the stepped-sine diagnosis where they mean the same."""

    final = diag.final
    best_bic = min(s.bic for s in diag.steps)
    alternatives = [{"effects": list(a.effects), "delta_bic": a.delta_bic, "rms_residual_n": a.rms_residual_n,
                     "ls_rms_residual_n": a.ls_rms_residual_n,
                     "consistent_with_noise": a.consistent_with_noise} for a in diag.alternatives]
    return {
        "domain": "time",
        "steps": [{"effects": list(s.effects), "rms_residual_n": s.fit.rms_residual,
                   "ls_rms_residual_n": s.fit.ls_rms_residual, "noise_ratio": s.fit.noise_ratio,
                   "relative_error_percent": s.fit.relative_error_percent, "bic": s.bic, "decision": s.decision,
                   "regimes": _regimes(s.fit)} for s in diag.steps],
        "not_admitted": [{"effects": list(m.effects), "delta_bic": m.delta_bic,
                          "ls_rms_residual_n": m.ls_rms_residual_n, "reason": m.reason} for m in diag.left_out],
        "ranking": [{"effect": c.effect, "delta_bic": c.delta_bic, "rms_residual_n": c.rms_residual_n,
                     "ls_rms_residual_n": c.ls_rms_residual_n}
                    for c in diag.ranking],
        "final_effects": list(diag.final_effects),
        "added_effects": list(diag.added),
        "parameters": {n: {"value": v, "stderr": final.stderr.get(n), "stderr_ols": final.stderr_ols.get(n),
                           "fixed": n not in final.stderr} for n, v in final.values.items()},
        "where_it_fails": diag.where_it_fails,
        "direction": {"forward_n": diag.direction.forward_n, "backward_n": diag.direction.backward_n,
                      "description": diag.direction.description},
        "notes": list(diag.notes),
        "flags": list(final.flags),
        "verdict": diag.verdict,
        "explanation": diag.explanation,
        "implausible": list(diag.implausible),
        "final_rms_residual_n": final.rms_residual,
        "final_noise_ratio": final.noise_ratio,
        "noise_rms_n": final.noise_rms,
        "n_effective": diag.n_effective,
        "best_bic": best_bic,
        "residual_peak_hz": diag.residual_peak_hz,
        "residual_peak_share": diag.residual_peak_share,
        "models_evaluated": len(diag.models),
        "alternatives": alternatives,
        "main_parameters": {e.name: {"name": f"{e.name}.{e.main_parameter}",
                                     "value": final.values[f"{e.name}.{e.main_parameter}"]}
                            for e in final.plant.effects},
        "rails": rails_to_dict(diag.rails),
    }


def rails_to_dict(rails) -> dict | None:
    """A time recording's two rails read jointly (``plant.diagnose.two_rails.RailReading``, docs/formats.md), None
    for one output."""
    if rails is None:
        return None
    return {"kind": rails.kind, "y2_scale": rails.y2_scale, "y2_scale_stderr": rails.y2_scale_stderr,
            "scale_claimed": rails.scale_claimed, "yaw_claimed": rails.yaw_claimed,
            "yaw_patterns": list(rails.yaw_patterns), "explained": rails.explained, "agree": rails.agree,
            "difference_rms": rails.difference_rms, "residual_rms": rails.residual_rms, "noise_rms": rails.noise_rms,
            "noise_ratio": rails.noise_ratio, "clause": rails.clause(),
            "imbalance_per_stiffness": dict(zip(("value", "stderr"),
                                                (finite_or_none(x) for x in rails.imbalance_per_stiffness))),
            "damping_difference_per_stiffness": dict(zip(("value", "stderr"), (
                finite_or_none(x) for x in rails.damping_difference_per_stiffness))),
            "terms": {t.name: {"value": t.value, "stderr": t.stderr, "share": t.share, "claimed": t.claimed}
                      for t in rails.terms.values()}}


def _regimes(fit) -> list[dict]:
    return [{"name": r.name, "share": r.share, "rms_residual_n": r.rms_residual, "noise_ratio": r.noise_ratio,
             "significant": r.significant} for r in fit.regimes]


def payload_sweep_rows(sweep: PayloadSweep) -> list[dict]:
    """One row per payload of a nominal payload sweep (``gantry reproduce --json``)."""
    return [
        {"stage": sweep.stage, "payload_kg": float(m), "open_loop_corner_hz": finite_or_none(c),
         "closed_loop_bandwidth_hz": finite_or_none(b), "phase_margin_deg": finite_or_none(p),
         "gain_margin_db": finite_or_none(g), "closed_loop_stable": bool(st)}
        for m, c, b, p, g, st in zip(sweep.payload_kg, sweep.open_loop_corner_hz, sweep.closed_loop_bandwidth_hz,
                                     sweep.phase_margin_deg, sweep.gain_margin_db, sweep.closed_loop_stable)
    ]


def sweep_rows(result: SweepResult) -> list[dict[str, float]]:
    """One row per payload; column names carry the statistic and the unit (``phase_margin_p5_deg``)."""
    rows = []
    for i, m in enumerate(result.payload_kg):
        row = {"payload_kg": float(m), "open_loop_corner_nominal_hz": float(result.nominal.open_loop_corner_hz[i])}
        for d in result.distributions:
            base = d.name.removesuffix(f"_{d.unit.lower()}")
            row[f"{base}_nominal_{d.unit.lower()}"] = float(getattr(result.nominal, d.name)[i])
            if result.samples:
                for lv, values in zip(d.levels, d.percentiles):
                    row[f"{base}_p{lv:g}_{d.unit.lower()}"] = float(values[i])
                row[f"{base}_worst_{d.unit.lower()}"] = float(d.worst[i])
        rows.append(row)
    return rows

def sweep_csv(result: SweepResult) -> str:
    """CSV text of ``sweep_rows``, plus ``samples`` and ``seed`` columns for a Monte Carlo sweep."""
    rows = sweep_rows(result)
    extra = {"samples": result.samples, "seed": result.seed} if result.samples else {}
    lines = [",".join([*rows[0], *extra])]
    lines += [",".join([*(repr(v) for v in row.values()), *(str(v) for v in extra.values())]) for row in rows]
    return "\n".join(lines) + "\n"

def sweep_check_to_dict(check, result: SweepResult) -> dict:
    """A sweep's verdict against the spec's requirements, with what it covered."""
    return {"requirements": {"phase_margin_deg": check.phase_margin_deg, "gain_margin_db": check.gain_margin_db,
                             "min_bandwidth_hz": check.min_bandwidth_hz},
            "meets_requirements": check.meets, "violations": list(check.violations),
            "covered": "every payload swept x the Monte Carlo samples" if result.samples else
                       "every payload swept, nominal parameters only"}


def sweep_to_dict(result: SweepResult) -> dict:
    """``gantry sweep --json`` (infinite or undefined values are ``None``)."""
    payloads = []
    for i, nominal in enumerate(payload_sweep_rows(result.nominal)):
        entry = {"payload_kg": nominal["payload_kg"],
                 "nominal": {k: v for k, v in nominal.items() if k not in ("stage", "payload_kg")}}
        for d in result.distributions:
            stats = {f"p{lv:g}": finite_or_none(v[i]) for lv, v in zip(d.levels, d.percentiles)}
            stats["worst"] = finite_or_none(d.worst[i])
            entry[d.name] = stats
        entry["unstable_samples"] = int(result.unstable_samples[i])
        payloads.append(entry)
    worst = {name: {"value": finite_or_none(w.value), "payload_kg": w.payload_kg, "sample_index": w.sample_index,
                    "parameters": w.parameters} for name, w in result.worst_case().items()}
    return {"stage": result.stage, **result.controller.gains(), "seed": result.seed, "samples": result.samples,
            "sampling": result.sampling,
            "uncertainty": {k: {"min": lo, "max": hi} for k, (lo, hi) in result.uncertainty.items()},
            "percentiles": list(result.levels), "payloads": payloads, "worst_case": worst,
            "unstable_samples": int(np.sum(result.unstable_samples)),
            "bandwidth_definition": BANDWIDTH_DEFINITIONS[result.bandwidth_definition]}


def evaluation_to_dict(ev: Evaluation, label: str) -> dict:
    """A design or baseline evaluated on the spec (``baselines`` of ``gantry synth --json``)."""
    return {"name": label, **ev.controller.gains(),
            "worst_bandwidth_hz": finite_or_none(ev.worst_bandwidth_hz) if ev.stable else None,
            "worst_phase_margin_deg": finite_or_none(np.min(ev.phase_margin_deg)),
            "worst_gain_margin_db": finite_or_none(np.min(ev.gain_margin_db)),
            "stable": ev.stable, "meets_requirements": ev.meets,
            "binding": evaluation_binding_to_dict(ev)}


def binding_to_dict(b: Binding) -> dict:
    """The binding requirement of a PI design: constraint, payload (kg) and the slack its producer knows (in the
    requirement's unit, or relative to it)."""
    return {"constraint": b.constraint, "payload_kg": b.payload_kg,
            **({"slack": b.slack} if b.slack is not None else {}),
            **({"relative_slack": b.relative_slack} if b.relative_slack is not None else {})}


def evaluation_binding_to_dict(ev: Evaluation) -> dict:
    """``binding_to_dict`` of an evaluation, with the requirements active there and, when the problem has
    uncertainty, the uncertain parameters' values where it binds."""
    b = ev.binding
    parameters = {} if b.scenario is None else dict(b.scenario.parameters)
    return {**binding_to_dict(b), "active": list(ev.active), **({"scenario": parameters} if parameters else {})}


def scan_diagnosis_to_dict(d: ScanDiagnosis) -> dict:
    """Why no gains of the scan meet the requirements (``solver.diagnosis`` of an infeasible PI design)."""
    return {"constraint": d.binding.constraint, "payload_kg": d.binding.payload_kg, "where": d.where,
            "relative_slack": d.binding.relative_slack, "kp": d.kp, "ki": d.ki, "alone": d.alone}


def admittance_binding_to_dict(b: Binding[MouseModel]) -> dict:
    """A requirement of an admittance design, binding or violated: where (scenario and mouse, None when the
    requirement holds everywhere alike), its value and limit, in words, and what it was computed on."""
    return {"constraint": b.constraint, "payload_kg": b.payload_kg,
            "scenario": None if b.scenario is None else b.scenario.as_dict(),
            "mouse": None if b.mouse is None else b.mouse.as_dict(), "value": b.value, "limit": b.limit,
            "detail": b.detail, **({"source": b.source} if b.source is not None else {}),
            **({"delay_samples": b.delay_samples} if b.delay_samples is not None else {})}


@dataclass(frozen=True)
class SynthesisedDesign:
    """What a later command takes from ``gantry synth --json``: the PI controller, the drive filters as the
    synthesis chose them, and (an admittance design) the virtual dynamics (m_v kg, b_v N*s/m)."""

    controller: PI
    filters: tuple[ChosenFilter, ...]
    admittance: tuple[float, float] | None


def synthesis_from_json(text: str, where: str, *, admittance: bool = False) -> SynthesisedDesign:
    """Read back what ``synthesis_to_dict`` (and the admittance design's writer) wrote; ParameterError naming
    ``where`` and what is missing or out of range."""
    need = ("kp", "ki", "m_v", "b_v") if admittance else ("kp", "ki")
    what = f"{where}: not the JSON of gantry synth --json with gains {', '.join(need)}"
    try:
        design = json.loads(text)
        gains = {k: float(design["gains"][k]) for k in need}
        filters = tuple(ChosenFilter(str(f["kind"]), bool(f["used"]),
                                     {k: float(v) for k, v in f.items() if k not in ("kind", "used", "designed")},
                                     tuple(str(d) for d in f.get("designed") or ()))
                        for f in design.get("filters") or [])
    except (json.JSONDecodeError, KeyError, TypeError, ValueError, AttributeError):
        raise ParameterError(what) from None
    if not all(math.isfinite(v) and v >= 0 for v in gains.values()):
        raise ParameterError(f"{where}: gains must be finite and non-negative, got {gains}")
    return SynthesisedDesign(PI(gains["kp"], gains["ki"]), filters,
                             (gains["m_v"], gains["b_v"]) if admittance else None)


def dual_admittance_from_json(text: str, where: str):
    """The two-motor Stage Y's admittance design as ``gantry synth --json`` writes it (``admittance``: its
    ``structure``, the structure's ``gains`` and ``m_v``, ``b_v``): (the structure with its gains, (m_v kg,
    b_v N*s/m)); ParameterError naming ``where`` and what is missing."""
    from design.loop.dual import BY_NAME

    what = (f"{where}: not the JSON of gantry synth --json on a two-motor Stage Y spec with an admittance design "
            "(admittance.structure, admittance.gains, admittance.m_v, admittance.b_v)")
    try:
        adm = json.loads(text)["admittance"]
        kind = BY_NAME[str(adm["structure"])]
        names = [f.name for f in dataclasses.fields(kind)]
        gains = {k: float(adm["gains"][k]) for k in names}
        virtual = (float(adm["m_v"]), float(adm["b_v"]))
    except (json.JSONDecodeError, KeyError, TypeError, ValueError, AttributeError):
        raise ParameterError(what) from None
    values = [*gains.values(), *virtual]
    if not all(math.isfinite(v) and v >= 0 for v in values) or min(virtual) <= 0:
        raise ParameterError(f"{where}: gains must be finite and non-negative and m_v, b_v positive, got "
                             f"{gains}, m_v = {virtual[0]}, b_v = {virtual[1]}")
    return kind(**gains), virtual


def fitted_parameters_from_json(text: str, where: str) -> FittedParameters:
    """Read back the plant's parameters that ``fit_to_dict``, ``time_fit_to_dict`` and the two diagnoses' writers
    wrote (``parameters``: name -> {"value": ...}, and ``fixed``: name -> value); SpecError naming ``where``
    and the key that is not a finite number."""
    try:
        fit = json.loads(text)
    except json.JSONDecodeError as exc:
        raise SpecError(f"{where}: not a JSON fit result ({exc})") from None
    if not isinstance(fit, dict) or not isinstance(fit.get("parameters"), dict):
        raise SpecError(f"{where}: not a fit result: expected the JSON of gantry fit --json (a 'parameters' object)")
    fixed = fit.get("fixed") or {}
    if not isinstance(fixed, dict):
        raise SpecError(f"{where}: fixed: expected an object of parameter values")
    values = {**fixed, **{n: p.get("value") if isinstance(p, dict) else None for n, p in fit["parameters"].items()}}
    for name, value in values.items():
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
            key = f"fixed.{name}" if name in fixed and name not in fit["parameters"] else f"parameters.{name}"
            raise SpecError(f"{where}: {key}: {value!r} is not a finite number")
    return FittedParameters({n: float(v) for n, v in values.items()}, where)


def record_to_dict(record: SolverRecord | AdmittanceSolverRecord) -> dict:
    """Every field of a solver record (null where its step did not run), each inner record a dict of its fields
    (a joint solve's ``start`` written ``from``)."""
    def plain(value):
        if isinstance(value, tuple):
            return [plain(v) for v in value]
        if dataclasses.is_dataclass(value):
            return {("from" if f.name == "start" else f.name): plain(getattr(value, f.name))
                    for f in dataclasses.fields(value)}
        return dict(value) if isinstance(value, Mapping) else value

    return {f.name: plain(getattr(record, f.name)) for f in dataclasses.fields(record)}


def synthesis_to_dict(result: SynthesisResult) -> dict:
    """``gantry synth --json`` of the PI stage."""
    e = result.evaluation
    ok = result.status == "optimal"
    return {
        "status": result.status, "message": result.message,
        "gains": e.controller.gains() if e and ok else {"kp": None, "ki": None},
        "worst_case": ({"bandwidth_hz": finite_or_none(e.worst_bandwidth_hz),
                        "phase_margin_deg": finite_or_none(np.min(e.phase_margin_deg)),
                        "gain_margin_db": finite_or_none(np.min(e.gain_margin_db))} if e else None),
        "per_payload": ([{"payload_kg": float(m), "bandwidth_hz": finite_or_none(b),
                          "phase_margin_deg": finite_or_none(p), "gain_margin_db": finite_or_none(g)}
                         for m, b, p, g in zip(e.payload_kg, e.bandwidth_hz, e.phase_margin_deg,
                                               e.gain_margin_db)] if e else []),
        "binding": (binding_to_dict(result.diagnosis.binding) if result.diagnosis is not None
                    else evaluation_binding_to_dict(e) if e else None),
        "verified": bool(result.verification and result.verification.verified and ok),
        "verification": None if result.verification is None else verification_to_dict(result.verification),
        "solver": {"method": result.method, "seconds": result.seconds,
                   "payload_points": list(result.payload_points_used), **record_to_dict(result.record),
                   **({"diagnosis": scan_diagnosis_to_dict(result.diagnosis)} if result.diagnosis is not None
                      else {})},
        "baselines": [evaluation_to_dict(b, n) for b, n in zip(result.baselines, result.baseline_names)],
        **({"monte_carlo": monte_carlo_to_dict(result.monte_carlo)} if result.monte_carlo is not None else {}),
        **({"discrete": discrete_to_dict(*result.discrete)} if result.discrete is not None else {}),
        **({"between_grid": pi_between_to_dict(result.between)} if result.between is not None else {}),
        **({"filters": [{"kind": f.kind, "used": f.used, **f.values, "designed": list(f.designed)}
                        for f in result.filters]} if result.filters else {}),
        "bandwidth_definition": BANDWIDTH_DEFINITIONS[result.bandwidth_definition],
    }


def pi_between_to_dict(b: PiBetween) -> dict:
    """``between_grid`` of the PI stage: the search between the dense check's points (``design.synth.between``)."""
    return {"starts": b.starts, "evaluations": b.evaluations, "grid_slack": finite_or_none(b.grid_slack),
            "slack": finite_or_none(b.slack), "holds": b.holds, "scenario": b.scenario.as_dict(),
            "coordinates": list(b.coordinates), "values": list(b.values),
            "grid_bandwidth_hz": finite_or_none(b.grid_bandwidth_hz),
            "least_bandwidth_hz": finite_or_none(b.least_bandwidth_hz),
            "bandwidth_scenario": None if b.bandwidth_scenario is None else b.bandwidth_scenario.as_dict(),
            "method": "compass search from the dense check's rows of least relative slack (and, for the bandwidth, "
                      "of lowest bandwidth) over the payload and every plant.uncertainty range at once, to 1/512 of "
                      "each range; each point evaluated as the dense check's rows (relative slack of every "
                      "requirement, -1 where the bandwidth cannot be read)"}


def discrete_to_dict(d: DiscreteDesign, check: DiscreteCheck) -> dict:
    """The design as the drive runs it: gains per sample period and biquad coefficients."""
    return {"loop_rate_hz": d.loop_rate_hz, "sample_period_s": 1.0 / d.loop_rate_hz, "kp": d.kp,
            "ki_per_sample": d.ki_per_sample,
            "integrator": "trapezoidal: i[k] = i[k-1] + ki_per_sample (e[k] + e[k-1]) / 2, u[k] = kp e[k] + i[k]",
            "filters": [{"name": f.name, "frequency_hz": f.frequency_hz, "damping_ratio": f.damping_ratio,
                         "b0": f.b0, "b1": f.b1, "b2": f.b2, "a1": f.a1, "a2": f.a2,
                         "form": "H(z) = (b0 + b1 z^-1 + b2 z^-2) / (1 + a1 z^-1 + a2 z^-2), Tustin pre-warped at "
                                 "frequency_hz"} for f in d.filters],
            "verification": {"tool": "python-control stability_margins (FRD, 500 points per decade to Nyquist) and "
                                     "closed-loop poles of the discrete loop: plant "
                                     "sampled exactly with its delay (zero-order hold), one sample of computation "
                                     "delay, discrete PI and filters",
                             "plants": check.plants, "verified": check.verified,
                             "min_phase_margin_deg": finite_or_none(check.min_phase_margin_deg),
                             "min_gain_margin_db": finite_or_none(check.min_gain_margin_db),
                             "failures": list(check.failures)}}


def monte_carlo_to_dict(mc: MonteCarloCheck) -> dict:
    """The Monte Carlo check of a design over payload x the spec's uncertainty."""
    return {"samples": mc.samples, "seed": mc.seed, "violations": mc.violations, "rate": mc.rate,
            "rate_upper_bound_95": mc.rate_upper_bound, "unstable": mc.unstable,
            "worst_phase_margin_deg": finite_or_none(mc.worst_phase_margin_deg),
            "worst_gain_margin_db": finite_or_none(mc.worst_gain_margin_db),
            "worst_bandwidth_hz": finite_or_none(mc.worst_bandwidth_hz),
            "worst_scenario": mc.worst_scenario.as_dict(),
            "sampling": "uniform and independent over the payload range and each plant.uncertainty range; "
                        "none of the draws is a design scenario",
            "bound": "Clopper-Pearson, one-sided 95 %"}


def verification_to_dict(v: Verification) -> dict:
    """The independent python-control check of a PI design."""
    return {"payloads": v.n_plants, "plants": v.n_plants,
            "max_closed_loop_pole_real_part": finite_or_none(v.max_pole_real_part),
            "min_phase_margin_deg": finite_or_none(v.min_phase_margin_deg),
            "min_gain_margin_db": finite_or_none(v.min_gain_margin_db),
            "min_bandwidth_hz": finite_or_none(v.min_bandwidth_hz),
            "max_bandwidth_rel_error": finite_or_none(v.max_bandwidth_rel_error),
            "failures": list(v.failures),
            "tool": f"python-control (Pade order {v.pade_order}): poles of feedback(L, 1), "
                    "stability_margins, bandwidth"}


def schedule_point_to_dict(p: SchedulePoint) -> dict:
    """One point of a gain schedule."""
    return {"payload_kg": p.payload_kg, **p.controller.gains(),
            "bandwidth_hz": finite_or_none(p.bandwidth_hz),
            "phase_margin_deg": finite_or_none(p.phase_margin_deg),
            "gain_margin_db": finite_or_none(p.gain_margin_db),
            "robust_bandwidth_hz": finite_or_none(p.robust_bandwidth_hz),
            "bandwidth_gain": finite_or_none(p.bandwidth_hz / p.robust_bandwidth_hz),
            "verified": p.verified, "failures": list(p.failures)}


def schedule_to_dict(points: list[SchedulePoint]) -> dict:
    """JSON block: the points, and the worst-case bandwidth with and without the schedule."""
    sched = min(p.bandwidth_hz for p in points)
    robust = min(p.robust_bandwidth_hz for p in points)
    return {"points": [schedule_point_to_dict(p) for p in points], "verified": all(p.verified for p in points),
            "worst_case_bandwidth_hz": finite_or_none(sched), "robust_worst_case_bandwidth_hz": finite_or_none(robust),
            "min_bandwidth_gain": finite_or_none(min(p.bandwidth_hz / p.robust_bandwidth_hz for p in points)),
            "max_bandwidth_gain": finite_or_none(max(p.bandwidth_hz / p.robust_bandwidth_hz for p in points)),
            "note": "verified at the scheduled payloads only; interpolated gains are not checked"}


def admittance_verification_to_dict(v: AdmittanceVerification) -> dict:
    """The independent check of an admittance design."""
    return {"cases": v.cases, "sampled": v.sampled,
            "max_closed_loop_pole": v.max_closed_loop_pole,
            "max_closed_loop_pole_meaning": "largest modulus (discrete loop)" if v.sampled
            else "largest real part, 1/s",
            "max_open_loop_pole_real_part": v.max_open_loop_pole_real_part,
            "python_control_min_phase_margin_deg": finite_or_none(v.min_phase_margin_deg),
            "python_control_min_gain_margin_db": finite_or_none(v.min_gain_margin_db),
            "failures": list(v.failures),
            "tool": f"python-control state-space models interconnected from their blocks (Pade order {PADE_ORDER}), "
                    "eigenvalues of the closed loops, stability_margins on the loop's response"
                    + ("; the admittance law's loop sampled by control.c2d (zero-order hold)" if v.sampled else "")}


def admittance_monte_carlo_to_dict(mc: AdmittanceMonteCarlo) -> dict:
    """The Monte Carlo check of an admittance design over payload x uncertainty x mouse."""
    return {"samples": mc.samples, "seed": mc.seed, "violations": mc.violations, "rate": mc.rate,
            "rate_upper_bound_95": mc.rate_upper_bound, "unstable": mc.unstable,
            "worst_phase_margin_deg": finite_or_none(mc.worst_phase_margin_deg),
            "worst_gain_margin_db": finite_or_none(mc.worst_gain_margin_db),
            "worst_sensor_current_a": mc.worst_sensor_current_a, "worst_motor_force_n": mc.worst_motor_force_n,
            "worst_scenario": mc.worst_scenario.as_dict(), "worst_mouse": mc.worst_mouse.as_dict(),
            "margins_computed": mc.exact,
            "sampling": "uniform and independent over the payload range, each plant.uncertainty range and each "
                        "admittance.mouse range (leg stiffness log-uniform, a quarter of the mice floating); none "
                        "of the draws is a design scenario",
            "bound": "Clopper-Pearson, one-sided 95 %"}


def _front(points) -> list[dict]:
    return [{"requirement": p.requirement, "force_n": finite_or_none(p.force_n), "m_v": finite_or_none(p.m_v),
             "b_v": finite_or_none(p.b_v)} for p in points]


def between_check_to_dict(b: BetweenCheck) -> dict:
    """One search between the dense check's points (``design.admittance.between.BetweenCheck``)."""
    return {"starts": b.starts, "evaluations": b.evaluations, "grid_slack": finite_or_none(b.grid_slack),
            "slack": finite_or_none(b.slack), "holds": b.holds, "phase_margin_deg": finite_or_none(b.phase_margin_deg),
            "gain_margin_db": finite_or_none(b.gain_margin_db), "stable": b.stable, "scenario": b.scenario.as_dict(),
            "mouse": b.mouse.as_dict(), "coordinates": list(b.coordinates), "values": list(b.values)}


def held_between_to_dict(held: HeldBetween) -> dict:
    """``admittance.between_grid`` of ``gantry synth --json``: the last search, the first failing point and the
    scale-up that cured it (``design.admittance.between.hold_between``)."""
    return {**between_check_to_dict(held.search), "rounds": held.rounds, "scale_up": held.scale,
            "failed_at_ray_design": None if held.failed is None else between_check_to_dict(held.failed),
            "method": "compass search from the dense check's curves of least margin slack (floating and braced "
                      "mice) over every coordinate listed (the declared ranges: carriage travel, payload, "
                      "plant.uncertainty, admittance.mouse; leg stiffness in log) at once, to 1/512 of each range; "
                      "margins of the exactly sampled loop; slack = least relative margin, -1 unstable"}


def latency_to_dict(lat) -> dict:
    """``admittance.latency`` of ``gantry synth --json`` (``design.admittance.latency.LatencyCheck``)."""
    samples = None if lat.margin_samples is None else finite_or_none(lat.margin_samples)
    return {"margin_ms": finite_or_none(1e3 * lat.margin_s), "margin_samples": samples,
            "worst": lat.worst, "computation_delay_samples": lat.delay_samples,
            "one_more_sample": None if lat.delay_samples is None else {
                "computation_delay_samples": lat.delay_samples + 1,
                "phase_margin_deg": finite_or_none(lat.one_more_phase_margin_deg),
                "gain_margin_db": finite_or_none(lat.one_more_gain_margin_db), "stable": lat.one_more_stable},
            "meaning": "the extra delay in the interaction loop (drive, bus, law) that destabilises its worst "
                       "scenario and mouse: at each gain crossover the phase to -180 deg over the frequency; and "
                       "the exact margins and stability with one more sample of computation delay"}


def recorded_force_to_dict(c, adm) -> dict | None:
    """The motor on the spec's force record (``admittance.locomotion.force_record``) at the design: None without a
    record."""
    record, worst = adm.locomotion.force_record, c.recorded_worst()
    if record is None:
        return None
    out = {"file": record.file, "duration_s": record.duration_s, "samples": len(record.time_s),
           "motor_limit_n": adm.hardware.motor_peak_force_n}
    if worst is None:
        return {**out, "motor_peak_force_n": None, "checked": "not computed (a continuous law)"}
    peak, at_s, j = worst
    return {**out, "motor_peak_force_n": peak, "at_s": at_s, "scenario": c.scenarios.row(j).as_dict(),
            "where": c.scenarios.describe(j),
            "checked": f"on the dense check's {len(c.scenarios)} scenarios (payload points x uncertainty corners) at "
                       "every computation delay; the Monte Carlo draws are checked on the locomotion profile only",
            "model": "the record taken as given (the mouse pushes as recorded whatever the gantry does), linear "
                     "between the law's instants; the gantry from the steady state of its first value; the motor's "
                     f"force read every {1e3 * FINE_STEP_S:g} ms after each law instant (design.admittance.recorded)"}


def admittance_to_dict(result: AdmittanceResult, problem: LoopProblem) -> dict:
    """``admittance`` of ``gantry synth --json``."""

    adm = admittance_problem(problem)
    c = result.check
    designed = result.status in ("optimal", "mouse_cannot_drive")
    payloads, w = c.per_payload()
    timing, feel = result.timing, result.feel
    out = {
        "status": result.status, "message": result.message,
        "m_v": result.m_v if designed else None, "b_v": result.b_v if designed else None,
        **result.controller.gains(),
        "peak_resistance_n": result.peak_resistance_n if designed else None,
        **_check_figures(c, result.between),
        "binding": admittance_binding_to_dict(result.binding), "active": list(result.active),
        "verified": result.verified,
        "mouse_can_follow_profile": None if feel is None else feel.can_drive,
        **_admittance_setting(adm, timing, result.discrete),
        "evaluated_at": {"m_v": result.m_v, "b_v": result.b_v},
        **({"latency": latency_to_dict(result.latency)} if result.latency is not None else {}),
        "between_grid": None if result.between is None else held_between_to_dict(result.between),
        "recorded_force": recorded_force_to_dict(c, adm),
        "mice": [m.as_dict() for m in result.corners],
        "mouse_corners": [m.as_dict() for m in result.corners],
        "per_payload": [{"payload_kg": float(m), "phase_margin_deg": finite_or_none(w["phase_margin_deg"][j]),
                         "gain_margin_db": finite_or_none(w["gain_margin_db"][j]),
                         "rendered_bandwidth_hz": finite_or_none(w["rendered_bandwidth_hz"][j]),
                         "passive_up_to_hz": finite_or_none(w["passive_up_to_hz"][j]),
                         "sensor_current_a": float(w["sensor_current_a"][j]),
                         "motor_force_n": float(w["motor_force_n"][j])} for j, m in enumerate(payloads)],
        "check_scenarios": len(c.scenarios),
        "violations": [v.detail for v in c.violations],
        "verification": None if result.verification is None else
        admittance_verification_to_dict(result.verification),
        "monte_carlo": None if result.monte_carlo is None else admittance_monte_carlo_to_dict(result.monte_carlo),
        "solver": {"method": "rays m_v / b_v: closed-form least scale per requirement, scan of the ratio on an "
                             "active set of (scenario, mouse) curves minimising the force the mouse feels; dense "
                             "check, Monte Carlo, python-control verification", "seconds": result.seconds,
                   **record_to_dict(result.solver)},
    }
    if feel is not None:
        out["mouse"] = _feel(feel)
    if result.contact is not None:
        out["stiffest_contact_n_per_m"] = finite_or_none(result.contact.worst_n_per_m)
        out["stiffest_contact_at"] = result.contact.worst_scenario
    if result.codesign is not None:
        r = result.codesign
        out["codesign"] = {**r.controller.gains(), "force_filter_hz": r.timing.filter_hz,
                           "given_kp": float(r.given.kp), "given_ki": float(r.given.ki),
                           "force_felt_n": finite_or_none(r.force_n),
                           "given_force_felt_n": finite_or_none(r.given_force_n), "evaluations": r.evaluations,
                           "pi_phase_margin_deg": finite_or_none(r.pi_phase_margin_deg),
                           "pi_gain_margin_db": finite_or_none(r.pi_gain_margin_db),
                           "note": "scores on the reduced co-design set; the design figures above are on the full sets"}
    if result.tradeoff is not None:
        t = result.tradeoff
        out["tradeoff"] = {"force": "m_v a_pk + b_v v_pk, the force the virtual dynamics ask",
                           "mouse_peak_force_n": t.mouse_peak_force_n,
                           "phase_margin_front": _front(t.margin_front),
                           "passivity_front": _front(t.passivity_front),
                           "hardware_changes": [{"change": h.change, "force_n": finite_or_none(h.force_n),
                                                 "baseline_n": finite_or_none(h.baseline_n)} for h in t.changes]}
    return out


def _check_figures(c, held=None) -> dict:
    """The worst figures of an admittance design's dense check (``AdmittanceCheck``), the margins with the point
    the search between its points found (``held``, ``design.admittance.between.HeldBetween``)."""
    legs = worst_by_legs(c, held)
    return {
        "rendered_bandwidth_hz": finite_or_none(np.nanmin(c.rendered_bandwidth_hz))
        if np.any(np.isfinite(c.rendered_bandwidth_hz)) else None,
        "worst_phase_margin_deg": finite_or_none(min(v[0] for v in legs.values())) if legs else None,
        "worst_gain_margin_db": finite_or_none(min(v[1] for v in legs.values())) if legs else None,
        "margins_by_mouse": {k: {"phase_margin_deg": finite_or_none(v[0]), "gain_margin_db": finite_or_none(v[1])}
                             for k, v in legs.items()},
        "worst_sensor_current_a": float(np.max(c.sensor_current_a)),
        "worst_motor_force_n": float(np.max(c.motor_force_n)),
        "passive_up_to_hz": finite_or_none(np.min(c.passive_up_to_hz)),
        "drift_mm_per_s": c.drift_mm_per_s}


def _admittance_setting(adm, timing, discrete) -> dict:
    """The locomotion profile, the limits and the rig of an admittance design."""
    loc, hw, sensor = adm.locomotion, adm.hardware, adm.sensor
    return {
        "locomotion": {"profile": "trapezoidal (peak acceleration held until peak speed, over the travel)",
                       "peak_speed_m_per_s": loc.peak_speed_m_per_s,
                       "peak_acceleration_m_per_s2": loc.peak_acceleration_m_per_s2, "travel_m": loc.travel_m},
        "limits": {"phase_margin_deg": adm.phase_margin_deg, "gain_margin_db": adm.gain_margin_db,
                   "motor_peak_force_n": hw.motor_peak_force_n, "motor_force_criterion": hw.motor_force_criterion,
                   "max_current_per_sensor_step_a": hw.max_current_per_sensor_step_a,
                   "force_sensor_resolution_n": hw.force_sensor_resolution_n,
                   "mouse_peak_force_n": adm.mouse.peak_force_n,
                   "max_drift_mm_per_s": sensor.max_drift_mm_per_s,
                   "passive_up_to_hz": None if adm.passivity is None else
                   (adm.passivity.up_to_hz if adm.passivity.up_to_hz is not None else "everywhere")},
        "rig": {"update_rate_hz": None if timing.period_s is None else 1.0 / timing.period_s,
                "computation_delay_samples": timing.delay_samples if len(timing.delays) == 1 else
                {"min": timing.delays[0], "max": timing.delays[-1]}, "force_filter_hz": timing.filter_hz,
                "force_filter_order": timing.filter_order if timing.filter_hz is not None else None,
                "discrete": None if discrete is None else {
                    "alpha": discrete.alpha, "beta_m_per_s_per_n": discrete.beta_m_per_s_per_n,
                    "beta_prev_m_per_s_per_n": discrete.beta_prev_m_per_s_per_n,
                    "rule": discrete.rule,
                    "form": "v[k] = alpha v[k-1] + beta F[k]" + (" + beta_prev F[k-1]" if
                                                                         discrete.beta_prev_m_per_s_per_n else "")
                            + f"; v held until the next update, applied {timing.delay_samples} sample(s) after F[k] "
                              "is read"}}}


def _feel(feel) -> dict:
    return {"force_felt_peak_n": feel.peak_force_n, "force_felt_rms_n": feel.rms_force_n,
            "virtual_dynamics_force_n": feel.ideal_peak_force_n, "worst": feel.worst,
            "reachable_speed_m_per_s": feel.reachable_speed_m_per_s,
            "reachable_acceleration_m_per_s2": feel.reachable_acceleration_m_per_s2,
            "can_drive": feel.can_drive, "breakaway_force_n": feel.breakaway_force_n,
            "drift_mm_per_s": feel.drift_mm_per_s,
            "velocity_shortfall_at_cruise_end": feel.velocity_shortfall,
            "velocity_shortfall_reported": feel.shortfall_reported,
            "velocity_shortfall": "how far the velocity loop leaves the gantry short of the law's reference at the "
                                  "end of the profile's cruise, worst over the payloads (fraction of the peak speed)",
            "force_felt": "the neck force when the body follows the profile and the head rides the clamp"}


def dual_admittance_to_dict(result: DualAdmittanceResult, problem: LoopProblem) -> dict:
    """``admittance`` of ``gantry synth --json`` on a two-motor Stage Y: the virtual dynamics on the recommended
    structure, worst over carriage position x payload x uncertainty x mouse, and per carriage position."""

    c = result.check
    designed = result.status in ("optimal", "mouse_cannot_drive")
    worst = result.worst_position
    out = {
        "status": result.status, "message": result.message, "structure": result.structure, "gains": result.gains,
        "m_v": result.m_v if designed else None, "b_v": result.b_v if designed else None,
        "peak_resistance_n": result.peak_resistance_n if designed else None,
        **_check_figures(c, result.between), "binding": admittance_binding_to_dict(result.binding),
        "verified": result.status in ("optimal", "mouse_cannot_drive"),
        "mouse_can_follow_profile": None if result.feel is None else result.feel.can_drive,
        "worst_carriage_position_m": worst.carriage_position_m,
        "by_carriage_position": [dataclasses.asdict(r) for r in result.by_position],
        **_admittance_setting(admittance_problem(problem), result.timing, result.discrete),
        "evaluated_at": {"m_v": result.m_v, "b_v": result.b_v},
        **({"latency": latency_to_dict(result.latency)} if result.latency is not None else {}),
        "between_grid": None if result.between is None else held_between_to_dict(result.between),
        "mice": [m.as_dict() for m in result.corners],
        "check_scenarios": len(c.scenarios), "design_scenarios": result.design_scenarios,
        "violations": [v.detail for v in c.violations],
        "monte_carlo": None if result.monte_carlo is None else admittance_monte_carlo_to_dict(result.monte_carlo),
        "codesign": None if result.codesign is None else dual_codesign_to_dict(result.codesign),
        "solver": {"method": "rays m_v / b_v on the structure's loops seen from the head clamp "
                             "(design.admittance.dual); dense check over carriage position x payload x uncertainty "
                             "x mice, Monte Carlo", "seconds": result.seconds},
    }
    if result.feel is not None:
        out["mouse"] = _feel(result.feel)
    return out


def measured_design_to_dict(d: MeasuredDesign) -> dict:
    """A design on measured responses, in the ``gantry synth --json`` contract."""
    out = {"solver": {"method": "ccp on measured responses (cvxpy+CLARABEL)", "seconds": d.seconds,
                      "lp_solves": d.lp_solves, "payload_points": d.payload_kg.tolist(),
                      "frequency_band_hz": list(d.band_hz)},
           "baselines": [], "data_driven": True}
    if d.controller is None:
        return {**out, "status": d.status, "message": d.message, "gains": {"kp": None, "ki": None},
                "worst_case": None, "per_payload": [], "binding": None, "verified": False}
    gm_all_finite = bool(np.all(np.isfinite(d.gain_margin_db)))
    return {**out, "gains": d.controller.gains(),
            "worst_case": {"bandwidth_hz": finite_or_none(np.min(d.bandwidth_hz)),
                           "phase_margin_deg": finite_or_none(np.min(d.phase_margin_deg)),
                           "gain_margin_db": float(np.min(d.gain_margin_db)) if gm_all_finite else None},
            "per_payload": [{"payload_kg": float(p), "bandwidth_hz": finite_or_none(b),
                             "phase_margin_deg": finite_or_none(pm),
                             "gain_margin_db": finite_or_none(g)}
                            for p, b, pm, g in zip(d.payload_kg, d.bandwidth_hz, d.phase_margin_deg,
                                                   d.gain_margin_db)],
            "binding": binding_to_dict(d.binding),
            "verified": d.verified,
            "verification": {"tool": "python-control stability_margins on the measured FRD (open loop assumed "
                                     "stable)", "failures": list(d.failures), "payloads": int(d.payload_kg.size)},
            "status": d.status, "message": d.message}


def design_to_dict(outcome: DesignOutcome) -> dict:
    """``gantry synth --json``: the PI stage, its schedule, the admittance stage (whose failure makes the
    whole design infeasible) and the fit the plant came from."""
    problem, spec = outcome.problem, outcome.problem.spec
    if outcome.dual is not None:
        out = dual_design_to_dict(outcome.dual)
        if outcome.dual_admittance is not None:
            out = {**out, "admittance": dual_admittance_to_dict(outcome.dual_admittance, problem.loop),
                   "status": outcome.status, "message": outcome.message, "verified": outcome.verified}
    elif outcome.measured is not None:
        out = measured_design_to_dict(outcome.measured)
    else:
        out = synthesis_to_dict(outcome.synthesis)
        if outcome.schedule is not None:
            out["schedule"] = schedule_to_dict(list(outcome.schedule))
        if outcome.admittance_skipped:
            out["admittance"] = {"status": "skipped", "message": "no PI gains (PI synthesis failed and no "
                                                                 "controller values in the spec)", "verified": False}
        elif outcome.admittance is not None:
            adm = admittance_to_dict(outcome.admittance, problem.loop)
            if outcome.admittance_schedule is not None:
                adm["schedule"] = [{"payload_kg": p.payload_kg, "status": p.status, **p.controller.gains(),
                                    "m_v": p.m_v, "b_v": p.b_v, "force_felt_n": finite_or_none(p.force_felt_n),
                                    "robust_force_felt_n": p.robust_force_felt_n, "kept_robust": p.kept_robust,
                                    "own_force_felt_n": finite_or_none(p.own_force_felt_n),
                                    "peak_resistance_n": p.peak_resistance_n}
                                   for p in outcome.admittance_schedule]
            out = {**out, "admittance": adm, "gains": {**out["gains"], "m_v": adm["m_v"], "b_v": adm["b_v"]},
                   "status": outcome.status, "message": outcome.message, "verified": outcome.verified}
    if outcome.dual is None and outcome.measured is None:
        out["coverage"] = coverage(problem.loop).as_dict()
    if problem.plant_from is not None:
        out["plant_from"] = {"file": problem.plant_from.file, "left_out": list(problem.plant_from.left_out),
                             "carried": list(problem.plant_from.carried),
                             "damping_n_s_per_m": spec.plant.damping_n_s_per_m,
                             "force_constant_n_per_a": spec.plant.force_constant_n_per_a,
                             "effects": spec.plant.effects}
    return out


def _worst(w) -> dict | None:
    return None if w is None else dataclasses.asdict(w)


def _dual_between(b) -> dict | None:
    """A two-motor design's check between its grid's points (``design.synth.dual_worst.BetweenCheck``)."""
    return None if b is None else {"worst": _worst(b.worst), "least_slack": b.least_slack,
                                   "worst_point": b.worst_point.as_dict(), "coverage": b.coverage(),
                                   "dense_plants": b.dense_plants, "searches": b.searches,
                                   "evaluations": b.evaluations, "holds": b.holds}


def dual_codesign_to_dict(record: DualCodesignRecord) -> dict:
    """The two-motor co-design (``design.admittance.dual_codesign``): the structure's gains and the chosen ones, the
    force felt at each on the reduced set, and the chosen gains' velocity loops on the design plants, between their
    points and on the Monte Carlo draws."""
    return {"given_gains": record.given.gains(), "gains": record.controller.gains(),
            "force_felt_n": record.force_n, "given_force_felt_n": record.given_force_n,
            "candidates": record.candidates, "candidates_meeting_velocity_requirements": record.meeting_requirements,
            "velocity_loops": {"design_plants": _worst(record.design_plants),
                               "between": _dual_between(record.between),
                               "monte_carlo": _worst(record.monte_carlo)},
            "verified": record.verified}


def dual_design_to_dict(dual: DualDesign) -> dict:
    """The two-motor Stage Y's designs: per structure its gains (A/(m/s), A/m) and its worst case on the design
    plants and on the Monte Carlo draws; the recommended structure."""
    rows = [{"structure": c.design.structure,
             "gains": None if c.design.controller is None else c.design.controller.gains(),
             "design_plants": _worst(c.design.design), "between": _dual_between(c.between), "design_rounds": c.rounds,
             "offset_ramp_a_per_s_per_mm_s": 1e-3 * c.offset_ramp_a_per_s,
             "monte_carlo": _worst(c.design.monte_carlo), "at_bound": list(c.design.at_bound),
             "binding": [] if c.between is None else list(dual.requirements.binding(c.between.worst))}
            for c in dual.checked]
    return {"status": dual.status, "message": dual.message, "verified": dual.recommended is not None,
            "kind": "dual_drive", "recommended": dual.recommended,
            "requirements": dataclasses.asdict(dual.requirements),
            "design_plants": dual.n_design_plants, "monte_carlo_draws": dual.n_monte_carlo, "structures": rows,
            "seconds": dual.seconds}


def excitation_to_dict(ms: Multisine, pred: VariancePrediction, stepped: SteppedSine) -> dict:
    """``gantry excite --json`` (without ``out`` and ``form``): both designs and their predicted FRF variance."""
    return {"f_hz": ms.f_hz, "harmonics": ms.harmonics, "amplitudes_a": ms.amplitudes,
            "phases_rad": ms.phases, "phase_method": ms.phase_method, "period_s": ms.period_s,
            "periods": ms.periods, "machine_time_s": ms.duration_s, "sample_rate_hz": ms.sample_rate_hz,
            "samples": int(ms.current_a.size), "peak_a": ms.peak_a, "rms_a": ms.rms_a,
            "crest_factor": ms.crest_factor, "noise_m_per_s": pred.noise_m_per_s,
            "multisine_variance": pred.multisine_variance,
            "multisine_variance_s": pred.multisine_variance_s,
            "stepped": {"f_hz": pred.stepped_f_hz, "block_s": stepped.block_s, "amplitude_a": stepped.amplitude_a,
                        "samples_per_block": stepped.samples_per_block, "machine_time_s": pred.stepped_time_s,
                        "variance": pred.stepped_variance, "variance_s": pred.stepped_variance_s},
            "ratio": pred.ratio, "better": pred.better, "verdict": pred.verdict(ms.crest_factor)}


def simulation_to_dict(rec: Recording, out, sidecar, *, amplitude_a: float, simulation_s: float) -> dict:
    """``gantry simulate --json``: where the recording went and how it was simulated."""
    md = rec.metadata
    return {"out": str(out), "sidecar": str(sidecar), "stage": md["stage"], "effects": md["effects"],
            "parameters": md["parameters"], "n_blocks": len(rec.blocks), "f_hz": md["f_hz"],
            "current_amplitude_a": amplitude_a, "duration_s": md["duration_s"],
            "sample_rate_hz": md["sample_rate_hz"], "noise_fraction": md["noise_fraction"], "seed": md["seed"],
            "method": md["method"], "simulation_s": simulation_s}


def time_simulation_to_dict(rec, out, sidecar, *, simulation_s: float) -> dict:
    """``gantry simulate --form continuous|chirp --json``: where the run went, how it was simulated, how far the
    carriage went and what that travel cannot show."""

    md = rec.metadata
    return {"out": str(out), "sidecar": str(sidecar), "stage": md["stage"], "effects": md["effects"],
            "parameters": md["parameters"], "excitation": md["excitation"], "duration_s": md["duration_s"],
            "sample_rate_hz": md["sample_rate_hz"], "current_noise_std_a": md["current_noise_std_a"],
            "position_noise_std_m": md["noise_std"], "travel_m": float(np.ptp(rec.output[0])),
            "notes": travel_notes(rec), "seed": md["seed"], "method": md["method"],
            "internal_rate_hz": md["internal_rate_hz"], "simulation_s": simulation_s}


def mouse_run_to_dict(run, source: str, corners=None) -> dict:
    """``gantry mouse-run --json``: the run's figures and a summary in words, and the setting over the spec's
    corners (``design.admittance.corners.CornerCheck``) when checked."""
    s = run.settings
    keeps_up = bool(run.peak_force_n <= s.mouse_peak_force_n * 1.001 and run.speed_shortfall_m_per_s
                    <= 0.05 * float(np.max(run.path.v_m_per_s)))
    summary = [
        f"force felt {run.peak_force_n:.3g} N peak, {run.rms_force_n:.3g} N RMS (the mouse pushes at most "
        f"{s.mouse_peak_force_n:g} N)",
        f"speed {float(np.max(run.trace.v_m_per_s)):.3g} m/s of the intended {float(np.max(run.path.v_m_per_s)):.3g} "
        f"m/s (shortfall {run.speed_shortfall_m_per_s:.3g} m/s); largest lag behind the path "
        f"{1e3 * run.max_lag_m:.3g} mm",
        f"motor at its force limit {100 * run.saturated_fraction:.2g} % of the time",
        f"at rest: the free gantry drifts {run.drift_mm_per_s:.3g} mm/s; with the mouse standing it moves "
        f"{run.limit_cycle_um:.3g} um peak to peak (limit cycle)",
        "the mouse keeps up" if keeps_up else "the mouse CANNOT keep up with this path"]
    extra = {}
    if corners is not None:
        where = f"{corners.scenarios} scenarios x {corners.mice} mice of the spec"
        summary.append(
            f"over {where}: stable at every one, worst interaction PM {corners.worst_phase_margin_deg:.3g} deg, "
            f"GM {corners.worst_gain_margin_db:.3g} dB" if corners.stable else
            f"over {where}: UNSTABLE at {corners.unstable} (first: {corners.unstable_at[0]})")
        if corners.violation_count:
            summary.append(f"{corners.violation_count} requirement(s) missed there, first: {corners.violations[0]}")
        extra = {"stable_at_every_corner": corners.stable, "corners": {
            "scenarios": corners.scenarios, "mice": corners.mice, "unstable": corners.unstable,
            "unstable_at": list(corners.unstable_at),
            "worst_phase_margin_deg": finite_or_none(corners.worst_phase_margin_deg),
            "worst_gain_margin_db": finite_or_none(corners.worst_gain_margin_db),
            "requirements_missed": corners.violation_count, "first_missed": list(corners.violations)}}
    return {**extra, "design": source, "path": run.path.source, "payload_kg": s.gantry_mass_kg,
            "drive_rate_hz": s.drive_rate_hz, "admittance_rate_hz": s.admittance_rate_hz,
            "gains": {"kp": s.kp, "ki": s.ki, "m_v": s.m_v, "b_v": s.b_v},
            "mouse": {"head_mass_kg": s.head_mass_kg, "body_mass_kg": s.body_mass_kg,
                      "neck_stiffness_n_per_m": s.neck_stiffness_n_per_m,
                      "neck_damping_n_s_per_m": s.neck_damping_n_s_per_m,
                      "leg_stiffness_n_per_m": s.leg_stiffness_n_per_m,
                      "leg_damping_n_s_per_m": s.leg_damping_n_s_per_m, "peak_force_n": s.mouse_peak_force_n},
            "friction_n": s.friction_n, "peak_force_n": run.peak_force_n, "rms_force_n": run.rms_force_n,
            "speed_shortfall_m_per_s": run.speed_shortfall_m_per_s, "max_lag_m": run.max_lag_m,
            "saturated_fraction": run.saturated_fraction, "drift_mm_per_s": run.drift_mm_per_s,
            "limit_cycle_um": run.limit_cycle_um, "mouse_keeps_up": keeps_up, "summary": summary}


def mouse_run_csv(run) -> str:
    """The run, one row per drive tick, units in the column names."""

    t = run.trace
    cols = {"time_s": t.time_s, "intended_x_m": t.intended_x_m, "intended_v_m_per_s": t.intended_v_m_per_s,
            "x_m": t.x_m, "v_m_per_s": t.v_m_per_s, "body_x_m": t.body_x_m, "sensed_force_n": t.sensed_force_n,
            "leg_force_n": t.leg_force_n, "current_a": t.current_a, "reference_m_per_s": t.reference_m_per_s}
    return ",".join(cols) + "\n" + csv_rows(np.column_stack(list(cols.values())), ["%.9g"] * len(cols))


def planar_run_to_dict(run, sources: Mapping[str, str]) -> dict:
    """``gantry planar-run --json``: the machine and the settings run, the figures
    (``design.admittance.planar_run.PlanarRun``) and a summary in words."""
    s, m = run.settings, run.settings.mouse
    summary = [
        f"force felt {run.peak_force_n:.3g} N peak, {run.rms_force_n:.3g} N RMS (the mouse pushes at most "
        f"{m.peak_force_n:g} N); {run.peak_lateral_force_n:.3g} N across its heading at most",
        f"the clamp lags the intended path by {1e3 * run.max_lag_m:.3g} mm at most, its heading off the mouse's by "
        f"{run.max_heading_error_deg:.3g} deg at most, its peak speed {1e3 * abs(run.speed_shortfall_m_per_s):.3g} "
        f"mm/s {'short of' if run.speed_shortfall_m_per_s > 0 else 'above'} the mouse's",
        "motors' peak force Y1 {:.4g} N, Y2 {:.4g} N, X {:.4g} N; a motor at its limit {:.2g} % of the time".format(
            *run.motor_peak_force_n, 100 * run.saturated_fraction),
        f"the beam yaws {run.peak_yaw_urad:.3g} urad at most",
        "the mouse keeps up" if run.mouse_keeps_up else "the mouse CANNOT keep up with this path"]
    return {"path": run.path.source, "designs": dict(sources),
            "carriage_mass_kg": s.machine.carriage_mass_kg, "carriage_start_m": s.carriage_position_m,
            "drive_rate_hz": s.drive_rate_hz, "admittance_rate_hz": s.x_law.update_rate_hz,
            "x": {"kp": float(s.x_controller.kp), "ki": float(s.x_controller.ki), "m_v": s.x_law.m_v,
                  "b_v": s.x_law.b_v, "law": s.x_law.rule},
            "y": {"structure": s.y_controller.name, "gains": s.y_controller.gains(), "m_v": s.y_law.m_v,
                  "b_v": s.y_law.b_v, "law": s.y_law.rule},
            "mouse": dataclasses.asdict(m), "peak_force_n": run.peak_force_n, "rms_force_n": run.rms_force_n,
            "peak_lateral_force_n": run.peak_lateral_force_n,
            "speed_shortfall_m_per_s": run.speed_shortfall_m_per_s, "max_lag_m": run.max_lag_m,
            "max_heading_error_deg": run.max_heading_error_deg,
            "motor_peak_force_n": dict(zip(("y1", "y2", "x"), run.motor_peak_force_n)),
            "saturated_fraction": run.saturated_fraction, "peak_yaw_urad": run.peak_yaw_urad,
            "legs_at_limit_fraction": run.legs_at_limit_fraction, "mouse_keeps_up": run.mouse_keeps_up,
            "summary": summary}


def planar_run_csv(run) -> str:
    """The planar run, one row per drive tick, units in the column names."""
    t, p = run.trace, run.path
    cols = {"time_s": t.time_s, "intended_x_m": p.position_m[:, 0], "intended_y_m": p.position_m[:, 1],
            "x_m": t.clamp_m[:, 0], "y_m": t.clamp_m[:, 1], "vx_m_per_s": t.clamp_m_per_s[:, 0],
            "vy_m_per_s": t.clamp_m_per_s[:, 1], "sensed_force_x_n": t.sensed_force_n[:, 0],
            "sensed_force_y_n": t.sensed_force_n[:, 1], "leg_force_x_n": t.leg_force_n[:, 0],
            "leg_force_y_n": t.leg_force_n[:, 1], "current_y1_a": t.current_a[:, 0], "current_y2_a": t.current_a[:, 1],
            "current_x_a": t.current_a[:, 2], "reference_x_m_per_s": t.reference_m_per_s[:, 0],
            "reference_y_m_per_s": t.reference_m_per_s[:, 1], "yaw_rad": t.yaw_rad}
    return ",".join(cols) + "\n" + csv_rows(np.column_stack(list(cols.values())), ["%.9g"] * len(cols))


def _planar_worst_to_dict(w) -> dict:
    return {"plants": w.n_plants, "failing": w.n_failing, "unstable": w.unstable, "least_slack": w.least_slack,
            "stage_y": {"phase_margin_deg": w.y_phase_margin_deg, "gain_margin_db": w.y_gain_margin_db,
                        "common_phase_margin_deg": w.y_common_phase_margin_deg,
                        "common_gain_margin_db": w.y_common_gain_margin_db,
                        "disk_margin": finite_or_none(w.y_disk_margin),
                        "translation_bandwidth_hz": w.y_bandwidth_hz},
            "rotation": {"phase_margin_deg": w.rotation_phase_margin_deg, "gain_margin_db": w.rotation_gain_margin_db,
                         "bandwidth_hz": w.rotation_bandwidth_hz},
            "worst_at": w.worst_at, "worst_point": w.worst_point, "rate_upper_bound": w.rate_upper_bound}


def planar_design_to_dict(outcome) -> dict:
    """``gantry planar-synth --json``: Stage X's and Stage Y's designs as ``gantry synth --json`` gives them, the
    rotation PI (A/(rad/s), A/rad) designed with Stage Y's loops closed, and the whole loop's check."""
    rot, c = outcome.rotation, outcome.check
    out = {"status": outcome.status, "message": outcome.message, "verified": outcome.status == "optimal",
           "spec": str(outcome.spec_path), "stage_x": design_to_dict(outcome.x), "stage_y": design_to_dict(outcome.y),
           "rotation": None, "check": None, "seconds": outcome.seconds}
    if rot is not None:
        out["rotation"] = {"kp": None if rot.pi is None else rot.pi.kp, "ki": None if rot.pi is None else rot.pi.ki,
                           "units": {"kp": "A/(rad/s)", "ki": "A/rad"},
                           "worst_bandwidth_hz": rot.bandwidth_hz if rot.pi is not None else None,
                           "scan_plants": rot.active_plants, "scan_evaluations": rot.evaluations}
        if outcome.rotation_alone is not None:
            gm, pm, bw = outcome.rotation_alone
            out["rotation"]["with_stage_y_open"] = {"gain_margin_db": gm, "phase_margin_deg": pm, "bandwidth_hz": bw}
    if c is not None:
        out["check"] = {"holds": c.holds, "coverage": c.coverage(), "design_plants": _planar_worst_to_dict(c.design),
                        "between": {**_planar_worst_to_dict(c.between), "dense_plants": c.dense_plants,
                                    "searches": c.searches, "search_plants": c.search_evaluations},
                        "monte_carlo": None if c.monte_carlo is None else _planar_worst_to_dict(c.monte_carlo)}
    return out


def coupling_to_dict(d) -> dict:
    """``gantry coupling --json`` (``plant.diagnose.coupling.CouplingDiagnosis``): the verdict, the model chosen and
    every model's fit (values in SI: rad, m), and the measured coupling (each rail's velocity per the carriage's)."""
    def fit(f):
        return {"model": f.model, "parameters": dict(zip(f.parameters, f.values)),
                "stderr": dict(zip(f.parameters, f.stderr)), "chi2": f.chi2, "dof": f.dof,
                "reduced_chi2": f.reduced_chi2, "bic": f.bic, "identified": f.identified, "at_bound": f.at_bound}

    return {"verdict": d.verdict, "explained": d.explained, "chosen": fit(d.chosen), "fits": [fit(f) for f in d.fits],
            "carriage_position_m": d.carriage_position_m, "f_hz": d.f_hz.tolist(),
            "ratio": {rail: {"re": d.ratio[k].real.tolist(), "im": d.ratio[k].imag.tolist(),
                             "variance": d.variance[k].tolist()} for k, rail in enumerate(("y1", "y2"))}}
