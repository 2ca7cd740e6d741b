"""The velocity loop as python-control models, for a notebook or for MATLAB: the plant P (current in, measured
velocity out), the PI controller C = Kp + Ki/s, the loop L = P C, the sensitivity S = 1/(1 + L) and the
complementary sensitivity T = L/(1 + L) (thesis Eq. 3.17-3.20), each a balanced state-space model.

The plant is ``Plant.to_state_space``: a series of state-space blocks, the drive chain's effects, the mechanics
and the sensor chain's effects, every block balanced by a diagonal similarity
(``plant.physics.effect_base.balanced``): multiplying the
transfer functions instead gives a Pade delay's product polynomials with coefficients near 1e28. A delay is
a Pade approximant of order ``pade_order`` (python-control's ``pade``, as ``Delay.to_tf`` builds it).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from design.loop.controller import PI
from plant.arguments import check_instance
from plant.bode import bode
from plant.physics.effect_base import PADE_ORDER, balanced
from plant.physics.models import Plant

if TYPE_CHECKING:
    import control
    from matplotlib.figure import Figure


class Margins(NamedTuple):
    """A loop's stability margins by name (unpacks as (gain margin dB, phase margin deg))."""

    gain_margin_db: float
    phase_margin_deg: float


@dataclass(frozen=True)
class LoopModels:
    """P, C, L, S, T of one plant (SI units: A, m/s) under the PI ``controller``."""

    payload_kg: float
    controller: PI
    pade_order: int
    P: control.StateSpace
    C: control.StateSpace
    L: control.StateSpace
    S: control.StateSpace
    T: control.StateSpace

    def margins(self) -> Margins:
        """python-control's margins of L, named: ``gain_margin_db`` (``control.margin`` gives the gain margin as a
        ratio in the same place: 20 log10 of it here) and ``phase_margin_deg``; inf when L never crosses."""
        import control

        gm, pm, *_ = control.stability_margins(self.L)
        return Margins(20 * np.log10(gm) if np.isfinite(gm) and gm > 0 else np.inf,
                       float(pm) if np.isfinite(pm) else np.inf)

    def plot(self, f_hz=None) -> Figure:
        """Bode magnitude of L, S and T and the phase of L (a ``matplotlib.figure.Figure``: no pyplot, so an
        interactive session's backend is left as it is; show it in a notebook by leaving it as the cell's
        value, or save it with ``savefig``)."""

        f = np.geomspace(0.1, 1000.0, 600) if f_hz is None else np.asarray(f_hz, float)
        s = 2j * np.pi * f
        fig = bode(2 * np.pi * f, [_response(getattr(self, name), s) for name in ("L", "S", "T")], ["L", "S", "T"],
                   phase_of=[True, False, False], title=f"{self.payload_kg:g} kg, {self.controller}",
                   figsize=(7.0, 5.0))
        mag, ph = fig.axes
        mag.axhline(0.0, color="0.6", lw=0.8)
        ph.axhline(-180.0, color="0.6", lw=0.8)
        ph.set_ylabel("phase of L (deg)")
        return fig


def _response(sys, s: np.ndarray) -> np.ndarray:
    return np.asarray(sys(s)).reshape(-1)


def plant_ss(plant: Plant, *, pade_order: int = PADE_ORDER) -> control.StateSpace:
    """The plant (one payload, linear effects) as balanced state-space blocks in series (module docstring):
    ``Plant.to_state_space``."""
    return plant.to_state_space(pade_order=pade_order)


def loop_models(plant: Plant, controller: PI, *, pade_order: int = PADE_ORDER) -> LoopModels:
    """``LoopModels`` of one plant under the PI ``controller``."""
    import control

    check_instance("plant", plant, Plant, "plant.stage_x(mass_kg=...) makes one")
    check_instance("controller", controller, PI, "design.loop.controller.PI(kp, ki) makes one")

    P = plant_ss(plant, pade_order=pade_order)
    C = control.ss(controller.tf())
    L = balanced(P * C)
    S = balanced(control.feedback(control.ss([], [], [], [[1.0]]), L))
    T = balanced(control.feedback(L, 1))
    return LoopModels(float(np.asarray(plant.mass_kg).reshape(())), controller, pade_order, P, C, L, S, T)
