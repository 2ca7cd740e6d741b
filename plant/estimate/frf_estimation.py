"""Frequency responses from time records of any excitation, with calibrated uncertainty.

Three nonparametric estimators turn a ``TimeRecording`` into a ``MeasuredResponse`` (velocity
per current, m/s per A, with E|G_hat - G|^2 per point and its real degrees of freedom
``metadata["variance_dof"]``, which ``plant.identify.fitting.fit_plant`` uses):

``periodic_response``
    Periodic excitation (multisine, repeated chirp). The record is cut into whole periods, the
    first ``transient_periods`` dropped, each remaining period transformed by the DFT, and at
    the excited lines G_k = Y_bar(k) / U_bar(k), the ratio of the period means (Pintelon &
    Schoukens, "System Identification: A Frequency Domain Approach", 2nd ed. 2012, chapter 2).
    The ratio of means averages the noise before dividing, so noise on the measured
    current biases it only by O(1 / (P SNR_u)); the mean of per-period ratios keeps the full
    errors-in-variables bias of one period and, 1 / U being heavy-tailed, can have no finite
    variance. The variance comes from the scatter between the P periods: with
    e_p = (Y_p - G_hat U_p) / U_bar, var(G_hat) = sum_p |e_p|^2 / (P (P - 1)) -- the first-order
    variance of the ratio, sigma_Y^2/|U|^2 + |G|^2 sigma_U^2/|U|^2 - 2 Re(conj(G) sigma_YU)/|U|^2
    over P -- with nu = 2 (P - 1) real degrees of freedom. The output at the lines not excited
    measures the nonlinear distortion (odd and even lines of an odd multisine, chapter 3 of
    the book) against the same noise level.

``lpm_response``
    Non-periodic excitation (a single chirp, PRBS, noise, operating data): the local polynomial
    method (Pintelon, Schoukens, Vandersteen, Barbe 2010, "Estimation of nonparametric noise and
    FRF models for multivariable systems -- Part I: Theory", MSSP 24(3) 573-595, Part II 596-616).
    Around DFT line k of the whole record, Y(k+r) = G_k(r) U(k+r) + T_k(r) + V(k+r) for
    r = -n .. n, with G_k and the leakage (transient) term T_k polynomials of degree ``order`` in
    r, is solved by least squares; G_hat(k) = G_k(0). The noise variance is the residual's
    power over q = 2n + 1 - 2 (order + 1) (the residual's complex degrees of freedom), and
    var(G_hat) = sigma_V^2 [(K^H K)^-1]_00 with nu = 2 q. Points are evaluated at log-spaced
    lines whose windows do not overlap, so their errors are independent.

``closed_loop_response``
    Closed loop with a known reference r: G = G_yr / G_ur, each estimated against r (periodic
    or LPM), with the first-order variance including the covariance of the two estimates.

``estimate_frf`` chooses among them. Outputs in position (m) give the velocity response
j w G_position, exact for the continuous-time response at each line. Errors are
``plant.errors.DataError`` naming the recording (``rec.source``) and what is wrong.
"""

from __future__ import annotations

import dataclasses
import inspect
import math

import numpy as np
import scipy.special

from plant.data.frequency_response import MeasuredResponse
from plant.data.recordings import SAMPLING_TOLERANCE, TimeRecording
from plant.errors import DataError

#: fewest samples of a record
MIN_SAMPLES = 64
#: normalised autocorrelation the input must reach at its period to count as periodic
PERIODIC_CORRELATION = 0.9
#: a line is excited when |U_bar|^2 exceeds this multiple of the noise variance of U_bar
#: (median over the lines of its scatter between periods): 20 dB, far above chance (e^-100)
EXCITED_POWER_RATIO = 100.0
#: ... and this fraction of the strongest line's power (rounding of an exactly periodic input)
NUMERICAL_FLOOR = 1e-10
#: fewest periods ``estimate_frf`` needs to choose the periodic method
MIN_AUTO_PERIODS = 3
#: false-alarm probability of the nonlinear-distortion test per output and kind of line
DISTORTION_P = 1e-3
#: most frequency bands the distortion is reported in
DISTORTION_BANDS = 8
#: the LPM evaluates lines whose local input power is at least this fraction of the strongest
LPM_POWER_FLOOR = 1e-4
#: ... and whose input power per line that the transient cannot take is EXCITED_POWER_RATIO times the
#: input's noise floor, this quantile of the local input power over the record's lines (an upper bound of the
#: noise: a record sampled faster than its excitation has a band of floor)
LPM_FLOOR_QUANTILE = 0.02
#: default number of LPM points
LPM_POINTS = 100
#: an LPM window whose normalised regressor has a larger condition number is not evaluated
#: (too few lines with input energy to separate G from the transient, e.g. a multisine's gaps)
LPM_MAX_CONDITION = 1e8
#: relative standard error of G_ur above which the closed-loop ratio's first-order variance is flagged
RATIO_RELATIVE_ERROR = 0.1


# --- checks -----------------------------------------------------------------------------
def _check_record(rec: TimeRecording, signal: np.ndarray | None = None, what: str = "input current") -> float:
    """Sample rate (Hz) after checking uniform sampling, length and a moving ``signal``."""
    if rec.n_samples < MIN_SAMPLES:
        raise DataError(f"{rec.source}: {rec.n_samples} samples, an estimate needs at least {MIN_SAMPLES}")
    dt = np.diff(rec.time_s)
    med = float(np.median(dt))
    if not med > 0 or np.any(np.abs(dt - med) > SAMPLING_TOLERANCE * med):
        worst = float(dt[np.argmax(np.abs(dt - med))])
        raise DataError(f"{rec.source}: sampling is not uniform (interval {worst:g} s against the median "
                        f"{med:g} s)")
    x = rec.current_a if signal is None else signal
    if not np.all(np.isfinite(x)) or not np.all(np.isfinite(rec.output)):
        raise DataError(f"{rec.source}: the record holds non-finite samples")
    if np.std(x) <= 1e-12 * np.max(np.abs(x), initial=0.0) or np.ptp(x) == 0:
        raise DataError(f"{rec.source}: the {what} is constant; it excites nothing")
    return 1.0 / med


def _range_mask(f_hz: np.ndarray, f_range_hz, source: str) -> np.ndarray:
    if f_range_hz is None:
        return np.ones(f_hz.shape, dtype=bool)
    lo, hi = (float(v) for v in f_range_hz)
    if not 0 <= lo < hi:
        raise DataError(f"{source}: f_range_hz must be (low, high) with 0 <= low < high, got {f_range_hz!r}")
    return (f_hz >= lo) & (f_hz <= hi)


def _autocorrelation(x: np.ndarray) -> np.ndarray:
    """Normalised autocorrelation rho(L), L = 0 .. n // 2, of ``x`` about its mean, each lag over
    its overlapping samples: sum x[t] x[t+L] / sqrt(sum x[:n-L]^2 sum x[L:]^2)."""
    x = x - x.mean()
    n = x.size
    nfft = 1 << (2 * n - 1).bit_length()
    spec = np.fft.rfft(x, nfft)
    acf = np.fft.irfft(spec * spec.conj(), nfft)[: n // 2 + 1]
    energy = np.concatenate(([0.0], np.cumsum(x * x)))
    lag = np.arange(n // 2 + 1)
    denom = np.sqrt(energy[n - lag] * (energy[n] - energy[lag]))
    return acf / np.where(denom > 0, denom, np.inf)


def detect_period(x: np.ndarray, source: str = "<memory>", what: str = "input") -> int:
    """Period of ``x`` in samples: the first peak of its normalised autocorrelation after the main
    lobe (the first zero crossing), if it reaches ``PERIODIC_CORRELATION``; periods up to half the
    record are found. A DataError when ``x`` does not repeat."""
    rho = _autocorrelation(np.asarray(x, dtype=float))
    crossing = np.flatnonzero(rho[1:] <= 0)
    if crossing.size:
        start = int(crossing[0]) + 1
        high = np.flatnonzero(rho[start:] >= PERIODIC_CORRELATION)
        if high.size:
            first = start + int(high[0])
            stop = first
            while stop + 1 < rho.size and rho[stop + 1] >= PERIODIC_CORRELATION:
                stop += 1
            return first + int(np.argmax(rho[first:stop + 1]))
    raise DataError(f"{source}: the {what} is not periodic (it does not repeat within half the record; "
                    f"autocorrelation after the main lobe at most {np.max(rho[1:], initial=0.0):.2f})")


def _period_samples(x: np.ndarray, fs: float, period_s, rec: TimeRecording, what: str) -> int:
    if period_s is None:
        return detect_period(x, rec.source, what)
    samples = float(period_s) * fs
    if not samples > 0 or abs(samples - round(samples)) > 0.01:
        raise DataError(f"{rec.source}: period {period_s!r} s is not a whole number of samples at {fs:g} Hz "
                        f"({samples:g})")
    if round(samples) > rec.n_samples / 2:
        raise DataError(f"{rec.source}: period {period_s:g} s is longer than half the record "
                        f"({rec.duration_s:g} s)")
    if round(samples) < 2:
        raise DataError(f"{rec.source}: period {period_s!r} s is shorter than two samples")
    return int(round(samples))


# --- periodic -----------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class _Periodic:
    """Period means and per-period DFTs of one input x and outputs z (m of them), excited lines."""

    lines: np.ndarray        # excited DFT lines (within the range), (K,)
    f_hz: np.ndarray         # (K,)
    x_mean: np.ndarray       # (K,)
    g: np.ndarray            # z_mean / x_mean, (m, K)
    cov: np.ndarray          # E[dG_i conj(dG_j)], (m, m, K)
    periods: int
    z_bar_all: np.ndarray    # every line's output period mean, (m, N // 2 + 1)
    z_var_all: np.ndarray    # its noise variance from the scatter, (m, N // 2 + 1)
    excited_all: np.ndarray  # bool, every line, (N // 2 + 1,)
    notes: tuple[str, ...] = ()


def _periodic_core(x, z, n_period: int, transient: int, fs: float, f_range_hz, source: str) -> _Periodic:
    n_total = x.size // n_period
    periods = n_total - int(transient)
    if transient < 0:
        raise DataError(f"{source}: transient_periods must be >= 0, got {transient}")
    if periods < 2:
        raise DataError(f"{source}: {n_total} whole periods of {n_period / fs:g} s; with {transient} dropped as "
                        f"transient fewer than the 2 the variance needs")
    seg = slice(transient * n_period, n_total * n_period)
    xp = np.fft.rfft(x[seg].reshape(periods, n_period), axis=-1)
    zp = np.fft.rfft(z[:, seg].reshape(z.shape[0], periods, n_period), axis=-1)
    x_bar, z_bar = xp.mean(axis=0), zp.mean(axis=1)
    k = np.arange(x_bar.size)
    inner = (k > 0) & (2 * k != n_period)
    x_noise = np.var(xp, axis=0, ddof=1).real / periods
    power = np.abs(x_bar) ** 2
    floor = float(np.median(x_noise[inner]))
    excited_all = inner & (power > EXCITED_POWER_RATIO * floor) & (power > NUMERICAL_FLOOR * power[inner].max())
    f_all = k * fs / n_period
    excited = excited_all & _range_mask(f_all, f_range_hz, source)
    if not excited.any():
        where = "" if f_range_hz is None else f" in {f_range_hz[0]:g}..{f_range_hz[1]:g} Hz"
        raise DataError(f"{source}: no excited line{where} (input power at most {EXCITED_POWER_RATIO:g} x its noise)")
    lines = k[excited]
    g = z_bar[:, lines] / x_bar[lines]
    e = (zp[:, :, lines] - g[:, None, :] * xp[None, :, lines]) / x_bar[lines]
    cov = np.einsum("ipk,jpk->ijk", e, e.conj()) / (periods * (periods - 1))
    z_var = np.var(zp, axis=1, ddof=1).real / periods
    return _Periodic(lines, f_all[lines], x_bar[lines], g, cov, periods, z_bar, z_var, excited_all)


def _distortion(core: _Periodic, names, n_period: int, fs: float) -> tuple[dict, dict, list[str]]:
    """Output power at the lines not excited, between the lowest and highest excited line, over the
    noise level from the scatter between periods, in log-spaced bands; the pooled ratio in a band
    of M lines is F(2M, 2M(P - 1)) distributed for a linear system, tested at ``DISTORTION_P``
    (Bonferroni over the bands). Lines are classed odd / even when the excitation is an odd
    multisine (only odd lines excited), else all together as "non-excited"."""
    k = np.arange(core.excited_all.size)
    lo, hi = core.lines.min(), core.lines.max()
    free = (~core.excited_all) & (k > lo) & (k < hi)
    odd_only = bool(np.all(core.lines % 2 == 1))
    kinds = {"odd": free & (k % 2 == 1), "even": free & (k % 2 == 0)} if odd_only else {"non-excited": free}
    edges = np.unique(np.round(np.geomspace(lo, hi + 1, DISTORTION_BANDS + 1)).astype(int))
    levels, significant, notes = {}, {}, []
    dof = 2 * (core.periods - 1)
    for i, name in enumerate(names):
        levels[name], significant[name] = {}, {}
        for kind, mask in kinds.items():
            bands = []
            for a, b in zip(edges[:-1], edges[1:]):
                sel = mask & (k >= a) & (k < b)
                m = int(sel.sum())
                if m == 0:
                    continue
                ratio = float(np.sum(np.abs(core.z_bar_all[i, sel]) ** 2) / np.sum(core.z_var_all[i, sel]))
                bands.append({"f_lo_hz": a * fs / n_period, "f_hi_hz": (b - 1) * fs / n_period, "lines": m,
                              "level_db": 10 * math.log10(ratio) if ratio > 0 else -math.inf,
                              "p_value": float(scipy.special.fdtrc(2 * m, m * dof, ratio))})
            levels[name][kind] = bands
            hit = [band for band in bands if band["p_value"] < DISTORTION_P / len(bands)]
            significant[name][kind] = bool(hit)
            if hit:
                worst = max(hit, key=lambda band: band["level_db"])
                notes.append(f"output {name}: nonlinear distortion at the {kind} lines not excited, up to "
                             f"{worst['level_db']:.1f} dB above the noise "
                             f"({worst['f_lo_hz']:g}..{worst['f_hi_hz']:g} Hz)")
    return levels, significant, notes


def _velocity(g, cov, f_hz, kind):
    """Position responses (m per A) to velocity (m/s per A): times j w, covariance times w^2."""
    if kind == "velocity":
        return g, cov
    jw = 2j * np.pi * f_hz
    return g * jw, cov * (2 * np.pi * f_hz) ** 2


def _result(rec, f_hz, g, var, amplitude, method, metadata, notes) -> MeasuredResponse:
    var = np.real(var)
    with np.errstate(divide="ignore"):
        snr = 10 * np.log10(np.abs(g) ** 2 / var)
    return MeasuredResponse(
        f_hz=f_hz, response=g, variance=var, output_names=tuple(rec.output_names),
        current_amplitude_a=amplitude, snr_db=snr, harmonic_distortion=np.full(g.shape + (2,), np.nan),
        source=rec.source, method=method, metadata=metadata, notes=tuple(notes))


def periodic_response(rec: TimeRecording, *, period_s: float | None = None, transient_periods: int = 1,
                      f_range_hz: tuple[float, float] | None = None) -> MeasuredResponse:
    """Frequency response from a periodic excitation (see the module doc).

    ``period_s``: the excitation's period (s), a whole number of samples; detected from the
    current's autocorrelation when None (``detect_period``: whole samples, up to half the
    record). The first ``transient_periods`` periods are dropped and at least 2 must remain.
    ``f_range_hz``: keep excited lines in (low, high) Hz.

    Returns the excited lines with G (m/s per A), var = E|G_hat - G|^2 from the scatter between
    periods, ``snr_db`` = |G|^2 / var, ``current_amplitude_a`` the current's amplitude at each
    line (A). ``metadata``: ``period_s``, ``periods`` (P used), ``sample_rate_hz``,
    ``variance_dof`` (2 (P - 1) per point), ``distortion`` (per output and kind of line not
    excited: bands with ``f_lo_hz``, ``f_hi_hz``, ``lines``, ``level_db`` above the noise and
    ``p_value``) and ``distortion_significant``; a note names significant distortion.
    ``harmonic_distortion`` is NaN (a multisine has no harmonics per line).
    """
    fs = _check_record(rec)
    n_period = _period_samples(rec.current_a, fs, period_s, rec, "input current")
    core = _periodic_core(rec.current_a, rec.output, n_period, int(transient_periods), fs, f_range_hz, rec.source)
    levels, significant, notes = _distortion(core, rec.output_names, n_period, fs)
    g, cov = _velocity(core.g, core.cov, core.f_hz, rec.output_kind)
    var = np.einsum("iik->ik", cov)
    metadata = {"period_s": n_period / fs, "periods": core.periods, "sample_rate_hz": fs,
                "transient_periods": int(transient_periods),
                "variance_dof": np.full(core.f_hz.size, 2.0 * (core.periods - 1)),
                "distortion": levels, "distortion_significant": significant}
    return _result(rec, core.f_hz, g, var, 2 * np.abs(core.x_mean) / n_period, "periodic", metadata, notes)


# --- local polynomial method -----------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class _Lpm:
    lines: np.ndarray       # evaluated DFT lines, (K,)
    f_hz: np.ndarray        # (K,)
    g: np.ndarray           # (m, K)
    cov: np.ndarray         # (m, m, K)
    coherence: np.ndarray   # (m, K)
    x_amplitude: np.ndarray  # amplitude of a sinusoid with the window's input power, (K,)
    dof: int                # residual's complex degrees of freedom q
    notes: tuple[str, ...]


def _default_bandwidth(order: int) -> int:
    """Half-width n giving q = 2n + 1 - 2 (order + 1) = 2 order + 3 residual degrees of freedom."""
    return 2 * (order + 1)


def _lpm_core(x, z, fs: float, order: int, half: int, f_range_hz, n_freq: int, source: str) -> _Lpm:
    if order < 0:
        raise DataError(f"{source}: the LPM order must be >= 0, got {order}")
    n_par = 2 * (order + 1)
    width = 2 * half + 1
    q = width - n_par
    if q < 1:
        raise DataError(f"{source}: {width} lines per window cannot fit {n_par} LPM coefficients and estimate "
                        f"the noise (bandwidth_lines must exceed {(n_par - 1) // 2})")
    n = x.size
    xf = np.fft.rfft(x)
    zf = np.fft.rfft(z, axis=-1)
    n_lines = xf.size
    k_all = np.arange(n_lines)
    f_all = k_all * fs / n
    if n_lines - 1 - 2 * half <= half + 1:
        raise DataError(f"{source}: {n} samples give too few DFT lines for LPM windows of {width} lines")
    local = np.convolve(np.abs(xf) ** 2, np.ones(width) / width, mode="same")
    valid = (k_all >= half + 1) & (k_all <= n_lines - 2 - half)
    usable = valid & (local >= LPM_POWER_FLOOR * local[valid].max()) & _range_mask(f_all, f_range_hz, source)
    if not usable.any():
        where = "" if f_range_hz is None else f" in {f_range_hz[0]:g}..{f_range_hz[1]:g} Hz"
        raise DataError(f"{source}: no input energy{where} (local power below {LPM_POWER_FLOOR:g} of the strongest)")
    floor = float(np.quantile(local[valid], LPM_FLOOR_QUANTILE))
    candidates = k_all[usable]
    targets = np.geomspace(candidates[0], candidates[-1], max(int(n_freq), 1))
    lines, last = [], -width
    for target in targets:
        i = np.searchsorted(candidates, max(target, last + width))
        if i >= candidates.size:
            break
        last = int(candidates[i])
        if not lines or lines[-1] != last:
            lines.append(last)
    lines = np.array(lines)
    r = np.arange(-half, half + 1)
    poly = (r / max(half, 1))[:, None] ** np.arange(order + 1)           # (L, R+1)
    xw = xf[lines[:, None] + r]                                          # (K, L)
    scale = np.sqrt(np.mean(np.abs(xw) ** 2, axis=1))                    # (K,)
    transient = np.broadcast_to(poly, xw.shape + poly.shape[1:])
    design = np.concatenate([(xw / scale[:, None])[:, :, None] * poly, transient], axis=2)  # (K, L, n_par)
    gram = np.einsum("kla,klb->kab", design.conj(), design)
    conditioned = np.linalg.cond(gram) < LPM_MAX_CONDITION
    notes = []
    if not conditioned.all():
        if not conditioned.any():
            raise DataError(f"{source}: no LPM window of {width} lines has enough lines with input energy to "
                            f"separate G from the transient (a multisine with gaps needs the periodic method)")
        notes.append(f"{int(np.sum(~conditioned))} of {lines.size} LPM points left out: too few lines with input "
                     f"energy in their window")
        lines, xw, scale, design, gram = (a[conditioned] for a in (lines, xw, scale, design, gram))
    gram_inv = np.linalg.inv(gram)
    # the input power per line the transient's polynomials do not explain (the Schur complement) against the
    # noise floor: below a chirp's start the input is the smooth leakage of the record's ends, which the
    # transient takes, plus the current's measurement noise, on which G would be regressed (errors in
    # variables: a confident estimate biased towards 0)
    usable_power = scale**2 / gram_inv[:, 0, 0].real / (q + 1)
    # (no point above: the input is as broadband as the record, its floor is its excitation)
    excited = usable_power > EXCITED_POWER_RATIO * floor
    if excited.any() and not excited.all():
        notes.append(_left_out(f_all[lines], excited))
        lines, xw, scale, design, gram_inv = (a[excited] for a in (lines, xw, scale, design, gram_inv))
    zw = zf[:, lines[:, None] + r]                                       # (m, K, L)
    theta = np.einsum("kab,klb,mkl->mka", gram_inv, design.conj(), zw)  # (m, K, n_par)
    resid = zw - np.einsum("kla,mka->mkl", design, theta)
    sigma = np.einsum("ikl,jkl->ijk", resid, resid.conj()) / q           # (m, m, K)
    g = theta[:, :, 0] / scale
    cov = sigma * gram_inv[:, 0, 0].real / scale ** 2
    signal = np.einsum("kla,mka->mkl", design[:, :, : order + 1], theta[:, :, : order + 1])
    s_pow = np.mean(np.abs(signal) ** 2, axis=2)
    noise = np.einsum("iik->ik", sigma).real
    coherence = s_pow / (s_pow + noise)
    return _Lpm(lines, f_all[lines], g, cov, coherence, 2 * scale / n, q, tuple(notes))


def _left_out(f_hz: np.ndarray, kept: np.ndarray) -> str:
    """A note naming the points (frequencies ``f_hz``) not ``kept`` as not excited, by where they lie."""
    inside = f_hz[kept]
    low, high = ~kept & (f_hz < inside[0]), ~kept & (f_hz > inside[-1])
    parts = [f"{int(low.sum())} below {inside[0]:.3g} Hz"] if low.any() else []
    parts += [f"{int(high.sum())} above {inside[-1]:.3g} Hz"] if high.any() else []
    between = int((~kept & ~low & ~high).sum())
    parts += [f"{between} between {inside[0]:.3g} and {inside[-1]:.3g} Hz"] if between else []
    return (f"{int((~kept).sum())} of {kept.size} LPM points not excited, left out ({', '.join(parts)}): input power "
            f"that a transient does not explain within {10 * math.log10(EXCITED_POWER_RATIO):.0f} dB of the "
            f"input's noise floor")


def lpm_response(rec: TimeRecording, *, order: int = 2, bandwidth_lines: int | None = None,
                 f_range_hz: tuple[float, float] | None = None, n_freq: int | None = None) -> MeasuredResponse:
    """Frequency response from a non-periodic excitation by the local polynomial method (module doc).

    ``order``: degree of the local polynomials of G and of the transient; ``bandwidth_lines``: n,
    the window is 2n + 1 DFT lines of the whole record (default 2 (order + 1), leaving
    q = 2 order + 3 complex residual degrees of freedom); ``n_freq``: number of log-spaced target
    points (default ``LPM_POINTS``), fewer where non-overlapping windows do not fit;
    ``f_range_hz``: (low, high) Hz, which narrows the excited band and never widens it. Lines whose input
    power over the window is below ``LPM_POWER_FLOOR`` of the strongest window's are not evaluated, nor
    points whose input power per line that the transient's polynomials cannot take (the Schur complement
    of the window's regression) is within ``EXCITED_POWER_RATIO`` of the input's noise floor (the
    ``LPM_FLOOR_QUANTILE`` quantile of the local input power): the leakage below a chirp's start and its
    current's measurement noise. A note counts the points left out and says where they lie.

    Returns G (m/s per A) with var = sigma_V^2 [(K^H K)^-1]_00 and ``metadata``:
    ``variance_dof`` (2 q per point), ``coherence`` (per output and point: power of G U over the
    window over that plus sigma_V^2), ``order``, ``bandwidth_lines``, ``sample_rate_hz``.
    ``current_amplitude_a`` is the amplitude (A) of a sinusoid with the window's mean input
    power per line.
    """
    fs = _check_record(rec)
    half = _default_bandwidth(order) if bandwidth_lines is None else int(bandwidth_lines)
    core = _lpm_core(rec.current_a, rec.output, fs, int(order), half, f_range_hz,
                     LPM_POINTS if n_freq is None else n_freq, rec.source)
    g, cov = _velocity(core.g, core.cov, core.f_hz, rec.output_kind)
    metadata = {"variance_dof": np.full(core.f_hz.size, 2.0 * core.dof), "coherence": core.coherence,
                "order": int(order), "bandwidth_lines": half, "sample_rate_hz": fs}
    return _result(rec, core.f_hz, g, np.einsum("iik->ik", cov), core.x_amplitude, "lpm", metadata, core.notes)


# --- closed loop -------------------------------------------------------------------------------
def closed_loop_response(rec: TimeRecording, *, period_s: float | None = None, transient_periods: int = 1,
                         f_range_hz: tuple[float, float] | None = None, order: int = 2,
                         bandwidth_lines: int | None = None, n_freq: int | None = None) -> MeasuredResponse:
    """Plant response from closed-loop data with a known reference (indirect method).

    In a loop u = C (r - y - n), y = G u + v, the sensor noise n and process noise v are fed
    back into the current u, so the noise in u is correlated with the noise in y. With sensor
    noise alone, regressing y on u (H1, LPM on u) converges to
    (G S_rr - S_nn / C) / (S_rr + S_nn) (spectra of r and n): towards -1/C where the noise
    dominates. The reference r is set by the experimenter and uncorrelated
    with n and v, so the responses r -> y and r -> u estimated against r are unbiased, and their
    ratio G = G_yr / G_ur = (G S C) / (S C) is consistent (Pintelon & Schoukens 2012, chapter 2,
    FRF measurement in feedback; the "joint input-output" approach). Both are estimated by the periodic
    method when the reference repeats (``MIN_AUTO_PERIODS`` or more periods, or ``period_s``
    given; the ratio is then exactly Y_bar / U_bar of the period means), by the LPM otherwise,
    with the same regressor for y and u, so their errors' covariance is known. First order,
    dG = (dG_yr - G dG_ur) / G_ur and

        var(G) = (C_yy + |G|^2 C_uu - 2 Re(conj(G) C_yu)) / |G_ur|^2,

    C_yu = E[dG_yr conj(dG_ur)], with the real degrees of freedom of the scatter (2 (P - 1)) or
    of the LPM residual (2 q). First order needs G_ur known to a few percent; points where its
    relative standard error exceeds ``RATIO_RELATIVE_ERROR`` are counted in a note (there the
    reported variance overstates the error: with G_ur known to 25 %, by about a third).
    Keywords as ``periodic_response`` and ``lpm_response``. ``metadata["estimator"]`` is
    "periodic" or "lpm"; ``metadata["reference_to_current"]`` is G_ur (A per reference unit).
    """
    if rec.reference is None:
        raise DataError(f"{rec.source}: closed-loop estimation needs the loop's reference; the record has none")
    fs = _check_record(rec, rec.reference, "reference")
    _check_record(rec)
    z = np.vstack([rec.output, rec.current_a[None, :]])
    n_period = None
    if period_s is not None:
        n_period = _period_samples(rec.reference, fs, period_s, rec, "reference")
    else:
        try:
            n_period = detect_period(rec.reference, rec.source, "reference")
        except DataError:
            n_period = None
        if n_period is not None and rec.n_samples // n_period < MIN_AUTO_PERIODS:
            n_period = None
    metadata = {"sample_rate_hz": fs}
    if n_period is not None:
        core = _periodic_core(rec.reference, z, n_period, int(transient_periods), fs, f_range_hz, rec.source)
        dof = 2.0 * (core.periods - 1)
        amplitude = 2 * np.abs(core.g[-1] * core.x_mean) / n_period
        metadata.update(estimator="periodic", period_s=n_period / fs, periods=core.periods,
                        transient_periods=int(transient_periods))
    else:
        half = _default_bandwidth(order) if bandwidth_lines is None else int(bandwidth_lines)
        core = _lpm_core(rec.reference, z, fs, int(order), half, f_range_hz,
                         LPM_POINTS if n_freq is None else n_freq, rec.source)
        dof = 2.0 * core.dof
        amplitude = np.abs(core.g[-1]) * core.x_amplitude
        metadata.update(estimator="lpm", order=int(order), bandwidth_lines=half)
    g_y, g_u = core.g[:-1], core.g[-1]
    g = g_y / g_u
    c_yy = np.einsum("iik->ik", core.cov[:-1, :-1]).real
    c_uu = core.cov[-1, -1].real
    c_yu = core.cov[:-1, -1]
    var = (c_yy + np.abs(g) ** 2 * c_uu - 2 * np.real(g.conj() * c_yu)) / np.abs(g_u) ** 2
    cov = np.zeros((g.shape[0], g.shape[0], g.shape[1]))
    cov[np.arange(g.shape[0]), np.arange(g.shape[0])] = var
    g, cov = _velocity(g, cov, core.f_hz, rec.output_kind)
    metadata.update(variance_dof=np.full(core.f_hz.size, dof), reference_to_current=g_u)
    relative = np.sqrt(c_uu) / np.abs(g_u)
    notes = list(core.notes)
    if np.any(relative > RATIO_RELATIVE_ERROR):
        notes.append(f"{int(np.sum(relative > RATIO_RELATIVE_ERROR))} of {relative.size} points have the reference-to-"
                     f"current response known only to {relative.max():.0%} (above {RATIO_RELATIVE_ERROR:.0%}); "
                     f"the first-order variance of the ratio is unreliable there")
    return _result(rec, core.f_hz, g, np.einsum("iik->ik", cov), amplitude, "closed-loop", metadata, notes)


# --- dispatch --------------------------------------------------------------------------------------
_METHODS = {"periodic": periodic_response, "lpm": lpm_response, "closed-loop": closed_loop_response}


def estimate_frf(rec: TimeRecording, *, method: str = "auto", **kw) -> MeasuredResponse:
    """Frequency response by ``method``: "periodic", "lpm", "closed-loop" or "auto".

    "auto" takes the closed-loop estimate when the record has a reference, the periodic one when
    the current repeats with at least ``MIN_AUTO_PERIODS`` whole periods (or ``period_s`` is
    given), the LPM otherwise; keywords the chosen estimator does not take are ignored under
    "auto" (they belong to another estimator) and refused otherwise. The first note names the
    method and why.
    """
    if method not in ("auto", *_METHODS):
        raise DataError(f"{rec.source}: unknown method {method!r}; use auto, periodic, lpm or closed-loop")
    if method != "auto":
        return _with_note(_METHODS[method](rec, **kw), f"method {method}: requested")
    known = set().union(*(inspect.signature(f).parameters for f in _METHODS.values())) - {"rec"}
    unknown = set(kw) - known
    if unknown:
        raise DataError(f"{rec.source}: unknown estimator option {sorted(unknown)[0]!r}")
    if rec.reference is not None:
        chosen, why = "closed-loop", "the record has the loop's reference"
    elif kw.get("period_s") is not None:
        chosen, why = "periodic", f"period {kw['period_s']:g} s given"
    else:
        _check_record(rec)
        try:
            n_period = detect_period(rec.current_a, rec.source, "input current")
        except DataError:
            n_period = None
        periods = 0 if n_period is None else rec.n_samples // n_period
        if periods >= MIN_AUTO_PERIODS:
            chosen = "periodic"
            why = f"the current repeats every {n_period / rec.sample_rate_hz:g} s ({periods} whole periods)"
            kw = {**kw, "period_s": n_period / rec.sample_rate_hz}
        elif n_period is None:
            chosen, why = "lpm", "the current is not periodic"
        else:
            chosen, why = "lpm", f"the current repeats only {periods} times (fewer than {MIN_AUTO_PERIODS})"
    fn = _METHODS[chosen]
    accepted = inspect.signature(fn).parameters
    result = fn(rec, **{k: v for k, v in kw.items() if k in accepted})
    return _with_note(result, f"method {chosen}: {why}")


def _with_note(result: MeasuredResponse, note: str) -> MeasuredResponse:
    return dataclasses.replace(result, notes=(note, *result.notes))
