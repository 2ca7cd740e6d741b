"""Velocity PI loop (thesis Eq. 3.17-3.20) and admittance control (Eq. 3.21-3.23, Figure 3.22).

Frequency-response functions take a grid ``w_rad_s`` and broadcast gains and plant batches:
``(..., n_freq)`` in, ``(..., n_freq)`` out. Gains: ``kp`` in A per (m/s), ``ki`` in A per m.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from plant.errors import ParameterError
from plant.grid import check_grid
from plant.physics.models import Plant
from plant.physics.parameters import check_positive

if TYPE_CHECKING:
    import control


def pi_frd(w_rad_s, kp, ki) -> np.ndarray:
    """PI controller Kp + Ki/(jw)."""
    return np.asarray(kp)[..., None] + np.asarray(ki)[..., None] / (1j * np.asarray(w_rad_s))


def pi_tf(kp: float, ki: float) -> control.TransferFunction:
    """PI controller (Kp s + Ki)/s as a python-control transfer function."""
    import control

    return control.tf([kp, ki], [1.0, 0.0])


def plant_frd(plant, w_rad_s) -> np.ndarray:
    """Response of a ``Plant`` or an already evaluated/measured response array on ``w_rad_s``."""
    w = check_grid(w_rad_s)
    if isinstance(plant, Plant):
        return plant.frd(w)
    resp = np.asarray(plant, dtype=complex)
    if resp.shape[-1] != w.size:
        raise ParameterError(f"plant response has {resp.shape[-1]} frequencies but the grid has {w.size}")
    return resp


def open_loop_frd(plant, w_rad_s, kp, ki) -> np.ndarray:
    """Loop gain L = P(jw) (Kp + Ki/jw) (thesis Eq. 3.17/3.18) for a model or measured plant."""
    return plant_frd(plant, w_rad_s) * pi_frd(w_rad_s, kp, ki)


def closed_loop_frd(loop) -> np.ndarray:
    """Complementary sensitivity T = L/(1 + L) (thesis Eq. 3.19/3.20 for the thesis plants)."""
    L = np.asarray(loop)
    return L / (1 + L)


def balanced(sys) -> control.StateSpace:
    """A state-space realisation of ``sys`` (transfer function or state space) under the diagonal similarity
    that balances its state matrix (``scipy.linalg.matrix_balance``): the companion form of a high-order
    loop (Pade delay, resonances, filters) can have entries up to 1e24 and a condition number of 1e67, which
    a matrix exponential (``c2d``, a step response) cannot take."""
    import control
    from scipy.linalg import matrix_balance

    s = sys if isinstance(sys, control.StateSpace) else control.ss(sys)
    if s.nstates == 0:
        return s
    A, B, C, D = (np.asarray(x, float) for x in (s.A, s.B, s.C, s.D))
    _, (scale, _) = matrix_balance(A, permute=False, separate=True)
    return control.ss(A / scale[:, None] * scale[None, :], B / scale[:, None], C * scale[None, :], D, s.dt,
                      inputs=s.input_labels, outputs=s.output_labels)


def open_loop_tf(plant: Plant, kp: float, ki: float) -> control.TransferFunction:
    """Rational loop P(s)(Kp + Ki/s) (Pade for delays)."""
    return plant.to_control() * pi_tf(kp, ki)


def closed_loop_tf(plant: Plant, kp: float, ki: float) -> control.TransferFunction:
    """Rational closed velocity loop; for the thesis plants it equals Eq. 3.19 / 3.20."""
    import control

    return control.feedback(open_loop_tf(plant, kp, ki), 1)


def virtual_admittance_frd(w_rad_s, m_v, b_v, k_v=0.0) -> np.ndarray:
    """Admittance virtual dynamics, velocity per external force (m/s per N), thesis Eq. 3.23:
    Y_v = s / (m_v s^2 + b_v s + k_v).

    With k_v = 0 this is 1 / (m_v s + b_v). The thesis's Eq. 3.24 prints 1/(m_v s^2 + b_v),
    a typo: dividing Eq. 3.23 by s with k_v = 0 gives 1/(m_v s + b_v), implemented here.
    """
    check_positive("m_v", m_v, allow_zero=True)
    check_positive("b_v", b_v, allow_zero=True)
    check_positive("k_v", k_v, allow_zero=True)
    s = 1j * np.asarray(w_rad_s)
    return s / (np.asarray(m_v) * s**2 + np.asarray(b_v) * s + np.asarray(k_v))


def rendered_admittance_frd(plant: Plant, w_rad_s, *, kp, ki, m_v, b_v, force_pushes_plant: bool = True) -> np.ndarray:
    """Velocity per sensed force of the nested loop of thesis Figure 3.22 (m/s per N).

    force -> Y_v = 1/(m_v s + b_v) -> velocity reference -> PI -> current loop -> plant.
    With ``force_pushes_plant`` the sensed force also acts on the moving mass directly
    (it is a physical force on the gantry): v = (P/K_t F + P C (Y_v F - v)) ->
    v/F = (P_F + P C Y_v) / (1 + P C), where P_F = P / (K_t * electrical effects) is the
    mechanical velocity-per-force response.
    """
    w = check_grid(w_rad_s)
    P = plant.frd(w)
    C = pi_frd(w, kp, ki)
    Yv = virtual_admittance_frd(w, m_v, b_v)
    num = P * C * Yv
    if force_pushes_plant:
        electrical = plant.chain_response(1j * w, "drive")
        kt = np.asarray(plant.force_constant_n_per_a, float)
        num = num + P / (kt * electrical)
    return num / (1 + P * C)
