"""The record of a two-motor co-design (``design.admittance.dual_codesign``): the structure's gains chosen for the
mouse and the checks of their velocity loops; its own module so that the admittance result can hold it."""

from __future__ import annotations

from dataclasses import dataclass

from design.loop.dual import Controller
from design.synth.dual import Worst
from design.synth.dual_worst import BetweenCheck


@dataclass(frozen=True)
class DualCodesignRecord:
    """The structure's gains chosen for the mouse, the force felt there and at the structure's own design (on the
    reduced set, N), and the velocity loops' checks at the chosen gains."""

    controller: Controller
    given: Controller
    force_n: float
    given_force_n: float
    #: candidates whose velocity loops met the requirements on the design plants (scored), of all candidates
    meeting_requirements: int
    candidates: int
    #: the chosen gains' velocity loops on the design plants, between their points, on the Monte Carlo draws
    design_plants: Worst
    between: BetweenCheck
    monte_carlo: Worst

    @property
    def verified(self) -> bool:
        return self.design_plants.feasible and self.between.holds and self.monte_carlo.feasible
