"""Every effect of the library through both time simulators (the stepped-sine blocks and the continuous run): an
effect that is linear and time-invariant must give the plant's own frequency response (``Plant.frd``), read off
the simulated steady state by a least-squares lock-in written here; any other effect must change what is simulated
(it is not dropped) or be refused in an error that names it (the mouse run's refusals are tested in
``tests/design/admittance/test_mouse_run.py``)."""

from dataclasses import replace

import numpy as np
import pytest

from plant import stage_x, stage_y
from plant.errors import EffectError
from plant.experiment.simulate import simulate_stepped_sine
from plant.experiment.simulate_time import simulate_time_domain, stepped_sine
from plant.physics.effects import EFFECTS, make_effect

F_HZ = (5.0, 40.0, 120.0)
#: effects with the parameters that make them act (the defaults of some are zero), and what they need beside them
SETTINGS = {
    "offset": {"force_n": 3.0}, "force_ripple": {"sin1_n": 4.0, "cos2_n": 2.0},
    "force_constant_profile": {"slope": 0.3, "curvature": 0.2}, "stribeck_friction": {"excess_n": 4.0},
    "current_limit": {"limit_n": 12.0}, "cable_force": {"stiffness_n_per_m": 2000.0},
    "rail_scale": {"y2_scale": 1.05}, "motor_imbalance": {"fraction": 0.2},
}
NEEDS = {"second_resonance": ("resonance",), "stribeck_friction": ("coulomb_friction",),
         "motor_imbalance": ("tilt_coupling",)}
#: Stage Y's effects (both rails recorded, each compared with its own response)
STAGE_Y = ("tilt_coupling", "rail_scale", "motor_imbalance", "yaw_coupling")
#: linear, time-invariant effects: their simulated response is their frequency response
LTI = ("delay", "current_loop", "sampling", "sensor_filter", "encoder_velocity", "resonance", "payload_resonance",
       "second_resonance", "tilt_coupling", "cable_force", "rail_scale", "motor_imbalance")
#: how far each engine's steady state may sit from Plant.frd: the stepped blocks are exact but for the hold's images
#: (module doc of plant.experiment.simulate: ~2 (f / rate)^2); the continuous run's first-order hold of the current
#: at its internal rate adds ~ (w h)^2 / 12, 3e-4 at 120 Hz
TOLERANCE = {"stepped": 1e-3, "continuous": 1e-3}


def _plant(name: str):
    base = stage_y(mass_kg=20.0, load_position_m=0.3) if name in STAGE_Y else stage_x(mass_kg=20.0)
    effects = [make_effect(n) for n in NEEDS.get(name, ())] + [make_effect(name, **SETTINGS.get(name, {}))]
    return replace(base, effects=tuple(effects), excitation_current_a=1.0)


def _lock_in(t, y, u, f_hz, settled_s):
    """Complex ratio of the output's to the input's component at f (least squares over t >= settled_s)."""
    k = t >= settled_s
    X = np.stack([np.sin(2 * np.pi * f_hz * t[k]), np.cos(2 * np.pi * f_hz * t[k])], axis=1)
    cy, cu = (np.linalg.lstsq(X, v[k], rcond=None)[0] for v in (y, u))
    return complex(cy[0], cy[1]) / complex(cu[0], cu[1])


def _responses(engine: str, plant) -> np.ndarray:
    """(n_outputs, n_f): each engine's steady-state response at ``F_HZ`` (m/s per A)."""
    out = []
    for f in F_HZ:
        if engine == "stepped":
            rec = simulate_stepped_sine(plant, f_hz=[f], current_amplitude_a=1.0, duration_s=3.0, noise_fraction=0.0)
            b = rec.blocks[0]
            out.append([_lock_in(b.time_s, v, b.current_a, f, 1.0) for v in b.velocity_m_per_s])
        else:
            rec = simulate_time_domain(plant, stepped_sine([f], amplitude_a=1.0, block_s=3.0), sample_rate_hz=4000.0,
                                       output="velocity")
            out.append([_lock_in(rec.time_s, v, rec.current_a, f, 1.0) for v in rec.output])
    return np.array(out).T


def _raw(engine: str, plant) -> np.ndarray:
    """The simulated velocities of one 5 Hz run (m/s)."""
    if engine == "stepped":
        rec = simulate_stepped_sine(plant, f_hz=[5.0], current_amplitude_a=1.0, duration_s=1.0, noise_fraction=0.0)
        return rec.blocks[0].velocity_m_per_s
    return simulate_time_domain(plant, stepped_sine([5.0], amplitude_a=1.0, block_s=1.0), sample_rate_hz=4000.0,
                                output="velocity").output


@pytest.mark.parametrize("engine", ["stepped", "continuous"])
@pytest.mark.parametrize("name", list(EFFECTS))
def test_every_effect_is_simulated_as_its_response_says_or_refused_by_name(engine, name):
    plant = _plant(name)
    try:
        got = _responses(engine, plant)
    except EffectError as err:
        assert any(n in str(err) for n in (name, *NEEDS.get(name, ()))), str(err)    # it, or what it needs
        return
    if name in LTI:
        w = 2 * np.pi * np.array(F_HZ)
        want = plant.frd_outputs(w) if plant.stage == "y" else np.atleast_2d(plant.frd(w))
        assert np.max(np.abs(got - want) / np.abs(want)) < TOLERANCE[engine]
    else:      # simulated, so it must act: the same run without it differs
        without = replace(plant, effects=tuple(e for e in plant.effects if e.name != name))
        a, b = _raw(engine, plant), _raw(engine, without)
        assert np.max(np.abs(a - b)) > 1e-6 * np.max(np.abs(a))
