"""Batched state-space models and the rational building blocks every time-domain realisation is made of.

``StateSpace`` holds x' = A x + B u, y = C x + D u with leading batch axes (one model per plant of a batch);
``tf_ss`` realises a rational factor (observable canonical form, balanced as MATLAB's ``ssbal``), ``series``
chains two single-input single-output batches, ``pade_polys`` is the [n/n] Pade approximant of a delay. Each
chain effect builds its own realisation from these (``ChainEffect.state_space``), and
``plant.physics.effect_base.effects_state_space`` multiplies a plant's factors at one place of the chain.
``hold_step`` is the exact discretisation over one step of an input held or linear over it, the step every
simulator and sampled-data check takes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm, matrix_balance


@dataclass(frozen=True)
class StateSpace:
    """x' = A x + B u, y = C x + D u, batched over leading axes: A (..., n, n), B (..., n, m), C (..., p, n),
    D (..., p, m)."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray

    @property
    def order(self) -> int:
        return self.A.shape[-1]

    def take(self, index) -> StateSpace:
        return StateSpace(self.A[index], self.B[index], self.C[index], self.D[index])


def pade_polys(delay_s: float, order: int) -> tuple[np.ndarray, np.ndarray]:
    """The [order/order] Pade approximant of e^(-s delay) as numerator / denominator (highest power first)."""
    n = order
    c = [math.factorial(2 * n - k) * math.factorial(n) / (math.factorial(2 * n) * math.factorial(k)
                                                         * math.factorial(n - k)) for k in range(n + 1)]
    den = np.array([c[k] * delay_s**k for k in range(n, -1, -1)])
    num = np.array([c[k] * (-delay_s) ** k for k in range(n, -1, -1)])
    return num / den[0], den / den[0]


def tf_ss(num, den) -> StateSpace:
    """A proper num / den (highest power first) in observable canonical form, its states scaled as MATLAB's
    ``ssbal`` does (``scipy.linalg.matrix_balance`` of [[A, B], [C, 0]], the input and output unscaled)."""
    num, den = np.atleast_1d(np.asarray(num, float)), np.atleast_1d(np.asarray(den, float))
    num, den = num / den[0], den / den[0]
    n = den.size - 1
    if num.size > den.size:
        raise ValueError("improper transfer function")
    num = np.concatenate([np.zeros(den.size - num.size), num])
    d = num[0]
    if n == 0:
        return StateSpace(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[d]]))
    A = np.zeros((n, n))
    A[:, 0] = -den[1:]
    A[:-1, 1:] = np.eye(n - 1)
    B = (num[1:] - d * den[1:])[:, None]
    C = np.zeros((1, n))
    C[0, 0] = 1.0
    return balance(StateSpace(A, B, C, np.array([[d]])))


def balance(sys: StateSpace) -> StateSpace:
    """The states of an unbatched single-input single-output system rescaled so that A, B and C are of
    comparable size (``ssbal``)."""
    n = sys.order
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n:], M[n:, :n] = sys.A, sys.B, sys.C
    _, (scale, _) = matrix_balance(M, permute=False, separate=True)
    t = scale[:n] / scale[n]
    return StateSpace(sys.A * (1 / t)[:, None] * t[None, :], sys.B / t[:, None], sys.C * t[None, :], sys.D)


def batched(sys: StateSpace, n: int) -> StateSpace:
    """``sys`` with a leading batch axis of ``n`` (broadcast when it has none)."""
    if sys.A.ndim == 3:
        return sys
    return StateSpace(*(np.broadcast_to(x, (n, *x.shape)) for x in (sys.A, sys.B, sys.C, sys.D)))


def unity(n: int) -> StateSpace:
    """A batch of ``n`` unit gains (no states)."""
    return batched(tf_ss([1.0], [1.0]), n)


def series(first: StateSpace, second: StateSpace) -> StateSpace:
    """``second`` after ``first``, single-input single-output, batched (n, ...)."""
    n1, n2 = first.order, second.order
    batch = first.A.shape[0]
    A = np.zeros((batch, n1 + n2, n1 + n2))
    A[:, :n1, :n1] = first.A
    A[:, n1:, :n1] = second.B @ first.C
    A[:, n1:, n1:] = second.A
    B = np.concatenate([first.B, second.B @ first.D], axis=1)
    C = np.concatenate([second.D @ first.C, second.C], axis=2)
    return StateSpace(A, B, C, second.D @ first.D)


def column(value, n: int) -> np.ndarray:
    """A parameter (a value or a batch of values) as a batch of ``n`` values."""
    return np.broadcast_to(np.asarray(value, float).reshape(-1), (n,))


def hold_step(A: np.ndarray, B: np.ndarray, h_s: float, *, linear: bool = False):
    """The exact discretisation of x' = A x + B u over a step of ``h_s`` (s), batched over leading axes (Astrom &
    Wittenmark, Computer-Controlled Systems, section 2.3, by one matrix exponential of the augmented system): with
    u held, (Phi, Gamma), x+ = Phi x + Gamma u; with ``linear`` (u linear over the step, a first-order hold),
    (Phi, Gamma0, Gamma1), x+ = Phi x + Gamma0 u0 + Gamma1 (u1 - u0)."""
    n, m = A.shape[-1], B.shape[-1]
    batch = A.shape[:-2]
    size = n + (2 * m if linear else m)
    M = np.zeros((*batch, size, size))
    M[..., :n, :n], M[..., :n, n:n + m] = A * h_s, B * h_s
    if linear:
        M[..., n:n + m, n + m:] = np.eye(m)
    E = expm(M)
    if linear:
        return E[..., :n, :n], E[..., :n, n:n + m], E[..., :n, n + m:]
    return E[..., :n, :n], E[..., :n, n:]
