"""The library of physical effects the thesis model leaves out.

Where an effect sits decides how it composes (``plant.physics.effect_base``):

* drive and sensor chain, series factors (``plant.physics.chain``): ``delay``, ``current_loop``,
  ``sampling``, ``sensor_filter``, ``encoder_velocity``;
* mechanics, parts of the lumped network (``plant.physics.mechanics``): ``resonance`` (two-mass,
  recorded at the motor), ``payload_resonance`` (recorded at the payload), ``second_resonance``
  (three-mass chain), ``tilt_coupling`` (Y rails, off-centre load), ``coulomb_friction``,
  ``stribeck_friction`` (its rise towards rest, time-domain data only), ``offset`` (a constant force,
  time-domain data only); position-dependent motor forces
  (``plant.physics.motor_forces``, time-domain data with the position only): ``force_ripple``,
  ``force_constant_profile``; the drive's ``current_limit`` (time-domain data, and its describing function
  in a frequency response at the plant's excitation current); a cable carrier's spring, ``cable_force``
  (``plant.physics.cable_force``, time-domain data with the position only); a force constant or a damping
  drifting over a time recording, ``force_constant_drift`` and ``damping_drift`` (``plant.physics.drifts``);
* what makes Stage Y's rails differ besides the tilt (``plant.physics.rails``): ``rail_scale`` (one rail read to
  another scale), ``motor_imbalance`` (the two motors' force constants apart), ``yaw_coupling`` (the beam's yaw in
  a time recording's force balance).

Adding an effect means one class in a module of ``plant.physics`` (a chain factor in ``chain``, a part of the
network in ``mechanics``, a force in a module of its own) and its entry in ``EFFECTS`` here. Parameter names
and units follow ``docs/formats.md``: an effect parameter is written ``effect.parameter``.
"""

from __future__ import annotations

import numpy as np

from plant.arguments import check_optional_text
from plant.errors import EffectError, ParameterError
from plant.physics.cable_force import CableForce
from plant.physics.chain import CurrentLoop, Delay, EncoderVelocity, Sampling, SensorFilter
from plant.physics.drifts import DampingDrift, ForceConstantDrift
from plant.physics.effect_base import PADE_ORDER, ChainEffect, Effect, MechanicalEffect
from plant.physics.mechanics import (
    CoulombFriction,
    ModeEffect,
    Offset,
    PayloadResonance,
    Resonance,
    SecondResonance,
    StribeckFriction,
    TiltCoupling,
)
from plant.physics.motor_forces import CurrentLimit, ForceConstantProfile, ForceRipple
from plant.physics.rails import MotorImbalance, RailScale, YawCoupling

EFFECTS: dict[str, type[Effect]] = {
    cls.name: cls for cls in (Delay, CurrentLoop, Sampling, SensorFilter, EncoderVelocity, Resonance,
                              PayloadResonance, SecondResonance, CoulombFriction, StribeckFriction, Offset,
                              TiltCoupling, RailScale, MotorImbalance, ForceRipple, ForceConstantProfile, CurrentLimit,
                              CableForce, ForceConstantDrift, DampingDrift, YawCoupling)
}


def make_effect(name: str, **params: float) -> Effect:
    """Build an effect by its name (``delay``, ``current_loop``, ...) with keyword parameters."""
    try:
        cls = EFFECTS[check_optional_text("name", name)]
    except KeyError:
        raise EffectError(f"unknown effect {name!r}; known effects: {', '.join(EFFECTS)}") from None
    unknown = set(params) - set(cls.bounds)
    if unknown:
        raise EffectError(f"effect {name} has no parameter {sorted(unknown)[0]!r}; known: {', '.join(cls.bounds)}")
    try:
        return cls(**{k: float(v) if isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool)
                      else v for k, v in params.items()})
    except (TypeError, ValueError) as exc:
        if isinstance(exc, ParameterError):
            raise
        raise ParameterError(f"effect {name}: {exc}") from None


__all__ = [
    "EFFECTS", "PADE_ORDER", "CableForce", "ChainEffect", "CoulombFriction", "CurrentLimit", "CurrentLoop",
    "DampingDrift", "Delay",
    "Effect",
    "EncoderVelocity", "ForceConstantDrift", "ForceConstantProfile", "ForceRipple",
    "MechanicalEffect", "ModeEffect", "MotorImbalance", "Offset", "PayloadResonance", "RailScale", "Resonance",
    "Sampling", "SecondResonance",
    "SensorFilter", "StribeckFriction",
    "TiltCoupling", "make_effect",
]
