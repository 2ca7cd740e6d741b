"""Frequency response from stepped-sine recordings by lock-in detection (thesis section 4.1).

Per block: drop the start-up transient, fit the known-frequency sinusoid (and its 2nd and
3rd harmonics) by least squares over whole periods -- the single-bin DFT of lock-in
detection -- to the current and to every velocity output, and take G = V / I. The variance
of G comes from ``SUBBLOCKS`` consecutive sub-blocks (variance of their G divided by their
number); the harmonics give the distortion; the residual gives the signal-to-noise ratio.
``method="rms"`` is the thesis's Appendix B estimate, sqrt(2) RMS(v) / (sqrt(2) RMS(i)) over
the whole block: magnitude only, inflated by noise and harmonics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plant.errors import DataError
from plant.frequency_response import MeasuredResponse
from plant.recording import Block, Recording

SUBBLOCKS = 10
#: settling is searched for in whole periods, never less than this many seconds
MIN_SETTLE_S = 0.05


def _design(t_s: np.ndarray, f_hz: float, harmonics: int, offset: bool = True) -> np.ndarray:
    cols = [np.ones_like(t_s)] if offset else []
    for h in range(1, harmonics + 1):
        wt = 2 * np.pi * h * f_hz * t_s
        cols += [np.cos(wt), np.sin(wt)]
    return np.column_stack(cols)


def _phasors(t_s, f_hz, signals, harmonics=1, offset=True):
    """Least-squares complex amplitudes a_h (x ~ Re(a_h e^{j h w t})) of each row of ``signals``,
    shape (n_signals, harmonics), and the residual RMS of each (with a constant offset term
    unless ``offset`` is False)."""
    X = _design(t_s, f_hz, harmonics, offset)
    coef, *_ = np.linalg.lstsq(X, np.atleast_2d(signals).T, rcond=None)
    k = 1 if offset else 0
    amps = coef[k::2].T - 1j * coef[k + 1::2].T
    resid = np.atleast_2d(signals) - (X @ coef).T
    return amps, np.sqrt(np.mean(resid**2, axis=1))


def settling_time_s(block: Block) -> float:
    """Start-up transient estimated from the data.

    Per-period phasor ratios r_j are compared with the mean of the last half (scatter s).
    Where the leading deviations |r_j - ref| / s exceed 3, their exponential decay rate is
    fitted and the block is cut where the transient left in the remaining periods biases
    their mean by less than 0.1 of its own noise (s / sqrt(n)); without a clear decay, after
    the last period beyond 4 s. At least one period and ``MIN_SETTLE_S``.
    """
    period = 1.0 / block.f_hz
    n_per = int(np.floor(block.time_s[-1] / period))
    if n_per < 4:
        return max(period, MIN_SETTLE_S)
    edges = np.searchsorted(block.time_s, np.arange(n_per + 1) * period)
    ratios = []
    for a, b in zip(edges[:-1], edges[1:]):
        t = block.time_s[a:b]
        if t.size < 4:
            return max(period, MIN_SETTLE_S)
        amps, _ = _phasors(t, block.f_hz, np.vstack([block.current_a[a:b], block.velocity_m_per_s[:, a:b]]))
        ratios.append(amps[1:, 0] / amps[0, 0])
    r = np.array(ratios)                         # (n_periods, n_outputs)
    tail = r[n_per // 2:]
    ref = tail.mean(axis=0)
    spread = np.sqrt(np.mean(np.abs(tail - ref) ** 2, axis=0)) + 1e-9 * np.abs(ref)
    d = np.max(np.abs(r - ref) / spread, axis=1)  # deviation in units of the per-period scatter
    outside = d > 4
    cut = int(np.flatnonzero(outside)[-1]) + 1 if outside.any() else 0
    lead = np.flatnonzero(d > 3)
    lead = lead[lead == np.arange(lead.size)]      # the leading run of large deviations
    if lead.size >= 2:
        slope, intercept = np.polyfit(lead, np.log(d[lead]), 1)
        if slope < 0:
            k = -slope
            for j in range(cut, n_per - 1):
                left = n_per - j
                bias = np.exp(intercept - k * j) / (1 - np.exp(-k)) / left
                if bias < 0.1 / np.sqrt(left):
                    cut = j
                    break
            else:
                cut = max(cut, n_per // 2)
    return max(cut * period, period, MIN_SETTLE_S)


def _block_estimate(block: Block, settle_s: float | None, source: str):
    period = 1.0 / block.f_hz
    settle = settling_time_s(block) if settle_s is None else settle_s
    usable = block.time_s[-1] - settle
    n_per = int(np.floor(usable / period + 1e-9))
    if n_per < 2:
        raise DataError(f"{source}: block {block.f_hz:g} Hz: {usable / period:.2f} periods left after settling "
                        f"({settle:.3g} s); at least 2 whole periods are needed")
    t_end = block.time_s[-1] + 0.5 / block.sample_rate_hz
    keep = block.time_s >= t_end - n_per * period
    t = block.time_s[keep]
    sig = np.vstack([block.current_a[keep], block.velocity_m_per_s[:, keep]])
    amps, resid = _phasors(t, block.f_hz, sig, harmonics=3)
    if abs(amps[0, 0]) == 0:
        raise DataError(f"{source}: block {block.f_hz:g} Hz: the current has no component at {block.f_hz:g} Hz")
    g = amps[1:, 0] / amps[0, 0]
    # sub-blocks: consecutive equal slices of the kept samples (each >= half a period), fitted
    # without an offset after removing the block's offset (cos and sin stay orthogonal over
    # half periods, so short sub-blocks do not inflate the variance)
    X = _design(t, block.f_hz, 3)
    coef, *_ = np.linalg.lstsq(X, sig.T, rcond=None)
    centred = sig - coef[0][:, None]
    k = int(min(SUBBLOCKS, max(2, 2 * n_per)))
    parts = np.array_split(np.arange(t.size), k)
    sub = np.array([(lambda a: a[1:, 0] / a[0, 0])(_phasors(t[p], block.f_hz, centred[:, p], offset=False)[0])
                    for p in parts])
    var = np.sum(np.abs(sub - sub.mean(axis=0)) ** 2, axis=0) / (k - 1) / k
    fund = np.abs(amps[1:, 0])
    hd = np.abs(amps[1:, 1:3]) / fund[:, None]
    snr_db = 20 * np.log10(fund / np.sqrt(2) / np.maximum(resid[1:], 1e-300))
    return g, var, abs(amps[0, 0]), snr_db, hd, settle


def _rms_estimate(block: Block):
    i_amp = np.sqrt(2) * np.sqrt(np.mean(block.current_a**2))
    v_amp = np.sqrt(2) * np.sqrt(np.mean(block.velocity_m_per_s**2, axis=1))
    parts = np.array_split(np.arange(block.time_s.size), SUBBLOCKS)
    sub = np.array([np.sqrt(np.mean(block.velocity_m_per_s[:, p] ** 2, axis=1) / np.mean(block.current_a[p] ** 2))
                    for p in parts])
    return v_amp / i_amp, np.var(sub, axis=0, ddof=1) / SUBBLOCKS, i_amp


def estimate_response(recording: Recording, *, settle_s: float | None = None, method: str = "lock-in") -> MeasuredResponse:
    """Measured G = V/I (m/s per A) per output and block; see the module doc.

    ``settle_s`` overrides the transient estimated from the data (seconds dropped at the
    start of every block)."""
    if method not in ("lock-in", "rms"):
        raise DataError(f"method must be 'lock-in' or 'rms', got {method!r}")
    if not recording.blocks:
        raise DataError(f"{recording.source}: the recording has no blocks")
    if settle_s is not None and not settle_s >= 0:
        raise DataError(f"settle_s must be >= 0 seconds, got {settle_s!r}")
    n_out, n_f = len(recording.output_names), len(recording.blocks)
    G = np.empty((n_out, n_f), complex)
    V = np.empty((n_out, n_f))
    amp = np.empty(n_f)
    snr = np.full((n_out, n_f), np.nan)
    hd = np.full((n_out, n_f, 2), np.nan)
    settle = np.zeros(n_f)
    for j, block in enumerate(recording.blocks):
        if method == "rms":
            G[:, j], V[:, j], amp[j] = _rms_estimate(block)
        else:
            G[:, j], V[:, j], amp[j], snr[:, j], hd[:, j], settle[j] = _block_estimate(block, settle_s,
                                                                                         recording.source)
    return MeasuredResponse(recording.f_hz, G, V, recording.output_names, amp, snr, hd, source=recording.source,
                            method=method, metadata={"settle_s": settle.tolist(), "subblocks": SUBBLOCKS})


@dataclass(frozen=True)
class AmplitudeDependence:
    """How G changes between recordings at different excitation amplitudes (same frequencies)."""

    f_hz: np.ndarray
    #: current amplitude (A) of each recording, (n_recordings, n_freq)
    current_amplitude_a: np.ndarray
    #: |G_k| / |G_0| - 1 and angle(G_k / G_0) in degrees for every recording k >= 1, (n_rec - 1, n_out, n_freq)
    relative_magnitude_change: np.ndarray
    phase_change_deg: np.ndarray
    #: |G_k - G_0| / sqrt(var_k + var_0)
    z: np.ndarray
    #: some change is beyond 5 sigma and 0.5 %
    significant: bool


def amplitude_dependence(responses: list[MeasuredResponse]) -> AmplitudeDependence:
    """Compare responses recorded at different amplitudes on their common frequencies."""
    if len(responses) < 2:
        raise DataError("amplitude dependence needs recordings at two or more amplitudes")
    common = responses[0].f_hz
    for r in responses[1:]:
        common = np.intersect1d(common, r.f_hz)
        if len(r.output_names) != len(responses[0].output_names):
            raise DataError(f"{r.source}: {len(r.output_names)} outputs, {responses[0].source} has "
                            f"{len(responses[0].output_names)}")
    if common.size == 0:
        raise DataError("the recordings share no frequency")
    idx = [np.searchsorted(r.f_hz, common) for r in responses]
    G = np.array([r.response[:, i] for r, i in zip(responses, idx)])
    var = np.array([r.variance[:, i] for r, i in zip(responses, idx)])
    amps = np.array([r.current_amplitude_a[i] for r, i in zip(responses, idx)])
    ratio = G[1:] / G[0]
    z = np.abs(G[1:] - G[0]) / np.sqrt(var[1:] + var[0])
    significant = bool(np.any((z > 5) & (np.abs(ratio - 1) > 0.005)))
    return AmplitudeDependence(common, amps, np.abs(ratio) - 1, np.degrees(np.angle(ratio)), z, significant)
