"""Black-box rational transfer-function fits to frequency-response data (like MATLAB ``tfest``).

Model (rad/s, optional input-output delay tau):

    G(s) = (b_m s^m + ... + b_0) / (s^n + a_(n-1) s^(n-1) + ... + a_0) * exp(-s tau)

Estimation minimises the weighted output error sum_k |w_k (G_k - G(jw_k))|^2 (real and
imaginary parts split explicitly) by nonlinear least squares from several starts, and keeps
the lowest cost:

- Levy's linearised least squares followed by Sanathanan-Koerner (SK) iterations (re-weighting
  by 1/|D_prev(jw)|; Sanathanan & Koerner, IEEE TAC 8(1), 1963) under the fit's own weights,
  uniform weights, relative weights 1/|G| and, when a variance is given, 1/sigma. SK weighted
  one way can lock onto a low-frequency fit of the noise and never see a lightly damped mode
  that another weighting sees.
- Peak picking, as the starting poles of vector fitting (Gustavsen & Semlyen, IEEE TPWRD
  14(3), 1999): a lightly damped pair (damping ratio 0.02 and 0.08) at each of the most
  prominent local maxima of the detrended log magnitude, the other poles real and spread
  log-uniformly over the band, the numerator from linear least squares.

Frequencies are normalised by the geometric mean of the grid during estimation for
conditioning. The delay, when asked for, is found on a grid (SK for each candidate) and refined
with the coefficients inside [0, max_delay_s].

Weights follow ``tfest``'s ``WeightingFilter`` vector: the error at each frequency is
multiplied by its weight. With a ``variance`` the default is 1/sigma (maximum likelihood for
circular complex Gaussian noise). ``weights="thesis"`` is the thesis's Appendix B (Stage Y
code): 20 below 20 Hz, 0.5 from 20 Hz up. (The Stage X code passes an n-by-2 matrix, which
``tfest`` reads as pass bands; the vector of the Stage Y code is what the text describes.)
With 5 % relative noise the thesis weights let the low-frequency noise outweigh a resonance
above 20 Hz, so a lightly damped mode can be missed by the optimum itself; the chi-square
flag reports it when a variance is given.

A fit is flagged (``RationalFit.flags``) for pole-zero cancellation, a negligible pole or one far
outside the band, the delay at a bound, unstable poles reflected, an optimiser that did not
converge, and a residual inconsistent with the given variance; ``success`` is True only for a converged, unflagged fit.
"""

from __future__ import annotations

from dataclasses import dataclass

import control
import numpy as np
from scipy import special
from scipy.optimize import least_squares
from scipy.signal import find_peaks

from plant.arguments import check_count
from plant.errors import DataError, ParameterError
from plant.grid import check_grid
from plant.identify.fit_result import Fit
from plant.story import Section

#: SK iterations stop when the relative change of the denominator is below this
_SK_TOL = 1e-10
_SK_MAX_ITER = 50
#: delay candidates tried on the grid before the nonlinear refinement
_DELAY_GRID_POINTS = 41
#: peak-picking starts: this many magnitude peaks, each with these damping ratios
_PEAKS = 2
_PEAK_DAMPING = (0.02, 0.08)
#: nonlinear refinement: evaluations per start and tolerances
_MAX_NFEV = 1000
_TOL = 1e-10
#: a pole and a zero closer than this fraction of |pole| cancel
PZ_CANCEL_REL = 0.02
#: a pole whose partial-fraction term stays below this fraction of max |G| on the grid is negligible
NEGLIGIBLE_RESIDUE = 1e-3
#: a pole beyond this factor outside the measured band is not determined by the data
OUT_OF_BAND = 100.0
#: the residual is flagged when either tail probability of its chi-square is below this
CHI2_P_FLAG = 1e-3
#: the delay is at a bound when within this fraction of max_delay_s of it
_BOUND_REL = 1e-4

WEIGHTINGS = ("uniform", "thesis", "inverse_sigma")


@dataclass(frozen=True, kw_only=True)
class RationalFit(Fit):
    """Result of ``fit_rational``: the rational part as a python-control ``TransferFunction``
    (monic denominator, rad/s) and the delay ``delay_s`` (not part of ``tf``). ``n_data`` counts the
    real and imaginary parts of the weighted frequencies; ``n_params`` the coefficients and the delay."""

    tf: control.TransferFunction
    #: numerator and denominator coefficients, highest power first (den[0] == 1)
    num: np.ndarray
    den: np.ndarray
    delay_s: float
    #: the delay was estimated (else fixed at 0)
    delay: bool
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
    #: converged and no flag raised
    success: bool
    message: str
    #: "uniform", "thesis", "inverse_sigma" or "array"
    weighting: str
    #: sum over weighted frequencies of |G - G_fit|^2 / (variance / 2) (real and imaginary parts
    #: each carry half the variance); NaN without a variance
    chi2: float
    #: 2 x weighted frequencies - estimated parameters
    dof: int
    #: upper-tail probability P(chi^2_dof >= chi2); NaN without a variance
    chi2_p: float
    #: name of the start the kept fit was refined from
    start: str

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

    def _model_lines(self) -> list[str]:
        delay = f", delay {1e3 * self.delay_s:.4g} ms" if self.delay else ""
        return [f"rational: {self.n_poles} poles, {self.n_zeros} zeros{delay}; {self.weighting} weighting"]

    def _statistics_lines(self) -> list[str]:
        chi2 = (f"{self.chi2:.6g} for {self.dof} degrees of freedom (P = {self.chi2_p:.2g})"
                if np.isfinite(self.chi2) else "not computed (no variance)")
        return [
            f"# data points      = {self.n_data} ({self.n_data // 2} weighted frequencies x re/im)",
            f"# variables        = {self.n_params}",
            f"fit                = {self.fit_percent:.2f} % (100 (1 - |G - G_fit| / |G - mean G|), unweighted)",
            f"weighted cost      = {self.cost:.6g}",
            f"chi-square         = {chi2}",
            f"starts             = {self.n_starts} (kept: {self.start}; {self.sk_iterations} SK iterations)",
            f"success            = {self.success} ({self.message})",
        ]

    def _sections(self) -> list[Section]:
        roots = []
        for kind, rs in (("pole", self.poles), ("zero", self.zeros)):
            for r in sorted(rs[rs.imag >= 0], key=abs):
                zeta = -r.real / abs(r) if abs(r) > 0 else float("nan")
                roots.append(f"{kind} {r:.5g}: {abs(r) / (2 * np.pi):.4g} Hz, damping {zeta:.3g}")
        tf = tuple(line for line in str(self.tf).splitlines()
                   if line.strip() and not line.startswith(("<", "Inputs", "Outputs")))
        return [Section("Poles and zeros", tuple(roots), aside="(rad/s; Hz and damping ratio)"),
                Section("Transfer function", tf, aside="" if not self.delay else "(times the delay)")]


@dataclass(frozen=True)
class _Candidate:
    """One refined start, in normalised frequency (coefficients low power first, ``a`` monic)."""

    b: np.ndarray
    a: np.ndarray
    tau: float
    cost: float
    converged: bool
    message: str
    reflected: bool
    start: str


def thesis_weights(f_hz) -> np.ndarray:
    """Thesis Appendix B (Stage Y): weight 20 below 20 Hz, 0.5 (= 1/2) from 20 Hz up."""
    f = np.asarray(f_hz, dtype=float)
    return np.where(f < 20.0, 20.0, 0.5)


def _check_variance(variance, w: np.ndarray) -> np.ndarray | None:
    if variance is None:
        return None
    var = np.asarray(variance, dtype=float)
    if var.shape != w.shape:
        raise DataError(f"variance must have one value per frequency ({w.size}), got shape {var.shape}")
    bad = ~np.isfinite(var) | (var <= 0)
    if bad.any():
        i = int(np.argmax(bad))
        raise DataError(f"variance must be finite and positive; element {i} is {float(var[i])!r}")
    return var


def _check_weights(weights, w: np.ndarray, var: np.ndarray | None) -> tuple[np.ndarray, str]:
    """Weight per frequency and the weighting's name; None means 1/sigma with a variance, else uniform."""
    if weights is None:
        weights = "uniform" if var is None else "inverse_sigma"
    if isinstance(weights, str):
        if weights not in WEIGHTINGS:
            raise ParameterError(f"weights must be None, one of {', '.join(WEIGHTINGS)} or an array, "
                                 f"got {weights!r}")
        if weights == "inverse_sigma":
            if var is None:
                raise ParameterError("weights='inverse_sigma' needs variance=")
            return 1.0 / np.sqrt(var), weights
        return (thesis_weights(w / (2 * np.pi)) if weights == "thesis" else np.ones_like(w)), weights
    arr = np.asarray(weights, dtype=float)
    if arr.shape != w.shape:
        raise ParameterError(f"weights must have one value per frequency ({w.size}), got shape {arr.shape}")
    bad = ~np.isfinite(arr) | (arr < 0)
    if bad.any():
        i = int(np.argmax(bad))
        raise ParameterError(f"weights must be finite and non-negative; element {i} is {float(arr[i])!r}")
    if not np.any(arr > 0):
        raise ParameterError("weights are all zero")
    return arr, "array"


def _lstsq(A: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Real least-squares solution of the complex system A x = rhs (rows split into real and
    imaginary parts, columns scaled to unit norm)."""
    Ar = np.vstack([A.real, A.imag])
    col = np.linalg.norm(Ar, axis=0)
    col[col == 0] = 1.0
    return np.linalg.lstsq(Ar / col, np.concatenate([rhs.real, rhs.imag]), rcond=None)[0] / col


def _powers(s: np.ndarray, k: int) -> np.ndarray:
    """Columns s^0 .. s^(k-1), shape (n_freq, k)."""
    return s[:, None] ** np.arange(k)


def _sk(s: np.ndarray, h: np.ndarray, wt: np.ndarray, n: int, m: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Levy + Sanathanan-Koerner on normalised s; returns (b, a) low power first (a monic) and iterations."""
    sp_num, sp_den = _powers(s, m + 1), _powers(s, n)
    a = np.zeros(n)
    d_prev = np.ones_like(s)
    it = 0
    for it in range(1, _SK_MAX_ITER + 1):
        scale = wt / np.abs(d_prev)
        theta = _lstsq(np.hstack([sp_num, -h[:, None] * sp_den]) * scale[:, None], h * s**n * scale)
        b, a_new = theta[: m + 1], theta[m + 1:]
        change = np.linalg.norm(a_new - a) / max(np.linalg.norm(a_new), 1e-300)
        a = a_new
        d_prev = sp_den @ a + s**n
        if it > 1 and change < _SK_TOL:
            break
    return b, a, it


def _numerator(s: np.ndarray, h: np.ndarray, wt: np.ndarray, a: np.ndarray, m: int) -> np.ndarray:
    """Numerator (low power first) minimising sum |wt (h - N/D)|^2 for the fixed monic denominator ``a``."""
    d = _powers(s, a.size) @ a + s**a.size
    return _lstsq(_powers(s, m + 1) * (wt / d)[:, None], wt * h)


def _reflect_unstable(a: np.ndarray) -> np.ndarray:
    """Monic denominator (low power first, leading 1 implicit) with right-half-plane poles mirrored."""
    den = np.concatenate([[1.0], a[::-1]])
    p = np.roots(den)
    if np.all(p.real < 0):
        return a
    p = np.where(p.real >= 0, -np.abs(p.real) - 1e-9 + 1j * p.imag, p)
    return np.real(np.poly(p))[1:][::-1]


def _peak_poles(s: np.ndarray, h: np.ndarray, wt: np.ndarray, n: int, w0: float) -> list[tuple[str, np.ndarray]]:
    """Peak-picking starting denominators (monic, low power first, normalised s): a lightly damped
    pair at each of the ``_PEAKS`` most prominent maxima of log|h| minus its straight-line trend
    over log w, the other n - 2 poles real and log-spaced over the band. ``w0`` (rad/s) names the
    peaks in Hz."""
    use = (wt > 0) & (np.abs(h) > 0)
    if n < 2 or np.count_nonzero(use) < 3:
        return []
    x, y = np.log(s[use].imag), np.log(np.abs(h[use]))
    idx, props = find_peaks(y - np.polyval(np.polyfit(x, y, 1), x), prominence=0.0)
    peaks = np.exp(x[idx[np.argsort(props["prominences"])[::-1][:_PEAKS]]])
    rest = -np.geomspace(s[use].imag[0], s[use].imag[-1], n - 2) if n > 2 else np.array([])
    out = []
    for wp in peaks:
        for zeta in _PEAK_DAMPING:
            pair = wp * (-zeta + np.array([1j, -1j]) * np.sqrt(1 - zeta**2))
            den = np.real(np.poly(np.concatenate([pair, rest])))
            out.append((f"peak {wp * w0 / (2 * np.pi):.4g} Hz, damping {zeta:g}", den[1:][::-1]))
    return out


class _Problem:
    """The weighted output-error problem in normalised frequency s = jw / w0."""

    def __init__(self, w: np.ndarray, g: np.ndarray, wt: np.ndarray, n: int, m: int, delay: bool,
                 tau_max: float) -> None:
        self.w, self.g, self.wt, self.n, self.m, self.delay, self.tau_max = w, g, wt, n, m, delay, tau_max
        self.w0 = float(np.sqrt(w[0] * w[-1]))
        self.s = 1j * w / self.w0

    def model(self, b: np.ndarray, a: np.ndarray, tau: float) -> np.ndarray:
        s = self.s
        return (_powers(s, self.m + 1) @ b) / (_powers(s, self.n) @ a + s**self.n) * np.exp(-1j * self.w * tau)

    def cost(self, b: np.ndarray, a: np.ndarray, tau: float) -> float:
        return float(np.sum(np.abs(self.wt * (self.g - self.model(b, a, tau))) ** 2))

    def unpack(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        m, n = self.m, self.n
        return theta[: m + 1], theta[m + 1: m + 1 + n], float(theta[-1]) if self.delay else 0.0

    def residual(self, theta: np.ndarray) -> np.ndarray:
        r = self.wt * (self.model(*self.unpack(theta)) - self.g)
        return np.concatenate([r.real, r.imag])

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        """d residual / d theta in closed form: dG/db_k = s^k e / D, dG/da_k = -s^k N e / D^2,
        dG/dtau = -jw G, rows split into real and imaginary parts."""
        b, a, tau = self.unpack(theta)
        s, n, m = self.s, self.n, self.m
        num, den = _powers(s, m + 1) @ b, _powers(s, n) @ a + s**n
        e = self.wt * np.exp(-1j * self.w * tau)
        cols = [_powers(s, m + 1) * (e / den)[:, None], -_powers(s, n) * (e * num / den**2)[:, None]]
        if self.delay:
            cols.append((-1j * self.w * e * num / den)[:, None])
        J = np.hstack(cols)
        return np.vstack([J.real, J.imag])

    def delay_start(self) -> tuple[float, int]:
        """Delay (s) whose SK fit under the fit's weights has the lowest cost on the delay grid,
        and the SK iterations there."""
        if not self.delay:
            b, a, it = _sk(self.s, self.g, self.wt, self.n, self.m)
            return 0.0, it
        best = None
        for tau in np.linspace(0.0, self.tau_max, _DELAY_GRID_POINTS):
            b, a, it = _sk(self.s, self.g * np.exp(1j * self.w * tau), self.wt, self.n, self.m)
            cost = self.cost(b, _reflect_unstable(a), tau)
            if best is None or cost < best[0]:
                best = (cost, tau, it)
        return best[1], best[2]

    def starts(self, tau: float, variance: np.ndarray | None) -> list[tuple[str, np.ndarray]]:
        """Named starting denominators (monic, low power first): SK under several weightings
        (frequencies the fit ignores stay ignored), then peak picking."""
        h = self.g * np.exp(1j * self.w * tau)
        mask = (self.wt > 0).astype(float)
        with np.errstate(divide="ignore"):
            relative = np.where(np.abs(h) > 0, 1.0 / np.abs(h), 0.0)
        weightings = [("SK, fit weights", self.wt), ("SK, uniform", mask), ("SK, 1/|G|", mask * relative)]
        if variance is not None:
            weightings.append(("SK, 1/sigma", mask / np.sqrt(variance)))
        out, seen = [], []
        for name, wt in weightings:
            unit = wt / np.max(wt)
            if any(np.allclose(unit, u, rtol=1e-12, atol=0) for u in seen):
                continue
            seen.append(unit)
            out.append((name, _sk(self.s, h, wt, self.n, self.m)[1]))
        return out + _peak_poles(self.s, h, self.wt, self.n, self.w0)

    def refine(self, name: str, a0: np.ndarray, tau0: float, enforce_stability: bool) -> _Candidate:
        """Nonlinear least squares from the denominator ``a0`` (numerator by linear least squares);
        an unstable result has its poles mirrored and its numerator refitted when
        ``enforce_stability``."""
        if enforce_stability:
            a0 = _reflect_unstable(a0)
        h = self.g * np.exp(1j * self.w * tau0)
        x0 = np.concatenate([_numerator(self.s, h, self.wt, a0, self.m), a0, [tau0] if self.delay else []])
        lb, ub = np.full(x0.shape, -np.inf), np.full(x0.shape, np.inf)
        if self.delay:
            lb[-1], ub[-1] = 0.0, self.tau_max
        sol = least_squares(self.residual, x0, jac=self.jacobian, bounds=(lb, ub), method="trf", x_scale="jac",
                            xtol=_TOL, ftol=_TOL, gtol=_TOL, max_nfev=_MAX_NFEV)
        b, a, tau = self.unpack(sol.x)
        reflected = False
        if enforce_stability and not np.array_equal(_reflect_unstable(a), a):
            a, reflected = _reflect_unstable(a), True
            b = _numerator(self.s, self.g * np.exp(1j * self.w * tau), self.wt, a, self.m)
        return _Candidate(b=b, a=a, tau=tau, cost=self.cost(b, a, tau), converged=sol.status > 0,
                          message=str(sol.message), reflected=reflected, start=name)


def _hz(p: complex) -> str:
    return f"{abs(p) / (2 * np.pi):.4g} Hz"


def _order_flags(num: np.ndarray, den: np.ndarray, w: np.ndarray) -> list[str]:
    """Pole-zero cancellation (|p - z| < PZ_CANCEL_REL |p|), poles more than OUT_OF_BAND times
    outside the grid ``w`` (rad/s), and poles whose partial-fraction term N(p) / (D'(p) (jw - p))
    stays below NEGLIGIBLE_RESIDUE x max |N/D| on the grid."""
    poles = np.roots(den)
    zeros = np.roots(num) if len(num) > 1 else np.array([], dtype=complex)
    flags = []
    peak = np.max(np.abs(np.polyval(num, 1j * w) / np.polyval(den, 1j * w)))
    for p in poles[poles.imag >= 0]:
        if zeros.size:
            z = zeros[np.argmin(np.abs(zeros - p))]
            d = abs(z - p) / abs(p)
            if d < PZ_CANCEL_REL:
                flags.append(f"pole-zero cancellation: pole {p:.4g} and zero {z:.4g} rad/s ({_hz(p)}) are {d:.2%} "
                             "apart; the data support a lower order")
                continue
        if not w[0] / OUT_OF_BAND < abs(p) < OUT_OF_BAND * w[-1]:
            flags.append(f"pole outside the measured band: {p:.4g} rad/s ({_hz(p)}), band {_hz(w[0])} to "
                         f"{_hz(w[-1])}; the data support a lower order")
            continue
        with np.errstate(divide="ignore", invalid="ignore"):
            term = np.abs(np.polyval(num, p) / np.polyval(np.polyder(den), p) / (1j * w - p))
        if np.all(np.isfinite(term)) and term.max() < NEGLIGIBLE_RESIDUE * peak:
            flags.append(f"negligible pole: {p:.4g} rad/s ({_hz(p)}) contributes at most {term.max() / peak:.1e} "
                         "of the peak response; the data support a lower order")
    return flags


def _chi2(g: np.ndarray, fit: np.ndarray, wt: np.ndarray, var: np.ndarray | None,
          n_params: int) -> tuple[float, int, float, list[str]]:
    """Chi-square of the residual over the weighted frequencies against chi^2(dof), both tails."""
    use = wt > 0
    dof = 2 * int(np.count_nonzero(use)) - n_params
    if var is None or dof <= 0:
        return float("nan"), dof, float("nan"), []
    chi2 = float(np.sum(np.abs(g - fit)[use] ** 2 / (var[use] / 2)))
    upper, lower = float(special.chdtrc(dof, chi2)), float(special.chdtr(dof, chi2))
    flags = []
    if upper < CHI2_P_FLAG:
        flags.append(f"residual larger than the noise: chi-square {chi2:.4g} for {dof} degrees of freedom "
                     f"(P = {upper:.1e}); the model misses part of the response (order, weighting or delay)")
    elif lower < CHI2_P_FLAG:
        flags.append(f"residual smaller than the noise: chi-square {chi2:.4g} for {dof} degrees of freedom "
                     f"(P(chi2 <= observed) = {lower:.1e}); the variance is overestimated or the model fits noise")
    return chi2, dof, upper, flags


def _delay_flags(tau: float, tau_max: float) -> list[str]:
    if tau <= _BOUND_REL * tau_max:
        return ["delay at its lower bound 0 s: the data do not support a delay; its value is not estimated"]
    if tau >= (1 - _BOUND_REL) * tau_max:
        return [f"delay at its upper bound max_delay_s = {tau_max:.4g} s: the delay the data ask for is "
                "larger; raise max_delay_s"]
    return []


def fit_rational(w_rad_s, response, *, n_poles: int, n_zeros: int, delay: bool = False, weights=None,
                 variance=None, enforce_stability: bool = True, max_delay_s: float | None = None) -> RationalFit:
    """Fit an ``n_poles``/``n_zeros`` rational model (optionally with a delay) to the complex
    ``response`` at ``w_rad_s`` (rad/s).

    ``variance``: E|G_hat - G|^2 per frequency (as ``MeasuredResponse.variance``), enables the
    chi-square flag and the default weighting 1/sigma. ``weights``: None (1/sigma with a variance,
    else uniform), ``"uniform"``, ``"thesis"`` (Appendix B), ``"inverse_sigma"`` or an array
    multiplying the error at each frequency. ``max_delay_s`` bounds the delay (default one period
    of the highest frequency). Each start of the module docstring is refined; the lowest weighted
    cost is kept."""
    w = check_grid(w_rad_s, name="fit_rational frequencies")
    g = np.asarray(response)
    if g.shape != w.shape:
        raise DataError(f"response must have one value per frequency ({w.size}), got shape {g.shape}")
    if not np.all(np.isfinite(g)):
        raise DataError(f"response contains NaN or infinite values (first at index {int(np.argmax(~np.isfinite(g)))})")
    g = g.astype(complex)
    n, m = check_count("n_poles", n_poles), check_count("n_zeros", n_zeros)
    if n < 0 or m < 0 or m > n:
        raise ParameterError(f"need 0 <= n_zeros <= n_poles, got n_poles={n_poles}, n_zeros={n_zeros}")
    var = _check_variance(variance, w)
    wt, weighting = _check_weights(weights, w, var)
    n_unknown = n + m + 1 + int(delay)
    if n_unknown > 2 * int(np.count_nonzero(wt > 0)):
        raise DataError(f"{n_unknown} unknowns but only {int(np.count_nonzero(wt > 0))} weighted frequencies "
                        "(2 real equations each)")
    tau_max = float(max_delay_s) if max_delay_s is not None else 2 * np.pi / w[-1]
    if delay and not (np.isfinite(tau_max) and tau_max > 0):
        raise ParameterError(f"max_delay_s must be positive, got {max_delay_s!r}")

    problem = _Problem(w, g, wt, n, m, delay, tau_max)
    tau0, iterations = problem.delay_start()
    starts = problem.starts(tau0, var)
    best = min((problem.refine(name, a0, tau0, enforce_stability) for name, a0 in starts), key=lambda c: c.cost)

    # back to rad/s: D(s) = sum a_k (s/w0)^k + (s/w0)^n -> multiply by w0^n for a monic polynomial
    w0 = problem.w0
    den = np.concatenate([[1.0], (best.a * w0 ** (n - np.arange(n)))[::-1]])
    num = (best.b * w0 ** (n - np.arange(m + 1)))[::-1]
    fit = problem.model(best.b, best.a, best.tau)
    chi2, dof, chi2_p, chi2_flags = _chi2(g, fit, wt, var, n_unknown)
    flags = _order_flags(num, den, w) + (_delay_flags(best.tau, tau_max) if delay else [])
    if best.reflected:
        flags.append("unstable poles reflected into the left half-plane: the result is not a least-squares "
                     "optimum; the data ask for an unstable model or a different order or delay")
    if not best.converged:
        flags.append(f"optimiser did not converge: {best.message}")
    flags += chi2_flags
    spread = np.linalg.norm(g - g.mean())
    fit_percent = float(100 * (1 - np.linalg.norm(g - fit) / spread)) if spread > 0 else float("nan")
    return RationalFit(tf=control.tf(num, den), num=num, den=den, delay_s=best.tau, n_poles=n, n_zeros=m,
                       weights=wt, fit_percent=fit_percent, cost=best.cost, mse=best.cost / w.size,
                       sk_iterations=iterations, stable=bool(np.all(np.roots(den).real < 0)),
                       success=best.converged and not flags,
                       message=(f"the optimiser converged: {best.message.rstrip('.')}; {len(flags)} flag(s) below"
                                if best.converged and flags else best.message), flags=tuple(flags),
                       weighting=weighting, chi2=chi2, dof=dof, chi2_p=chi2_p, start=best.start,
                       n_starts=len(starts), delay=delay, n_data=2 * int(np.count_nonzero(wt > 0)),
                       n_params=n_unknown)
