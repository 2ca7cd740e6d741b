"""Distortion counts in the verdict: a model that fits the fundamental but makes no harmonics does not
explain a recording whose harmonics stand above the noise.

Recordings from independent simulators (``tests/reference``): a stepped sine through an amplifier that
clips the current at 60 % of its command (the commanded current recorded, as drives log it), which a linear
model fits within the noise with mass and damping 40 % high (the clipping's describing gain), and an odd
multisine through a static output nonlinearity; controls without the nonlinearity.
"""

import independent_linear_motor as lm
import independent_sim as sim
import independent_timesim as timesim
import numpy as np
import pytest

from plant import stage_x
from plant.data.read_stepped_sine import read_recording
from plant.data.recordings import TimeRecording
from plant.diagnose.diagnosis import diagnose
from plant.diagnose.evidence import EXPLAINED, NOT_EXPLAINED
from plant.estimate.frf_estimation import periodic_response
from plant.estimate.lockin import estimate_response

F_HZ = np.geomspace(1.0, 75.0, 24)


def _stepped(tmp_path, axis, seed):
    rec = lm.stepped_sine(axis, F_HZ, amplitude_a=1.0, block_s=3.0, sample_rate_hz=1000.0, noise=0.01, seed=seed)
    return estimate_response(read_recording(sim.write_csv(rec, tmp_path / "rec.csv")))


def test_clipped_current_is_not_explained_by_a_linear_describing_function(tmp_path):
    diag = diagnose(stage_x(), _stepped(tmp_path, lm.LinearMotorAxis(current_limit_a=0.6), seed=1))
    assert diag.nonlinearity.distortion
    assert diag.nonlinearity.max_third_harmonic > 0.05
    assert diag.verdict == NOT_EXPLAINED
    assert "makes no harmonics" in diag.explanation or "distortion a linear model does not make" in diag.explanation
    assert "odd harmonics only" in diag.explanation
    assert "coulomb_friction" in diag.explanation


def test_the_same_axis_without_the_limit_is_explained(tmp_path):
    diag = diagnose(stage_x(), _stepped(tmp_path, lm.LinearMotorAxis(), seed=2))
    assert not diag.nonlinearity.distortion
    assert diag.verdict == EXPLAINED
    assert diag.final.values["mass_kg"] == pytest.approx(35.0, rel=0.03)


def _multisine(quadratic: float, seed: int) -> TimeRecording:
    rec = timesim.multisine_record(timesim.Axis(), np.random.default_rng(seed), fs_hz=1000.0, period_samples=2000,
                                   periods=6, lines=timesim.odd_multisine_lines(150), rms_a=1.0, noise_std=2e-5,
                                   quadratic=quadratic)
    return TimeRecording(rec.time_s, rec.current_a, rec.output[None, :], "velocity", ("v",), source="multisine")


def test_multisine_with_output_at_its_lines_not_excited_is_not_explained_by_a_linear_model():
    data = periodic_response(_multisine(quadratic=20.0, seed=3), transient_periods=1)
    diag = diagnose(stage_x(), data)
    assert diag.nonlinearity.distortion
    assert diag.verdict == NOT_EXPLAINED
    assert "lines not excited" in diag.explanation


def test_multisine_of_the_linear_axis_is_explained():
    data = periodic_response(_multisine(quadratic=0.0, seed=4), transient_periods=1)
    diag = diagnose(stage_x(), data)
    assert not diag.nonlinearity.distortion
    assert diag.verdict == EXPLAINED


def test_encoder_quantisation_harmonics_do_not_count_as_distortion(tmp_path):
    """A linear stage whose velocity is a 1 um encoder differenced at 1 kHz: the quantisation makes harmonics
    above the noise (2.3 % at 48 Hz, where the motion is a few um), within what a position error of half a
    step makes; they are no distortion a model must reproduce."""
    protocol = sim.Protocol(f_hz=tuple(np.geomspace(1.0, 75.0, 30)), block_s=3.0, sample_rate_hz=1000.0)
    rec = sim.simulate(sim.rigid_stage(34.0), sim.Drive(encoder_quantum_m=1e-6), protocol, noise=0.002, seed=1035)
    diag = diagnose(stage_x(), estimate_response(read_recording(sim.write_csv(rec, tmp_path / "rec.csv"))))
    assert diag.nonlinearity.detected and diag.nonlinearity.max_third_harmonic > diag.nonlinearity.threshold
    assert not diag.nonlinearity.distortion
    assert diag.verdict == EXPLAINED
