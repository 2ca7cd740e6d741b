"""An effect that adds a force on the rails says so once, in both domains: the force a time simulation applies
(``rail_force_n``, the friction along the travel ``rail_friction_n`` against the motion, and the ground spring
``rail_stiffness`` the mechanics carries, relaxed at x = 0) is minus the
force its identification model says the motor must supply on top of the rigid body (``force_regressors``: the sum
of its parameters times the signals), at every position, velocity and motor force; and every effect with a force
model of that kind is one the simulation applies."""

import numpy as np
import pytest

from plant.physics.effect_base import ForceSignals
from plant.physics.effects import EFFECTS, make_effect

#: parameter values that make each force visible (defaults elsewhere)
VALUES = {"offset": {"force_n": 2.5},
          "force_ripple": {"sin1_n": 0.8, "cos1_n": -0.3, "sin2_n": 0.2, "cos2_n": 0.1, "pitch_m": 0.03},
          "force_constant_profile": {"slope": 0.04, "curvature": -0.02, "centre_m": 0.01, "half_span_m": 0.2},
          "cable_force": {"stiffness_n_per_m": 45.0, "pull_n": -1.5, "centre_m": 0.12, "drag_n_per_m": 30.0}}
RAIL = [name for name, cls in EFFECTS.items() if cls.rail_force]


def test_the_position_and_offset_forces_are_the_rail_forces():
    assert set(RAIL) == set(VALUES)


@pytest.mark.parametrize("name", RAIL)
def test_rail_force_is_minus_the_identified_force(name):
    effect = make_effect(name, **VALUES[name])
    x = np.linspace(-0.3, 0.3, 41)
    force = np.linspace(-40.0, 60.0, 41)
    v = np.linspace(-0.2, 0.3, 41)
    signals = ForceSignals(velocity_m_per_s=v, force_n=force, position_m=x)
    regressors = effect.force_regressors(signals)
    identified = sum(getattr(effect, field) * signal for field, signal in regressors.items())
    # a friction along the travel (``rail_friction_n``) opposes the motion with the Coulomb friction's law
    applied = np.array([effect.rail_force_n(xi, vi, fi) - effect.rail_friction_n(xi) * np.sign(vi)
                        for xi, vi, fi in zip(x, v, force)]) - effect.rail_stiffness() * x
    assert np.max(np.abs(applied + identified)) < 1e-12 * max(1.0, np.max(np.abs(identified)))
    assert np.max(np.abs(applied)) > 0.1


def test_a_force_constant_drift_is_minus_the_motor_force_times_the_time():
    """K(t) = K (1 + change u): its column is -F u with u from -1 to 1 over the samples it was configured on, and a
    simulation that cannot run it refuses it by name (``tests/plant/experiment/test_every_effect.py``)."""
    from plant.physics.effect_base import FitSamples

    t = np.linspace(3.0, 13.0, 101)
    force = np.linspace(-40.0, 60.0, 101)
    samples = FitSamples(np.ones(101), np.zeros(101), force, None, t)
    drift = make_effect("force_constant_drift", change=0.03).configured(samples, np.zeros(101))
    assert (drift.mid_s, drift.half_s) == (8.0, 5.0)
    column = drift.force_regressors(ForceSignals(np.ones(101), force, None, t))["change"]
    np.testing.assert_allclose(column, -force * np.linspace(-1.0, 1.0, 101), atol=1e-12)
