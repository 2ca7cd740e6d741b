"""Physics of the exoskeleton gantry: parameters, thesis models, effects, data, fitting.

The names below are imported on first use (PEP 562), so that importing a light submodule such as
``plant.host.interrupts`` or ``plant.errors`` does not load numpy and the models first: the command line
installs its signal handlers before anything heavy is imported.

May import: ``plant`` (its names load from the floors on first use).
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

_EXPORTS = {
    "plant.physics.effects": ("EFFECTS", "CoulombFriction", "CurrentLimit", "CurrentLoop", "Delay", "Effect",
                              "EncoderVelocity", "ForceConstantProfile", "ForceRipple", "Offset", "PayloadResonance",
                              "Resonance", "Sampling", "SecondResonance", "SensorFilter", "StribeckFriction",
                              "TiltCoupling", "make_effect"),
    "plant.errors": ("DataError", "EffectError", "GantryError", "GridError", "ParameterError", "SpecError"),
    "plant.physics.models": ("Plant", "build_plant", "corner_frequency_hz", "stage_x", "stage_y"),
    "plant.physics.parameters": ("THESIS", "Parameter"),
}
_WHERE = {name: module for module, names in _EXPORTS.items() for name in names}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name not in _WHERE:
        raise AttributeError(f"module 'plant' has no attribute {name!r}")
    value = getattr(importlib.import_module(_WHERE[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_WHERE])
