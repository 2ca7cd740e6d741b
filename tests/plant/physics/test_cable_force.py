"""The cable carrier's spring (``cable_force``) in the frequency domain against closed forms: thesis Eq. 3.15
(Stage X) and Eq. 3.16 (Stage Y, one loop) with a spring k to the ground, K_t s / (m_e s^2 + b_e s + k); the
bodies' own modes unchanged by it; a python-control model of the same; the rest position from pull and stiffness.
The time domain (the continuous run and the mouse run) is checked against independent simulators in
``tests/plant/experiment/test_every_effect.py``, ``tests/design/admittance/test_mouse_run.py`` and the diagnosis
in ``tests/plant/diagnose/test_motor_forces.py``."""

import numpy as np
import pytest

from plant.errors import EffectError
from plant.physics.effects import make_effect
from plant.physics.models import stage_x, stage_y

W = 2 * np.pi * np.geomspace(0.01, 100.0, 50)
K = 80.0


@pytest.mark.parametrize("stage", ["x", "y"])
def test_the_spring_is_a_stiffness_to_the_ground_beside_the_rail_damping(stage):
    plant = (stage_x if stage == "x" else stage_y)(mass_kg=25.0).with_effects(
        make_effect("cable_force", stiffness_n_per_m=K, pull_n=2.0, centre_m=0.1))
    m = 25.0 if stage == "x" else 2 * 25.0 * plant.load_position_m / plant.motor_length_m
    b = plant.damping_n_s_per_m * (1 if stage == "x" else 2)
    s = 1j * W
    closed = plant.force_constant_n_per_a * s / (m * s**2 + b * s + K)
    assert np.max(np.abs(plant.frd(W) / closed - 1)) < 1e-12
    tf = plant.to_control()
    assert np.max(np.abs(tf(s) / closed - 1)) < 1e-9
    # near the spring's corner k / b (0.03 Hz) the velocity falls towards DC, where the free stage's does not
    free = (stage_x if stage == "x" else stage_y)(mass_kg=25.0)
    assert abs(plant.frd(W[:1])[0]) < 0.7 * abs(free.frd(W[:1])[0])


def test_the_bodies_modes_are_their_own_and_the_rest_position_follows_from_the_pull():
    mode = make_effect("resonance", frequency_hz=60.0, antiresonance_hz=40.0)
    cable = make_effect("cable_force", stiffness_n_per_m=K, pull_n=-4.0, centre_m=0.2)
    with_cable, without = (stage_x(mass_kg=25.0).with_effects(*e) for e in ((mode, cable), (mode,)))
    assert with_cable.modes_hz() == pytest.approx(without.modes_hz(), rel=1e-12)
    assert cable.rest_m == pytest.approx(0.2 + 4.0 / K)
    assert cable.force(cable.rest_m) == pytest.approx(0.0, abs=1e-12)


def test_a_cable_is_neither_an_offset_beside_it_nor_on_the_tilting_beam():
    for other in ("offset", "tilt_coupling"):
        with pytest.raises(EffectError, match="cable_force"):
            stage_y().with_effects(make_effect("cable_force"), make_effect(other))


def test_the_drag_is_a_friction_that_grows_along_the_travel():
    """The drag d (x - centre) is a friction magnitude where the carriage is, (x - centre) sign(v) per unit of d in the
    inverse model, and no rail force: it only opposes the motion (the simulations' friction law applies it)."""
    from plant.physics.effect_base import ForceSignals

    cable = make_effect("cable_force", stiffness_n_per_m=K, pull_n=1.0, centre_m=0.1, drag_n_per_m=50.0)
    assert cable.rail_friction_n(0.3) == pytest.approx(50.0 * 0.2)
    assert cable.rail_force_n(0.3, 1.0, 0.0) == cable.rail_force_n(0.3, -1.0, 0.0) == pytest.approx(-(1.0 - K * 0.1))
    x, v = np.array([0.0, 0.2, 0.3]), np.array([1.0, -2.0, 0.5])
    cols = cable.force_regressors(ForceSignals(v, np.zeros(3), x))
    np.testing.assert_allclose(cols["drag_n_per_m"], (x - 0.1) * np.sign(v))
    with pytest.raises(Exception, match="drag_n_per_m"):
        make_effect("cable_force", drag_n_per_m=float("nan"))
