"""Diagnosis on recordings from the independent simulator (tests/reference/independent_sim.py: state space of
the physical networks, exact sine responses from rest; it imports nothing of the tool).

One recording per failure class that users met on recordings the tool had never seen: a flexible
payload recorded at the motor and at the payload, a delay together with a mode (a local minimum
before), Stage Y rails with an off-centre load, and a truth outside the library.
"""

import math

import independent_sim as sim
import numpy as np
import pytest

from plant import stage_x, stage_y
from plant.data.read_stepped_sine import read_recording
from plant.diagnose.diagnosis import diagnose
from plant.estimate.lockin import estimate_response
from plant.identify.fitting import fit_plant
from plant.physics.effects import Delay, Resonance

PROTOCOL = sim.Protocol(f_hz=tuple(np.geomspace(1.0, 75.0, 30)), block_s=3.0, sample_rate_hz=1000.0)


def measured(tmp_path, net, drive=sim.Drive(), *, noise=0.03, seed=0, protocol=PROTOCOL):
    path = sim.write_csv(sim.simulate(net, drive, protocol, noise=noise, seed=seed), tmp_path / "rec.csv")
    return estimate_response(read_recording(path))


def test_delay_and_mode_fit_globally_and_nest(tmp_path):
    # 1 ms delay and a 55 Hz mode: the exact effect pair reaches the noise, and no model of the
    # search fits worse than a model it contains (a nested model starts from its parent's optimum)
    net = sim.two_mass(9.0, 26.0, spring_n_per_m=9.0 * 26.0 / 35.0 * (2 * math.pi * 55) ** 2,
                       coupling_n_s_per_m=60.0)
    data = measured(tmp_path, net, sim.Drive(delay_s=1e-3))
    fit = fit_plant(stage_x() * Delay() * Resonance(), data)
    assert fit.reduced_chi2 < 2
    assert fit.values["delay.seconds"] == pytest.approx(1e-3, rel=0.05)
    diag = diagnose(stage_x(), data)
    assert diag.verdict == "explained" and set(diag.final_effects) == {"delay", "resonance"}
    assert diag.final.plant.modes_hz() == pytest.approx(net.mode_frequencies_hz(), rel=0.02)
    # a search, not a greedy path: every valid combination of up to three of the four chain effects and
    # the modes (resonance or payload_resonance, second_resonance only with one of them) is fitted:
    # 1 base + (4 + 2) + (6 + 4 * 2 + 2) + (4 + 6 * 2 + 4 * 2) = 47 models
    assert len(diag.models) == 47
    for effects, child in diag.models.items():
        for parent_effects, parent in diag.models.items():
            if set(parent_effects) < set(effects):
                assert child.chi2 <= parent.chi2 * (1 + 1e-6) + 1e-3, (effects, parent_effects)


def test_payload_sensed_mode_is_named_as_such(tmp_path):
    # velocity at the payload: no antiresonance, the phase falls by a further 180 deg
    net = sim.two_mass(14.0, 21.0, spring_n_per_m=14.0 * 21.0 / 35.0 * (2 * math.pi * 45) ** 2,
                       coupling_n_s_per_m=40.0, sensed="payload")
    diag = diagnose(stage_x(), measured(tmp_path, net, seed=1))
    assert diag.verdict == "explained" and diag.final_effects == ("payload_resonance",)
    assert diag.final.plant.modes_hz() == pytest.approx(net.mode_frequencies_hz(), rel=0.02)


def test_stage_y_off_centre_tilt_is_found_from_both_rails(tmp_path):
    # load 0.28 m from Y1 on the 0.8 m beam, tilt mode 32 Hz; the diagnosis is not told the position
    inertia = 1.5
    net = sim.stage_y_beam(40.0, inertia, rail1_m=0.28, tilt_stiffness_n_m_per_rad=inertia * (2 * math.pi * 32) ** 2)
    protocol = sim.Protocol(f_hz=PROTOCOL.f_hz, block_s=3.0, sample_rate_hz=1000.0, amplitude_a=1.75)
    diag = diagnose(stage_y(), measured(tmp_path, net, seed=2, protocol=protocol))
    assert diag.verdict == "explained" and diag.final_effects == ("tilt_coupling",)
    assert diag.final.values["tilt_coupling.frequency_hz"] == pytest.approx(32.0, rel=0.03)
    assert diag.final.values["tilt_coupling.offset_m"] == pytest.approx(0.28 - 0.4, abs=0.03)


def test_truth_outside_the_library_is_not_explained(tmp_path):
    # four masses, three modes in band: no model of up to three effects reproduces it
    net = sim.tuned_chain([8.0, 10.0, 9.0, 8.0], modes_hz=(24.0, 41.0, 63.0), damping_ratio=0.03)
    diag = diagnose(stage_x(), measured(tmp_path, net, noise=0.02, seed=3))
    assert diag.verdict == "not_explained"
    assert diag.explanation.startswith("not explained") and "no effect of the library reproduces" in diag.explanation
