"""The forces on the locomotion profile are computed on a time grid (``design.admittance.profile.MAX_STEP_S``, the
reach on ``design.admittance.feel.REACH_STEP_S``): each figure against the same computation on a grid eight or four
times finer, where it is hardest (the lightest and the heaviest payload, the stiffest neck on the lightest head, laws
from 100 Hz to 1 kHz and a continuous one)."""

from pathlib import Path

import numpy as np
import pytest

import design.admittance.feel as feel_module
from design.admittance.feel import REACH_STEP_S, mouse_feel
from design.admittance.model import PiLoops
from design.admittance.mouse import MouseModel
from design.admittance.profile import MAX_STEP_S, FeltForce
from design.admittance.rig import RigTiming
from design.loop.controller import PI
from design.spec.schema import load_spec
from design.synth.scenarios import Scenarios

SPEC = Path(__file__).resolve().parents[3] / "specs" / "stage_x_admittance.toml"
#: a 2 g head on a 200 N/m neck (50 Hz, the bundled mice's fastest) and a 10 g head on a 20 N/m neck
MICE = [MouseModel(0.002, 0.02, 200.0, 0.2, 1e4, 0.5), MouseModel(0.010, 0.035, 20.0, 1.0, 300.0, 0.5)]
M_V, B_V = 0.0419, 5.02


def _figures(spec, loops, timing, payload, max_step_s):
    felt = FeltForce(spec, Scenarios(np.array([payload])), MICE, loops=loops, timing=timing, max_step_s=max_step_s)
    return np.array([felt(M_V, B_V), felt.motor_peak_n(M_V, B_V)[0], felt.staircase_n(M_V, B_V)[0],
                     felt.velocity_shortfall()[0]])


@pytest.mark.parametrize("period_s", [0.01, 0.005, 0.001, None])
@pytest.mark.parametrize("payload", [5.0, 40.0])
def test_profile_forces_are_converged_at_the_profile_step(period_s, payload):
    # measured: neck and motor peaks and the staircase within 1.3e-4 of a 0.25 ms grid; the velocity shortfall at the
    # cruise's last sample within 0.7 % of itself (where the cruise ends moves by up to one step)
    spec = load_spec(SPEC).problem()
    loops, timing = PiLoops.of(spec, PI(199.9, 18.54)), RigTiming(period_s)
    coarse = _figures(spec, loops, timing, payload, MAX_STEP_S)
    fine = _figures(spec, loops, timing, payload, MAX_STEP_S / 8)
    np.testing.assert_allclose(coarse[:3], fine[:3], rtol=5e-4, atol=1e-9)
    assert coarse[3] == pytest.approx(fine[3], rel=1e-2)


@pytest.mark.parametrize("period_s", [0.01, 0.001, None])
def test_reach_acceleration_is_converged_at_its_own_step(period_s, monkeypatch):
    # the reach is the impulse response's first instants: within 0.15 % of a four times finer grid (the profile's
    # 2 ms step is up to 18 % off at 5 kg with a continuous law)
    spec = load_spec(SPEC).problem()
    loops, timing = PiLoops.of(spec, PI(199.9, 18.54)), RigTiming(period_s)
    scenarios = Scenarios(np.array([5.0]))

    def reach():
        return mouse_feel(spec, loops=loops, m_v=M_V, b_v=B_V, scenarios=scenarios, corners=MICE,
                          timing=timing).reachable_acceleration_m_per_s2

    coarse = reach()
    monkeypatch.setattr(feel_module, "REACH_STEP_S", REACH_STEP_S / 4)
    assert coarse == pytest.approx(reach(), rel=1.5e-3)
