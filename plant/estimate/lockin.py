"""Frequency response from stepped-sine recordings by lock-in detection (thesis section 4.1).

Per block: drop the start-up transient (``settling_time_s``), fit the known-frequency
sinusoid with a constant offset and the 2nd and 3rd harmonics by least squares over every
sample after settling -- whole and partial periods alike: the basis at the known frequency
needs no whole number of periods, and the fit is exact on a clean sinusoid whatever the
window -- to the current and to every velocity output, and take G = V / I. A transient still
significant after settling (a block too short to see it decay) is fitted with the sinusoid as an
exponential decay (``_with_transient``), its time constant's uncertainty in the variance.

Uncertainty: the fitted window is cut into ``subblocks`` sub-blocks of whole half periods
(whole periods below ``MIN_SEGMENT_SAMPLES`` samples per period) counted back from the end of
the block, a leading partial half period joining the first; the variance E|G_hat - G|^2 is the
delete-one-sub-block jackknife of G (for equal sub-blocks exactly the variance of sub-block
estimates divided by their number; refitting offset and harmonics without each sub-block
keeps it unbiased where separate half-period fits are not), scaled by its exact white-noise
bias for this design (``_white_noise_factor``: 1 over whole periods). It covers current noise,
coloured noise near the excitation and drifts, with nu = 2 (k - 1) real degrees of freedom for
k sub-blocks (``metadata["subblocks"]``). A short block gets fewer sub-blocks, never sub-blocks
shorter than half a period. Below ``MIN_SCATTER_SUBBLOCKS`` sub-blocks (nu < 10) the scatter's own
variance is too large to weight a fit by (1/var of an estimate with nu = 2 or 4 degrees of freedom
has an infinite or enormous mean), so such a block's variance is the white-noise prediction from
its fit residual, gain * (s_v^2 + |G|^2 s_i^2) / |I|^2 with the residual mean squares s^2 over
n - p degrees of freedom; the note says so. ``metadata["variance_dof"]`` gives each block's nu. A block needs at least
``MIN_PERIODS`` period after settling, and every fit without one sub-block needs twice as many
samples as it has coefficients; otherwise the block is left out with a note.

Data checks per block (``_CurrentCheck``, notes in ``MeasuredResponse.notes``): the current,
the excitation, must be a sinusoid at the block frequency -- its fundamental detected against
its own scatter between sub-blocks (broadband excitation puts only noise-like, inconsistent
content there). A block whose current fails is left out; when most blocks fail, the recording
is broadband data and is refused. An output whose fundamental is not detected (a lightly damped
plant at its antiresonance) is kept and weighted down by its variance, with a note. The
residual of the fit gives the signal-to-noise ratio, the harmonic amplitudes the distortion.
An encoder position differenced at the logging rate is recognised by its velocity lattice
(``encoder_velocity_quantum``).

``method="rms"`` is the thesis's Appendix B estimate: sqrt(2) RMS(v) / (sqrt(2) RMS(i)) over
the whole block, magnitude only; noise, harmonics, offsets and the start-up transient all
inflate it.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import scipy.special

from plant.data.frequency_response import MeasuredResponse
from plant.data.lattice import lattice_step
from plant.data.recordings import Block, Recording
from plant.errors import DataError

#: default number of sub-blocks for the variance of each point
SUBBLOCKS = 10
#: the transient is searched for in whole periods and never cut shorter than this many seconds
MIN_SETTLE_S = 0.05
#: a harmonic is fitted and reported only below this fraction of the sample rate (else aliased)
HARMONIC_LIMIT = 0.45
#: fewest samples in a segment of the settling search
MIN_SEGMENT_SAMPLES = 8
#: fewest samples per period of the excitation a block needs (the fundamental well below Nyquist)
MIN_SAMPLES_PER_PERIOD = 4
#: fewest periods (whole or partial) a block must keep after settling
MIN_PERIODS = 1.0
#: false-alarm probability of each per-block test on the data (``_detection_limit``,
#: ``OUTPUT_DETECTION_LIMIT``): about one false finding in 250 recordings of 40 blocks
TEST_P = 1e-4
#: fewest sub-blocks whose scatter gives the variance (nu = 2 (k - 1) >= 10); below, the fit residual does
MIN_SCATTER_SUBBLOCKS = 6
#: an output's fundamental is detected when |V_hat|^2 exceeds this multiple of its white-noise
#: variance (``_phasor_gain`` x the residual's power, known to thousands of degrees of freedom):
#: without a sinusoid, |V_hat|^2 / var is exponential with mean 1, beyond ln(1 / TEST_P) with
#: probability TEST_P
OUTPUT_DETECTION_LIMIT = math.log(1 / TEST_P)


def _basis(t_s: np.ndarray, f_hz: float, harmonics: tuple[int, ...]) -> np.ndarray:
    """Columns 1, cos(h w t), sin(h w t) for h = 1 .. ``harmonics[-1]`` (consecutive from 1):
    shape (n_samples, 1 + 2 len(harmonics)); the harmonics as powers of e^{j w t}."""
    z = np.exp(2j * np.pi * f_hz * t_s)
    B = np.empty((t_s.size, 1 + 2 * len(harmonics)))
    B[:, 0] = 1.0
    zh = z
    for k in range(len(harmonics)):
        B[:, 1 + 2 * k], B[:, 2 + 2 * k] = zh.real, zh.imag
        zh = zh * z
    return B


def _segment_fundamentals(cos_sin, signals, starts):
    """Least-squares fundamental phasor a (x ~ Re(a e^{j w t})) of every row of ``signals``
    (n_signals, n_samples), no offset, on every segment beginning at the sample indices
    ``starts`` (each runs to the next start, the last to the end), from the basis columns
    ``cos_sin`` (n_samples, 2): shape (n_segments, n_signals). The normal equations of all
    segments are summed with one ``np.add.reduceat``."""
    A = np.add.reduceat(cos_sin[:, :, None] * cos_sin[:, None, :], starts, axis=0)
    rhs = np.add.reduceat(cos_sin[:, :, None] * signals.T[:, None, :], starts, axis=0)
    coef = np.linalg.solve(A, rhs)
    return coef[:, 0, :] - 1j * coef[:, 1, :]


def _harmonics(f_hz: float, fs: float) -> tuple[int, ...]:
    """Fundamental, 2nd and 3rd harmonic, those aliased by the sampling left out."""
    return tuple(h for h in (1, 2, 3) if h * f_hz <= HARMONIC_LIMIT * fs)


def settling_time_s(block: Block) -> float:
    """Start-up transient (s) estimated from the data; see ``_settling_time``."""
    fs = block.sample_rate_hz
    return _settling_time(block, fs, _basis(block.time_s, block.f_hz, _harmonics(block.f_hz, fs)))[0]


def _settling_time(block: Block, fs: float, basis: np.ndarray) -> tuple[float, bool]:
    """Start-up transient (s) estimated from the data (``basis``: ``_basis`` of the whole block), and whether
    some of it may be left: the block was too short to search (or had a gap), the decay never reached its
    cut, or the cut was capped to keep one period.

    The block's offset and harmonics (fitted over its second half) are removed; segments of
    whole half periods with at least ``MIN_SEGMENT_SAMPLES`` samples each give fundamental
    phasors v_j, i_j; their deviation from the second half's steady relation,
    (v_j - ref i_j) / |I| with ref = sum v_j / sum i_j, is linear in the noise (the ratios
    v_j / i_j are heavy-tailed when the current is noisy). The scatter s_j of
    a segment is the larger of the second half's empirical scatter and the white-noise
    prediction from the fit residual (sigma_v^2 + |ref|^2 sigma_i^2) 4 / (n_j |I|^2), so a few
    segments cannot fake a transient. Where the leading deviations |r_j - ref| / s_j exceed 3,
    their exponential decay is fitted to them and to the next segment's deviation (at least 1,
    the noise level), and the block is cut where the transient left in the
    remaining segments biases their mean by less than 0.1 of its own noise (s / sqrt(n)),
    or at half the block if that point is never reached. Always after the last segment
    beyond 4 s, and at least one segment and ``MIN_SETTLE_S``; at most what leaves the one
    period the estimate needs.
    """
    f, t = block.f_hz, block.time_s
    seg = _segment_s(f, fs)
    n_seg = int(np.floor((t[-1] + 1.0 / fs) / seg + 1e-9))
    cap_s = max(t[-1] + 1.0 / fs - MIN_PERIODS / f, 0.0)
    floor_s = min(max(seg, MIN_SETTLE_S), cap_s)
    if n_seg < 6:
        return floor_s, True
    edges = np.searchsorted(t, np.arange(n_seg + 1) * seg - 0.5 / fs)
    n_j = np.diff(edges)
    if np.any(n_j < 3):                       # a gap in the samples: no estimate from the data
        return floor_s, True
    n, half = edges[-1], edges[n_seg // 2]
    sig = np.vstack([block.current_a, block.velocity_m_per_s])[:, :n]
    B = basis[half:n]                         # fit over the second half: whole half periods
    coef = np.linalg.solve(B.T @ B, B.T @ sig[:, half:].T)
    dof = max(n - half - B.shape[1], 1)
    sigma2 = np.sum((sig[:, half:].T - B @ coef) ** 2, axis=0) / dof
    coef[1:3] = 0.0                           # keep the fundamental, remove offset and harmonics
    a = _segment_fundamentals(basis[:n, 1:3], sig - (basis[:n] @ coef).T, edges[:-1])
    h = n_seg // 2
    if not abs(a[h:, 0].sum()) > 1e-9 * np.sqrt(np.sum(sig[0, half:] ** 2)):
        return floor_s, False                 # no current at the block frequency: nothing to settle against
    ref = a[h:, 1:].sum(axis=0) / a[h:, 0].sum()            # steady-state G of the second half
    current = np.abs(a[h:, 0].mean())
    # deviation of each segment from the steady relation v = ref i, in units of G: linear in the
    # noise (a ratio of per-segment phasors is heavy-tailed when the current is noisy)
    dev = (a[:, 1:] - ref * a[:, :1]) / current             # (n_seg, n_outputs)
    empirical = np.sqrt(np.mean(np.abs(dev[h:]) ** 2, axis=0))
    predicted = np.sqrt(4 * (sigma2[1:] + np.abs(ref) ** 2 * sigma2[0]) / (n_j[:, None] * current**2))
    spread = np.maximum(empirical, predicted) + 1e-9 * np.abs(ref)
    d = np.max(np.abs(dev) / spread, axis=1)  # deviation in units of the per-segment scatter
    outside = np.flatnonzero(d > 4)
    cut = int(outside[-1]) + 1 if outside.size else 0
    lead = np.flatnonzero(d > 3)
    lead = lead[lead == np.arange(lead.size)]      # the leading run of large deviations ...
    unsettled = False
    if lead.size:
        lead = np.arange(lead.size + 1)            # ... and the next segment, at least at the noise level
        slope, intercept = np.polyfit(lead, np.log(np.maximum(d[lead], 1.0)), 1)
        if slope < 0:
            j = np.arange(cut, n_seg - 1)
            left = n_seg - j
            bias = np.exp(intercept + slope * j) / (1 - np.exp(slope)) / left
            ok = np.flatnonzero(bias < 0.1 / np.sqrt(left))
            cut = int(j[ok[0]]) if ok.size else max(cut, n_seg // 2)
            unsettled = not ok.size
    return min(max(cut * seg, floor_s), cap_s), unsettled or max(cut * seg, floor_s) > cap_s


def _segment_s(f_hz: float, fs: float) -> float:
    """Length (s) of a segment of the settling search: whole half periods of ``MIN_SEGMENT_SAMPLES``."""
    return max(math.ceil(MIN_SEGMENT_SAMPLES * 2 * f_hz / fs), 1) * 0.5 / f_hz


def shortest_block_s(f_hz: float, sample_rate_hz: float) -> float:
    """The shortest block (s) at ``f_hz`` whose estimate keeps ``MIN_PERIODS`` after the shortest settling
    (one segment, at least ``MIN_SETTLE_S``): a shorter block is left out, or its settling is cut short
    and its start-up transient biases the estimate."""
    return max(_segment_s(f_hz, sample_rate_hz), MIN_SETTLE_S) + MIN_PERIODS / f_hz


def _whole_half_periods(block: Block, settle_s: float, fs: float) -> tuple[np.ndarray, int]:
    """Samples of the whole half periods that end with the block and start at or after
    ``settle_s`` (a sample stands for [t - 0.5/fs, t + 0.5/fs)), and their number."""
    t_end = block.time_s[-1] + 0.5 / fs
    n_half = int(np.floor((t_end - (max(settle_s, 0.0) - 0.5 / fs)) * 2 * block.f_hz + 1e-9))
    return block.time_s >= t_end - n_half * 0.5 / block.f_hz, n_half


def _subblock_starts(t_s: np.ndarray, f_hz: float, fs: float, n_half: int, subblocks: int) -> np.ndarray:
    """First sample of each sub-block: the last ``n_half`` half periods of ``t_s`` in at most
    ``subblocks`` groups of whole half periods (whole periods below ``MIN_SEGMENT_SAMPLES``
    samples per period), sizes differing by at most one unit; samples before them join the first."""
    per_unit = 1 if fs / f_hz >= MIN_SEGMENT_SAMPLES else 2
    n_units = n_half // per_unit
    k = min(subblocks, n_units)
    left_units = n_units - np.floor(np.arange(1, k) * n_units / k)
    return np.r_[0, np.searchsorted(t_s, t_s[-1] + 0.5 / fs - left_units * per_unit * 0.5 / f_hz)]


def _jackknife_variance(full: np.ndarray, minus: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """Delete-a-group jackknife statistic for E|theta_hat - theta|^2 with groups of unequal
    ``sizes`` (Busing, Meijer & van der Leeden 1999): ``full`` (n,) from all groups,
    ``minus`` (k, n) without group j."""
    return np.sum(np.abs(_jackknife_weights(sizes) @ np.vstack([full, minus])) ** 2 * _jackknife_scale(sizes)[:, None],
                  axis=0)


def _jackknife_weights(sizes: np.ndarray) -> np.ndarray:
    """Rows l_j with pseudo-value_j - jackknife mean = l_j . (theta_hat, theta_-1, ..., theta_-k)."""
    k = sizes.size
    h = sizes.sum() / sizes
    L = np.tile(np.r_[0.0, 1 - 1 / h], (k, 1))
    L[:, 0] = h - k
    L[np.arange(k), np.arange(k) + 1] -= h - 1
    return L


def _jackknife_scale(sizes: np.ndarray) -> np.ndarray:
    return 1.0 / ((sizes.sum() / sizes - 1) * sizes.size)


def _phasor_gain(A: np.ndarray) -> float:
    """var(a_hat) / sigma^2 of the fundamental phasor a_hat = e . coef under white noise of
    variance sigma^2 (normal matrix ``A``): e A^-1 e^* with e = (0, 1, -j, 0, ...); 4 / N over
    whole periods."""
    e = np.zeros(A.shape[0], complex)
    e[1], e[2] = 1.0, -1.0j
    return float(np.real(e @ np.linalg.solve(A, e.conj())))


def _jackknife_expectation(A: np.ndarray, A_j: np.ndarray, sizes: np.ndarray) -> float:
    """E[jackknife statistic] / sigma^2 of the fundamental phasor under white noise for this
    design (normal matrix ``A`` = sum of the sub-blocks' ``A_j``). With e as in ``_phasor_gain``,
    cov(theta_-i, theta_-j) = sigma^2 e A_-i^-1 (A - A_i - A_j) A_-j^-1 e^*,
    cov(theta_hat, theta_-j) = var(theta_hat) = sigma^2 e A^-1 e^*."""
    e = np.zeros(A.shape[0], complex)
    e[1], e[2] = 1.0, -1.0j
    q = _phasor_gain(A)
    u = np.linalg.solve(A - A_j, np.broadcast_to(e.conj(), (sizes.size, e.size))[..., None])[..., 0]  # (k, p)
    k = sizes.size
    rest = A[None, None] - A_j[:, None] - A_j[None, :]                                             # (k, k, p, p)
    rest[np.arange(k), np.arange(k)] = A - A_j
    gamma = np.empty((k + 1, k + 1), complex)
    gamma[0, :] = gamma[:, 0] = q
    gamma[1:, 1:] = np.einsum("ia,ijab,jb->ij", u.conj(), rest, u)
    L = _jackknife_weights(sizes)
    return float(np.real(np.einsum("ja,ab,jb->j", L, gamma, L)) @ _jackknife_scale(sizes))


def _white_noise_factor(A: np.ndarray, A_j: np.ndarray, sizes: np.ndarray) -> float:
    """var(a_hat) / E[jackknife statistic] of the fundamental phasor, both under white noise
    for this design: 1 for whole-period sub-blocks; it removes the jackknife's bias over half
    and partial periods."""
    return _phasor_gain(A) / _jackknife_expectation(A, A_j, sizes)


@dataclass(frozen=True)
class _CurrentCheck:
    """Whether a block's current is a sinusoid at the block frequency.

    ``fraction``: the fundamental's share of the current's power about its fitted offset;
    ``snr_db``: fundamental power over the fit residual's; ``z2`` = |I_hat|^2 / var(I_hat) with
    the sub-block variance, against ``z2_limit`` (``_detection_limit``). Only the detection
    decides: a detected sinusoid is used whatever else the current holds (ripple, another
    excitation), since the least-squares fit separates it and the sub-block variance covers
    what leaks from the rest; ``fraction`` and ``snr_db`` describe the data in the notes.
    """

    fraction: float
    snr_db: float
    z2: float
    z2_limit: float

    @property
    def sinusoid(self) -> bool:
        return self.z2 >= self.z2_limit


@dataclass(frozen=True)
class _BlockEstimate:
    """Lock-in estimate of one block and its data checks; arrays have one entry per output."""

    g: np.ndarray                # complex, m/s per A
    variance: np.ndarray         # (m/s per A)^2
    current_amplitude_a: float
    #: variance of the current amplitude estimate (A^2): the radial half of its phasor's
    current_amplitude_variance: float
    snr_db: np.ndarray
    distortion: np.ndarray       # (n_outputs, 2), NaN where not measurable
    fraction: np.ndarray         # the fundamental's share of the output power about its offset
    detected: np.ndarray         # bool: the output's fundamental is significant (``OUTPUT_DETECTION_LIMIT``)
    current: _CurrentCheck
    settle_s: float
    periods: float
    subblocks: int
    #: real degrees of freedom of ``variance``: 2 (k - 1) from the sub-blocks, or the residual's n - p
    variance_dof: float
    #: time constant (s) of the start-up transient left after settling and fitted with the sinusoid, or None
    transient_s: float | None = None


@dataclass(frozen=True)
class _RmsEstimate:
    g: np.ndarray                # magnitude, m/s per A
    variance: np.ndarray
    current_amplitude_a: float
    settle_s: float
    periods: float
    subblocks: int


@dataclass(frozen=True)
class _Excluded:
    """A block left out of the response: the note saying why, and whether its current is not a
    sinusoid at the block frequency (these count towards refusing the recording as broadband)."""

    note: str
    not_sinusoid: bool = False


@functools.lru_cache(maxsize=None)
def _detection_limit(k: int) -> float:
    """Smallest z^2 = |a_hat|^2 / var_hat of a detected fundamental, ``k`` sub-blocks.

    Without a sinusoid at the block frequency (noise or broadband excitation), a_hat is a
    circular complex Gaussian with E|a_hat|^2 = var and the sub-block variance var_hat has
    nu = 2 (k - 1) real degrees of freedom, so z^2 follows F(2, nu); the limit is its upper
    ``TEST_P`` quantile (16 for k = 10, 9999 for k = 2: two sub-blocks can only confirm a
    strong sinusoid). The scatter between sub-blocks, not the fit residual, is the yardstick:
    broadband excitation concentrated near the block frequency is far above the residual's
    average level there, but it is no more consistent from sub-block to sub-block than noise.
    """
    return float(scipy.special.fdtri(2, 2 * (k - 1), 1 - TEST_P))


def _settled(block: Block, settle_s: float, fs: float) -> tuple[np.ndarray, float]:
    """Samples from ``settle_s`` on (a sample stands for [t - 0.5/fs, t + 0.5/fs)) and the
    periods they span (rounded to 1e-9: ``fs`` is a median of rounded time steps)."""
    keep = block.time_s >= settle_s - 0.5 / fs
    return keep, round(np.count_nonzero(keep) / fs * block.f_hz, 9)


def _too_short(label: str, periods: float, settle: float) -> _Excluded:
    return _Excluded(f"{label}: {periods:.2f} periods left after settling ({settle:.3g} s); at least "
                     f"{MIN_PERIODS:g} period is needed (record longer or settle shorter): excluded")


def _undersampled(label: str, f_hz: float, fs: float) -> _Excluded | None:
    if fs / f_hz >= MIN_SAMPLES_PER_PERIOD * (1 - 1e-6):     # tolerance: times read from text are rounded
        return None
    return _Excluded(f"{label}: {fs / f_hz:.2f} samples per period; at least {MIN_SAMPLES_PER_PERIOD} are needed "
                     f"(sample rate {fs:g} Hz is too low for {f_hz:g} Hz): excluded")


def _block_estimate(block: Block, settle_s: float | None, subblocks: int) -> _BlockEstimate | _Excluded:
    """Lock-in estimate of one block over all its samples after settling (whole and partial
    periods), or why the block is excluded."""
    f, fs = block.f_hz, block.sample_rate_hz
    label = f"block {f:g} Hz"
    undersampled = _undersampled(label, f, fs)
    if undersampled:
        return undersampled
    whole = f * (block.time_s[-1] - block.time_s[0] + 1.0 / fs)
    if not whole >= MIN_PERIODS * (1 - 1e-9):        # too few periods even before settling (or f ~ 0)
        return _too_short(label, whole, 0.0)
    harmonics = _harmonics(f, fs)
    basis = _basis(block.time_s, f, harmonics)
    settle, unsettled = _settling_time(block, fs, basis) if settle_s is None else (settle_s, False)
    keep, periods = _settled(block, settle, fs)
    if periods < MIN_PERIODS * (1 - 1e-9):
        return _too_short(label, periods, settle)
    t = block.time_s[keep]
    sig = np.vstack([block.current_a[keep], block.velocity_m_per_s[:, keep]]).T   # (n_samples, n_signals)
    B, transient_s = _with_transient(t, basis[keep], sig) if unsettled else (basis[keep], None)
    starts = _subblock_starts(t, f, fs, int(np.floor(2 * periods + 1e-9)), subblocks)
    ends = np.r_[starts[1:], t.size]
    if starts.size < 2 or np.min(t.size - (ends - starts)) < 2 * B.shape[1]:
        return _Excluded(f"{label}: {periods:.2f} periods of {fs / f:.3g} samples left after settling "
                         f"({settle:.3g} s): too few for a variance from sub-blocks: excluded")
    A_j = np.array([B[a:b].T @ B[a:b] for a, b in zip(starts, ends)])
    R_j = np.array([B[a:b].T @ sig[a:b] for a, b in zip(starts, ends)])
    A = A_j.sum(axis=0)
    coef = np.linalg.solve(A, R_j.sum(axis=0))
    n_h = len(harmonics)
    amps = (coef[1:2 * n_h:2] - 1j * coef[2:2 * n_h + 1:2]).T    # (n_signals, n_harmonics)
    if abs(amps[0, 0]) <= 1e-9 * np.sqrt(np.mean(sig[:, 0] ** 2)):
        return _Excluded(f"{label}: the current has no component at {f:g} Hz: excluded", not_sinusoid=True)
    minus = np.linalg.solve(A - A_j, R_j.sum(axis=0) - R_j)   # (k, n_columns, n_signals)
    a_minus = minus[:, 1] - 1j * minus[:, 2]
    sizes = (ends - starts).astype(float)
    gain = _phasor_gain(A)
    factor = _white_noise_factor(A, A_j, sizes)
    var_i = float(_jackknife_variance(amps[:1, 0], a_minus[:, :1], sizes)[0]) * factor
    g = amps[1:, 0] / amps[0, 0]
    var = _jackknife_variance(g, a_minus[:, 1:] / a_minus[:, :1], sizes) * factor
    distortion = np.full((g.size, 2), np.nan)
    distortion[:, : len(harmonics) - 1] = np.abs(amps[1:, 1:]) / np.abs(amps[1:, :1])
    fundamental, residual, fraction = _powers(sig, B, coef, amps)
    snr_db = 10 * np.log10(fundamental / residual)
    k = starts.size
    current = _CurrentCheck(float(fraction[0]), float(snr_db[0]), float(fundamental[0] * 2 / max(var_i, 1e-300)),
                            _detection_limit(k))
    if not current.sinusoid:
        return _Excluded(_current_note(label, current, fraction[1:]), not_sinusoid=True)
    detected = fundamental[1:] * 2 / (gain * residual[1:]) >= OUTPUT_DETECTION_LIMIT
    dof = 2.0 * (k - 1)
    if k < MIN_SCATTER_SUBBLOCKS:
        n, p = B.shape
        s2 = residual * n / (n - p)                                # unbiased residual mean squares
        var = gain * (s2[1:] + np.abs(g) ** 2 * s2[0]) / abs(amps[0, 0]) ** 2
        var_i = gain * float(s2[0])
        dof = float(n - p)
    return _BlockEstimate(g, var, float(abs(amps[0, 0])), var_i / 2, snr_db[1:], distortion, fraction[1:], detected,
                          current, float(settle), periods, k, dof, transient_s)


def _with_transient(t: np.ndarray, B: np.ndarray, sig: np.ndarray) -> tuple[np.ndarray, float | None]:
    """The basis ``B`` of the settled samples, with the columns e^{-(t - t_0) / tau} and its derivative in
    log tau when a start-up transient is still significant in the outputs, and tau (s); else ``B`` and None.

    Used where the settling search may have left part of the transient (``_settling_time``): for a
    rigid body it is one exponential of time constant m / b. tau is searched on a log grid from a
    tenth of the window (faster decays are gone by its end; the jackknife still sees the column in
    every sub-block) to three times the window and refined (``scipy.optimize.minimize_scalar``), the
    outputs sharing it; the exponential is
    kept when the drop of chi^2 it brings (each output's residual variance from the fit with it)
    exceeds the upper ``TEST_P`` quantile of chi^2 with one amplitude per output plus tau. The derivative
    column is the fit linearised in log tau at its optimum (a Gauss-Newton step of zero): it leaves the
    estimate as it is and puts the uncertainty of tau into the variance.
    """
    from scipy.optimize import minimize_scalar

    n, p = B.shape
    n_out = sig.shape[1] - 1
    if n <= p + 2 * n_out + 2:
        return B, None
    Q, _ = np.linalg.qr(B)
    out = sig[:, 1:]
    r = out - Q @ (Q.T @ out)
    ss = np.sum(r**2, axis=0)
    if not np.all(ss > 0):
        return B, None
    dt = (t[-1] - t[0]) / (n - 1)

    def drops(log_tau):
        """Drop of each output's residual sum of squares with the exponential of each tau, (n_out, n_tau)."""
        e = np.exp(-(t - t[0])[:, None] / np.exp(np.atleast_1d(log_tau)))
        pe = e - Q @ (Q.T @ e)
        return (r.T @ pe) ** 2 / np.maximum(np.sum(pe**2, axis=0), 1e-300)

    def cost(log_tau):
        return -float(np.sum(drops(log_tau)[:, 0] / ss))

    window = t[-1] - t[0] + dt
    grid = np.linspace(math.log(window / 10), math.log(3 * window), 32)
    k = int(np.argmax(np.sum(drops(grid) / ss[:, None], axis=0)))
    best = minimize_scalar(cost, bounds=(grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]), method="bounded",
                           options={"xatol": 1e-4})
    drop = drops(best.x)[:, 0]
    s2 = np.maximum(ss - drop, 1e-15 * ss) / (n - p - 2)
    if not np.sum(drop / s2) > scipy.special.chdtri(n_out + 1, TEST_P):
        return B, None
    tau = float(np.exp(best.x))
    decay = np.exp(-(t - t[0]) / tau)
    return np.column_stack([B, decay, (t - t[0]) / tau * decay]), tau


def _powers(sig: np.ndarray, B: np.ndarray, coef: np.ndarray, amps: np.ndarray):
    """Per signal (columns of ``sig``, fitted ``coef`` on basis ``B``, phasors ``amps``): the
    fundamental's power |a|^2 / 2, the residual's mean square, and the fundamental's share of the
    power about the fitted offset (at most 1; over a partial period |a|^2 / 2 is not exactly the
    window's power of the fundamental)."""
    fundamental = np.abs(amps[:, 0]) ** 2 / 2
    residual = np.maximum(np.mean((sig - B @ coef) ** 2, axis=0), 1e-300)
    fraction = np.minimum(fundamental / np.maximum(np.mean((sig - coef[0]) ** 2, axis=0), 1e-300), 1.0)
    return fundamental, residual, fraction


def _rms_estimate(block: Block, settle_s: float | None, subblocks: int) -> _RmsEstimate | _Excluded:
    """Thesis Appendix B: sqrt(2) RMS(v) / (sqrt(2) RMS(i)) over the block (from ``settle_s``
    if given); the variance of this magnitude by the sub-block jackknife."""
    f, fs = block.f_hz, block.sample_rate_hz
    label = f"block {f:g} Hz"
    undersampled = _undersampled(label, f, fs)
    if undersampled:
        return undersampled
    settle = settle_s or 0.0
    after = block.time_s >= settle - 0.5 / fs
    n_half = _whole_half_periods(block, settle, fs)[1]
    if n_half < 2 * MIN_PERIODS:
        return _too_short(label, _settled(block, settle, fs)[1], settle)
    t, i, v = block.time_s[after], block.current_a[after], block.velocity_m_per_s[:, after]
    if np.ptp(i) <= 1e-12 * max(1.0, float(np.max(np.abs(i)))):
        return _Excluded(f"{label}: the current is constant: excluded", not_sinusoid=True)
    starts = _subblock_starts(t, f, fs, n_half, subblocks)
    if starts.size < 2:
        return _Excluded(f"{label}: {n_half / 2:g} whole periods of {fs / f:.3g} samples: too few for a variance "
                         "from sub-blocks: excluded")
    sum_v, sum_i = np.add.reduceat(v**2, starts, axis=1).T, np.add.reduceat(i**2, starts)
    g = np.sqrt(sum_v.sum(axis=0) / sum_i.sum())
    minus = np.sqrt((sum_v.sum(axis=0) - sum_v) / (sum_i.sum() - sum_i)[:, None])
    var = _jackknife_variance(g, minus, np.diff(np.r_[starts, t.size]).astype(float))
    return _RmsEstimate(g, var, float(np.sqrt(2 * np.mean(i**2))), settle, n_half / 2, starts.size)


def estimate_response(recording: Recording, *, settle_s: float | None = None, method: str = "lock-in",
                      subblocks: int = SUBBLOCKS) -> MeasuredResponse:
    """Measured G = V/I (m/s per A) per output and usable block; see the module doc.

    ``settle_s``: seconds dropped at the start of every block; None estimates the transient
    from the data (``settling_time_s``) for the lock-in and keeps the whole block for
    ``method="rms"``, as the thesis did. ``subblocks`` (>= 2): number of sub-blocks for the
    variance (fewer when the block has fewer half periods). Blocks that cannot be used (too
    short, undersampled, a current that is not a sinusoid at the block frequency, a flat output)
    are left out, each with a note in ``notes``; ``DataError`` when none is left, or when most
    blocks' currents are not sinusoids (broadband data). The sinusoid checks need the lock-in
    fit; ``method="rms"`` checks only length, sampling and a constant current. ``metadata``
    records per kept block the settling time, the periods and sub-blocks used, its middle's seconds from the
    recording's start (``block_time_s``: blocks taken as recorded in file order), the excluded
    frequencies, the sample rate, an encoder-differenced velocity's quantum
    (``encoder_velocity_quantum``) and the recording's metadata.
    """
    _check_arguments(recording, settle_s, method, subblocks)
    dead = _dead_outputs(recording)
    results = []
    for block, flat in zip(recording.blocks, dead):
        if flat.any():
            k = int(np.argmax(flat))
            results.append(_Excluded(f"block {block.f_hz:g} Hz, output {recording.output_names[k]!r}: every sample "
                                     f"is {block.velocity_m_per_s[k, 0]:g} (no motion above the velocity "
                                     "resolution): excluded"))
        elif method == "rms":
            results.append(_rms_estimate(block, settle_s, subblocks))
        else:
            results.append(_block_estimate(block, settle_s, subblocks))
    _refuse_unusable(recording, results)
    kept = [j for j, r in enumerate(results) if not isinstance(r, _Excluded)]
    notes = [n for j, r in enumerate(results) for n in _notes(recording, j, r)]
    starts = _block_starts(recording)
    metadata = {"settle_s": [results[j].settle_s for j in kept], "periods_used": [results[j].periods for j in kept],
                "subblocks": [results[j].subblocks for j in kept],
                "variance_dof": [getattr(results[j], "variance_dof", 2.0 * (results[j].subblocks - 1)) for j in kept],
                "excluded_f_hz": [recording.blocks[j].f_hz for j, r in enumerate(results) if isinstance(r, _Excluded)],
                "sample_rate_hz": _sample_rate_hz(recording), "recording": dict(recording.metadata),
                "block_time_s": [float(starts[j] + recording.blocks[j].time_s[-1] / 2) for j in kept]}
    quantum = encoder_velocity_quantum(recording)
    if quantum is not None:
        metadata["encoder_velocity_quantum_m_per_s"] = quantum
        notes.append(f"velocity is an encoder position quantum {_short(quantum / metadata['sample_rate_hz'])} m "
                     f"differenced at {metadata['sample_rate_hz']:g} Hz: its half-sample delay and sinc droop are "
                     "part of the sensor")
    f_hz = np.array([recording.blocks[j].f_hz for j in kept])
    return _response(recording, [results[j] for j in kept], f_hz, method, metadata, tuple(notes))


def _check_arguments(recording: Recording, settle_s, method: str, subblocks) -> None:
    if method not in ("lock-in", "rms"):
        raise DataError(f"method must be 'lock-in' or 'rms', got {method!r}")
    if not recording.blocks:
        raise DataError(f"{recording.source}: the recording has no blocks")
    if settle_s is not None and not (math.isfinite(settle_s) and settle_s >= 0):
        raise DataError(f"settle_s must be finite and >= 0 seconds, got {settle_s!r}")
    if isinstance(subblocks, bool) or not isinstance(subblocks, (int, np.integer)) or subblocks < 2:
        raise DataError(f"subblocks must be an integer >= 2, got {subblocks!r}")


def _dead_outputs(recording: Recording) -> np.ndarray:
    """(n_blocks, n_outputs) bool: the output is constant over the block. An output constant in
    every block is a dead channel (or a wrong column): ``DataError``."""
    flat = np.array([np.ptp(b.velocity_m_per_s, axis=1) == 0 for b in recording.blocks])
    for k in np.flatnonzero(flat.all(axis=0)):
        b = recording.blocks[0]
        raise DataError(f"{recording.source}: block {b.f_hz:g} Hz, output {recording.output_names[k]!r}: every "
                        f"sample is {b.velocity_m_per_s[k, 0]:g}; a dead channel or motion below the velocity "
                        "resolution (leave the column out of the column map)")
    return flat


def _refuse_unusable(recording: Recording, results: list) -> None:
    """``DataError`` when most blocks' currents are not sinusoids at their frequency (broadband
    data read as a stepped sine) or no block is usable."""
    excluded = [r for r in results if isinstance(r, _Excluded)]
    not_sine = [r.note for r in excluded if r.not_sinusoid]
    if len(not_sine) > len(results) / 2:
        raise DataError(f"{recording.source}: the recording does not look like a stepped sine: in {len(not_sine)} of "
                        f"{len(results)} blocks the current is not a sinusoid at the block frequency (e.g. "
                        f"{not_sine[0]}); for broadband excitation (random, PRBS, multisine, chirp) use a method "
                        "for broadband data")
    if len(excluded) == len(results):
        raise DataError(f"{recording.source}: no usable block: {'; '.join(r.note for r in excluded)}")


def _notes(recording: Recording, j: int, result) -> list[str]:
    """Data-check findings of block ``j``: why it was excluded, that it is short, or that an
    output's fundamental was not detected (kept: its variance weights it down)."""
    label = f"block {recording.blocks[j].f_hz:g} Hz"
    if isinstance(result, _Excluded):
        return [result.note]
    notes = []
    if result.periods < 2 or result.subblocks < MIN_SCATTER_SUBBLOCKS:
        residual = isinstance(result, _BlockEstimate) and result.subblocks < MIN_SCATTER_SUBBLOCKS
        source = (f"{result.subblocks} sub-blocks are too few for a scatter: variance from the fit residual, white "
                  f"noise assumed ({result.variance_dof:.0f} degrees of freedom)" if residual else
                  f"variance from {result.subblocks} sub-blocks ({2 * (result.subblocks - 1)} degrees of freedom)")
        only = "only " if result.periods < 2 else ""
        notes.append(f"{label}: {only}{result.periods:.2f} periods after settling ({result.settle_s:.3g} s): used, "
                     f"{source}")
    if isinstance(result, _BlockEstimate) and result.transient_s is not None:
        notes.append(f"{label}: a start-up transient is left after settling ({result.settle_s:.3g} s): fitted with "
                     f"the sinusoid as a decay of time constant {result.transient_s:.3g} s")
    if isinstance(result, _BlockEstimate):
        for k in np.flatnonzero(~result.detected):
            notes.append(f"{label}, output {recording.output_names[k]!r}: the fundamental is not detected above the "
                         f"noise (SNR {result.snr_db[k]:.0f} dB, {100 * result.fraction[k]:.2g} % of the output "
                         "power): kept, weighted by its variance")
    return notes


def _current_note(label: str, check: _CurrentCheck, output_fraction: np.ndarray) -> str:
    return (f"{label}: the current is not a sinusoid at the block frequency: only {100 * check.fraction:.2g} % of "
            f"its power is there (SNR {check.snr_db:.0f} dB) and that part is not significant against its scatter "
            f"between sub-blocks (z^2 = {check.z2:.3g} < {check.z2_limit:.3g}); "
            f"{100 * np.max(output_fraction):.2g} % of the output power: excluded")


def _response(recording: Recording, results: list, f_hz: np.ndarray, method: str, metadata: dict,
              notes: tuple[str, ...]) -> MeasuredResponse:
    """The ``MeasuredResponse`` of the kept blocks (``results``, at ``f_hz``)."""
    n_out, n_f = len(recording.output_names), len(results)
    G = np.array([r.g for r in results], complex).T.reshape(n_out, n_f)
    var = np.array([r.variance for r in results], float).T.reshape(n_out, n_f)
    amp = np.array([r.current_amplitude_a for r in results], float)
    amp_var = np.array([getattr(r, "current_amplitude_variance", np.nan) for r in results], float)
    snr, hd = np.full((n_out, n_f), np.nan), np.full((n_out, n_f, 2), np.nan)
    fraction = np.full((n_out, n_f), np.nan)
    current_fraction, current_snr = np.full(n_f, np.nan), np.full(n_f, np.nan)
    for j, r in enumerate(results):
        if isinstance(r, _BlockEstimate):
            snr[:, j], hd[:, j], fraction[:, j] = r.snr_db, r.distortion, r.fraction
            current_fraction[j], current_snr[j] = r.current.fraction, r.current.snr_db
    return MeasuredResponse(f_hz, G, var, recording.output_names, amp, snr, hd, source=recording.source,
                            method=method, metadata=metadata, notes=notes, fundamental_fraction=fraction,
                            current_fundamental_fraction=current_fraction, current_snr_db=current_snr,
                            current_amplitude_variance=amp_var)


def _block_starts(recording: Recording) -> np.ndarray:
    """Seconds from the recording's start to each block's first sample, the blocks taken as recorded one after
    the other in file order (each block's own clock restarts at 0)."""
    durations = [b.time_s[-1] + 1.0 / b.sample_rate_hz if b.time_s.size > 1 else 0.0 for b in recording.blocks]
    return np.concatenate([[0.0], np.cumsum(durations)[:-1]])


def _sample_rate_hz(recording: Recording) -> float:
    """The logging rate (Hz): the median of the blocks' sample rates."""
    return float(np.median([b.sample_rate_hz for b in recording.blocks]))


def encoder_velocity_quantum(recording: Recording) -> float | None:
    """The velocity step q fs (m/s) when every output is an encoder position (quantum q, m)
    differenced at the logging rate fs, else None: all outputs' samples lie on one lattice
    n q fs (``lattice_step``). A velocity from a coarse converter lies on a lattice too; the
    values cannot tell the two apart, the note says which is assumed."""
    steps = [lattice_step(np.concatenate([b.velocity_m_per_s[k] for b in recording.blocks]))
             for k in range(len(recording.output_names))]
    if any(s is None for s in steps) or np.ptp(steps) > 1e-6 * max(steps):
        return None
    return float(np.median(steps))


def _short(x: float) -> str:
    """``x`` with 3 significant digits, exponent without padding: 1e-7, 2.5e-6, 0.05."""
    mantissa, exponent = f"{x:.2e}".split("e")
    if -4 <= int(exponent) < 4:
        return f"{x:.3g}"
    return f"{float(mantissa):g}e{int(exponent)}"


#: a change is significant beyond this many standard deviations (the sub-block variances have
#: few degrees of freedom, so their z has heavier tails than a Gaussian's) ...
Z_SIGNIFICANT = 5.0
#: ... and beyond this relative size
MIN_RELATIVE_CHANGE = 0.005


@dataclass(frozen=True)
class AmplitudeDependence:
    """How G changes between recordings at different excitation amplitudes (common frequencies).

    Every recording k >= 1 is compared with the first (the reference), output by output.
    """

    f_hz: np.ndarray
    #: current amplitude (A) of each recording, (n_recordings, n_freq)
    current_amplitude_a: np.ndarray
    #: |G_k| / |G_0| - 1, (n_recordings - 1, n_outputs, n_freq)
    relative_magnitude_change: np.ndarray
    #: angle(G_k / G_0) in degrees, same shape
    phase_change_deg: np.ndarray
    #: |G_k - G_0| / sqrt(var_k + var_0), same shape
    z: np.ndarray
    #: per point: z > ``Z_SIGNIFICANT`` and |G_k / G_0 - 1| > ``MIN_RELATIVE_CHANGE``, same shape
    significant_points: np.ndarray
    #: some point is significant
    significant: bool


def amplitude_dependence(responses: list[MeasuredResponse]) -> AmplitudeDependence:
    """Compare responses recorded at different amplitudes on their common frequencies
    (matched to 1e-9 relative), each against the first."""
    if len(responses) < 2:
        raise DataError("amplitude dependence needs recordings at two or more amplitudes")
    ref = responses[0]
    idx = []
    for r in responses:
        if len(r.output_names) != len(ref.output_names):
            raise DataError(f"{r.source}: {len(r.output_names)} outputs, {ref.source} has {len(ref.output_names)}")
        f = np.asarray(r.f_hz, float)
        match = np.abs(f[None, :] - np.asarray(ref.f_hz, float)[:, None]) <= 1e-9 * f[None, :]
        idx.append(match)
    common = np.all([m.any(axis=1) for m in idx], axis=0)
    if not common.any():
        raise DataError(f"the recordings share no frequency ({', '.join(r.source for r in responses)})")
    cols = [m[common].argmax(axis=1) for m in idx]
    G = np.array([r.response[:, c] for r, c in zip(responses, cols)])
    var = np.array([r.variance[:, c] for r, c in zip(responses, cols)])
    amps = np.array([np.asarray(r.current_amplitude_a)[c] for r, c in zip(responses, cols)])
    ratio = G[1:] / G[0]
    z = np.abs(G[1:] - G[0]) / np.sqrt(var[1:] + var[0])
    points = (z > Z_SIGNIFICANT) & (np.abs(ratio - 1) > MIN_RELATIVE_CHANGE)
    return AmplitudeDependence(np.asarray(ref.f_hz, float)[common], amps, np.abs(ratio) - 1,
                               np.degrees(np.angle(ratio)), z, points, bool(points.any()))
