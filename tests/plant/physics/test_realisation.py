"""The plant's time-domain realisation against its own frequency response, effect by effect of the library: what
every simulator and sampled-data check is built from reproduces ``Plant.frd_outputs`` (the delay and the drive's
sampling, which a simulator applies exactly to the command, multiplied back in by their exact factors)."""

import numpy as np
import pytest

from plant.errors import ParameterError
from plant.physics.chain import Delay
from plant.physics.effects import EFFECTS, make_effect
from plant.physics.models import stage_x, stage_y
from plant.physics.realisation import realise

W = np.geomspace(2 * np.pi * 0.1, 2 * np.pi * 2000.0, 60)
#: effects whose frequency response the realisation does not change (forces in the time domain only) or that no
#: rational model realises exactly (the encoder's differencing: ``ChainEffect.state_space`` approximates it)
NOT_RATIONAL = {"encoder_velocity", "coulomb_friction", "stribeck_friction", "current_limit", "yaw_coupling"}


def response(sys_A, sys_B, rows, w):
    """rows (jw - A)^-1 B, (n_rows, n_inputs, n_w)."""
    n = sys_A.shape[0]
    x = np.linalg.solve(1j * w[:, None, None] * np.eye(n) - sys_A, np.broadcast_to(sys_B, (w.size, *sys_B.shape)))
    return np.einsum("rn,wni->riw", rows, x)


def exact_factors(plant, w):
    out = np.ones(w.size, complex)
    for e in plant.effects:
        if e.realised_as == "applied":
            out = out * e.frd(w)
    return out


CASES = [(stage, name) for stage in "xy" for name in EFFECTS if name not in NOT_RATIONAL
         and (stage == "y" or "x" in EFFECTS[name].stages)]


@pytest.mark.parametrize("stage,name", CASES, ids=[f"{s}-{n}" for s, n in CASES])
def test_realisation_reproduces_the_plants_frequency_response(stage, name):
    base = (stage_x if stage == "x" else stage_y)(mass_kg=12.0)
    extra = {"current_loop": (), "second_resonance": (make_effect("resonance"),),
             "motor_imbalance": (make_effect("tilt_coupling", offset_m=0.05),)}.get(
        name, (make_effect("current_loop", bandwidth_hz=800.0),))
    acting = {"rail_scale": {"y2_scale": 1.07}, "motor_imbalance": {"fraction": 0.15}}.get(name, {})
    plant = base.with_effects(*extra, make_effect(name, **acting))
    r = realise(plant).one()
    got = response(r.A, r.B[:, :1], r.outputs, W)[:, 0] * exact_factors(plant, W)
    want = plant.frd_outputs(W)
    assert np.max(np.abs(got / want - 1)) < 1e-9


def test_the_rail_force_input_is_the_mechanics_alone_and_the_current_the_drive_chain():
    """Per newton on the rails the velocity is the mechanics' (no drive chain, no force constant); the motor
    current per command is the drive chain's factor."""
    plant = stage_x(mass_kg=20.0).with_effects(make_effect("current_loop", bandwidth_hz=500.0),
                                                  make_effect("resonance"), make_effect("sensor_filter"))
    r = realise(plant).one()
    w = W
    per_force = response(r.A, r.B[:, 1:], r.velocity, w)[0, 0]
    assert np.max(np.abs(per_force / plant.mechanics().velocity_per_force(1j * w) - 1)) < 1e-9
    current = response(r.A, r.B[:, :1], r.current[None, :-1], w)[0, 0] + r.current[-1]
    assert np.max(np.abs(current / plant.chain_response(1j * w, "drive") - 1)) < 1e-9


def test_a_batch_is_its_plants_one_by_one_and_a_pade_order_brings_the_delay_in():
    payloads = np.array([15.0, 30.0, 50.0])
    plants = stage_x(mass_kg=payloads[:, None]).with_effects(make_effect("delay", seconds=5e-4),
                                                        make_effect("payload_resonance"))
    batch = realise(plants, 3, pade_order=8)
    assert isinstance(plants.effect("delay"), Delay)
    w = W[W < 2 * np.pi * 300]          # where the order-8 Pade approximant of 0.5 ms is exact to double precision
    for j, m in enumerate(payloads):
        one = stage_x(mass_kg=float(m)).with_effects(*plants.effects)
        got = response(batch.A[j], batch.B[j, :, :1], batch.outputs[j], w)[:, 0]
        assert np.max(np.abs(got / one.frd_outputs(w) - 1)) < 1e-9


def test_the_tilt_model_is_realised_for_one_plant():
    plants = stage_y(mass_kg=np.array([[15.0], [20.0]])).with_effects(make_effect("tilt_coupling"))
    with pytest.raises(ParameterError, match="one plant"):
        realise(plants, 2)


def test_every_effect_declares_what_the_realisation_holds_of_it():
    """``realised_as`` is what the simulators (the mouse run's list of effects it simulates among them) read: each
    effect declares it, and each that claims its linear model is held exactly is one the response test above
    holds to ``Plant.frd``; the approximate and the nonlinear ones are not."""
    from plant.physics.effect_base import REALISED_AS

    for name, cls in EFFECTS.items():
        assert cls.realised_as in REALISED_AS, name
        if cls.realised_as in ("state_space", "applied", "beam"):
            assert name not in NOT_RATIONAL and any(name == n for _, n in CASES), name
        if cls.realised_as in ("approximate", "drive_limit"):
            assert name in NOT_RATIONAL, name
