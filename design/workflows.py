"""The tool's workflows as a notebook calls them, and as the commands do: read a design problem (a
spec, optionally with the plant of a fit), design it, measure a recording.

    from design.workflows import design, load_problem, measure
    problem = load_problem("specs/stage_x_synth.toml", plant_from="fit.json")
    outcome = design(problem)                   # typed; design_to_dict(outcome) is ``gantry synth --json``
    response = measure("run.csv")               # a MeasuredResponse from any recording

Each workflow imports the synthesis, diagnosis or admittance it runs inside its function: ``import
design.workflows`` takes 0.45 s, 0.90 s with all of them (measured on the 2-core machine), and a fit or a
measurement should not pay for the solvers.

May import: ``design.views`` (which imports nothing of the workflows: its codec reads a fit back),
``design.results``, ``design.admittance``, ``design.synth``, ``design.spec``, ``design.loop``, ``design.problem``,
``design.parallel``, ``plant``.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import TYPE_CHECKING

from design.loop.controller import PI
from design.results import (
    ComparedRecording,
    DesignOutcome,
    DesignProblem,
    DiagnosisOutcome,
    DualReportContent,
    FitOutcome,
    FittedParameters,
    PlanarOutcome,
    PlantFromFit,
    ReportContent,
)
from design.spec.schema import load_spec
from plant.arguments import (
    check_instance,
    check_names,
    check_number,
    check_optional_text,
    check_path,
    check_values,
)
from plant.errors import GantryError, ParameterError, SpecError
from plant.physics.effects import EFFECTS

if TYPE_CHECKING:
    from plant.data.frequency_response import MeasuredResponse
    from plant.identify.inverse_model import Preprocessing
    from plant.identify.rational_fit import RationalFit

#: thesis section 4.1: 0.5 A sine for Stage X, 1.75 A for Stage Y
THESIS_AMPLITUDE_A = {"x": 0.5, "y": 1.75}
#: plant parameters a fit hands to a design (the mass is the payload the design sweeps)
FIT_BASE_PARAMETERS = ("damping_n_s_per_m", "force_constant_n_per_a")


def load_problem(spec_path: str | Path, *, plant_from: str | Path | FittedParameters | None = None) -> DesignProblem:
    """The spec file, with its plant's damping, force constant and effects replaced by those of a fit
    (the ``gantry fit --json`` output, or its ``FittedParameters`` read back) when ``plant_from`` is given. The
    payload range, uncertainty, requirements and controller bounds stay the spec's; effects a synthesis cannot
    design for (``coulomb_friction``, ``offset``: no linear response) are left out and listed."""
    spec_path = check_path("spec_path", spec_path)
    fitted = None if plant_from is None else _fitted(plant_from)
    plant, left_out, yaw = _plant_from_fit(fitted) if fitted is not None else (None, [], {})
    spec = load_spec(spec_path, plant=plant)
    carried: tuple[str, ...] = ()
    if yaw:
        if spec.dual_drive is None:
            raise SpecError(f"{fitted.file}: tilt_coupling: the fitted beam yaws on its two rails, which a one-loop "
                            f"Stage Y design cannot hold; design it as the two-motor Stage Y: give {spec_path} a "
                            "[dual_drive] section (as specs/stage_y_dual.toml), and its yaw stiffness will be the "
                            "fit's")
        spec = spec.model_copy(update={"dual_drive": spec.dual_drive.model_copy(update=yaw)})
        carried = tuple(f"tilt_coupling.stiffness_n_m_per_rad -> dual_drive.{k}" for k in yaw)
        left_out = [e for e in left_out if e != "tilt_coupling"]
    try:
        loop = spec.problem()
    except SpecError as exc:
        raise SpecError(f"{spec_path}: {exc}") from None
    origin = PlantFromFit(fitted.file, tuple(left_out), carried) if fitted is not None else None
    return DesignProblem(spec, loop, spec_path, origin)


def _fitted(plant_from) -> FittedParameters:
    """A fit's parameters as given, or read from its ``gantry fit --json`` file by the codec (imported here: it
    loads the admittance and synthesis modules, 1 s that a spec without a fit need not pay)."""
    if isinstance(plant_from, FittedParameters):
        return plant_from
    from design.views.json import fitted_parameters_from_json
    from plant.host.text_io import read_text

    path = check_path("plant_from", plant_from)
    return fitted_parameters_from_json(read_text(path, what="the fit result"), str(path))


def _plant_from_fit(fitted: FittedParameters) -> tuple[dict, list[str], dict]:
    """The ``[plant]`` keys a fit's parameters set, the effects left out, and the ``[dual_drive]`` keys they set (a
    fitted ``tilt_coupling``'s stiffness is the beam's yaw stiffness K_a of the two-motor model, the same
    parameter of the same Xie-Wang equations; its inertia and the load's offset belong to the recording's
    carriage position and payload, and stay the spec's)."""
    plant: dict = {"effects": {}}
    left_out = set()
    yaw: dict = {}
    for name, value in fitted.values.items():
        effect, dot, field = name.partition(".")
        if not dot:
            if name in FIT_BASE_PARAMETERS:
                plant[name] = value
            continue
        if effect not in EFFECTS:
            raise SpecError(f"{fitted.file}: parameters.{name}: unknown effect {effect!r}")
        if effect == "tilt_coupling" and field == "stiffness_n_m_per_rad":
            yaw["yaw_stiffness_n_m_per_rad"] = value
        if not EFFECTS[effect].in_synthesis:
            left_out.add(effect)
            continue
        plant["effects"].setdefault(effect, {})[field] = value
    return plant, sorted(left_out), yaw


def design(problem: DesignProblem, *, method: str = "ccp+exact", schedule: bool = False,
           progress=None) -> DesignOutcome:
    """The one synthesis driver: PI gains for the spec's plant family (or its measured responses), the
    gain schedule when asked, and the admittance stage when the spec has one (with ``admittance.codesign``
    and the spec's controller values: the PI gains chosen with it). ``progress(stage)`` hears each stage of
    the synthesis begin. ``design.views.json.design_to_dict`` turns the outcome into the ``gantry synth --json``
    contract."""
    check_instance("problem", problem, DesignProblem, "design.workflows.load_problem(spec_path) makes one")
    spec, loop = problem.spec, problem.loop
    if spec.dual_drive is not None:
        dual = _dual(problem, progress)
        return DesignOutcome(problem, dual=dual, dual_admittance=_dual_admittance(problem, dual, progress))
    if spec.plant.measured:
        from design.synth.measured import synthesise_from_data

        return DesignOutcome(problem, measured=synthesise_from_data(loop, measured_plants(problem)))
    from design.synth.pi import as_designed, synthesise_pi

    codesign = loop.admittance is not None and loop.admittance.codesign
    given = loop.controller.kp.value is not None and loop.controller.ki.value is not None
    if codesign and given:
        return _codesigned(problem, progress, schedule=schedule)
    result = synthesise_pi(loop, method=method, progress=progress)
    optimal = result.status == "optimal"
    points = None
    if schedule and optimal:
        from design.synth.schedule import gain_schedule

        points = tuple(gain_schedule(as_designed(loop, result), result.evaluation.controller))
    if loop.admittance is None:
        return DesignOutcome(problem, synthesis=result, schedule=points)
    loop = as_designed(loop, result)
    controller = result.evaluation.controller if optimal else PI.given(loop.controller)
    if controller is None:
        return DesignOutcome(problem, synthesis=result, schedule=points, admittance_skipped=True)
    from design.admittance.synthesis import synthesise_admittance

    adm = synthesise_admittance(loop, controller=controller, progress=progress)
    return DesignOutcome(problem, synthesis=result, schedule=points, admittance=adm,
                         admittance_schedule=_admittance_schedule(loop, adm, progress, controller=controller)
                         if schedule else None)


def _admittance_schedule(loop, adm, progress, *, controller=None):
    """The admittance designed per payload beside the robust one (``design.admittance.schedule``)."""
    from design.admittance.schedule import admittance_schedule

    if adm.status not in ("optimal", "mouse_cannot_drive"):
        return None
    return admittance_schedule(loop, adm, controller=controller, progress=progress)


def _codesigned(problem: DesignProblem, progress, *, schedule: bool = False) -> DesignOutcome:
    """The admittance co-design from the spec's controller values, and the PI stage reported at the gains it
    chose: evaluated on the dense scenarios and checked with python-control like a synthesised design."""
    import time

    from design.admittance.synthesis import synthesise_admittance
    from design.parallel import thread_map
    from design.synth.between import search_pi_between
    from design.synth.evaluation import evaluate
    from design.synth.monte_carlo import monte_carlo_check
    from design.synth.pi import SynthesisResult
    from design.synth.scenarios import check_scenarios
    from design.synth.verify import verify

    loop = problem.loop
    adm = synthesise_admittance(loop, progress=progress)
    t0 = time.perf_counter()
    ev, ver, mc = thread_map(lambda check: check(), (
        lambda: evaluate(loop, adm.controller), lambda: verify(loop, adm.controller),
        lambda: monte_carlo_check(loop, adm.controller) if loop.plant.uncertainty else None))
    between = search_pi_between(loop, adm.controller, check_scenarios(loop))
    ok = ev.meets and ver.verified and (mc is None or mc.violations == 0) and (between is None or between.holds)
    message = (f"PI gains chosen with the admittance (co-design from Kp = {loop.controller.kp.value:g}, Ki = "
               f"{loop.controller.ki.value:g}); the velocity loop alone "
               + ("meets requirements at every check scenario" if ok else "MISSES its requirements: "
                  + "; ".join(ver.failures[:2]) if ver.failures else "misses its requirements"))
    pi = SynthesisResult("optimal" if ok else "infeasible", message, ev, ver, "co-design (design.admittance.codesign)",
                         time.perf_counter() - t0, monte_carlo=mc, between=between)
    return DesignOutcome(problem, synthesis=pi, admittance=adm,
                         admittance_schedule=_admittance_schedule(loop, adm, progress) if schedule else None)


def measured_plants(problem: DesignProblem):
    """The spec's ``[[plant.measured]]`` recordings as ``MeasuredPlants`` (relative paths from the spec's folder)."""
    from design.synth.measured import MeasuredPlants

    entries = problem.spec.plant.measured
    paths = [Path(e.file) if Path(e.file).is_absolute() else problem.spec_dir / e.file for e in entries]
    return MeasuredPlants.from_responses([e.payload_kg for e in entries],
                                         [measure(p, columns=e.columns) for p, e in zip(paths, entries)])


def dual_report_content(outcome: DesignOutcome, *, command: str = "", progress=None) -> DualReportContent:
    """Everything the report of a ``[dual_drive]`` design draws (``design.results.DualReportContent``)."""
    from design.admittance.dual import rendered_by_position
    from design.synth.dual_curves import structure_curves

    (progress or (lambda stage: None))("the structures over the travel")
    spec = outcome.problem.spec
    rendered = None
    r = outcome.dual_admittance
    if r is not None and r.status in ("optimal", "mouse_cannot_drive"):
        rendered = rendered_by_position(r, spec)
    return DualReportContent(outcome, structure_curves(outcome.dual, spec), rendered, command)


def report_content(problem: DesignProblem, *, outcome: DesignOutcome | None = None, synthesise: bool = True,
                   data=(), columns: str | None = None, sample_rate_hz: float | None = None,
                   samples: int | None = None, seed: int | None = None, command: str = "",
                   progress=None, schedule: bool = False) -> ReportContent:
    """Everything ``design.views.report.design_report`` draws: the gains (of ``outcome``, or synthesised
    when ``synthesise`` and the plant has a phase-limiting effect, else the spec's controller values)
    evaluated on the dense payloads beside the thesis gains, the loop's curves (with the binding scenario),
    one Monte Carlo check over the spec's uncertainty (``samples`` draws of ``seed``, default the spec's
    ``verification``, and the synthesis' own check when they agree; 0: none), and the diagnoses of ``data``
    (recordings read with the column map ``columns`` and ``sample_rate_hz`` in Hz, as ``measure``).
    ``progress(stage)`` hears each stage begin; ``schedule``: the gain (and admittance) schedule too."""
    from design.loop.curves import loop_curves, report_payloads
    from design.synth.evaluation import evaluate
    from design.synth.pi import PHASE_LIMITING, THESIS_GAINS, as_designed

    check_instance("problem", problem, DesignProblem, "design.workflows.load_problem(spec_path) makes one")
    if outcome is not None:
        check_instance("outcome", outcome, DesignOutcome, "design.workflows.design(problem) makes one")
    loop = problem.loop
    if samples and not loop.plant.uncertainty:     # before any long computation
        raise SpecError(f"{problem.spec_path}: plant.uncertainty: no parameter ranges to sample; add some or drop "
                        "--samples")
    measured = [measure(path, columns=columns, sample_rate_hz=sample_rate_hz) for path in data]   # before the work
    say = progress or (lambda stage: None)
    if outcome is None and synthesise and any(e in PHASE_LIMITING for e in loop.plant.effects):
        outcome = design(problem, progress=progress, schedule=schedule)
    if outcome is not None and outcome.synthesis is not None:
        loop = as_designed(loop, outcome.synthesis)
    controller, source = PI.given(loop.controller), "from the spec's controller values"
    if outcome is not None and outcome.controller is not None:
        controller, source = outcome.controller, "synthesised" + (", independently verified" if outcome.verified
                                                                  else ", NOT verified")
    elif outcome is not None:
        source += f" (synthesis {outcome.status}: {outcome.message})"
    if controller is None:
        raise SpecError(f"{problem.spec_path}: no gains to report: synthesis did not succeed and "
                        "controller.kp.value / controller.ki.value are not set")
    say("the gains on the payload range")
    ev = evaluate(loop, controller)
    adm_curves = None
    if outcome is not None and outcome.admittance is not None and outcome.admittance.status in (
            "optimal", "mouse_cannot_drive"):
        from design.admittance.curves import admittance_curves

        adm_curves = admittance_curves(loop, outcome.admittance)
    recordings = []
    for path, response in zip(data, measured):
        from design.loop.fitted import check_fitted
        from plant.diagnose.diagnosis import diagnose

        diagnosis = diagnose(loop.plant.plant(), response)
        recordings.append(ComparedRecording(Path(path), response, diagnosis,
                                            check_fitted(loop, controller, diagnosis.final)))
    check, comparison, adm_comparison = None, (), None
    if loop.plant.uncertainty and samples != 0:
        say("Monte Carlo check, and the design for the nominal parameters beside it")
        check, comparison = _robustness(loop, controller, outcome, samples, seed)
        if adm_curves is not None:
            adm_comparison = _admittance_robustness(loop, outcome.admittance)
    binding = ev.worst_scenario if loop.plant.uncertainty or ev.worst_scenario.payload_kg not in \
        report_payloads(loop) else None
    say("the loop's curves")
    return ReportContent(problem, controller, source, ev, evaluate(loop, THESIS_GAINS),
                         loop_curves(loop, controller, binding), outcome, adm_curves, tuple(recordings), command, check,
                         comparison, adm_comparison)


def _admittance_robustness(loop, robust):
    """The admittance design for the nominal parameters (the robust design's PI gains), with its Monte
    Carlo check over the uncertainty the robust design was made for."""
    from design.admittance.model import PiLoops
    from design.admittance.monte_carlo import admittance_monte_carlo
    from design.admittance.synthesis import synthesise_admittance
    from design.results import AdmittanceComparison

    nominal = synthesise_admittance(loop, controller=robust.controller, nominal=True)
    mc = None
    if nominal.status in ("optimal", "mouse_cannot_drive"):
        mc = admittance_monte_carlo(loop, loops=PiLoops.of(loop, robust.controller), m_v=nominal.m_v,
                                    b_v=nominal.b_v, timing=robust.timing)
    return AdmittanceComparison(nominal, mc)


def _robustness(loop, controller: PI, outcome: DesignOutcome | None, samples: int | None = None,
                seed: int | None = None):
    """The reported gains on the Monte Carlo draws (the synthesis' own check, or ``samples`` draws of ``seed``
    when given: the one Monte Carlo of the report); and, when they were synthesised, the robust design beside
    the design for the nominal parameters, each on the nominal plants, the check scenarios and the same draws."""
    from dataclasses import replace

    from design.results import DesignOnPlants
    from design.synth.evaluation import evaluate
    from design.synth.monte_carlo import monte_carlo_check
    from design.synth.pi import synthesise_pi

    s = outcome.synthesis if outcome is not None else None
    robust_synthesised = s is not None and s.status == "optimal" and s.monte_carlo is not None
    own = robust_synthesised and (samples is None or samples == s.monte_carlo.samples) and (
        seed is None or seed == s.monte_carlo.seed)
    check = s.monte_carlo if own else monte_carlo_check(loop, controller, samples=samples, seed=seed)
    if not robust_synthesised:
        return check, ()
    nominal_problem = replace(loop, plant=replace(loop.plant, uncertainty={}))
    nominal = synthesise_pi(loop, nominal=True)
    rows = [DesignOnPlants("robust (this design)", evaluate(nominal_problem, controller), s.evaluation, check)]
    if nominal.status == "optimal":
        n = nominal.evaluation
        rows.append(DesignOnPlants("nominal parameters only", evaluate(nominal_problem, n.controller),
                                   evaluate(loop, n.controller),
                                   monte_carlo_check(loop, n.controller, samples=check.samples, seed=check.seed)))
    return check, tuple(rows)


def _dual(problem: DesignProblem, progress=None):
    """The two-motor Stage Y's structures on the spec's carriage travel, payloads, uncertainty and requirements."""
    import numpy as np

    from design.synth.dual import DualRequirements
    from design.synth.dual_design import design_dual

    spec = problem.spec
    d, p, c, r = spec.dual_drive, spec.plant, spec.controller, spec.requirements
    travel = d.carriage_position_m

    def box(g):            # a log scan: a lower bound of 0 starts 6 decades below the upper
        return max(g.min, g.max * 1e-6), g.max

    return design_dual(spec.dual_model(), positions_m=np.linspace(travel.min, travel.max, travel.points),
                       payloads_kg=p.payload_kg.design_points(), stage_x_mass_kg=d.stage_x_mass_kg,
                       ranges={k: (v.min, v.max) for k, v in d.uncertainty.items()},
                       requirements=DualRequirements.of(r),
                       structures=tuple(d.structures), kp_box=box(c.kp), ki_box=box(c.ki),
                       monte_carlo_samples=spec.verification.monte_carlo_samples, seed=spec.verification.seed,
                       progress=progress)


def _dual_admittance(problem: DesignProblem, dual, progress=None):
    """The spec's admittance on the recommended two-motor structure (None without ``[admittance]`` or when no
    structure holds its requirements); with ``admittance.codesign`` on the structure's translation gains chosen for
    the mouse (``design.admittance.dual_codesign``)."""
    if problem.spec.admittance is None or dual.recommended is None:
        return None
    from design.admittance.dual import synthesise_dual_admittance
    from design.admittance.dual_codesign import dual_codesign
    from design.admittance.model import admittance_problem
    from design.admittance.rig import RigTiming
    from design.synth.dual import DualRequirements

    d = problem.spec.dual_drive
    best = next(s for s in dual.structures if s.structure == dual.recommended)
    travel = d.carriage_position_m
    loop = problem.loop
    where = dict(model=problem.spec.dual_model(), travel_m=(travel.min, travel.max), design_positions=travel.points,
                 stage_x_mass_kg=d.stage_x_mass_kg, ranges={k: (v.min, v.max) for k, v in d.uncertainty.items()})
    record = None
    adm = admittance_problem(loop)
    if adm.codesign:
        if progress is not None:
            progress("co-design of the translation gains for the mouse")
        timing = RigTiming.of(adm.rig)
        record = dual_codesign(loop, controller=best.controller, requirements=DualRequirements.of(loop.requirements),
                               timing=timing.at_delay(timing.delays[-1]), samples=loop.verification.monte_carlo_samples,
                               seed=loop.verification.seed, **where)
    return synthesise_dual_admittance(loop, structure=best.structure, controller=best.controller, progress=progress,
                                      codesign=record, **where)


def planar_design(spec_path: str | Path, *, progress=None) -> PlanarOutcome:
    """The planar spec's loops designed and verified together (``design.synth.planar``): Stage X's PI on its spec,
    Stage Y's structures on theirs (``planar.y_structures`` when given), the rotation PI on the rotation channel with
    Stage Y's recommended structure closed, then the whole loop checked on the design plants, between them and on
    the Monte Carlo draws."""
    import dataclasses
    import time

    import numpy as np

    from design.spec.planar import load_planar_spec
    from design.synth import planar as pl
    from design.synth.dual import W_RAD_S, DualRequirements

    start = time.perf_counter()
    path = Path(spec_path)
    spec = load_planar_spec(path)
    x_problem = load_problem(path.parent / spec.planar.stage_x)
    y_problem = load_problem(path.parent / spec.planar.stage_y)
    if x_problem.spec.plant.stage != "x" or x_problem.spec.plant.measured:
        raise SpecError(f"{path}: planar.stage_x: {spec.planar.stage_x} must be a Stage X spec with a plant model "
                        "(plant.stage = \"x\", no plant.measured)")
    d = y_problem.spec.dual_drive
    if d is None:
        raise SpecError(f"{path}: planar.stage_y: {spec.planar.stage_y} has no [dual_drive] section: the planar "
                        "machine's Stage Y is the two-motor model")
    xr, yr = x_problem.spec.plant.payload_kg, y_problem.spec.plant.payload_kg
    if (xr.min, xr.max) != (yr.min, yr.max):
        raise SpecError(f"{path}: the payload rides on Stage X's carriage: plant.payload_kg of "
                        f"{spec.planar.stage_x} ({xr.min:g}-{xr.max:g} kg) and of {spec.planar.stage_y} "
                        f"({yr.min:g}-{yr.max:g} kg) must be the same range")
    # Stage Y's structures on the planar spec's list and Monte Carlo draws (the whole loop's check supersedes its own)
    y_spec = y_problem.spec.model_copy(update={
        "dual_drive": d.model_copy(update={"structures": list(spec.planar.y_structures or d.structures)}),
        "verification": dataclasses.replace(y_problem.spec.verification,
                                            monte_carlo_samples=max(spec.verification.monte_carlo_samples, 1))})
    y_problem = DesignProblem(y_spec, y_problem.loop, y_problem.spec_path)
    d = y_spec.dual_drive
    say = progress or (lambda _: None)
    say("Stage X's loop")
    x = design(x_problem, progress=progress)
    say("Stage Y's structures")
    y = DesignOutcome(y_problem, dual=_dual(y_problem, progress))
    done = dict(spec_path=path, x=x, y=y)
    if x.status != "optimal" or y.status != "optimal":
        return PlanarOutcome(**done, rotation=None, check=None, rotation_alone=None,
                             seconds=time.perf_counter() - start)
    r = spec.rotation
    stage = pl.RotationStage(r.inertia_kg_m2, r.damping_n_m_s_per_rad, r.torque_constant_n_m_per_a,
                             r.drive_effects())
    y_ranges = {k: (v.min, v.max) for k, v in d.uncertainty.items()}
    r_ranges = {k: (v.min, v.max) for k, v in r.uncertainty.items()}
    travel = d.carriage_position_m
    masses = d.stage_x_mass_kg + np.asarray(yr.design_points(), float)
    model = y_problem.spec.dual_model()
    plants = pl.planar_scenarios(model, stage, np.linspace(travel.min, travel.max, travel.points), masses, y_ranges,
                                 r_ranges, d.stage_x_mass_kg)
    best = next(s for s in y.dual.structures if s.structure == y.dual.recommended).controller
    say(f"the rotation loop on {len(plants)} plants with Stage Y's loops closed")
    frds = [plants.frd_of(i, i + pl.CHUNK) for i in range(0, len(plants), pl.CHUNK)]
    channels = np.concatenate([pl.rotation_channel(W_RAD_S, P, best) for P in frds])
    open_loop = np.concatenate([P[:, 2, 2] for P in frds])            # the rotation channel, Stage Y's loops open
    del frds
    r_req = pl.RotationRequirements(r.requirements.phase_margin_deg, r.requirements.gain_margin_db)
    rot = pl.design_rotation(channels, r_req, (r.controller.kp.min, r.controller.kp.max),
                             (r.controller.ki.min, r.controller.ki.max))
    if rot.pi is None:
        return PlanarOutcome(**done, rotation=rot, check=None, rotation_alone=None,
                             seconds=time.perf_counter() - start)
    gm, pm, bw = pl.rotation_figures(W_RAD_S, open_loop, rot.pi)
    say("the whole loop: design plants, between them, Monte Carlo")
    checked = pl.check(best, rot.pi, design=plants, y_model=model, rotation=stage, travel_m=(travel.min, travel.max),
                       mass_range_kg=(float(masses.min()), float(masses.max())), y_ranges=y_ranges,
                       rotation_ranges=r_ranges, y_req=DualRequirements.of(y_problem.loop.requirements), r_req=r_req,
                       stage_x_mass_kg=d.stage_x_mass_kg, samples=spec.verification.monte_carlo_samples,
                       seed=spec.verification.seed)
    return PlanarOutcome(**done, rotation=rot, check=checked,
                         rotation_alone=(float(np.min(gm)), float(np.min(pm)),
                                         float(np.min(np.where(np.isfinite(bw), bw, 0)))),
                         seconds=time.perf_counter() - start)


def coupling(path: str | Path, *, carriage_position_m: float, machine: dict[str, float] | None = None,
             columns: str | None = None, sample_rate_hz: float | None = None):
    """Where X and Y meet (``plant.diagnose.coupling.diagnose_coupling``): a stepped sine of the X motor with every
    encoder recorded, against the planar machine (``plant.physics.planar.PlanarGantry`` with the values
    ``machine``, field by name; its defaults otherwise) with the carriage at ``carriage_position_m`` (m from Y1)."""
    from dataclasses import fields

    from plant.diagnose.coupling import diagnose_coupling
    from plant.physics.planar import PlanarGantry

    known = [f.name for f in fields(PlanarGantry)]
    for key in machine or {}:
        if key not in known:
            raise ParameterError(f"--machine {key}: not a value of the planar machine ({', '.join(known)})")
    gantry = PlanarGantry(**(machine or {}))
    p = check_number("carriage_position_m", carriage_position_m, minimum=0.0)
    if not 0 < p < gantry.rail_separation_m:
        raise ParameterError(f"carriage_position_m must lie between the rails (0, {gantry.rail_separation_m:g}) m, "
                             f"got {p:g}")
    return diagnose_coupling(measure(path, columns=columns, sample_rate_hz=sample_rate_hz), gantry, p)


def measure(path: str | Path, *, columns: str | None = None, sample_rate_hz: float | None = None,
            frf: str = "auto") -> MeasuredResponse:
    """The frequency response of any recording: a stepped sine by the lock-in, a time-domain recording
    by ``plant.estimate.frf_estimation.estimate_frf`` (``frf``: auto, periodic, lpm or closed-loop)."""
    from plant.data.read import parse_column_map, read_measurement
    from plant.estimate.response import estimate

    columns = check_optional_text("columns", columns)
    if sample_rate_hz is not None:
        sample_rate_hz = check_number("sample_rate_hz", sample_rate_hz, minimum=0.0)
    rec = read_measurement(check_path("path", path), columns=parse_column_map(columns) if columns else None,
                           sample_rate_hz=sample_rate_hz)
    return estimate(rec, method=frf)


def simulation_plant(*, spec: Path | None, stage: str | None, values: dict[str, float],
                     effects_added: dict[str, dict[str, float]], amplitude_a: float | None):
    """The plant a simulation runs (the spec's at its nominal payload, or the thesis's, then ``values`` and
    ``effects_added``) and the excitation amplitude (A; default the thesis's for the stage)."""
    from plant.physics.models import Plant, build_plant

    if (spec is None) == (stage is None):
        raise ParameterError("give exactly one of --spec FILE or --stage x|y")
    effects: dict[str, dict[str, float]] = {}
    base: dict[str, float] = {}
    if spec is not None:
        p = load_spec(spec).plant
        stage = p.stage
        effects = {name: dict(params) for name, params in p.effects.items()}
        base = p.base_values()
    elif stage not in ("x", "y"):
        raise ParameterError(f"--stage must be x or y, got {stage!r}")
    for name, params in effects_added.items():
        effects.setdefault(name, {}).update(params)
    for key, value in values.items():
        if "." in key:
            name, param = key.split(".", 1)
            if name not in effects:
                raise ParameterError(f"--set {key}: the plant has no effect {name}; add it with --effects {name}")
            effects[name][param] = value
        else:
            base[key] = value
    if amplitude_a is None:
        amplitude_a = THESIS_AMPLITUDE_A[stage]
    if not (math.isfinite(amplitude_a) and amplitude_a > 0):
        raise ParameterError(f"--amplitude-a must be a positive number of amperes, got {amplitude_a:g}")
    excitation = amplitude_a if any(name in EFFECTS and not EFFECTS[name].linear for name in effects) else None
    try:
        plant: Plant = build_plant(stage, effects=effects, excitation_current_a=excitation, **base)
        plant.parameters()          # within the limits every command checks
    except GantryError as exc:
        raise type(exc)(f"plant from --spec/--stage, --set and --effects: {exc}") from None
    return plant, amplitude_a


def fit_recording(path: str | Path, *, stage: str, effects: tuple[str, ...] = (), free: tuple[str, ...] | None = None,
                  values: dict[str, float] | None = None, load_position_m: float | None = None,
                  columns: str | None = None, sample_rate_hz: float | None = None, frf: str | None = None,
                  band: dict | None = None, method: str = "inverse-model", prep: Preprocessing | None = None,
                  rational: str | None = None, rational_weighting: str = "inverse_sigma",
                  progress=lambda stage: None) -> FitOutcome:
    """Fit a plant with ``effects`` to any recording: a stepped sine (lock-in, then maximum likelihood), a
    time-domain recording by the inverse model or output error (``method``), or its frequency response
    (``frf``: auto, periodic, lpm or closed-loop) as a stepped sine's. ``rational`` ("POLES,ZEROS") adds
    a tfest-like rational fit of the frequency response. ``progress(stage)`` hears each stage begin."""
    from plant.data.read import parse_column_map, read_measurement
    from plant.data.recordings import TimeRecording
    from plant.diagnose.two_rails import at_one_scale
    from plant.identify.fitting import fit_plant
    from plant.identify.inverse_model import Preprocessing, inverse_model_data
    from plant.identify.time_fit import configure_from_recording, fit_inverse_model, fit_output_error
    from plant.physics.effects import make_effect
    from plant.physics.models import Plant

    prep = prep or Preprocessing()
    path, effects = check_path("path", path), check_names("effects", effects)
    free = None if free is None else check_names("free", free)
    columns, rational = check_optional_text("columns", columns), check_optional_text("rational", rational)
    values = check_values("values", values)
    if load_position_m is not None:
        load_position_m = check_number("load_position_m", load_position_m)
    if stage not in ("x", "y"):
        raise ParameterError(f"--stage must be x or y, got {stage!r}")
    fx = tuple(make_effect(n) for n in effects)
    geometry = {"load_position_m": load_position_m} if load_position_m is not None else {}
    progress("reading the recording")
    recording = read_measurement(path, columns=parse_column_map(columns) if columns else None,
                                 sample_rate_hz=sample_rate_hz)
    if isinstance(recording, TimeRecording) and frf is None:
        if method not in ("inverse-model", "output-error"):
            raise ParameterError(f"--method must be inverse-model or output-error, got {method!r}")
        plant = Plant(stage, effects=fx, excitation_current_a=1.0, **geometry).with_values(values or {})
        progress("filtering and differencing")
        data = inverse_model_data(recording, float(plant.force_constant_n_per_a), prep)
        rails, recording, data = at_one_scale(dataclasses.replace(plant, effects=()), recording, data, prep)
        progress("fitting the inverse model")
        plant = configure_from_recording(plant, data, tuple(values or {}))
        result = fit_inverse_model(plant, data, free=free)
        if method == "output-error":
            progress("fitting the output error (simulating the velocity)")
            result = fit_output_error(plant, recording, start=result, prep=prep)
        return FitOutcome(result, rails=rails)
    progress("estimating the frequency response")
    measured = _estimate(recording, frf, band)
    plant = Plant(stage, effects=fx, excitation_current_a=float(measured.current_amplitude_a.mean()),
                  **geometry).with_values(values or {})
    progress("fitting the model")
    result = fit_plant(plant, measured, free=free)
    return FitOutcome(result, _rational(measured, rational, rational_weighting) if rational else None, measured)


def _rational(measured: MeasuredResponse, rational: str, weighting: str) -> RationalFit:
    """The rational fit of the output-averaged response (variance: the mean variance / number of outputs)."""
    from plant.identify.rational_fit import WEIGHTINGS, fit_rational

    try:
        n_poles, n_zeros = (int(v) for v in rational.split(","))
    except ValueError:
        raise ParameterError(f"--rational {rational!r}: expected POLES,ZEROS, e.g. 1,0") from None
    if weighting not in WEIGHTINGS:
        raise ParameterError(f"--rational-weighting must be one of {', '.join(WEIGHTINGS)}, got {weighting!r}")
    return fit_rational(measured.w_rad_s, measured.response.mean(axis=0), n_poles=n_poles, n_zeros=n_zeros,
                        weights=weighting, variance=measured.variance.mean(axis=0) / measured.response.shape[0])


#: parameters the frequency-domain diagnosis always fits
BASE_FREE = ("mass_kg", "damping_n_s_per_m")


def diagnose_recording(path: str | Path, *, stage: str, candidates: tuple[str, ...] | None = None,
                       values: dict[str, float] | None = None, load_position_m: float | None = None,
                       motor_length_m: float | None = None, columns: str | None = None,
                       sample_rate_hz: float | None = None, amplitude_files: tuple[Path, ...] = (),
                       fit_force_constant: bool = False, frf: str | None = None, band: dict | None = None,
                       prep: Preprocessing | None = None, progress=None) -> DiagnosisOutcome:
    """Start from the thesis model and find what the recording needs: a stepped sine (or a time-domain
    recording's frequency response, ``frf``) by the frequency-domain diagnosis with recordings at
    other amplitudes as evidence of nonlinearity; a time-domain recording by its force balance.
    ``progress(done, total)`` hears the models fitted."""
    from plant.data.read import parse_column_map, read_measurement
    from plant.data.recordings import TimeRecording
    from plant.diagnose.diagnosis import diagnose
    from plant.estimate.lockin import amplitude_dependence
    from plant.identify.inverse_model import Preprocessing
    from plant.physics.models import Plant

    prep = prep or Preprocessing()
    path, columns = check_path("path", path), check_optional_text("columns", columns)
    candidates = None if candidates is None else check_names("candidates", candidates)
    values = check_values("values", values)
    load_position_m, motor_length_m = (None if v is None else check_number(n, v) for n, v in
                                       (("load_position_m", load_position_m), ("motor_length_m", motor_length_m)))
    if stage not in ("x", "y"):
        raise ParameterError(f"--stage must be x or y, got {stage!r}")
    unknown = [e for e in candidates or () if e not in EFFECTS]
    if unknown:
        raise ParameterError(f"--effects: unknown effect {unknown[0]!r}; known: {', '.join(EFFECTS)}")
    geometry = {k: v for k, v in (("load_position_m", load_position_m), ("motor_length_m", motor_length_m))
                if v is not None}
    base = Plant(stage, **geometry).with_values(values or {})
    column_map = parse_column_map(columns) if columns else None
    recording = read_measurement(path, columns=column_map, sample_rate_hz=sample_rate_hz)
    if isinstance(recording, TimeRecording) and frf is None:
        if amplitude_files or fit_force_constant:
            raise ParameterError("--amplitude-files and --fit-force-constant apply to stepped sines; a time-domain "
                                 "fit needs the force constant set (--set force_constant_n_per_a=...)")
        from plant.diagnose.time_diagnosis import diagnose_time

        return DiagnosisOutcome(diagnose_time(base, recording, candidates=candidates, prep=prep, progress=progress))
    measured = _estimate(recording, frf, band)
    dependent = None
    if amplitude_files:
        others = []
        for other in amplitude_files:
            rec = read_measurement(other, columns=column_map, sample_rate_hz=sample_rate_hz)
            if isinstance(rec, TimeRecording):
                raise ParameterError(f"{other}: a time-domain recording; --amplitude-files takes stepped sines")
            others.append(_estimate(rec, None, None))
        dependent = bool(amplitude_dependence([measured, *others]).significant)
    free = BASE_FREE + (("force_constant_n_per_a",) if fit_force_constant else ())
    return DiagnosisOutcome(diagnose(base, measured, candidates=candidates, free_base=free,
                                     amplitude_dependent=dependent, progress=progress), measured)


def _estimate(recording, frf: str | None, band: dict | None) -> MeasuredResponse:
    """``plant.estimate.response.estimate`` of a recording, the band (``fit``/``diagnose --band``) for a
    time-domain one's FRF."""
    from plant.data.recordings import TimeRecording
    from plant.estimate.response import estimate

    return estimate(recording, method=frf or "auto", **((band or {}) if isinstance(recording, TimeRecording) else {}))

