"""Signals of the time-domain inverse dynamic model: force, velocity and acceleration, filtered
and decimated as IDIM-LS does it (Gautier; Janot, Gautier & Brunot, "Data Set and Reference
Models of EMPS", 2019, and its script ``Script_IDIM_LS.m``).

The motor force is F = K_f u (``force_constant_n_per_a`` times the drive input). When the drive
holds each logged command until the next sample (``input_hold=True``), the force acting between
t_(k-1) and t_(k+1), which the central difference of the velocity sees at t_k, is the mean
(F_(k-1) + F_k) / 2; ignoring that half sample biases mass by b h / 2 and damping by about 1 %
on a simulated zero-order-hold axis. The reference script does not align (the default, which
reproduces the published EMPS values); on EMPS the alignment moves the damping by +2 %, the
size of the uncertainty about when the drive applied each command. Position (or
velocity) is low-passed by a Butterworth filter applied forward and backward (zero phase; order
4, corner ``filter_hz``, the script's 100 Hz = 5 x the axis's 20 Hz dynamics), then differentiated
by central differences; ``EDGE_SAMPLES`` are dropped at both ends where the filter and the
differences have no past or future. Every regressor column (sign(v) of the Coulomb friction
included, computed at the full rate) and the force are then decimated by
``scipy.signal.decimate`` (order-8 Chebyshev type I anti-alias filter at 0.8 x the new Nyquist
frequency, forward and backward, as MATLAB's ``decimate``), with the factor of the script,
round(0.8 (fs / 2) / decimate_band_hz). The decimation filter removes the force's content above
the band, where the rigid-body model says nothing and the controller's noise lives, so the
regression sees the same band in every column (a "parallel" filter).

Noise. The white measurement noise of the force and of the position is estimated from fourth differences of
the raw signals at the full rate: for a smooth signal plus white noise of variance sigma^2,
sum (Delta^4 x)^2 / (70 (n - 4)) estimates sigma^2 (70 = C(8, 4), the differences' squared weights; Gasser, Sroka
& Jennen-Steinmetz 1986 use the second differences, sum / 6, which keep (omega h)^2 of the motion: 1 m/s^2 at
1 kHz is a 1 um second difference, the size of an encoder's quantum; the fourth keep (omega h)^4). An encoder's
quantisation error is read as its q / sqrt(12). In a closed loop (a reference recorded) the current is the
controller's command (EMPS logs the command ``vir``): its reaction to the encoder's noise, and any dither it adds,
are forces the axis feels, so the force's noise is zero and what is left is the position's noise,
differentiated and filtered. Its contribution to the regression residual, F_noise - M a_noise - b v_noise after
the whole chain, is computed by passing seeded white noise of those levels through the same chain
(``residual_noise_std_n``); the noise the columns carry, which the fit takes out of X^T X, is the chain's exact
expectation (``noise_moments``, from its impulse response), not one realisation's. Rests shorter than a decimated
sample are read from the raw position (``raw_rest``): the filters smear them over moving samples.
"""

from __future__ import annotations

import functools
import math
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np

from plant.data.recordings import TimeRecording
from plant.errors import DataError
from plant.physics.effect_base import Effect, ForceSignals

#: Butterworth corner (Hz) and order of the reference script
FILTER_HZ = 100.0
FILTER_ORDER = 4
#: band (Hz) kept by the decimation of the reference script (2 x 20 Hz)
DECIMATE_BAND_HZ = 40.0
#: samples dropped at each end after filtering and differencing (the script drops 50)
EDGE_SAMPLES = 50
#: order of the differences the white noise is estimated from (module doc)
DIFFERENCE_ORDER = 4
#: the chain's impulse response is taken this many periods of its filter (or of the decimation) either side
IMPULSE_SPAN = 50
#: seed of the white noise passed through the chain to predict the residual's noise
NOISE_SEED = 20190101
#: a velocity within this many noise standard deviations of zero is indistinguishable from rest
REST_SIGMAS = 3.0
#: guard around rest, in periods of the decimation band's upper edge (``InverseModelData.at_rest``)
REST_GUARD_PERIODS = 2.0
#: bytes of decimated effect columns one ``InverseModelData`` keeps for reuse (``effect_columns``)
COLUMN_MEMO_BYTES = 64 * 2**20


@dataclass(frozen=True)
class Preprocessing:
    """How the signals are prepared (module doc): filter corner (Hz), decimation band (Hz) and whether
    the drive held each logged command until the next sample."""

    filter_hz: float = FILTER_HZ
    decimate_band_hz: float = DECIMATE_BAND_HZ
    input_hold: bool = False


@dataclass(frozen=True)
class InverseModelData:
    """Filtered, differentiated and decimated signals of one recording (SI units)."""

    time_s: np.ndarray
    force_n: np.ndarray
    velocity_m_per_s: np.ndarray
    acceleration_m_per_s2: np.ndarray
    sample_rate_hz: float
    decimation: int
    filter_hz: float
    decimate_band_hz: float
    #: white-noise standard deviation of the raw force (N) and output (m or m/s) at the full rate
    force_noise_n: float
    output_noise: float
    #: the chain applied to seeded white noise of those levels: (force, velocity, acceleration)
    noise_force_n: np.ndarray
    noise_velocity_m_per_s: np.ndarray
    noise_acceleration_m_per_s2: np.ndarray
    source: str
    #: filtered velocity at the full rate, edges cut: nonlinear regressors are formed from it
    #: before the decimation (``decimate``)
    full_rate_velocity_m_per_s: np.ndarray
    #: filtered position (m) at the decimated samples, None when the recording has velocity only
    position_m: np.ndarray | None
    #: the motor force and the filtered position at the full rate, edges cut (position None as above)
    full_rate_force_n: np.ndarray | None = None
    full_rate_position_m: np.ndarray | None = None
    #: decimated samples whose span holds a raw sample at rest (``_raw_rest``), None for none
    raw_rest: np.ndarray | None = None
    #: the times (s) of the full-rate signals, edges cut
    full_rate_time_s: np.ndarray | None = None
    #: both rails recorded: the rails' difference y2 - y1 filtered and differentiated at the full rate, edges cut,
    #: its velocity (m/s) and acceleration (m/s^2) (None for one output)
    full_rate_rail_difference: tuple[np.ndarray, np.ndarray] | None = None
    _memo: _ColumnMemo = field(default_factory=lambda: _ColumnMemo(COLUMN_MEMO_BYTES), init=False, repr=False,
                               compare=False)

    @property
    def at_rest(self) -> np.ndarray:
        """Samples whose velocity is within ``REST_SIGMAS`` noise standard deviations of zero, and those
        within ``REST_GUARD_PERIODS`` periods of the decimation band of one: the filters spread a rest
        period's static friction force, which is no function of the velocity, over its neighbours."""
        rest = np.abs(self.velocity_m_per_s) <= REST_SIGMAS * float(np.std(self.noise_velocity_m_per_s))
        guard = int(np.ceil(REST_GUARD_PERIODS * self.sample_rate_hz / self.decimate_band_hz))
        return _widened(rest, guard)

    @property
    def at_reversal(self) -> np.ndarray:
        """The two samples either side of each change of sign of the velocity, and those whose span holds a raw
        sample at rest (``raw_rest``): the sampled sign(v) cannot say when between them the friction turned, nor
        for how long the axis stuck."""
        v = self.velocity_m_per_s
        out = np.zeros(v.size, bool)
        flip = np.sign(v[1:]) * np.sign(v[:-1]) < 0
        out[1:] |= flip
        out[:-1] |= flip
        return out if self.raw_rest is None else out | self.raw_rest

    def decimate(self, signal: np.ndarray) -> np.ndarray:
        """A full-rate signal (``full_rate_velocity_m_per_s``'s samples; or several, one per row) decimated as the
        columns are."""
        return _decimate(signal, self.decimation)

    @property
    def force_signals(self) -> ForceSignals:
        """The full-rate signals the effects' force models are formed from."""
        rails = self.full_rate_rail_difference or (None, None)
        return ForceSignals(self.full_rate_velocity_m_per_s, self.full_rate_force_n, self.full_rate_position_m,
                            self.full_rate_time_s, *rails)

    def effect_columns(self, effect: Effect) -> dict[str, np.ndarray]:
        """``effect``'s force regressors (force per unit of each of its parameters, by field name) at the
        decimated samples, read-only. A diagnosis fits the same effect, at the same trial pitch or span, in many
        models: the columns of each effect value are kept (the oldest dropped past ``COLUMN_MEMO_BYTES``)."""
        cols = self._memo.get(effect)
        if cols is None:
            full = effect.force_regressors(self.force_signals) or {}
            # a copy: the decimated samples alone, not a view that keeps the full-rate filtered rows alive
            cols = dict(zip(full, self.decimate(np.stack(list(full.values()))).copy())) if full else {}
            for c in cols.values():
                c.setflags(write=False)
            self._memo.put(effect, cols)
        return cols

    @functools.cached_property
    def noise_moments(self) -> np.ndarray:
        """E[n n^T] per sample (2 x 2) of the noise the chain leaves in (velocity, acceleration), from
        ``_noise_response``."""
        rows = self._noise_response
        return self.output_noise ** 2 * (rows @ rows.T)

    @functools.cached_property
    def noise_lag_factor(self) -> float:
        """F = sum over the decimated samples' lags k of rho_k^2, the chain noise's autocorrelation (the larger of the
        velocity's and the acceleration's): a mean of n squares of it scatters as a chi^2 of n / F samples."""
        import scipy.signal  # here, not at the top: the command line imports Preprocessing for any recording

        rows, r = self._noise_response, self.decimation
        factors = []
        for h in rows:
            c = scipy.signal.fftconvolve(h, h[::-1])            # the autocovariance, lag 0 in the middle
            lags = c[(c.size // 2) % r::r]
            factors.append(float(np.sum(lags**2) / c[c.size // 2] ** 2))
        return max(factors)

    @functools.cached_property
    def _noise_response(self) -> np.ndarray:
        """The chain's impulse response at the full rate, (velocity, acceleration) rows: a unit of white output noise
        through filter, differences and the decimation's anti-alias filter. Its squares summed over every lag are the
        noise's variance at any decimated sample (exact away from the edges; the seeded realisation's own mean squares
        scatter by about 5 % on a few thousand decimated samples). Cut ``IMPULSE_SPAN`` filter periods either side
        (tests: converged)."""
        fs = self.sample_rate_hz * self.decimation
        span = EDGE_SAMPLES + IMPULSE_SPAN * max(int(math.ceil(fs / self.filter_hz)), self.decimation)
        impulse = np.zeros(2 * span + 1)
        impulse[span] = 1.0
        rows = full_rate_derivatives(fs, impulse, self.filter_hz, 2 if self.position_m is not None else 1)[-2:]
        if self.decimation > 1:
            rows = _anti_aliased(rows, self.decimation)
        return rows

    def residual_noise_std_n(self, mass_kg: float, damping_n_s_per_m: float, yaw: tuple[float, float] = (0.0, 0.0)
                             ) -> float:
        """Standard deviation (N) of the regression residual that the measurement noise alone gives; ``yaw``: the
        coefficients (kg, N*s/m) of the rails' difference's acceleration and velocity (``yaw_coupling``), whose
        noise is twice the mean's through the same chain and independent of it (equal encoders)."""
        e = self.noise_force_n - mass_kg * self.noise_acceleration_m_per_s2 - damping_n_s_per_m * \
            self.noise_velocity_m_per_s
        d = 2 * (yaw[0] * self.noise_acceleration_m_per_s2 + yaw[1] * self.noise_velocity_m_per_s)
        return float(np.sqrt(np.var(e) + np.var(d)))


def _widened(mask: np.ndarray, samples: int) -> np.ndarray:
    """``mask`` with every sample within ``samples`` of a set one set."""
    if not mask.any() or samples == 0:
        return mask
    return np.convolve(mask.astype(float), np.ones(2 * samples + 1), mode="same") > 0


class _ColumnMemo:
    """Least recently used entries of arrays by key, within a byte budget."""

    def __init__(self, budget_bytes: int) -> None:
        self.budget, self.used, self.entries = budget_bytes, 0, OrderedDict()

    def get(self, key):
        hit = self.entries.get(key)
        if hit is not None:
            self.entries.move_to_end(key)
        return hit

    def put(self, key, arrays: dict[str, np.ndarray]) -> None:
        self.entries[key] = arrays
        self.used += sum(a.nbytes for a in arrays.values())
        while self.used > self.budget and self.entries:
            self.used -= sum(a.nbytes for a in self.entries.popitem(last=False)[1].values())


def difference_noise_std(x: np.ndarray) -> float:
    """White-noise standard deviation of ``x`` from its fourth differences (module doc)."""
    d4 = np.diff(np.asarray(x, dtype=float), DIFFERENCE_ORDER)
    return float(np.sqrt(np.sum(d4**2) / (math.comb(2 * DIFFERENCE_ORDER, DIFFERENCE_ORDER) * max(d4.size, 1))))


def _raw_rest(output: np.ndarray, sigma: float, kind: str, r: int, n: int) -> np.ndarray:
    """Decimated samples (``n``, factor ``r``, after the edge cut) whose span of ``r`` raw samples holds one at rest:
    a raw velocity, or a position's central difference, within ``REST_SIGMAS`` of its white noise (``sigma``) of
    zero. The filters smear a stick shorter than their span over moving samples; the raw signal does not."""
    if kind == "position":
        moved = np.abs(output[2:] - output[:-2]) / 2
        rest = np.r_[False, moved <= REST_SIGMAS * sigma / np.sqrt(2), False]
    else:
        rest = np.abs(output) <= REST_SIGMAS * sigma
    rest = rest[EDGE_SAMPLES: output.size - EDGE_SAMPLES]
    rest = _widened(rest, r // 2)[::r][:n]
    return np.r_[rest, np.zeros(n - rest.size, bool)]


def decimation_factor(sample_rate_hz: float, band_hz: float) -> int:
    """The reference script's factor round(0.8 (fs / 2) / band), at least 1."""
    return max(1, int(round(0.8 * sample_rate_hz / 2 / band_hz)))


def _chain(rec_fs: float, output: np.ndarray, force: np.ndarray, kind: str, filter_hz: float, r: int):
    """(force, velocity, acceleration) through filter, differences, edge cut and decimation."""
    import scipy.signal  # here, not at the top: the command line imports Preprocessing for any recording

    b, a = scipy.signal.butter(FILTER_ORDER, filter_hz / (rec_fs / 2))
    h = 1.0 / rec_fs
    y = scipy.signal.filtfilt(b, a, output)
    if kind == "position":
        v = np.gradient(y, h)
    else:
        v = y
    acc = np.gradient(v, h)
    cut = slice(EDGE_SAMPLES, output.size - EDGE_SAMPLES)
    position = _decimate(y[cut], r) if kind == "position" else None
    return [_decimate(c, r) for c in (force[cut], v[cut], acc[cut])] + [v[cut], position, force[cut],
                                                                         y[cut] if kind == "position" else None]


def full_rate_derivatives(rec_fs: float, output: np.ndarray, filter_hz: float, order: int) -> np.ndarray:
    """An output (a rail, the rails' mean or their difference) low-passed as ``_chain`` does and its derivatives
    0..``order`` by central differences at the full rate (accurate to (w h)^2 / 6 of each: 0.1 % at 12 Hz and 1 kHz),
    edges cut, as rows."""
    import scipy.signal

    b, a = scipy.signal.butter(FILTER_ORDER, filter_hz / (rec_fs / 2))
    rows = [scipy.signal.filtfilt(b, a, output)]
    for _ in range(order):
        rows.append(np.gradient(rows[-1], 1.0 / rec_fs))
    return np.stack(rows)[:, EDGE_SAMPLES: output.size - EDGE_SAMPLES]


def derivatives_chain(rec_fs: float, output: np.ndarray, filter_hz: float, r: int, order: int) -> np.ndarray:
    """``full_rate_derivatives`` decimated as the regressors are."""
    return _decimate(full_rate_derivatives(rec_fs, output, filter_hz, order), r)


def _rail_difference(rec: TimeRecording, filter_hz: float) -> tuple[np.ndarray, np.ndarray] | None:
    """Both rails recorded: the velocity and acceleration of y2 - y1 at the full rate (``full_rate_derivatives``)."""
    if rec.output.shape[0] != 2:
        return None
    rows = full_rate_derivatives(rec.sample_rate_hz, rec.output[1] - rec.output[0], filter_hz,
                                 2 if rec.output_kind == "position" else 1)
    return rows[-2], rows[-1]


@functools.lru_cache(maxsize=8)
def _decimation_filter(r: int) -> tuple[np.ndarray, np.ndarray, int]:
    """The anti-aliasing filter of ``scipy.signal.decimate(ftype="iir")`` for factor ``r`` (Chebyshev type I, order
    8, 0.05 dB ripple, corner 0.8 / r of Nyquist) as second-order sections, their steady initial state per unit
    input (``scipy.signal.sosfilt_zi``) and ``scipy.signal.sosfiltfilt``'s default edge (3 x its taps); made once
    per factor (a fit decimates hundreds of columns)."""
    import scipy.signal

    sos = scipy.signal.cheby1(8, 0.05, 0.8 / r, output="sos")
    taps = 2 * len(sos) + 1 - min(int((sos[:, 2] == 0).sum()), int((sos[:, 5] == 0).sum()))
    return sos, scipy.signal.sosfilt_zi(sos), 3 * taps


def _decimate(x: np.ndarray, r: int) -> np.ndarray:
    """``scipy.signal.decimate(x, r, ftype="iir", zero_phase=True)`` along the last axis, several signals (rows) in
    one call: ``sosfiltfilt``'s steps (odd extension by the edge, a forward and a backward pass started in the
    steady state of their first sample, the edge cut) with the filter, its initial state and edge made once
    (bit for bit scipy's numbers with scipy 1.17)."""
    x = np.asarray(x, dtype=float)
    return x if r == 1 else _anti_aliased(x, r)[..., ::r]


def _anti_aliased(x: np.ndarray, r: int) -> np.ndarray:
    """``_decimate``'s zero-phase anti-alias filtering at the full rate, before it keeps every ``r``-th sample."""
    import scipy.signal

    sos, zi, edge = _decimation_filter(r)
    if x.shape[-1] <= edge:
        raise ValueError(f"decimation by {r}: {x.shape[-1]} samples, at least {edge + 1} needed")
    ext = np.concatenate((2 * x[..., :1] - x[..., edge:0:-1], x, 2 * x[..., -1:] - x[..., -2:-(edge + 2):-1]), axis=-1)
    zi = zi.reshape((len(sos),) + (1,) * (x.ndim - 1) + (2,))
    y, _ = scipy.signal.sosfilt(sos, ext, axis=-1, zi=zi * ext[..., :1])
    y, _ = scipy.signal.sosfilt(sos, y[..., ::-1], axis=-1, zi=zi * y[..., -1:])
    return y[..., ::-1][..., edge:-edge]


def inverse_model_data(rec: TimeRecording, force_constant_n_per_a: float,
                       prep: Preprocessing = Preprocessing()) -> InverseModelData:
    """The IDIM-LS signals of ``rec`` (module doc); outputs are averaged (both rails of Stage Y)."""
    filter_hz, decimate_band_hz = prep.filter_hz, prep.decimate_band_hz
    fs = rec.sample_rate_hz
    if not 0 < filter_hz < 0.5 * fs:
        raise DataError(f"{rec.source}: the filter corner {filter_hz:g} Hz must lie below the Nyquist frequency "
                        f"{fs / 2:g} Hz")
    if not 0 < decimate_band_hz <= filter_hz:
        raise DataError(f"{rec.source}: the decimation band {decimate_band_hz:g} Hz must be positive and at most the "
                        f"filter corner {filter_hz:g} Hz")
    r = decimation_factor(fs, decimate_band_hz)
    n_kept = (rec.n_samples - 2 * EDGE_SAMPLES) // r
    if n_kept < 30:
        raise DataError(f"{rec.source}: {rec.n_samples} samples leave {max(n_kept, 0)} after the edges and decimation "
                        f"by {r}; record at least {(30 * r + 2 * EDGE_SAMPLES) / fs:.3g} s")
    with np.errstate(over="ignore", invalid="ignore"):      # a value far out of range: refused just below
        output = rec.output.mean(axis=0)
        force = force_constant_n_per_a * rec.current_a
        if prep.input_hold:
            force = np.r_[force[0], (force[1:] + force[:-1]) / 2]
        f, v, acc, v_full, position, f_full, x_full = _chain(fs, output, force, rec.output_kind, filter_hz, r)
    if not all(np.all(np.isfinite(x)) for x in (f, v, acc)):
        raise DataError(f"{rec.source}: the filtered signals overflow: a current or {rec.output_kind} value in the "
                        "recording is far out of range")
    # a closed loop (its reference recorded) logs the command: exact (module doc)
    sigma_f = 0.0 if rec.reference is not None else difference_noise_std(force)
    sigma_y = float(np.mean([difference_noise_std(o) for o in rec.output])) / np.sqrt(rec.output.shape[0])
    rng = np.random.default_rng(NOISE_SEED)
    nf, nv, na, *_ = _chain(fs, sigma_y * rng.standard_normal(rec.n_samples),
                        sigma_f * rng.standard_normal(rec.n_samples), rec.output_kind, filter_hz, r)
    t = rec.time_s[EDGE_SAMPLES: rec.n_samples - EDGE_SAMPLES][::r][: f.size]
    raw_rest = _raw_rest(output, sigma_y, rec.output_kind, r, f.size)
    return InverseModelData(t, f, v, acc, fs / r, r, filter_hz, decimate_band_hz, sigma_f, sigma_y, nf, nv, na,
                            rec.source,
                            v_full, position, f_full, x_full, raw_rest,
                            rec.time_s[EDGE_SAMPLES: rec.n_samples - EDGE_SAMPLES], _rail_difference(rec, filter_hz))
