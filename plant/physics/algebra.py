"""Complex arithmetic that one response formula shares between NumPy and casadi.

Effects write their response as a function of the Laplace variable ``s`` with ordinary
operators and ``ops.exp`` / ``ops.expm1``. With NumPy, ``s`` is a complex array and ``ops`` is
``NUMPY``; with casadi (which has no complex type), ``s`` is a ``Pair`` of real expressions and
``ops`` is ``CASADI``: the same formula then builds the real and imaginary parts symbolically.
"""

from __future__ import annotations

import numpy as np


class Pair:
    """A complex value held as real and imaginary parts (casadi expressions or real arrays)."""

    __slots__ = ("re", "im")

    def __init__(self, re, im=0.0) -> None:
        self.re, self.im = re, im

    @staticmethod
    def of(x) -> Pair:
        if isinstance(x, Pair):
            return x
        if isinstance(x, complex | np.complexfloating):
            return Pair(x.real, x.imag)
        return Pair(x, 0.0)

    def __add__(self, other) -> Pair:
        o = Pair.of(other)
        return Pair(self.re + o.re, self.im + o.im)

    __radd__ = __add__

    def __neg__(self) -> Pair:
        return Pair(-self.re, -self.im)

    def __sub__(self, other) -> Pair:
        return self + (-Pair.of(other))

    def __rsub__(self, other) -> Pair:
        return Pair.of(other) + (-self)

    def __mul__(self, other) -> Pair:
        o = Pair.of(other)
        return Pair(self.re * o.re - self.im * o.im, self.re * o.im + self.im * o.re)

    __rmul__ = __mul__

    def __truediv__(self, other) -> Pair:
        o = Pair.of(other)
        d = o.re * o.re + o.im * o.im
        return Pair((self.re * o.re + self.im * o.im) / d, (self.im * o.re - self.re * o.im) / d)

    def __rtruediv__(self, other) -> Pair:
        return Pair.of(other) / self

    def __pow__(self, n: int) -> Pair:
        if int(n) != n or n < 1:
            raise ValueError("Pair supports positive integer powers only")
        out = self
        for _ in range(int(n) - 1):
            out = out * self
        return out


class _NumpyOps:
    exp = staticmethod(np.exp)
    expm1 = staticmethod(np.expm1)

    @staticmethod
    def exp_product(s, tau) -> np.ndarray:
        """e^(-s tau) of complex ``s`` and real ``tau`` (broadcast) from its modulus and angle: half the time of
        ``np.exp`` of the complex product (a delay's response on a large grid)."""
        s, tau = np.asarray(s), np.asarray(tau, float)
        angle = np.multiply(-s.imag, tau)
        out = np.empty(angle.shape, complex)
        np.cos(angle, out=out.real)
        np.sin(angle, out=out.imag)
        if np.any(s.real != 0):
            out *= np.exp(np.multiply(-s.real, tau))
        return out


class _CasadiOps:
    @staticmethod
    def exp(z: Pair) -> Pair:
        import casadi as ca

        z = Pair.of(z)
        mag = ca.exp(z.re)
        return Pair(mag * ca.cos(z.im), mag * ca.sin(z.im))

    @classmethod
    def expm1(cls, z: Pair) -> Pair:
        return cls.exp(z) - 1.0

    @classmethod
    def exp_product(cls, s: Pair, tau: float) -> Pair:
        return cls.exp(-s * tau)


NUMPY = _NumpyOps()
CASADI = _CasadiOps()
