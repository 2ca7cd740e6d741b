"""Frequency response from stepped-sine recordings by lock-in detection (thesis section 4.1).

Per block: drop the start-up transient (``settling_time_s``), fit the known-frequency
sinusoid with a constant offset and the 2nd and 3rd harmonics by least squares over whole
half periods ending with the block -- the single-bin DFT of lock-in detection, exact also
when a period is not a whole number of samples -- to the current and to every velocity
output, and take G = V / I.

Uncertainty: the fitted window is cut into ``subblocks`` sub-blocks of whole half periods
(whole periods below ``MIN_SEGMENT_SAMPLES`` samples per period); the variance E|G_hat - G|^2
is the delete-one-sub-block jackknife of G (for equal sub-blocks exactly the variance of
sub-block estimates divided by their number; refitting offset and harmonics without each
sub-block keeps it unbiased where separate half-period fits are not). It covers current
noise, coloured noise near the excitation and drifts. The residual of the fit gives the
signal-to-noise ratio, the harmonic amplitudes the distortion.

``method="rms"`` is the thesis's Appendix B estimate: sqrt(2) RMS(v) / (sqrt(2) RMS(i)) over
the whole block, magnitude only; noise, harmonics, offsets and the start-up transient all
inflate it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from plant.errors import DataError
from plant.frequency_response import MeasuredResponse
from plant.recording import Block, Recording

#: default number of sub-blocks for the variance of each point
SUBBLOCKS = 10
#: the transient is searched for in whole periods and never cut shorter than this many seconds
MIN_SETTLE_S = 0.05
#: a harmonic is fitted and reported only below this fraction of the sample rate (else aliased)
HARMONIC_LIMIT = 0.45
#: fewest samples in a segment of the settling search
MIN_SEGMENT_SAMPLES = 8


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
    return _settling_time(block, fs, _basis(block.time_s, block.f_hz, _harmonics(block.f_hz, fs)))


def _settling_time(block: Block, fs: float, basis: np.ndarray) -> float:
    """Start-up transient (s) estimated from the data (``basis``: ``_basis`` of the whole block).

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
    beyond 4 s, and at least one segment and ``MIN_SETTLE_S``; at most what leaves the two
    whole periods the estimate needs.
    """
    f, t = block.f_hz, block.time_s
    seg = math.ceil(MIN_SEGMENT_SAMPLES * 2 * f / fs) * 0.5 / f
    n_seg = int(np.floor((t[-1] + 1.0 / fs) / seg + 1e-9))
    cap_s = max(t[-1] + 1.0 / fs - 2.0 / f, 0.0)
    floor_s = min(max(seg, MIN_SETTLE_S), cap_s)
    if n_seg < 6:
        return floor_s
    edges = np.searchsorted(t, np.arange(n_seg + 1) * seg - 0.5 / fs)
    n_j = np.diff(edges)
    if np.any(n_j < 3):                       # a gap in the samples: no estimate from the data
        return floor_s
    n, half = edges[-1], edges[n_seg // 2]
    sig = np.vstack([block.current_a, block.velocity_m_per_s])[:, :n]
    B = basis[half:n]                         # fit over the second half: whole half periods
    coef = np.linalg.solve(B.T @ B, B.T @ sig[:, half:].T)
    dof = max(n - half - B.shape[1], 1)
    sigma2 = np.sum((sig[:, half:].T - B @ coef) ** 2, axis=0) / dof
    coef[1:3] = 0.0                           # keep the fundamental, remove offset and harmonics
    a = _segment_fundamentals(basis[:n, 1:3], sig - (basis[:n] @ coef).T, edges[:-1])
    h = n_seg // 2
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
    if lead.size:
        lead = np.arange(lead.size + 1)            # ... and the next segment, at least at the noise level
        slope, intercept = np.polyfit(lead, np.log(np.maximum(d[lead], 1.0)), 1)
        if slope < 0:
            j = np.arange(cut, n_seg - 1)
            left = n_seg - j
            bias = np.exp(intercept + slope * j) / (1 - np.exp(slope)) / left
            ok = np.flatnonzero(bias < 0.1 / np.sqrt(left))
            cut = int(j[ok[0]]) if ok.size else max(cut, n_seg // 2)
    return min(max(cut * seg, floor_s), cap_s)


@dataclass(frozen=True)
class _BlockEstimate:
    g: np.ndarray            # (n_outputs,) complex
    variance: np.ndarray     # (n_outputs,)
    current_amplitude_a: float
    snr_db: np.ndarray       # (n_outputs,)
    distortion: np.ndarray   # (n_outputs, 2)
    settle_s: float
    periods: float
    subblocks: int


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


def _white_noise_factor(A: np.ndarray, A_j: np.ndarray, sizes: np.ndarray) -> float:
    """var(a_hat) / E[jackknife statistic] of the fundamental phasor a_hat = e . coef, both
    under white noise for this design (normal matrix ``A`` = sum of the sub-blocks' ``A_j``).
    With e = (0, 1, -j, 0, ...), cov(theta_-i, theta_-j) = sigma^2 e A_-i^-1 (A - A_i - A_j)
    A_-j^-1 e^*, cov(theta_hat, theta_-j) = var(theta_hat) = sigma^2 e A^-1 e^*. The ratio is
    1 for whole-period sub-blocks; it removes the jackknife's bias over half periods."""
    e = np.zeros(A.shape[0], complex)
    e[1], e[2] = 1.0, -1.0j
    q = float(np.real(e @ np.linalg.solve(A, e.conj())))
    u = np.linalg.solve(A - A_j, np.broadcast_to(e.conj(), (sizes.size, e.size))[..., None])[..., 0]  # (k, p)
    k = sizes.size
    rest = A[None, None] - A_j[:, None] - A_j[None, :]                                             # (k, k, p, p)
    rest[np.arange(k), np.arange(k)] = A - A_j
    gamma = np.empty((k + 1, k + 1), complex)
    gamma[0, :] = gamma[:, 0] = q
    gamma[1:, 1:] = np.einsum("ia,ijab,jb->ij", u.conj(), rest, u)
    L = _jackknife_weights(sizes)
    expected = float(np.real(np.einsum("ja,ab,jb->j", L, gamma, L)) @ _jackknife_scale(sizes))
    return q / expected


def _block_estimate(block: Block, settle_s: float | None, subblocks: int, where: str) -> _BlockEstimate:
    f, fs = block.f_hz, block.sample_rate_hz
    harmonics = _harmonics(f, fs)
    basis = _basis(block.time_s, f, harmonics)
    settle = _settling_time(block, fs, basis) if settle_s is None else settle_s
    keep, n_half = _whole_half_periods(block, settle, fs)
    label = f"{where}: block {f:g} Hz"
    if n_half < 4:
        left = (block.time_s[-1] + 1.0 / fs - settle) * f
        raise DataError(f"{label}: {left:.2f} periods left after settling ({settle:.3g} s); at least 2 whole "
                        "periods are needed (record longer or settle shorter)")
    t = block.time_s[keep]
    sig = np.vstack([block.current_a[keep], block.velocity_m_per_s[:, keep]]).T   # (n_samples, n_signals)
    B = basis[keep]
    starts = _subblock_starts(t, f, fs, n_half, subblocks)
    ends = np.r_[starts[1:], t.size]
    A_j = np.array([B[a:b].T @ B[a:b] for a, b in zip(starts, ends)])
    R_j = np.array([B[a:b].T @ sig[a:b] for a, b in zip(starts, ends)])
    coef = np.linalg.solve(A_j.sum(axis=0), R_j.sum(axis=0))
    amps = (coef[1::2] - 1j * coef[2::2]).T                    # (n_signals, n_harmonics)
    if abs(amps[0, 0]) <= 1e-9 * np.sqrt(np.mean(sig[:, 0] ** 2)):
        raise DataError(f"{label}, current: the current has no component at {f:g} Hz")
    minus = np.linalg.solve(A_j.sum(axis=0) - A_j, R_j.sum(axis=0) - R_j)   # (k, n_columns, n_signals)
    a_minus = minus[:, 1] - 1j * minus[:, 2]
    g = amps[1:, 0] / amps[0, 0]
    sizes = (ends - starts).astype(float)
    var = _jackknife_variance(g, a_minus[:, 1:] / a_minus[:, :1], sizes) * _white_noise_factor(A_j.sum(axis=0), A_j,
                                                                                                  sizes)
    distortion = np.full((g.size, 2), np.nan)
    distortion[:, : len(harmonics) - 1] = np.abs(amps[1:, 1:]) / np.abs(amps[1:, :1])
    rms_noise = np.sqrt(np.mean((sig[:, 1:] - B @ coef[:, 1:]) ** 2, axis=0))
    snr_db = 20 * np.log10(np.abs(amps[1:, 0]) / np.sqrt(2) / np.maximum(rms_noise, 1e-300))
    return _BlockEstimate(g, var, float(abs(amps[0, 0])), snr_db, distortion, float(settle), n_half / 2, starts.size)


def _rms_estimate(block: Block, settle_s: float | None, subblocks: int, where: str):
    """Thesis Appendix B: sqrt(2) RMS(v) / (sqrt(2) RMS(i)) over the block (from ``settle_s``
    if given); the variance of this magnitude by the sub-block jackknife."""
    f, fs = block.f_hz, block.sample_rate_hz
    settle = settle_s or 0.0
    after = block.time_s >= settle - 0.5 / fs
    n_half = _whole_half_periods(block, settle, fs)[1]
    if n_half < 4:
        left = (block.time_s[-1] + 1.0 / fs - settle) * f
        raise DataError(f"{where}: block {f:g} Hz: {left:.2f} periods left after settling ({settle:.3g} s); at "
                        "least 2 whole periods are needed")
    t, i, v = block.time_s[after], block.current_a[after], block.velocity_m_per_s[:, after]
    starts = _subblock_starts(t, f, fs, n_half, subblocks)
    sum_v, sum_i = np.add.reduceat(v**2, starts, axis=1).T, np.add.reduceat(i**2, starts)
    g = np.sqrt(sum_v.sum(axis=0) / sum_i.sum())
    minus = np.sqrt((sum_v.sum(axis=0) - sum_v) / (sum_i.sum() - sum_i)[:, None])
    var = _jackknife_variance(g, minus, np.diff(np.r_[starts, t.size]).astype(float))
    return g, var, float(np.sqrt(2 * np.mean(i**2))), starts.size


def estimate_response(recording: Recording, *, settle_s: float | None = None, method: str = "lock-in",
                      subblocks: int = SUBBLOCKS) -> MeasuredResponse:
    """Measured G = V/I (m/s per A) per output and block; see the module doc.

    ``settle_s``: seconds dropped at the start of every block; None estimates the transient
    from the data (``settling_time_s``) for the lock-in and keeps the whole block for
    ``method="rms"``, as the thesis did. ``subblocks`` (>= 2): number of sub-blocks for the
    variance (fewer when the block has fewer half periods). ``metadata`` records per block
    the settling time and the whole periods and sub-blocks used, and the recording's metadata.
    """
    if method not in ("lock-in", "rms"):
        raise DataError(f"method must be 'lock-in' or 'rms', got {method!r}")
    if not recording.blocks:
        raise DataError(f"{recording.source}: the recording has no blocks")
    if settle_s is not None and not (math.isfinite(settle_s) and settle_s >= 0):
        raise DataError(f"settle_s must be finite and >= 0 seconds, got {settle_s!r}")
    if isinstance(subblocks, bool) or not isinstance(subblocks, (int, np.integer)) or subblocks < 2:
        raise DataError(f"subblocks must be an integer >= 2, got {subblocks!r}")
    n_out, n_f = len(recording.output_names), len(recording.blocks)
    G = np.empty((n_out, n_f), complex)
    var = np.empty((n_out, n_f))
    amp = np.empty(n_f)
    snr = np.full((n_out, n_f), np.nan)
    hd = np.full((n_out, n_f, 2), np.nan)
    settle, periods, used = np.zeros(n_f), np.zeros(n_f), np.zeros(n_f, int)
    for j, block in enumerate(recording.blocks):
        for k in np.flatnonzero(np.ptp(block.velocity_m_per_s, axis=1) == 0):
            raise DataError(f"{recording.source}: block {block.f_hz:g} Hz, output {recording.output_names[k]!r}: "
                            f"every sample is {block.velocity_m_per_s[k, 0]:g}; a dead channel or motion below the "
                            "velocity resolution (leave the column out of the column map)")
        if method == "rms":
            G[:, j], var[:, j], amp[j], used[j] = _rms_estimate(block, settle_s, subblocks, recording.source)
            settle[j] = settle_s or 0.0
            periods[j] = _whole_half_periods(block, settle[j], block.sample_rate_hz)[1] / 2
        else:
            e = _block_estimate(block, settle_s, subblocks, recording.source)
            G[:, j], var[:, j], amp[j], snr[:, j], hd[:, j] = e.g, e.variance, e.current_amplitude_a, e.snr_db, \
                e.distortion
            settle[j], periods[j], used[j] = e.settle_s, e.periods, e.subblocks
    metadata = {"settle_s": settle.tolist(), "periods_used": periods.tolist(), "subblocks": used.tolist(),
                "recording": dict(recording.metadata)}
    return MeasuredResponse(recording.f_hz, G, var, recording.output_names, amp, snr, hd, source=recording.source,
                            method=method, metadata=metadata)


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
