"""Whether a fitted stage is physically plausible: its base parameters (mass, rail damping, force constant) against
the plant the diagnosis was given (the spec's, or the thesis's Stage X/Y: 35 kg, 440 N·s/m, 20 N/A).

A fitted base parameter more than ``FACTOR`` from its declared value is implausible: an order of magnitude, far
beyond what the thesis's own spread allows (payloads of 5-40 kg on the 35 kg nominal, Figure 4.31; ball-bearing
damping of 330-550 N·s/m, section 3.4), so a model that needs it describes another machine (a 0.5 kg, 4.8 N·s/m
"stage" fitted where the truth is 30 kg and 440 N·s/m). A diagnosis keeps such a model when it fits best but says
so in its verdict, never presenting it as the stage without the warning.
"""

from __future__ import annotations

from plant.identify.fit_result import PlantFit
from plant.physics.models import Plant
from plant.story import unit_text

#: a fitted base parameter beyond this factor of its declared value (either way) is implausible
FACTOR = 10.0
#: the base parameters judged
BASE = ("mass_kg", "damping_n_s_per_m", "force_constant_n_per_a")


def implausible(fit: PlantFit, declared: Plant) -> tuple[str, ...]:
    """The base parameters ``fit`` found implausible against ``declared``, one phrase each with the figures
    ("mass_kg = 0.5 kg, 70x below the declared 35 kg"); () when all are plausible or not fitted."""
    given = declared.parameters()
    out = []
    for name in BASE:
        if name not in fit.free or name not in given:
            continue
        value, ref, unit = fit.values[name], float(given[name].value), unit_text(given[name].unit)
        if ref <= 0:
            continue
        if value * FACTOR < ref:
            ratio = f"{ref / max(value, 1e-300):.3g}x below"
        elif value > ref * FACTOR:
            ratio = f"{value / ref:.3g}x above"
        else:
            continue
        out.append(f"{name} = {value:.3g} {unit}, {ratio} the declared {ref:g} {unit}")
    return tuple(out)


def warning(phrases: tuple[str, ...]) -> str:
    """The verdict's clause for implausible parameters ("" when there are none)."""
    if not phrases:
        return ""
    return (f"; but the model needs an implausible stage ({'; '.join(phrases)}: more than {FACTOR:g}x from the "
            "declared value), so it describes another machine rather than this one")
