"""Stage Y's two rails diagnosed jointly: what the averaged view cannot see (a rail read to another scale, two
motors whose force constants differ) the joint fit names, with its size.

Recordings from the independent simulator (tests/reference/independent_sim.py, which imports nothing of the tool):
its Stage Y beam with the load at l1 from rail Y1 and each motor's force K_t i / 2 on its rail; the encoder scale
error is put on the recorded Y2 column, the force constants by the beam's input matrix (K_t (1 + d) / 2,
K_t (1 - d) / 2), as the simulator's own ``stage_y_beam`` builds it for d = 0.
"""

import dataclasses
import math
import re

import independent_sim as sim
import numpy as np
import pytest
from in_process import gantry

from plant import stage_y
from plant.data.read_stepped_sine import read_recording
from plant.diagnose.diagnosis import diagnose
from plant.estimate.lockin import estimate_response

PROTOCOL = sim.Protocol(f_hz=tuple(np.geomspace(1.0, 75.0, 30)), block_s=3.0, sample_rate_hz=1000.0, amplitude_a=1.75)
INERTIA = 1.5


def beam(rail1_m: float, tilt_hz: float, imbalance: float = 0.0):
    net = sim.stage_y_beam(40.0, INERTIA, rail1_m=rail1_m,
                           tilt_stiffness_n_m_per_rad=INERTIA * (2 * math.pi * tilt_hz) ** 2)
    l1, l2 = rail1_m, sim.BEAM_LENGTH_M - rail1_m
    T = np.array([[1.0, -l1], [1.0, l2]])
    kt = sim.KT_N_PER_A
    return dataclasses.replace(net, input_n_per_a=T.T @ np.array([kt * (1 + imbalance) / 2, kt * (1 - imbalance) / 2]))


def measured(tmp_path, net, *, y2_scale: float = 1.0, seed: int = 4):
    rec = sim.simulate(net, sim.Drive(), PROTOCOL, noise=0.03, seed=seed)
    for v in rec.velocity_m_per_s:
        v[:, 1] *= y2_scale
    return estimate_response(read_recording(sim.write_csv(rec, tmp_path / "rec.csv")))


def test_an_encoder_reading_one_rail_3_percent_long_is_named_with_its_scale(tmp_path):
    # a centred load (no tilt to see): the rails disagree by 0.26 dB at every frequency, which the mean of the rails
    # hides and the joint fit names
    data = measured(tmp_path, beam(0.4, 32.0), y2_scale=1.03)
    diag = diagnose(stage_y(load_position_m=0.4), data)
    assert diag.verdict == "explained" and diag.final_effects == ("rail_scale",)
    scale, err = diag.final.values["rail_scale.y2_scale"], diag.final.stderr["rail_scale.y2_scale"]
    assert scale == pytest.approx(1.03, abs=3 * err + 1e-3)
    # the base model's failure says how far apart the rails are: 20 log10 1.03 = +0.26 dB
    words = diag.steps[0].residuals.description
    assert float(re.search(r"the rails disagree by ([+-][\d.]+) ± [\d.e-]+ dB \(Y2 over Y1\)", words).group(1)) == \
        pytest.approx(20 * math.log10(1.03), abs=0.02)


def test_rails_that_agree_need_no_scale(tmp_path):
    diag = diagnose(stage_y(load_position_m=0.4), measured(tmp_path, beam(0.4, 32.0)))
    assert diag.verdict == "explained" and "rail_scale" not in diag.final_effects
    assert "the rails disagree" not in diag.steps[0].residuals.description


def test_two_motors_10_percent_apart_are_named_beside_the_tilt(tmp_path):
    # force constants 1.05 and 0.95 K_t with the load at 0.28 m from Y1 (given, as an experimenter knows it): the
    # beam twists by the motors' torque, so the rails part around the 32 Hz tilt mode more than the load alone makes
    data = measured(tmp_path, beam(0.28, 32.0, imbalance=0.05))
    diag = diagnose(stage_y(load_position_m=0.28), data)
    assert diag.verdict == "explained" and set(diag.final_effects) == {"tilt_coupling", "motor_imbalance"}
    d, err = diag.final.values["motor_imbalance.fraction"], diag.final.stderr["motor_imbalance.fraction"]
    assert d == pytest.approx(0.05, abs=3 * err + 0.005)
    assert diag.final.values["tilt_coupling.frequency_hz"] == pytest.approx(32.0, rel=0.03)


@pytest.mark.parametrize("argv,words", [
    (["--stage", "y", "--effects", "rail_scale.y2_scale=-1"], "parameter rail_scale.y2_scale must be positive"),
    (["--stage", "y", "--effects", "motor_imbalance.fraction=1.5,tilt_coupling"],
     "motor_imbalance.fraction must lie in (-1, 1)"),
    (["--stage", "x", "--effects", "rail_scale"], "rail_scale applies to Stage Y only"),
])
def test_a_rail_effect_out_of_range_is_refused_in_one_line(tmp_path, argv, words):
    out = gantry("simulate", *argv, "--out", str(tmp_path / "z.csv"))
    assert out.returncode == 2 and words in out.stderr and len(out.stderr.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []
