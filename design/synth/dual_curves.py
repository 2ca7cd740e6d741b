"""What the two-motor Stage Y report draws of each structure, computed here so the view only formats: its
design over carriage position x payload (worst over the uncertainty corners, ``design.synth.dual.design_map``)
and the rails' velocities after a translation step at the travel's ends and middle (python-control,
``design.loop.dual.translation_step``), with the yaw error the step leaves."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from design.loop.dual import translation_step
from design.synth.dual import DesignMap, design_map

#: the map's grid: carriage positions and payloads
MAP_POSITIONS, MAP_PAYLOADS = 17, 11
#: the step response: duration (s), samples
STEP_S, STEP_SAMPLES = 0.25, 2501


def rail_gap_m(y: np.ndarray, t: np.ndarray) -> np.ndarray:
    """y2 - y1 (m per m/s of command) over time: the rails' velocity difference integrated (trapezoids)."""
    d = y[1] - y[0]
    return np.concatenate([[0.0], np.cumsum((d[1:] + d[:-1]) / 2) * (t[1] - t[0])])


@dataclass(frozen=True)
class StructureCurves:
    """One structure's map and translation steps (``module docstring``)."""

    structure: str
    design_map: DesignMap
    time_s: np.ndarray
    #: (carriage position m, rail velocities per command (2, n_t)) at the travel's ends and middle
    steps: tuple[tuple[float, np.ndarray], ...]
    payload_kg: float

    @property
    def largest_rail_gap_m(self) -> float:
        """The largest y2 - y1 over the steps (m per m/s of command)."""
        return max(float(np.abs(rail_gap_m(y, self.time_s)).max()) for _, y in self.steps)


def structure_curves(dual, spec) -> tuple[StructureCurves, ...]:
    """``StructureCurves`` of every structure of ``dual`` (a ``design.synth.dual_design.DualDesign``) that has gains,
    on ``spec``'s two-motor model, travel and payload range."""
    d, payload = spec.dual_drive, spec.plant.payload_kg
    ranges = {k: (v.min, v.max) for k, v in d.uncertainty.items()}
    model = spec.dual_model()
    positions = np.linspace(d.carriage_position_m.min, d.carriage_position_m.max, MAP_POSITIONS)
    payloads = np.linspace(payload.min, payload.max, MAP_PAYLOADS)
    t = np.linspace(0.0, STEP_S, STEP_SAMPLES)
    heavy = model.with_values(carriage_mass_kg=d.stage_x_mass_kg + payload.max)
    places = (d.carriage_position_m.min, (d.carriage_position_m.min + d.carriage_position_m.max) / 2,
              d.carriage_position_m.max)
    out = []
    for s in dual.structures:
        if s.controller is None:
            continue
        m = design_map(s.controller, model, positions, payloads, d.stage_x_mass_kg, ranges, dual.requirements)
        steps = tuple((p, translation_step(heavy.with_values(carriage_position_m=p), s.controller, t)) for p in places)
        out.append(StructureCurves(s.structure, m, t, steps, float(payload.max)))
    return tuple(out)
