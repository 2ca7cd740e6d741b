"""``gantry coupling``: a recording of the X motor with every encoder, from the tool's simulator of the planar machine
(the diagnosis itself is held to an independent simulator in ``tests/plant/diagnose/test_coupling.py``), read from
CSV as a measured one; bad input in one line."""

import json

import numpy as np
import pytest
from in_process import gantry

from plant.data.writers import write_recording_csv
from plant.experiment.planar_recording import x_motor_recording
from plant.physics.planar import PlanarGantry


@pytest.fixture(scope="module")
def skewed(tmp_path_factory):
    path = tmp_path_factory.mktemp("coupling") / "x_motor.csv"
    write_recording_csv(x_motor_recording(PlanarGantry(beam_skew_rad=0.0015), 0.3, np.geomspace(3.0, 90.0, 6),
                                          seed=5), path)
    return path


def test_a_skewed_beam_is_found_in_the_json_and_said_on_the_console(skewed):
    r = gantry("coupling", str(skewed), "--carriage-m", "0.3", "--json")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["explained"] and doc["chosen"]["model"] == "beam_skew"
    assert doc["chosen"]["parameters"]["beam_skew_rad"] == pytest.approx(0.0015, rel=0.02)
    assert [f["model"] for f in doc["fits"]][0] == "none" and len(doc["ratio"]["y1"]["re"]) == len(doc["f_hz"]) == 6
    r = gantry("coupling", str(skewed), "--carriage-m", "0.3")
    assert r.returncode == 0 and "beam_skew (chosen)" in r.stdout and "X moves the rails" in r.stdout


@pytest.mark.parametrize("args, says", [
    (["--carriage-m", "0.9"], "between the rails"),
    (["--carriage-m", "0.3", "--machine", "carriage_mas_kg=3"], "not a value of the planar machine"),
    (["--carriage-m", "0.3", "--machine", "carriage_mass_kg=-3"], "carriage_mass_kg"),
    (["--carriage-m", "0.3", "--machine", "beam_skew_rad"], "expected KEY=VALUE")])
def test_bad_input_is_one_line_naming_it(skewed, args, says):
    r = gantry("coupling", str(skewed), *args)
    assert r.returncode == 2 and says in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr


def test_a_recording_of_one_encoder_is_refused_naming_the_output(tmp_path):
    path = tmp_path / "one.csv"
    path.write_text("frequency_hz,time_s,current_a,velocity_m_per_s\n" + "".join(
        f"5,{k / 1000:.3f},{np.sin(2 * np.pi * 5 * k / 1000):.6f},{1e-3 * np.cos(2 * np.pi * 5 * k / 1000):.6e}\n"
        for k in range(2000)))
    r = gantry("coupling", str(path), "--carriage-m", "0.3")
    assert r.returncode == 2 and "velocity_y1_m_per_s is missing" in r.stderr, r.stderr
