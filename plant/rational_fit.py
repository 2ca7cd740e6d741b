"""Black-box rational transfer-function fits to frequency-response data (like MATLAB ``tfest``).

Model (rad/s, optional input-output delay tau):

    G(s) = (b_m s^m + ... + b_0) / (s^n + a_(n-1) s^(n-1) + ... + a_0) * exp(-s tau)

Estimation: Levy's linearised least squares, then Sanathanan-Koerner (SK) iterations
(re-weighting by 1/|D_prev(jw)|) which converge to the output-error optimum, then a
nonlinear least-squares refinement of the output error sum_k |w_k (G_k - G(jw_k))|^2 with
real and imaginary parts split explicitly. Frequencies are normalised by the geometric
mean of the grid during estimation for conditioning. The delay, when asked for, is found
on a grid (SK for each candidate) and refined with the coefficients.

Weights follow ``tfest``'s ``WeightingFilter`` vector: the error at each frequency is
multiplied by its weight. ``weights="thesis"`` is the thesis's Appendix B (Stage Y code):
20 below 20 Hz, 0.5 from 20 Hz up. (The Stage X code passes an n-by-2 matrix, which
``tfest`` reads as pass bands; the vector of the Stage Y code is what the text describes.)
"""

from __future__ import annotations

from dataclasses import dataclass

import control
import numpy as np
from scipy.optimize import least_squares

from plant.errors import DataError, ParameterError
from plant.grid import check_grid

#: SK iterations stop when the relative change of the denominator is below this
_SK_TOL = 1e-10
_SK_MAX_ITER = 50
#: delay candidates tried on the grid before the nonlinear refinement
_DELAY_GRID_POINTS = 41


@dataclass(frozen=True)
class RationalFit:
    """Result of ``fit_rational``: the rational part as a python-control ``TransferFunction``
    (monic denominator, rad/s) and the delay ``delay_s`` (not part of ``tf``)."""

    tf: control.TransferFunction
    #: numerator and denominator coefficients, highest power first (den[0] == 1)
    num: np.ndarray
    den: np.ndarray
    delay_s: float
    n_poles: int
    n_zeros: int
    #: weight per frequency (multiplies the error, as tfest's WeightingFilter vector)
    weights: np.ndarray
    #: MATLAB-style fit percentage 100 (1 - ||G - G_fit|| / ||G - mean G||), unweighted
    fit_percent: float
    #: weighted cost sum |w (G - G_fit)|^2
    cost: float
    #: weighted mean squared error cost / n_freq
    mse: float
    sk_iterations: int
    stable: bool
    success: bool
    message: str

    @property
    def poles(self) -> np.ndarray:
        return np.roots(self.den)

    @property
    def zeros(self) -> np.ndarray:
        return np.roots(self.num) if len(self.num) > 1 else np.array([], dtype=complex)

    def frd(self, w_rad_s) -> np.ndarray:
        """Complex response of the fitted model, delay included, at ``w_rad_s`` (rad/s)."""
        w = np.asarray(w_rad_s, dtype=float)
        s = 1j * w
        return np.polyval(self.num, s) / np.polyval(self.den, s) * np.exp(-s * self.delay_s)


def thesis_weights(f_hz) -> np.ndarray:
    """Thesis Appendix B (Stage Y): weight 20 below 20 Hz, 0.5 (= 1/2) from 20 Hz up."""
    f = np.asarray(f_hz, dtype=float)
    return np.where(f < 20.0, 20.0, 0.5)


def _check_weights(weights, w: np.ndarray) -> np.ndarray:
    if weights is None:
        return np.ones_like(w)
    if isinstance(weights, str):
        if weights != "thesis":
            raise ParameterError(f"weights must be None, 'thesis' or an array, got {weights!r}")
        return thesis_weights(w / (2 * np.pi))
    arr = np.asarray(weights, dtype=float)
    if arr.shape != w.shape:
        raise ParameterError(f"weights must have one value per frequency ({w.size}), got shape {arr.shape}")
    bad = ~np.isfinite(arr) | (arr < 0)
    if bad.any():
        i = int(np.argmax(bad))
        raise ParameterError(f"weights must be finite and non-negative; element {i} is {float(arr[i])!r}")
    if not np.any(arr > 0):
        raise ParameterError("weights are all zero")
    return arr


def _sk(s: np.ndarray, h: np.ndarray, wt: np.ndarray, n: int, m: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Levy + Sanathanan-Koerner on normalised s; returns (b, a) low power first (a monic) and iterations."""
    sp_num = s[:, None] ** np.arange(m + 1)                  # (K, m+1)
    sp_den = s[:, None] ** np.arange(n)                      # (K, n)
    rhs = h * s**n
    a = np.zeros(n)
    d_prev = np.ones_like(s)
    it = 0
    for it in range(1, _SK_MAX_ITER + 1):
        scale = wt / np.abs(d_prev)
        A = np.hstack([sp_num, -h[:, None] * sp_den]) * scale[:, None]
        Ar = np.vstack([A.real, A.imag])
        br = np.concatenate([(rhs * scale).real, (rhs * scale).imag])
        col = np.linalg.norm(Ar, axis=0)
        col[col == 0] = 1.0
        theta = np.linalg.lstsq(Ar / col, br, rcond=None)[0] / col
        b_new, a_new = theta[: m + 1], theta[m + 1:]
        change = np.linalg.norm(a_new - a) / max(np.linalg.norm(a_new), 1e-300)
        a, b = a_new, b_new
        d_prev = sp_den @ a + s**n
        if it > 1 and change < _SK_TOL:
            break
    return b, a, it


def _reflect_unstable(a: np.ndarray) -> np.ndarray:
    """Monic denominator (low power first, leading 1 implicit) with right-half-plane poles mirrored."""
    den = np.concatenate([[1.0], a[::-1]])
    p = np.roots(den)
    if np.all(p.real < 0):
        return a
    p = np.where(p.real >= 0, -np.abs(p.real) - 1e-9 + 1j * p.imag, p)
    return np.real(np.poly(p))[1:][::-1]


def fit_rational(w_rad_s, response, *, n_poles: int, n_zeros: int, delay: bool = False,
                 weights=None, enforce_stability: bool = True, max_delay_s: float | None = None) -> RationalFit:
    """Fit ``n_poles``/``n_zeros`` rational model (optionally with a delay) to complex ``response``
    at ``w_rad_s`` (rad/s). ``weights``: None (uniform), ``"thesis"`` (Appendix B) or an array
    multiplying the error at each frequency. ``max_delay_s`` bounds the delay search (default one
    period of the highest frequency)."""
    w = check_grid(w_rad_s, name="fit_rational frequencies")
    g = np.asarray(response)
    if g.shape != w.shape:
        raise DataError(f"response must have one value per frequency ({w.size}), got shape {g.shape}")
    if not np.all(np.isfinite(g)):
        raise DataError(f"response contains NaN or infinite values (first at index {int(np.argmax(~np.isfinite(g)))})")
    g = g.astype(complex)
    n, m = int(n_poles), int(n_zeros)
    if n < 0 or m < 0 or m > n:
        raise ParameterError(f"need 0 <= n_zeros <= n_poles, got n_poles={n_poles}, n_zeros={n_zeros}")
    wt = _check_weights(weights, w)
    n_unknown = n + m + 1 + int(delay)
    if n_unknown > 2 * int(np.count_nonzero(wt > 0)):
        raise DataError(f"{n_unknown} unknowns but only {int(np.count_nonzero(wt > 0))} weighted frequencies "
                        "(2 real equations each)")
    w0 = float(np.sqrt(w[0] * w[-1]))
    s = 1j * w / w0

    tau_max = float(max_delay_s) if max_delay_s is not None else 2 * np.pi / w[-1]
    if delay and not (np.isfinite(tau_max) and tau_max > 0):
        raise ParameterError(f"max_delay_s must be positive, got {max_delay_s!r}")
    taus = np.linspace(0.0, tau_max, _DELAY_GRID_POINTS) if delay else np.zeros(1)

    def model(b, a, tau):
        return (s[:, None] ** np.arange(m + 1) @ b) / (s[:, None] ** np.arange(n) @ a + s**n) * np.exp(-1j * w * tau)

    best = None
    for tau in taus:
        b, a, it = _sk(s, g * np.exp(1j * w * tau), wt, n, m)
        if enforce_stability:
            a = _reflect_unstable(a)
        cost = float(np.sum(np.abs(wt * (g - model(b, a, tau))) ** 2))
        if best is None or cost < best[0]:
            best = (cost, b, a, tau, it)
    _, b0, a0, tau0, iterations = best

    # nonlinear output-error refinement (real and imaginary parts split explicitly)
    def resid(theta):
        b, a = theta[: m + 1], theta[m + 1: m + 1 + n]
        tau = theta[-1] if delay else 0.0
        r = wt * (model(b, a, tau) - g)
        return np.concatenate([r.real, r.imag])

    x0 = np.concatenate([b0, a0, [tau0] if delay else []])
    lb = np.full(x0.shape, -np.inf)
    ub = np.full(x0.shape, np.inf)
    if delay:
        lb[-1], ub[-1] = 0.0, np.inf
    sol = least_squares(resid, x0, bounds=(lb, ub), method="trf", x_scale="jac", xtol=1e-12, ftol=1e-12,
                        gtol=1e-12, max_nfev=2000)
    b, a = sol.x[: m + 1], sol.x[m + 1: m + 1 + n]
    tau = float(sol.x[-1]) if delay else 0.0
    message = str(sol.message)
    stable = bool(np.all(np.roots(np.concatenate([[1.0], a[::-1]])).real < 0))
    if enforce_stability and not stable:
        b, a, tau = b0, a0, tau0
        stable = True
        message = ("nonlinear refinement converged to an unstable model; kept the stabilised "
                   "Sanathanan-Koerner estimate")
    fit = model(b, a, tau)
    cost = float(np.sum(np.abs(wt * (g - fit)) ** 2))
    # back to rad/s: D(s) = sum a_k (s/w0)^k + (s/w0)^n -> multiply by w0^n for a monic polynomial
    den = np.concatenate([[1.0], (a * w0 ** (n - np.arange(n)))[::-1]])
    num = (b * w0 ** (n - np.arange(m + 1)))[::-1]
    spread = np.linalg.norm(g - g.mean())
    fit_percent = float(100 * (1 - np.linalg.norm(g - fit) / spread)) if spread > 0 else float("nan")
    return RationalFit(tf=control.tf(num, den), num=num, den=den, delay_s=tau, n_poles=n, n_zeros=m, weights=wt,
                       fit_percent=fit_percent, cost=cost, mse=cost / w.size, sk_iterations=iterations,
                       stable=stable, success=bool(sol.success), message=message)
