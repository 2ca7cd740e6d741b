"""Velocity PI loop (thesis Eq. 3.17-3.20) and admittance control (Eq. 3.21-3.23, Figure 3.22).

Frequency-response functions take a grid ``w_rad_s`` and broadcast gains and plant batches:
``(..., n_freq)`` in, ``(..., n_freq)`` out; the controller is a ``design.loop.controller.PI``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from design.loop.controller import PI
from plant.errors import ParameterError
from plant.grid import check_grid
from plant.physics.models import Plant

if TYPE_CHECKING:
    import control


def plant_frd(plant, w_rad_s) -> np.ndarray:
    """Response of a ``Plant`` or an already evaluated/measured response array on ``w_rad_s``."""
    w = check_grid(w_rad_s)
    if isinstance(plant, Plant):
        return plant.frd(w)
    resp = np.asarray(plant, dtype=complex)
    if resp.shape[-1] != w.size:
        raise ParameterError(f"plant response has {resp.shape[-1]} frequencies but the grid has {w.size}")
    return resp


def open_loop_frd(plant, w_rad_s, controller: PI) -> np.ndarray:
    """Loop gain L = P(jw) C(jw) (thesis Eq. 3.17/3.18) for a model or measured plant."""
    return plant_frd(plant, w_rad_s) * controller.frd(w_rad_s)


def closed_loop_frd(loop) -> np.ndarray:
    """Complementary sensitivity T = L/(1 + L) (thesis Eq. 3.19/3.20 for the thesis plants)."""
    L = np.asarray(loop)
    return L / (1 + L)


def open_loop_tf(plant: Plant, controller: PI) -> control.TransferFunction:
    """Rational loop P(s) C(s) (Pade for delays)."""
    return plant.to_control() * controller.tf()


def closed_loop_tf(plant: Plant, controller: PI) -> control.TransferFunction:
    """Rational closed velocity loop; for the thesis plants it equals Eq. 3.19 / 3.20."""
    import control

    return control.feedback(open_loop_tf(plant, controller), 1)
