"""The typed results (``design.loop.requirement``: ``Binding``, ``ScenarioPoint``; ``design.synth.scan.ScanDiagnosis``)
become the JSON of ``gantry synth --json`` in ``design.views.json`` alone: built here from real evaluations and
checks, they give the dicts the golden files hold, with their keys in the contract's order."""

from __future__ import annotations

import json
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from bundled_specs import admittance_data

from design.admittance.delays import DelaySpanEvaluator, samples_text
from design.admittance.model import AdmittanceEvaluator, PiLoops, relative_slack
from design.admittance.rig import RigTiming
from design.loop.controller import PI
from design.spec.schema import load_spec, parse_spec
from design.synth.dual import dual_scenarios
from design.synth.pi import baselines, synthesise_pi
from design.synth.scenarios import check_scenarios, describe_row
from design.views.json import admittance_binding_to_dict, evaluation_to_dict, synthesis_to_dict

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "tests" / "golden"))
from commands import GOLDEN, differences  # noqa: E402

ADMITTANCE_KEYS = ["constraint", "payload_kg", "scenario", "mouse", "value", "limit", "detail"]


def _golden(name: str) -> dict:
    return json.loads((GOLDEN / f"{name}.json").read_text())["json"]


@pytest.mark.parametrize("name, spec", [("synth_x", "stage_x_synth.toml"),
                                        ("synth_infeasible", "infeasible_example.toml")])
def test_the_baselines_bindings_are_the_golden_ones_in_the_contracts_order(name, spec):
    # with uncertainty the binding names the uncertain parameters where it binds; without, it has no "scenario"
    problem = load_spec(ROOT / "specs" / spec).problem()
    evaluations, names = baselines(problem)
    for ev, label, old in zip(evaluations, names, _golden(name)["baselines"]):
        new = evaluation_to_dict(ev, label)["binding"]
        assert not differences(new, old["binding"]), (new, old["binding"])
        scenario = ["scenario"] if problem.plant.uncertainty else []
        assert list(new) == ["constraint", "payload_kg", "slack", "active", *scenario]
        assert ev.binding.scenario == ev.worst_scenario and ev.binding.payload_kg == ev.worst_scenario.payload_kg


def test_scenario_points_round_trip_through_the_scenario_sets():
    problem = load_spec(ROOT / "specs" / "stage_x_synth.toml").problem()
    s = check_scenarios(problem)
    row = s.row(len(s) - 1)
    assert list(row.as_dict()) == ["payload_kg", *s.parameters]
    assert row.as_dict() == {"payload_kg": s.payload_kg[-1], **{n: v[-1] for n, v in s.parameters.items()}}
    assert s.contains(row) and not s.take(np.arange(len(s) - 1)).contains(row)
    assert s.take(np.arange(len(s) - 1)).with_row(row).row(len(s) - 1) == row
    assert describe_row(row).startswith(f"payload_kg = {row.payload_kg:.4g}, ")
    spec = load_spec(ROOT / "specs" / "stage_y_dual.toml")
    d = dual_scenarios(spec.dual_model(), [0.08, 0.72], [16.0 + 5.0, 16.0 + 40.0],
                       {"damping1_n_s_per_m": (330.0, 550.0)}, 16.0)
    point = d.row(len(d) - 1)
    assert point.as_dict() == {"carriage_position_m": 0.72, "payload_kg": 40.0, "damping1_n_s_per_m": 550.0}
    assert d.contains(point) and not d.take([0]).contains(point) and d.take([0]).with_row(point).contains(point)


def test_an_infeasible_pi_problem_prints_the_scans_diagnosis():
    data = tomllib.loads((ROOT / "specs" / "infeasible_example.toml").read_text())
    data["requirements"].pop("min_bandwidth_hz")
    data["controller"] = {"kp": {"min": 5000.0, "max": 10000.0}, "ki": {"min": 1.0e6, "max": 1.0e7}}
    res = synthesise_pi(parse_spec(data).problem(), method="ccp")
    assert res.status == "infeasible" and res.diagnosis is not None
    out = synthesis_to_dict(res)
    d = res.diagnosis
    assert out["binding"] == {"constraint": d.binding.constraint, "payload_kg": d.binding.payload_kg,
                              "relative_slack": d.binding.relative_slack}
    assert list(out["solver"])[-1] == "diagnosis"
    assert out["solver"]["diagnosis"] == {"constraint": d.binding.constraint, "payload_kg": d.binding.payload_kg,
                                          "where": d.where, "relative_slack": d.binding.relative_slack, "kp": d.kp,
                                          "ki": d.ki, "alone": d.alone}
    assert d.where in res.message and d.binding.constraint.replace("_", " ") in res.message


def _light_check(delays):
    """The dense check of a small admittance spec (two payloads x two dampings x a floating and a braced mouse) at
    far too light virtual dynamics, at each computation delay of ``delays``."""
    data = admittance_data()
    data["plant"]["payload_kg"] = {"min": 5.0, "max": 40.0, "points": 2, "nominal": 35.0}
    data["plant"]["uncertainty"] = {"damping_n_s_per_m": {"min": 330.0, "max": 550.0}}
    data["admittance"]["codesign"] = False
    data["admittance"]["locomotion"].pop("force_record")
    data["admittance"]["mouse"].update({"head_mass_kg": 0.005, "body_mass_kg": 0.03, "neck_stiffness_n_per_m": 100.0,
                                        "neck_damping_n_s_per_m": 0.5, "leg_stiffness_n_per_m": 1000.0})
    span = {"min": delays[0], "max": delays[-1]}
    data["admittance"]["rig"]["computation_delay_samples"] = span if len(delays) > 1 else delays[0]
    problem = parse_spec(data).problem()
    timing = RigTiming.of(problem.admittance.rig)
    loops = PiLoops.of(problem, PI(178.5, 19150.0))
    scenarios = check_scenarios(problem, [5.0, 40.0])
    if len(delays) == 1:
        return AdmittanceEvaluator(problem, scenarios, loops=loops, timing=timing).evaluate(0.005, 0.05)
    return DelaySpanEvaluator(problem, scenarios, loops=loops, timing=timing).evaluate(0.005, 0.05)


def test_an_admittance_checks_violations_print_where_they_are_missed():
    check = _light_check((0,))
    assert check.violations and not check.meets
    for v in check.violations:
        out = admittance_binding_to_dict(v)
        assert list(out) == ADMITTANCE_KEYS and out["detail"] == v.detail
        if v.scenario is None:
            assert v.constraint == "drift" and out["scenario"] is None and out["payload_kg"] is None
            continue
        j = [k for k in range(len(check.scenarios)) if check.scenarios.row(k) == v.scenario]
        assert j and out["scenario"] == check.scenarios.row(j[0]).as_dict()
        assert out["payload_kg"] == out["scenario"]["payload_kg"] == v.scenario.payload_kg
        if v.constraint in ("phase_margin", "gain_margin", "stability"):
            assert out["mouse"] in [m.as_dict() for m in check.mice] and relative_slack(v) < 0
    assert {v.constraint for v in check.violations} >= {"phase_margin"}


def test_a_delay_range_names_the_delay_of_each_violation_last():
    check = _light_check((0, 1))
    assert {v.delay_samples for v in check.violations} == {0, 1}
    for v in check.violations:
        out = admittance_binding_to_dict(v)
        assert list(out) == [*ADMITTANCE_KEYS, "delay_samples"]
        assert out["detail"].endswith(f"with {samples_text(v.delay_samples)}")
