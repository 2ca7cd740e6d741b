"""Coulomb friction through stick-slip, against recordings of ``independent_stick_slip`` (SciPy
event-located integration, no code of the tool): the tool's simulator reproduces them sample by
sample, and ``diagnose`` finds the friction in them with the right value and a chi^2 of noise.

The drive force is K_t I = 20 N/A x 0.5 A = 10 N (thesis Stage X amplitude); F_c = 3 N slides
throughout, F_c = 9 N sticks for part of every half period, beyond the 4 F_c / pi = 11.5 N above
which the describing function predicts no motion at all.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
from independent_stick_slip import velocity, write_recording

from plant import CoulombFriction, stage_x
from plant.data.read_stepped_sine import read_recording
from plant.diagnose.diagnosis import diagnose
from plant.estimate.lockin import estimate_response
from plant.experiment.simulate import simulate_stepped_sine

TESTS = Path(__file__).resolve().parents[2]

MASS_KG, DAMPING_N_S_PER_M, KT, AMPLITUDE_A = 40.0, 440.0, 20.0, 0.5


def test_simulator_is_independent_of_the_tool():
    tree = ast.parse((TESTS / "reference" / "independent_stick_slip.py").read_text())
    imported = {a.name.split(".")[0] for node in ast.walk(tree) if isinstance(node, ast.Import) for a in node.names}
    imported |= {node.module.split(".")[0] for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                 and node.module}
    assert not imported & {"plant", "design"}


@pytest.mark.parametrize("friction_n", [3.0, 9.0])
@pytest.mark.parametrize("f_hz", [2.0, 30.0])
def test_the_simulator_follows_stick_slip_sample_by_sample(friction_n, f_hz):
    # reversals inside an internal step are resolved within it: a step-resolved switch left 2.5e-3 of the peak
    plant = stage_x(mass_kg=MASS_KG, damping_n_s_per_m=DAMPING_N_S_PER_M, excitation_current_a=AMPLITUDE_A) \
        * CoulombFriction(friction_n)
    block = simulate_stepped_sine(plant, f_hz=[f_hz], current_amplitude_a=AMPLITUDE_A, duration_s=2.0,
                                  noise_fraction=0.0).blocks[0]
    truth = velocity(block.time_s, mass_kg=MASS_KG, damping_n_s_per_m=DAMPING_N_S_PER_M, friction_n=friction_n,
                     force_n=KT * AMPLITUDE_A, f_hz=f_hz)
    assert np.max(np.abs(block.velocity_m_per_s[0] - truth)) < 1e-4 * np.max(np.abs(truth))


@pytest.mark.parametrize("friction_n, seed", [(3.0, 1), pytest.param(9.0, 2, marks=pytest.mark.slow)])
def test_diagnose_finds_the_friction_of_an_independent_recording(tmp_path, friction_n, seed):
    path = write_recording(tmp_path / "stick_slip.csv", f_hz=np.geomspace(2.0, 60.0, 8), mass_kg=MASS_KG,
                           damping_n_s_per_m=DAMPING_N_S_PER_M, friction_n=friction_n, current_a=AMPLITUDE_A,
                           noise_fraction=0.01, seed=seed)
    diag = diagnose(stage_x(), estimate_response(read_recording(path)))
    assert diag.added == ("coulomb_friction",) and diag.verdict == "explained", (diag.added, diag.verdict)
    final = diag.final
    # a model whose variances were inflated to hide its own error "explains" anything: chi^2 / dof of a correct
    # model with 13 degrees of freedom is above 0.2 with probability 0.998
    assert final.reduced_chi2 > 0.2, final.reduced_chi2
    for name, truth in (("coulomb_friction.force_n", friction_n), ("mass_kg", MASS_KG),
                        ("damping_n_s_per_m", DAMPING_N_S_PER_M)):
        assert abs(final.values[name] - truth) < 4 * final.stderr[name], (name, final.values[name], final.stderr[name])
