"""Batched state-space models and the rational building blocks every time-domain realisation is made of.

``StateSpace`` holds x' = A x + B u, y = C x + D u with leading batch axes (one model per plant of a batch);
``tf_ss`` realises a rational factor (observable canonical form, balanced as MATLAB's ``ssbal``), ``series``
chains two single-input single-output batches, ``pade_polys`` is the [n/n] Pade approximant of a delay. Each
chain effect builds its own realisation from these (``ChainEffect.state_space``), and
``plant.physics.effect_base.effects_state_space`` multiplies a plant's factors at one place of the chain.
``hold_step`` is the exact discretisation over one step of an input held or linear over it, the step every
simulator and sampled-data check takes; ``expm`` the matrix exponential it rests on, for a whole batch at once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import matrix_balance


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


#: Higham's [13/13] Pade coefficients and the 1-norm up to which it is accurate to double precision (Higham, "The
#: scaling and squaring method for the matrix exponential revisited", SIAM J. Matrix Anal. Appl. 26 (2005))
_PADE13 = (64764752532480000., 32382376266240000., 7771770303897600., 1187353796428800., 129060195264000.,
           10559470521600., 670442572800., 33522128640., 1323241920., 40840800., 960960., 16380., 182., 1.)
_THETA13 = 5.371920351148152


def expm(A: np.ndarray) -> np.ndarray:
    """e^A of a batch of square matrices (..., n, n): scaling and squaring with the [13/13] Pade approximant
    (Higham 2005), every matrix of the batch in the same array operations, each scaled by its own power of two.
    scipy's ``expm`` takes a batch one matrix at a time, which made it the cost of the sampled-data checks."""
    A = np.asarray(A, float)
    shape, n = A.shape, A.shape[-1]
    A = A.reshape(-1, n, n)
    norm = np.abs(A).sum(axis=-2).max(axis=-1)
    with np.errstate(divide="ignore"):
        squarings = np.maximum(0, np.ceil(np.log2(norm / _THETA13))).astype(int)
    A = A * np.ldexp(1.0, -squarings)[:, None, None]
    b = _PADE13
    eye = np.eye(n)
    A2 = A @ A
    A4 = A2 @ A2
    A6 = A4 @ A2
    U = A @ (A6 @ (b[13] * A6 + b[11] * A4 + b[9] * A2) + b[7] * A6 + b[5] * A4 + b[3] * A2 + b[1] * eye)
    V = A6 @ (b[12] * A6 + b[10] * A4 + b[8] * A2) + b[6] * A6 + b[4] * A4 + b[2] * A2 + b[0] * eye
    R = np.linalg.solve(V - U, V + U)
    for k in range(int(squarings.max(initial=0))):
        more = squarings > k
        if more.all():
            R = R @ R
        else:
            R[more] = R[more] @ R[more]
    return R.reshape(shape)


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
