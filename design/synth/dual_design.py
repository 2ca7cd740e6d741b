"""The two-motor Stage Y designed and verified: every structure synthesised on the design grid
(``design.synth.dual``), checked between the grid's points over the whole box (``design.synth.dual_worst``: a
failing point found there joins the design plants and the structure is designed again, at most ``ROUNDS``
times), then on a Monte Carlo, and the fastest structure that holds everywhere recommended.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from design.loop.dual import offset_ramp_a_per_s
from design.parallel import thread_map
from design.synth.dual import (
    DualRequirements,
    StructureDesign,
    dual_scenarios,
    monte_carlo_scenarios,
    synthesise_structure,
    worst_cases,
)
from design.synth.dual_worst import BetweenCheck, between_check
from design.synth.monte_carlo import as_drawn
from plant.physics.dual_drive import DualDriveStageY

#: designs of one structure at most: the first on the grid, each next with the failing point found between
ROUNDS = 3


@dataclass(frozen=True)
class CheckedStructure:
    """A structure's design with its check between the grid's points (None when it has no gains) and the rounds
    it took."""

    design: StructureDesign
    between: BetweenCheck | None
    rounds: int
    #: how fast the motors' half-difference current ramps per m/s of a constant offset on rail Y1's velocity
    #: sensor (A/s per m/s; ``design.loop.dual.offset_ramp_a_per_s``), on the nominal plant with the carriage mid
    #: travel and the middle payload: 0 when the closed loop has no pole at s = 0
    offset_ramp_a_per_s: float = 0.0


def recommend(designs: list[CheckedStructure]) -> CheckedStructure | None:
    """The structure with the highest worst-case translation bandwidth among those that hold every requirement
    on the design plants, between them and on the Monte Carlo draws."""
    ok = [c for c in designs if c.design.controller is not None and c.design.design.feasible
          and c.between is not None and c.between.holds
          and (c.design.monte_carlo is None or c.design.monte_carlo.feasible)]
    return max(ok, key=lambda c: c.design.design.bandwidth_hz) if ok else None


@dataclass(frozen=True)
class DualDesign:
    """Every structure's robust design on the same plants, and the one recommended (``recommend``)."""

    checked: tuple[CheckedStructure, ...]
    recommended: str | None
    requirements: DualRequirements
    n_design_plants: int
    n_monte_carlo: int
    seconds: float

    @property
    def structures(self) -> tuple[StructureDesign, ...]:
        return tuple(c.design for c in self.checked)

    @property
    def status(self) -> str:
        """"optimal" when a structure holds every requirement on the design plants, between them and on the Monte
        Carlo draws, else "infeasible"."""
        return "optimal" if self.recommended is not None else "infeasible"

    @property
    def message(self) -> str:
        if self.recommended is None:
            return ("no structure's gains within the [controller] bounds hold the requirements on every design plant, "
                    "between them and on every Monte Carlo draw")
        best = next(c for c in self.checked if c.design.structure == self.recommended)
        binds = self.requirements.binding(best.between.worst)
        return (f"{self.recommended} recommended: worst-case translation bandwidth "
                f"{best.design.design.bandwidth_hz:.3g} Hz (at {best.design.design.worst_bandwidth_at}), every "
                f"requirement held on {self.n_design_plants} design plants, between them on "
                f"{best.between.coverage()} and on {self.n_monte_carlo} Monte Carlo draws"
                + (f"; it binds: {', '.join(binds)}" if binds else ""))


def design_dual(model: DualDriveStageY, *, positions_m, payloads_kg, stage_x_mass_kg: float,
                ranges: Mapping[str, tuple[float, float]], requirements: DualRequirements, structures,
                kp_box, ki_box, monte_carlo_samples: int, seed: int, progress=None) -> DualDesign:
    """Each structure designed on positions x payloads x corners of ``ranges``, checked between those points and
    on ``monte_carlo_samples`` draws, compared (``recommend``)."""
    start = time.perf_counter()
    masses = stage_x_mass_kg + np.asarray(payloads_kg, float)
    scenarios = dual_scenarios(model, positions_m, masses, ranges, stage_x_mass_kg)
    travel = (float(np.min(positions_m)), float(np.max(positions_m)))
    mass_range = (float(masses.min()), float(masses.max()))
    check = monte_carlo_scenarios(model, travel, mass_range, ranges, monte_carlo_samples, seed, stage_x_mass_kg)
    if progress is not None:
        progress(f"designing {', '.join(structures)}, each then checked between the grid's points and on "
                 f"{len(check)} Monte Carlo draws")
    scenarios.frd                                   # computed once, before the threads share it
    tick = None if progress is None else (lambda: progress(f"designing and checking {', '.join(structures)}"))

    def designed_and_checked(name: str) -> CheckedStructure:
        """The structure's design, its check between the grid's points (again with a failing point added), then
        its Monte Carlo check."""
        plants = scenarios
        for rounds in range(1, ROUNDS + 1):
            d = synthesise_structure(name, plants, requirements, kp_box=kp_box, ki_box=ki_box, progress=tick)
            if d.controller is None:
                return CheckedStructure(d, None, rounds)
            between = between_check(d.controller, model, travel_m=travel, carriage_masses_kg=mass_range,
                                    ranges=ranges, req=requirements, stage_x_mass_kg=stage_x_mass_kg)
            if between.holds or plants.contains(between.worst_point):
                break
            plants = plants.with_row(between.worst_point)
        nominal = model.with_values(carriage_position_m=sum(travel) / 2, carriage_mass_kg=sum(mass_range) / 2)
        drawn = as_drawn(worst_cases([d.controller], check, requirements)[0])
        return CheckedStructure(replace(d, monte_carlo=drawn), between, rounds,
                                offset_ramp_a_per_s(nominal, d.controller))

    designs = thread_map(designed_and_checked, structures)
    best = recommend(designs)
    return DualDesign(tuple(designs), None if best is None else best.design.structure, requirements, len(scenarios),
                      len(check), time.perf_counter() - start)
