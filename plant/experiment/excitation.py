"""Excitation for frequency-response measurement: the thesis stepped sine and a periodic multisine, and the
variance each is predicted to give.

The stepped sine (thesis section 4.1) plays A sin(2 pi f_k t) for one block of ``block_s`` seconds at each
frequency f_k, time restarting at 0 in each block, at the full peak current on one line at a time.

A multisine is a sum of cosines at harmonics of the base frequency f0 = 1 / period, played
for a whole number of periods. This module excites only ODD harmonics, log-spaced over the
band (Pintelon & Schoukens, *System Identification: A Frequency Domain Approach*, 2nd ed.
2012, ch. 2 and 3, odd and odd random-phase multisines): a nonlinearity of even order puts
its distortion on the even lines and one of odd order puts it on odd lines, among them the
odd lines left out, so the lines that carry no excitation show the distortion against the
noise. All lines have equal amplitude (a flat amplitude spectrum); the amplitude is chosen
so that the played peak current is ``peak_a``.

Phases:

* ``"schroeder"``: Schroeder (1970, "Synthesis of low-peak-factor signals and binary
  sequences with low autocorrelation", IEEE Trans. Inf. Theory 16:85-89) for arbitrary
  amplitudes, written with the harmonic numbers h_k of the excited lines,
  phi_k = -pi sum_{l<k} (h_k - h_l) p_l, with p_l the line's share of the power: a swept
  sine whose group delay grows with the power below each line, from 0 to half a period (a
  signal of odd harmonics only repeats with opposite sign after half a period, so the sweep
  spans that half). For F consecutive odd harmonics of equal amplitude this is Schroeder's
  -pi k (k - 1) / F, crest factor about 1.7 for many lines; for sparse log-spaced lines the
  swept-sine picture fails and the crest factor can reach that of random phases.
* ``"optimised"``: Schroeder phases and ``OPTIMISE_STARTS`` random ones (from ``seed``), each
  improved by the time-frequency swapping (clipping)
  algorithm of Van der Ouderaa, Schoukens & Renneboog (1988, "Peak factor minimization using
  a time-frequency domain swapping algorithm", IEEE Trans. Instrum. Meas. 37(1):145-147):
  clip the period in time, keep the phases of the clipped signal's spectrum on the excited
  lines with the original amplitudes and nothing elsewhere, repeat; the best period of all
  starts is kept, so the crest factor is never above Schroeder's.
* ``"random"``: independent phases uniform on [0, 2 pi) from ``seed`` (random-phase multisine).

The crest factor is measured on the samples as played (zero-order hold): peak / RMS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from plant.data.writers import csv_rows
from plant.errors import ParameterError
from plant.host.files import atomic_write_text

PHASES = ("schroeder", "optimised", "random")
#: what ``gantry excite`` writes: the better of the two per second of machine time, or the one named
FORMS = ("auto", "stepped", "multisine")
#: largest number of samples a design may hold (periods x samples per period): about 400 MB of float64
MAX_SAMPLES = 50_000_000
#: iterations of the clipping algorithm of ``"optimised"`` phases
OPTIMISE_ITERATIONS = 300
#: random starting phases of ``"optimised"`` phases besides Schroeder's
OPTIMISE_STARTS = 4
#: clipping levels, as fractions of the current peak, the clipping algorithm cycles through
CLIP_LEVELS = (0.8, 0.9)
#: thesis stepped sine (section 4.1): seconds per block and the number of log-spaced frequencies
#: the tool simulates by default over 1-75 Hz (``gantry simulate --f-hz 1:75:50``)
THESIS_BLOCK_S = 5.0
THESIS_FREQUENCIES = 50
#: seconds dropped at the start of each stepped-sine block before the lock-in; ``plant.estimate.lockin``
#: never cuts less (``MIN_SETTLE_S``)
STEPPED_SETTLE_S = 0.05


@dataclass(frozen=True)
class Multisine:
    """A designed multisine: ``periods`` periods of ``current_a`` (A) sampled at ``time_s`` (s).

    ``f_hz`` (Hz), ``harmonics`` (integers, f = h / period_s), ``amplitudes`` (A, peak of each
    cosine) and ``phases`` (rad) describe the excited lines: current(t) =
    sum_k amplitudes_k cos(2 pi f_k t + phases_k). ``crest_factor`` = ``peak_a`` / ``rms_a``
    of the samples.
    """

    time_s: np.ndarray
    current_a: np.ndarray
    f_hz: np.ndarray
    harmonics: np.ndarray
    amplitudes: np.ndarray
    phases: np.ndarray
    period_s: float
    sample_rate_hz: float
    periods: int
    samples_per_period: int
    crest_factor: float
    rms_a: float
    peak_a: float
    phase_method: str

    @property
    def duration_s(self) -> float:
        """Machine time of all periods (s)."""
        return self.periods * self.period_s


@dataclass(frozen=True)
class SteppedSine:
    """A stepped sine: ``amplitude_a`` sin(2 pi f t) (A) for ``block_s`` seconds at each frequency of ``f_hz`` (Hz,
    in order), sampled at ``sample_rate_hz`` (Hz) with t = 0 at each block's first sample (thesis section 4.1:
    each frequency a separate recording from rest)."""

    f_hz: np.ndarray
    amplitude_a: float
    block_s: float
    sample_rate_hz: float
    samples_per_block: int

    @property
    def duration_s(self) -> float:
        """Machine time of all blocks (s)."""
        return self.f_hz.size * self.block_s

    @property
    def time_s(self) -> np.ndarray:
        """Time within a block (s) of each of its samples."""
        return np.arange(self.samples_per_block) / self.sample_rate_hz

    def block_current_a(self, k: int) -> np.ndarray:
        """Current (A) of block ``k``."""
        return self.amplitude_a * np.sin(2 * np.pi * self.f_hz[k] * self.time_s)


def _finite_positive(name: str, value) -> float:
    if isinstance(value, (bool, str, bytes)):
        raise ParameterError(f"{name} must be a number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ParameterError(f"{name} must be finite and > 0, got {value!r}")
    return v


def _whole_count(name: str, value, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ParameterError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def samples_per_period(period_s: float, sample_rate_hz: float) -> int:
    """period_s x sample_rate_hz when it is a whole number (to 1e-9 relative), else ``ParameterError``."""
    n = period_s * sample_rate_hz
    whole = round(n)
    if whole < 1 or abs(n - whole) > 1e-9 * max(n, 1.0):
        raise ParameterError(f"period_s {period_s:g} s at sample_rate_hz {sample_rate_hz:g} Hz is {n:.6g} samples: "
                             "the period must be a whole number of samples")
    return int(whole)


def periods_for(*, period_s: float, sample_rate_hz: float, duration_s: float | None = None,
                periods: int | None = None) -> int:
    """Number of periods for a total machine time ``duration_s`` (a whole number of periods; default the
    thesis stepped sine's 50 x 5 s) or given directly; at least 2 (the first is dropped as the transient)
    and at most ``MAX_SAMPLES`` samples in all."""
    n_period = samples_per_period(_finite_positive("period_s", period_s),
                                  _finite_positive("sample_rate_hz", sample_rate_hz))
    if duration_s is not None and periods is not None:
        raise ParameterError("give duration_s or periods, not both")
    if periods is None:
        duration = THESIS_FREQUENCIES * THESIS_BLOCK_S if duration_s is None else _finite_positive("duration_s",
                                                                                                  duration_s)
        if duration * sample_rate_hz > MAX_SAMPLES:
            raise ParameterError(f"duration_s {duration:g} s at {sample_rate_hz:g} Hz is "
                                 f"{duration * sample_rate_hz:.3g} samples, more than {MAX_SAMPLES:.3g}")
        periods = round(duration / period_s)
        if abs(periods * period_s - duration) > 1e-9 * duration:
            raise ParameterError(f"duration_s {duration:g} s is not a whole number of periods of period_s "
                                 f"{period_s:g} s")
    elif periods * n_period > MAX_SAMPLES:
        raise ParameterError(f"periods {periods} x {n_period} samples is {periods * n_period:.3g} samples, "
                             f"more than {MAX_SAMPLES:.3g}")
    if periods < 2:
        raise ParameterError(f"{periods} period(s): at least 2 are needed (the first is dropped as the transient); "
                             "raise duration_s or periods")
    return int(periods)


def odd_log_lines(f_min_hz: float, f_max_hz: float, period_s: float, lines_per_decade: float | None) -> np.ndarray:
    """Odd harmonic numbers h (f = h / period_s) in [f_min_hz, f_max_hz], log-spaced.

    The lowest and highest odd harmonics of the band and round(decades x ``lines_per_decade``)
    - 1 log-spaced targets between them, each snapped to the nearest odd harmonic, duplicates
    merged: where the odd harmonics are sparser than the targets (the low end) every odd
    harmonic is excited, elsewhere the odd lines skipped carry no excitation and show odd-order
    distortion. ``lines_per_decade`` None keeps every odd harmonic of the band.
    """
    h_lo = math.ceil(f_min_hz * period_s - 1e-9)
    h_hi = math.floor(f_max_hz * period_s + 1e-9)
    h_lo += 1 - h_lo % 2
    h_hi -= 1 - h_hi % 2
    if h_hi < h_lo:
        return np.array([], dtype=int)
    if lines_per_decade is None or h_hi == h_lo:
        return np.arange(h_lo, h_hi + 1, 2)
    count = max(round(math.log10(h_hi / h_lo) * lines_per_decade), 1) + 1
    targets = np.geomspace(h_lo, h_hi, count)
    return np.unique(np.clip(2 * np.round((targets - 1) / 2) + 1, h_lo, h_hi).astype(int))


def schroeder_phases(harmonics: np.ndarray, amplitudes: np.ndarray) -> np.ndarray:
    """Schroeder (1970) phases (rad) of odd harmonics ``harmonics`` with ``amplitudes``:
    phi_k = -pi sum_{l<k} (h_k - h_l) p_l, p_l = a_l^2 / sum a^2 (the module doc)."""
    h = np.asarray(harmonics, float)
    p = np.asarray(amplitudes, float) ** 2
    p = p / p.sum()
    below = np.cumsum(p) - p                       # sum_{l<k} p_l
    below_h = np.cumsum(h * p) - h * p             # sum_{l<k} h_l p_l
    phi = -np.pi * (h * below - below_h)
    return np.mod(phi, 2 * np.pi)


def _period(harmonics, amplitudes, phases, n: int) -> np.ndarray:
    """One period (n samples) of sum_k a_k cos(2 pi h_k i / n + phi_k), i = 0 .. n-1."""
    X = np.zeros(n // 2 + 1, complex)
    X[harmonics] = n / 2 * amplitudes * np.exp(1j * phases)
    return np.fft.irfft(X, n)


def _crest(x: np.ndarray) -> float:
    return float(np.max(np.abs(x)) / np.sqrt(np.mean(x**2)))


def optimise_phases(harmonics: np.ndarray, amplitudes: np.ndarray, phases: np.ndarray, n: int,
                    iterations: int = OPTIMISE_ITERATIONS) -> np.ndarray:
    """Phases (rad) of lower crest factor from the starting ``phases``: the time-frequency
    swapping algorithm of Van der Ouderaa, Schoukens & Renneboog (1988). Each iteration clips
    the period (n samples) at a fraction (``CLIP_LEVELS``, in turn) of its peak, takes the
    clipped signal's DFT phases on the excited lines and rebuilds the period with the original
    amplitudes (nothing on other lines). The phases of the lowest crest factor seen, the start
    included, are returned."""
    best_phi, best = phases, _crest(_period(harmonics, amplitudes, phases, n))
    phi = phases
    for it in range(iterations):
        x = _period(harmonics, amplitudes, phi, n)
        c = _crest(x)
        if c < best:
            best_phi, best = phi, c
        level = CLIP_LEVELS[it % len(CLIP_LEVELS)] * np.max(np.abs(x))
        phi = np.angle(np.fft.rfft(np.clip(x, -level, level))[harmonics])
    x = _period(harmonics, amplitudes, phi, n)
    return phi if _crest(x) < best else best_phi


def design_multisine(*, f_min_hz: float, f_max_hz: float, peak_a: float, period_s: float,
                     sample_rate_hz: float = 2000.0, periods: int = 1, lines_per_decade: float | None = None,
                     phases: str = "schroeder", seed: int = 0) -> Multisine:
    """An odd log-spaced multisine of flat amplitude spectrum whose played peak is ``peak_a`` (A).

    ``period_s`` (s): one period, a whole number of samples at ``sample_rate_hz`` (Hz); the
    frequency resolution is 1 / period_s and the lines are its odd multiples (``odd_log_lines``)
    in [``f_min_hz``, ``f_max_hz``] (Hz, below the Nyquist frequency), about ``lines_per_decade``
    per decade where the odd harmonics are dense enough (None: every odd harmonic).
    ``periods``: how many periods ``current_a`` holds. ``phases``: "schroeder", "optimised" or
    "random" (the module doc); ``seed`` draws the random phases and the random starts of the
    optimisation. ``ParameterError`` names the argument that is not finite, out of range,
    leaves no line in the band or makes more than ``MAX_SAMPLES`` samples.
    """
    f_min = _finite_positive("f_min_hz", f_min_hz)
    f_max = _finite_positive("f_max_hz", f_max_hz)
    peak = _finite_positive("peak_a", peak_a)
    period = _finite_positive("period_s", period_s)
    fs = _finite_positive("sample_rate_hz", sample_rate_hz)
    n_periods = _whole_count("periods", periods, 1)
    if lines_per_decade is not None:
        lines_per_decade = _finite_positive("lines_per_decade", lines_per_decade)
    if phases not in PHASES:
        raise ParameterError(f"phases must be one of {', '.join(PHASES)}, got {phases!r}")
    if f_min > f_max:
        raise ParameterError(f"f_min_hz {f_min:g} Hz is above f_max_hz {f_max:g} Hz")
    if f_max >= fs / 2:
        raise ParameterError(f"f_max_hz {f_max:g} Hz is not below the Nyquist frequency {fs / 2:g} Hz "
                             f"(sample_rate_hz {fs:g})")
    n = samples_per_period(period, fs)
    if n * n_periods > MAX_SAMPLES:
        raise ParameterError(f"periods {n_periods} x {n} samples per period (period_s {period:g} s at {fs:g} Hz) is "
                             f"{n * n_periods:.3g} samples, more than {MAX_SAMPLES:.3g}")
    h = odd_log_lines(f_min, f_max, period, lines_per_decade)
    if h.size == 0:
        raise ParameterError(f"no odd harmonic of 1/period_s = {1 / period:g} Hz lies in the band f_min_hz {f_min:g} "
                             f"to f_max_hz {f_max:g} Hz; widen the band or lengthen period_s")
    amplitudes = np.ones(h.size)
    if phases == "random":
        phi = np.random.default_rng(seed).uniform(0, 2 * np.pi, h.size)
    else:
        phi = schroeder_phases(h, amplitudes)
        if phases == "optimised":
            rng = np.random.default_rng(seed)
            starts = [phi] + [rng.uniform(0, 2 * np.pi, h.size) for _ in range(OPTIMISE_STARTS)]
            phi = min((optimise_phases(h, amplitudes, p0, n) for p0 in starts),
                      key=lambda p: _crest(_period(h, amplitudes, p, n)))
    one = _period(h, amplitudes, phi, n)
    scale = peak / np.max(np.abs(one))
    one = one * scale
    current = np.tile(one, n_periods)
    rms = float(np.sqrt(np.mean(one**2)))
    return Multisine(time_s=np.arange(current.size) / fs, current_a=current, f_hz=h / period, harmonics=h,
                     amplitudes=amplitudes * scale, phases=np.mod(phi, 2 * np.pi), period_s=period,
                     sample_rate_hz=fs, periods=n_periods, samples_per_period=n, crest_factor=peak / rms,
                     rms_a=rms, peak_a=peak, phase_method=phases)


@dataclass(frozen=True)
class VariancePrediction:
    """Predicted E|G_hat - G|^2 ((m/s per A)^2) of the multisine and of the thesis stepped sine.

    ``multisine_variance`` per excited line (``f_hz``) after ``multisine_time_s`` of machine
    time; ``stepped_variance`` per block (``stepped_f_hz``) after ``stepped_time_s``. The
    figures of merit are variance x machine time ((m/s per A)^2 s): ``multisine_variance_s``
    and ``stepped_variance_s``, the mean over lines; ``ratio`` = stepped / multisine (> 1: the
    multisine is better per second of machine time).
    """

    f_hz: np.ndarray
    multisine_variance: np.ndarray
    multisine_time_s: float
    stepped_f_hz: np.ndarray
    stepped_variance: np.ndarray
    stepped_time_s: float
    noise_m_per_s: float

    @property
    def multisine_variance_s(self) -> float:
        return float(np.mean(self.multisine_variance) * self.multisine_time_s)

    @property
    def stepped_variance_s(self) -> float:
        return float(np.mean(self.stepped_variance) * self.stepped_time_s)

    @property
    def ratio(self) -> float:
        return self.stepped_variance_s / self.multisine_variance_s

    @property
    def better(self) -> str:
        """"multisine" or "stepped_sine": the lower variance per second of machine time."""
        return "multisine" if self.ratio > 1 else "stepped_sine"

    def verdict(self, crest_factor: float) -> str:
        """Which excitation to use and why: at one peak current, a multisine of N lines with crest factor c
        gives each line 2 / (c^2 N) of the peak power a stepped sine gives each of its N_f frequencies for
        N_f times less time, so it is better per second only when c^2 N < 2 N_f."""
        n, nf = self.f_hz.size, self.stepped_f_hz.size
        why = (f"at {crest_factor:.3g} crest factor and {n} lines, c^2 N = {crest_factor ** 2 * n:.3g} against "
               f"2 N_f = {2 * nf} for the stepped sine's {nf} frequencies")
        if self.better == "multisine":
            fewer = f"; it measures {n} frequencies, the stepped sine {nf}" if n < nf else ""
            return f"the multisine is better per second (ratio {self.ratio:.3g}): {why}{fewer}"
        return (f"the STEPPED SINE is better per second here (ratio {self.ratio:.3g}; this multisine needs "
                f"{1 / self.ratio:.3g} x the machine time for the same variance): {why}. Measure with the stepped "
                "sine, or keep the multisine where measuring every line at once matters (a plant that drifts, "
                "distortion seen at the lines not excited)")


def multisine_variance(multisine: Multisine, noise_m_per_s: float, transient_periods: int = 1) -> np.ndarray:
    """Predicted E|G_hat_k - G_k|^2 ((m/s per A)^2) per excited line from all periods but the
    first ``transient_periods``, for white velocity noise of standard deviation ``noise_m_per_s``.

    With the unnormalised DFT of one period of N samples, X_k = sum_{n<N} x[n] e^{-j 2 pi k n / N},
    a line a cos(2 pi k n / N + phi) has |U_k| = N a / 2 and white noise of variance s^2 has
    E|V_k|^2 = N s^2. G_hat_k = V_bar_k / U_bar_k, the ratio of the means over the P periods
    kept (``plant.estimate.frf_estimation.periodic_response``); the current is the command, known without
    noise, so U_bar_k = U_k and var(G_hat_k) = N s^2 / (P |U_k|^2) = 4 s^2 / (P N a_k^2).
    """
    p = multisine.periods - _whole_count("transient_periods", transient_periods, 0)
    if p < 1:
        raise ParameterError(f"transient_periods {transient_periods} leaves no period of {multisine.periods}")
    s = _finite_positive("noise_m_per_s", noise_m_per_s)
    n = multisine.samples_per_period
    return n * s**2 / (p * (n * multisine.amplitudes / 2) ** 2)


def stepped_sine_variance(*, amplitude_a: float, block_s: float, settle_s: float, sample_rate_hz: float,
                          noise_m_per_s: float) -> float:
    """Predicted E|G_hat - G|^2 ((m/s per A)^2) of one stepped-sine block (lock-in, ``plant.estimate.lockin``).

    The block is a sinusoid of amplitude A = ``amplitude_a`` (A) for ``block_s`` seconds; the
    lock-in fits it over the N = (block_s - settle_s) x fs samples after settling. The phasor
    estimate (2 / N) sum v[n] e^{-j w n / fs} of white noise of variance s^2 has variance
    4 s^2 / N (2 s^2 / N in each of its real and imaginary parts), so with the current known,
    var(G_hat) = 4 s^2 / (N A^2). Over whole periods the offset and harmonics the lock-in also
    fits are orthogonal to the fundamental and add nothing.
    """
    n = math.floor((block_s - settle_s) * sample_rate_hz + 1e-9)
    if n < 1:
        raise ParameterError(f"settle_s {settle_s:g} s leaves no sample of a {block_s:g} s block")
    return 4 * _finite_positive("noise_m_per_s", noise_m_per_s) ** 2 / (n * amplitude_a**2)


def thesis_frequencies(f_min_hz: float, f_max_hz: float, count: int = THESIS_FREQUENCIES) -> np.ndarray:
    """The stepped sine's frequencies (Hz): ``count`` log-spaced over the band, the tool's thesis default."""
    return np.geomspace(f_min_hz, f_max_hz, count) if count > 1 else np.array([f_min_hz])


def design_stepped_sine(*, f_min_hz: float, f_max_hz: float, amplitude_a: float,
                        frequencies: int = THESIS_FREQUENCIES, block_s: float = THESIS_BLOCK_S,
                        sample_rate_hz: float = 2000.0) -> SteppedSine:
    """The thesis stepped sine over a band: ``frequencies`` log-spaced from ``f_min_hz`` to ``f_max_hz`` (Hz,
    ``thesis_frequencies``), ``block_s`` (s, a whole number of samples at ``sample_rate_hz``) each, peak
    ``amplitude_a`` (A). ``ParameterError`` names the argument that is not finite or out of range."""
    f_min = _finite_positive("f_min_hz", f_min_hz)
    f_max = _finite_positive("f_max_hz", f_max_hz)
    amplitude = _finite_positive("amplitude_a", amplitude_a)
    count = _whole_count("frequencies", frequencies, 1)
    block = _finite_positive("block_s", block_s)
    fs = _finite_positive("sample_rate_hz", sample_rate_hz)
    if f_min > f_max:
        raise ParameterError(f"f_min_hz {f_min:g} Hz is above f_max_hz {f_max:g} Hz")
    if f_max >= fs / 2:
        raise ParameterError(f"f_max_hz {f_max:g} Hz is not below the Nyquist frequency {fs / 2:g} Hz "
                             f"(sample_rate_hz {fs:g})")
    try:
        n = samples_per_period(block, fs)
    except ParameterError:
        raise ParameterError(f"block_s {block:g} s at sample_rate_hz {fs:g} Hz is {block * fs:.6g} samples: a block "
                             "must be a whole number of samples") from None
    if n * count > MAX_SAMPLES:
        raise ParameterError(f"frequencies {count} x {n} samples per block is {n * count:.3g} samples, more than "
                             f"{MAX_SAMPLES:.3g}")
    if block <= STEPPED_SETTLE_S:
        raise ParameterError(f"block_s {block:g} s leaves nothing after the {STEPPED_SETTLE_S:g} s the lock-in "
                             "drops to settle")
    return SteppedSine(f_hz=thesis_frequencies(f_min, f_max, count), amplitude_a=amplitude, block_s=block,
                       sample_rate_hz=fs, samples_per_block=n)


def predicted_variance(multisine: Multisine, *, noise_m_per_s: float, transient_periods: int = 1,
                       stepped_f_hz: np.ndarray | None = None, stepped_amplitude_a: float | None = None,
                       block_s: float = THESIS_BLOCK_S, settle_s: float = STEPPED_SETTLE_S) -> VariancePrediction:
    """The frequency-response variance the design gives, against the thesis stepped sine.

    Both for white velocity noise of standard deviation ``noise_m_per_s`` (m/s) sampled at the
    multisine's rate: the multisine per line by ``multisine_variance`` (``transient_periods``
    dropped, their time still counted as machine time), the stepped sine per block by
    ``stepped_sine_variance`` with one ``block_s`` block per frequency of ``stepped_f_hz``
    (default ``thesis_frequencies`` over the multisine's band, ends at its lowest and highest
    line), ``settle_s`` dropped per block, amplitude ``stepped_amplitude_a`` (default the
    multisine's peak: the same peak current). Per line, for flat spectra, the ratio of variance
    x machine time is 2 K block_s / ((block_s - settle_s) F CF^2) with K frequencies, F lines
    and the multisine's crest factor CF: at equal peak current a single sine puts the most
    energy on its line per second (CF = sqrt 2), so the multisine gains through fewer lines
    than blocks, less settling, or not at all.
    """
    ms = multisine_variance(multisine, noise_m_per_s, transient_periods)
    f_ss = thesis_frequencies(float(multisine.f_hz[0]), float(multisine.f_hz[-1])) if stepped_f_hz is None \
        else np.asarray(stepped_f_hz, float)
    amp = multisine.peak_a if stepped_amplitude_a is None else _finite_positive("stepped_amplitude_a",
                                                                                stepped_amplitude_a)
    var = stepped_sine_variance(amplitude_a=amp, block_s=_finite_positive("block_s", block_s), settle_s=settle_s,
                                sample_rate_hz=multisine.sample_rate_hz, noise_m_per_s=noise_m_per_s)
    return VariancePrediction(f_hz=multisine.f_hz, multisine_variance=ms, multisine_time_s=multisine.duration_s,
                              stepped_f_hz=f_ss, stepped_variance=np.full(f_ss.shape, var),
                              stepped_time_s=f_ss.size * block_s, noise_m_per_s=float(noise_m_per_s))


def write_stepped_sine_csv(stepped: SteppedSine, path: str | Path) -> None:
    """Write ``frequency_hz,time_s,current_a`` rows (Hz, s, A) of every block atomically, the long format of
    a stepped-sine recording (``docs/formats.md``) without its outputs."""
    t = stepped.time_s
    atomic_write_text(path, "frequency_hz,time_s,current_a\n" + "".join(
        csv_rows(np.column_stack([np.full(t.size, f), t, stepped.block_current_a(k)]), ["%.9g", "%.9f", "%.9g"])
        for k, f in enumerate(stepped.f_hz)))


def write_excitation_csv(multisine: Multisine, path: str | Path) -> None:
    """Write ``time_s,current_a`` rows (s, A) of every period atomically (never a half-written file)."""
    atomic_write_text(path, "time_s,current_a\n" + csv_rows(np.column_stack([multisine.time_s, multisine.current_a]),
                                                              ["%.9f", "%.9g"]))
