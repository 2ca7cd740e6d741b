"""The documented Python API (docs/api.md) checks its arguments at the boundary: a wrong kind or a non-finite
value is a ``GantryError`` naming the argument, raised before any computation, never an AttributeError or a
numpy message from deep inside."""

import math

import numpy as np
import pytest

from design import workflows
from design.loop.control_models import loop_models
from design.loop.controller import PI
from design.views.mat import write_design_mat, write_response_mat
from design.views.report import design_report
from plant import Delay, Plant, make_effect, stage_x
from plant.errors import ArgumentError, GantryError
from plant.experiment.simulate import simulate_stepped_sine
from plant.identify.rational_fit import fit_rational

W = np.array([1.0, 2.0, 3.0])


def rec_path(tmp_path):
    path = tmp_path / "rec.csv"
    path.write_text("frequency_hz,time_s,current_a,velocity_m_per_s\n1,0,0,0\n")
    return path


CASES = [
    ("path", lambda tmp, a: workflows.measure(a), [None, 3.0, True, ["a.csv"]]),
    ("columns", lambda tmp, a: workflows.measure(rec_path(tmp), columns=a), [math.nan, True, ["time=1"]]),
    ("sample_rate_hz", lambda tmp, a: workflows.measure(rec_path(tmp), sample_rate_hz=a), ["2000", math.nan, -1.0]),
    ("path", lambda tmp, a: workflows.diagnose_recording(a, stage="x"), [None, 1.0]),
    ("candidates", lambda tmp, a: workflows.diagnose_recording(rec_path(tmp), stage="x", candidates=a),
     ["delay", [1, 2]]),
    ("values", lambda tmp, a: workflows.diagnose_recording(rec_path(tmp), stage="x", values=a),
     ["mass_kg=40", [40.0], {"mass_kg": "40"}, {"mass_kg": math.inf}]),
    ("motor_length_m", lambda tmp, a: workflows.diagnose_recording(rec_path(tmp), stage="x", motor_length_m=a),
     [[0.8, 0.9], "0.8"]),
    ("effects", lambda tmp, a: workflows.fit_recording(rec_path(tmp), stage="x", effects=a), [None, "delay", 1.0]),
    ("free", lambda tmp, a: workflows.fit_recording(rec_path(tmp), stage="x", free=a), ["mass_kg"]),
    ("rational", lambda tmp, a: workflows.fit_recording(rec_path(tmp), stage="x", rational=a), [(1, 0), 1.0]),
    ("load_position_m", lambda tmp, a: workflows.fit_recording(rec_path(tmp), stage="x", load_position_m=a),
     [[0.4], math.nan]),
    ("spec_path", lambda tmp, a: workflows.load_problem(a), [None, 1.0]),
    ("plant_from", lambda tmp, a: workflows.load_problem("specs/stage_x_synth.toml", plant_from=a), [1.0, True]),
    ("problem", lambda tmp, a: workflows.design(a), [None, "specs/stage_x_synth.toml"]),
    ("problem", lambda tmp, a: workflows.report_content(a), [None, "specs/stage_x_synth.toml"]),
    ("content", lambda tmp, a: design_report(a), [None, {}]),
    ("outcome", lambda tmp, a: write_design_mat(a, tmp / "d.mat"), [None, "synth.json"]),
    ("measured", lambda tmp, a: write_response_mat(a, tmp / "r.mat"), [None, np.ones(3)]),
    ("plant", lambda tmp, a: loop_models(a, PI(200.0, 10.0)), [None, "x", 40.0]),
    ("kp", lambda tmp, a: loop_models(stage_x(), PI(a, 10.0)), [None, "200", math.nan, True, -1.0, [200.0]]),
    ("ki", lambda tmp, a: loop_models(stage_x(), PI(200.0, a)), [math.inf, -5.0]),
    ("plant", lambda tmp, a: simulate_stepped_sine(a, f_hz=[1.0], current_amplitude_a=0.5), [None, "x"]),
    ("f_hz", lambda tmp, a: simulate_stepped_sine(stage_x(), f_hz=a, current_amplitude_a=0.5), ["1", True, [np.nan]]),
    ("current_amplitude_a", lambda tmp, a: simulate_stepped_sine(stage_x(), f_hz=[1.0, 2.0], current_amplitude_a=a),
     ["0.5", None, [0.5, 0.5, 0.5]]),
    ("duration_s", lambda tmp, a: simulate_stepped_sine(stage_x(), f_hz=[1.0], current_amplitude_a=0.5,
                                                        duration_s=a), [[1.0, 2.0], "5"]),
    ("mass_kg", lambda tmp, a: stage_x(mass_kg=a), ["40", True, math.nan, [35.0, 40.0]]),
    ("payload_kg", lambda tmp, a: stage_x().with_payload(a), [True, "40", [math.nan]]),
    ("delay.seconds", lambda tmp, a: Delay(a), ["0.001", [0.001, 0.002]]),
    ("effects", lambda tmp, a: Plant("x", effects=a), [None, 1.0]),
    ("name", lambda tmp, a: make_effect(a), [None, ["delay"]]),
    ("frequency grid", lambda tmp, a: stage_x().frd(a), ["1", True, [1.0, math.nan]]),
    ("pade_order", lambda tmp, a: stage_x().to_control(pade_order=a), [None, 2.5, 0]),
    ("n_poles", lambda tmp, a: fit_rational(W, np.ones(3, complex), n_poles=a, n_zeros=0), [None, "1", 1.5, -1]),
]


@pytest.mark.parametrize(("name", "call", "value"), [(n, c, v) for n, c, values in CASES for v in values],
                         ids=[f"{n}-{v!r}"[:40] for n, _, values in CASES for v in values])
def test_a_bad_argument_is_named_before_anything_is_computed(tmp_path, monkeypatch, name, call, value):
    monkeypatch.chdir(__import__("pathlib").Path(__file__).resolve().parents[2])
    with pytest.raises(GantryError) as info:
        call(tmp_path, value)
    message = str(info.value)
    unknown_effect = name == "name" and "unknown effect" in message
    assert name in message or unknown_effect, message
    assert len(message.splitlines()) == 1


def test_a_wrong_kind_is_also_a_type_error():
    with pytest.raises(TypeError):
        workflows.design("specs/stage_x_synth.toml")
    with pytest.raises(ArgumentError, match="load_problem"):
        workflows.design(None)
