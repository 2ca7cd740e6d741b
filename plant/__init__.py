"""Physics of the exoskeleton gantry: parameters, thesis models, effects, data, fitting."""

from plant.effects import (
    EFFECTS,
    CoulombFriction,
    CurrentLoop,
    Delay,
    Effect,
    EncoderVelocity,
    PayloadResonance,
    Resonance,
    Sampling,
    SecondResonance,
    SensorFilter,
    TiltCoupling,
    make_effect,
)
from plant.errors import (
    DataError,
    EffectError,
    GantryError,
    GridError,
    ParameterError,
    SpecError,
)
from plant.models import Plant, build_plant, corner_frequency_hz, stage_x, stage_y
from plant.parameters import THESIS, Parameter

__version__ = "0.1.0"

__all__ = [
    "EFFECTS", "THESIS", "CoulombFriction", "CurrentLoop", "DataError", "Delay", "Effect", "EffectError",
    "EncoderVelocity", "GantryError", "GridError", "Parameter", "ParameterError", "PayloadResonance", "Plant",
    "Resonance", "Sampling", "SecondResonance", "SensorFilter", "SpecError", "TiltCoupling", "build_plant",
    "corner_frequency_hz", "make_effect", "stage_x", "stage_y",
]
