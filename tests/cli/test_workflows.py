"""Identification flows into design: ``gantry synth --plant-from fit.json`` designs for the fitted plant,
exactly as a spec with the fitted values typed in by hand does; the workflow API measures any recording."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from in_process import gantry

from design.workflows import load_problem, measure
from plant.errors import SpecError

ROOT = Path(__file__).resolve().parents[2]
SPEC_X = ROOT / "specs" / "stage_x_synth.toml"
SPEC_Y_DUAL = ROOT / "specs" / "stage_y_dual.toml"
EMPS = ROOT / "examples" / "data" / "emps" / "DATA_EMPS.mat"




@pytest.fixture(scope="module")
def fit_json(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("fit")
    rec = tmp / "rec.csv"
    out = gantry("simulate", "--stage", "x", "--set", "damping_n_s_per_m=400", "--effects",
                 "delay.seconds=0.0007,current_loop.bandwidth_hz=800", "--f-hz", "2:300:20", "--duration-s", "1",
                 "--seed", "2", "--out", rec)
    assert out.returncode == 0, out.stderr
    out = gantry("fit", rec, "--stage", "x", "--effects", "delay,current_loop", "--json")
    assert out.returncode == 0, out.stderr
    path = tmp / "fit.json"
    path.write_text(out.stdout)
    return path


def test_plant_from_fit_designs_as_the_hand_written_spec_does(fit_json, tmp_path):
    fitted = json.loads(fit_json.read_text())["parameters"]
    out = gantry("synth", SPEC_X, "--plant-from", fit_json, "--json")
    assert out.returncode == 0, out.stderr
    from_fit = json.loads(out.stdout)
    assert from_fit["plant_from"]["effects"]["delay"]["seconds"] == fitted["delay.seconds"]["value"]
    assert from_fit["plant_from"]["damping_n_s_per_m"] == fitted["damping_n_s_per_m"]["value"]
    by_hand = tmp_path / "by_hand.toml"
    text = SPEC_X.read_text()
    text = text.replace("damping_n_s_per_m = 440.0", f"damping_n_s_per_m = {fitted['damping_n_s_per_m']['value']!r}")
    text = text.replace("delay = { seconds = 0.0005 }", f"delay = {{ seconds = {fitted['delay.seconds']['value']!r} }}")
    text = text.replace("current_loop = { bandwidth_hz = 1000.0 }",
                        f"current_loop = {{ bandwidth_hz = {fitted['current_loop.bandwidth_hz']['value']!r} }}")
    by_hand.write_text(text)
    out = gantry("synth", by_hand, "--json")
    assert out.returncode == 0, out.stderr
    hand = json.loads(out.stdout)
    assert from_fit["gains"] == hand["gains"]
    assert from_fit["worst_case"] == hand["worst_case"]
    # the fitted plant is not the spec's: the design differs from the spec's own
    spec_only = load_problem(SPEC_X).spec
    assert spec_only.plant.effects["delay"]["seconds"] != fitted["delay.seconds"]["value"]


def test_plant_from_a_time_domain_fit_leaves_out_what_synthesis_cannot_design_for(tmp_path):
    out = gantry("fit", EMPS, "--stage", "x", "--columns", "time=t,current=vir,position=qm", "--set",
                 "force_constant_n_per_a=35.15", "--effects", "coulomb_friction,offset", "--json")
    assert out.returncode == 0, out.stderr
    path = tmp_path / "emps_fit.json"
    path.write_text(out.stdout)
    problem = load_problem(ROOT / "specs" / "thesis_stage_x.toml", plant_from=path)
    assert problem.plant_from.left_out == ("coulomb_friction", "offset")
    assert problem.spec.plant.effects == {}
    assert problem.spec.plant.force_constant_n_per_a == pytest.approx(35.15)
    # the spec's uncertainty of its delay has no delay in the fitted plant to vary
    with pytest.raises(SpecError, match="plant.uncertainty.delay.seconds: unknown key"):
        load_problem(SPEC_X, plant_from=path)


@pytest.fixture(scope="module")
def tilt_fit_json(tmp_path_factory) -> Path:
    """A Stage Y recording of a beam that yaws (tilt_coupling: 60 Hz, K_a 1.5e5 N*m/rad, the load 0.15 m off
    centre) fitted with the effect."""
    tmp = tmp_path_factory.mktemp("tilt")
    rec = tmp / "rec.csv"
    out = gantry("simulate", "--stage", "y", "--effects", "delay.seconds=0.0005,current_loop.bandwidth_hz=1000,"
                 "tilt_coupling.frequency_hz=60,tilt_coupling.stiffness_n_m_per_rad=150000,tilt_coupling.offset_m=0.15",
                 "--f-hz", "1:120:40", "--out", rec)
    assert out.returncode == 0, out.stderr
    out = gantry("fit", rec, "--stage", "y", "--effects", "delay,current_loop,tilt_coupling", "--json")
    assert out.returncode == 0, out.stderr
    path = tmp / "fit.json"
    path.write_text(out.stdout)
    return path


def test_a_stage_y_fit_with_a_yawing_beam_hands_over_to_the_two_motor_design(tilt_fit_json):
    """The fitted tilt's stiffness is the two-motor model's yaw stiffness (the same K_a of the Xie-Wang equations);
    the design runs on it and says it carried it."""
    fitted = json.loads(tilt_fit_json.read_text())["parameters"]
    k_a = fitted["tilt_coupling.stiffness_n_m_per_rad"]["value"]
    assert k_a == pytest.approx(1.5e5, rel=1e-3)
    problem = load_problem(SPEC_Y_DUAL, plant_from=tilt_fit_json)
    assert problem.spec.dual_model().yaw_stiffness_n_m_per_rad == k_a
    assert problem.plant_from.carried == (
        "tilt_coupling.stiffness_n_m_per_rad -> dual_drive.yaw_stiffness_n_m_per_rad",)
    assert problem.plant_from.left_out == ()
    assert load_problem(SPEC_Y_DUAL).spec.dual_model().yaw_stiffness_n_m_per_rad == 2.0e5


def test_a_yawing_beam_on_a_one_loop_spec_is_refused_naming_dual_drive(tilt_fit_json, tmp_path):
    out = gantry("synth", ROOT / "specs" / "stage_y_synth.toml", "--plant-from", tilt_fit_json)
    assert out.returncode == 2 and out.stderr.count("\n") == 1 and "[dual_drive]" in out.stderr, out.stderr
    spec = tmp_path / "tilt.toml"
    spec.write_text((ROOT / "specs" / "stage_y_synth.toml").read_text().replace(
        "[plant.effects]", "[plant.effects]\ntilt_coupling = { frequency_hz = 60.0 }"))
    out = gantry("synth", spec)
    assert out.returncode == 2 and "[dual_drive]" in out.stderr, out.stderr


@pytest.mark.parametrize(("content", "message"), [
    ("not json", "not a JSON fit result"),
    ('{"status": "optimal"}', "not a fit result"),
    ('{"parameters": {"delay.seconds": {"value": null}}}', "parameters.delay.seconds: None is not a finite number"),
    ('{"parameters": {"backlash.width_m": {"value": 1e-3}}}', "unknown effect 'backlash'"),
    ('{"parameters": {}, "fixed": [1.0]}', "fixed: expected an object"),
    ('{"parameters": {}, "fixed": {"mass_kg": "40"}}', "fixed.mass_kg: '40' is not a finite number"),
])
def test_bad_fit_results_are_named(tmp_path, content, message):
    path = tmp_path / "fit.json"
    path.write_text(content)
    out = gantry("synth", SPEC_X, "--plant-from", path)
    assert out.returncode == 2 and out.stderr.count("\n") == 1 and message in out.stderr, out.stderr


def test_a_fit_read_back_is_its_parameters_and_designs_as_its_file(fit_json):
    """The codec reads every value the fit wrote (estimated and fixed), and a notebook that holds them typed gets
    the problem the command gets from the file."""
    from design.results import FittedParameters
    from design.views.json import fitted_parameters_from_json

    written = json.loads(fit_json.read_text())
    fitted = fitted_parameters_from_json(fit_json.read_text(), str(fit_json))
    assert fitted.values == {**written["fixed"], **{k: v["value"] for k, v in written["parameters"].items()}}
    assert set(written["parameters"]) <= set(fitted.values) and "mass_kg" in fitted.values
    typed = load_problem(SPEC_X, plant_from=FittedParameters(fitted.values, "in memory"))
    from_file = load_problem(SPEC_X, plant_from=fit_json)
    assert typed.spec == from_file.spec and typed.plant_from.left_out == from_file.plant_from.left_out
    assert typed.plant_from.file == "in memory" and from_file.plant_from.file == str(fit_json)


def test_measure_reads_stepped_sines_and_time_domain_recordings(fit_json):
    stepped = measure(fit_json.parent / "rec.csv")
    assert stepped.method == "lock-in" and stepped.f_hz.size == 20
    emps = measure(EMPS, columns="time=t,current=vir,position=qm,reference=qg")
    assert emps.notes[0].startswith("method closed-loop")
    assert np.all(np.isfinite(emps.response))
