"""Where X and Y meet (``plant.diagnose.coupling``): stepped sines of the X motor with every encoder recorded, made by
an independent simulator (``independent_planar_coupling``: the momentum principles written out, scipy's exact hold;
it imports nothing of the tool), read and estimated by the tool, and the geometric error named with its size."""

import independent_planar_coupling as sim
import numpy as np
import pytest

from plant.data.read_stepped_sine import read_recording
from plant.diagnose.coupling import diagnose_coupling
from plant.errors import DataError
from plant.estimate.lockin import estimate_response
from plant.physics.planar import PlanarGantry

F_HZ = np.geomspace(2.0, 120.0, 10)
POSITION = 0.28


def _diagnosed(tmp_path, machine=None, *, skew=0.0, offset=0.0, seed=0):
    path = tmp_path / "x_motor.csv"
    path.write_text(sim.x_motor_recording(sim.Machine(skew_rad=skew, offset_m=offset), POSITION, F_HZ, seed=seed))
    return diagnose_coupling(estimate_response(read_recording(path)), machine or PlanarGantry(), POSITION)


@pytest.mark.parametrize("skew, offset, model", [(0.003, 0.0, "beam_skew"), (0.0, 0.02, "carriage_offset"),
                                                 (-0.002, 0.015, "beam_skew+carriage_offset")])
def test_the_geometric_error_is_named_with_its_size(tmp_path, skew, offset, model):
    d = _diagnosed(tmp_path, skew=skew, offset=offset)
    assert d.chosen.model == model and d.explained, d.verdict
    truth = {"beam_skew_rad": skew, "carriage_offset_m": offset}
    for name, value, err in zip(d.chosen.parameters, d.chosen.values, d.chosen.stderr):
        assert abs(value - truth[name]) <= max(4 * err, 0.02 * abs(truth[name])), (name, value, err)
        assert abs(value - truth[name]) <= 0.05 * abs(truth[name])
    assert "X moves the rails" in d.verdict


def test_a_square_beam_and_a_centred_carriage_name_nothing(tmp_path):
    d = _diagnosed(tmp_path, seed=3)
    assert d.chosen.model == "none" and d.explained, d.verdict
    assert d.verdict.startswith("X and Y meet as the planar model says")


def test_mechanics_unlike_the_machines_are_not_explained_and_say_so(tmp_path):
    # the truth's carriage is 35 kg; a model with 12 kg puts the rails' answer to the skew off by far more than noise
    d = _diagnosed(tmp_path, PlanarGantry(carriage_mass_kg=12.0), skew=0.003)
    assert not d.explained and "not explained" in d.verdict


def test_a_recording_without_the_rails_encoders_is_refused_naming_the_output(tmp_path):
    path = tmp_path / "x_only.csv"
    lines = sim.x_motor_recording(sim.Machine(), POSITION, F_HZ[:3]).splitlines()
    path.write_text("\n".join(",".join(r.split(",")[:3] + r.split(",")[5:]) for r in lines) + "\n")
    with pytest.raises(DataError, match="velocity_y1_m_per_s is missing"):
        _ = diagnose_coupling(estimate_response(read_recording(path)), PlanarGantry(), POSITION)


def test_the_tools_simulator_records_what_the_independent_one_does(tmp_path):
    # noiseless, the same machine with both errors: the rails' velocity per the carriage's agrees to 1e-6
    from plant.experiment.planar_recording import x_motor_recording

    f = F_HZ[::3]
    path = tmp_path / "ref.csv"
    path.write_text(sim.x_motor_recording(sim.Machine(skew_rad=0.002, offset_m=0.01), POSITION, f,
                                          velocity_noise=0.0, current_noise=0.0))
    ref = estimate_response(read_recording(path))
    own = estimate_response(x_motor_recording(PlanarGantry(beam_skew_rad=0.002, carriage_offset_m=0.01), POSITION, f,
                                              velocity_noise_m_per_s=0.0, current_noise_a=0.0))
    from plant.diagnose.coupling import coupling_ratio

    a, b = coupling_ratio(ref)[0], coupling_ratio(own)[0]
    assert np.abs(a - b).max() <= 1e-6 * np.abs(a).max()


def test_a_carriage_that_never_answers_is_refused_in_words():
    from plant.data.frequency_response import MeasuredResponse

    f = np.array([5.0, 10.0, 20.0])
    g = np.array([[1e-4, 1e-4, 1e-4], [1e-4, 1e-4, 1e-4], [0.0, 0.0, 1e-3]], complex)
    measured = MeasuredResponse(f, g, np.full(g.shape, 1e-12), ("velocity_y1_m_per_s", "velocity_y2_m_per_s",
                                                                 "velocity_x_m_per_s"), np.ones(3),
                                np.full(g.shape, 40.0), np.zeros((3, 3, 2)))
    with pytest.raises(DataError, match="at 1 of 3 frequencies"):
        diagnose_coupling(measured, PlanarGantry(), POSITION)
