"""Multisine against the thesis stepped sine: FRF variance per second of machine time, measured.

Run:  python benchmarks/bench_excitation.py [--repeats 100] [--noise-m-per-s 1e-3] [--seed 0]

Plant: Stage X as a mass-damper, v' = (k_t i - c v) / m with m = 20 kg, c = 400 N s/m and the
force constant k_t of ``plant.physics.models.Plant`` (20 N/A), driven by a zero-order-held current and
sampled at 2 kHz: exactly v[n+1] = a v[n] + b i[n], a = exp(-c Ts / m), b = k_t (1 - a) / c,
so the truth every estimate is compared with is G(f) = b z^-1 / (1 - a z^-1), z = exp(j 2 pi f Ts).
White velocity noise of the same standard deviation in both experiments; both start from rest.

* Stepped sine (thesis section 4.1): 50 log-spaced frequencies 1-75 Hz, one 5 s block each
  (250 s of machine time), amplitude = the multisine's peak current; estimated with the tool's
  lock-in, ``plant.estimate.lockin.estimate_response``.
* Multisine (``plant.experiment.excitation.design_multisine``): repeated periods for the same 250 s, the
  first period dropped; estimated with the tool's periodic estimator,
  ``plant.estimate.frf_estimation.periodic_response``.

Printed per method: the mean over lines and repeats of the actual error |G_hat - G|^2 (the
figure that matters) and of the reported variance, each times the machine time; the ratio
stepped / multisine (> 1: the multisine is better); and measured / predicted
(``plant.experiment.excitation.predicted_variance``). The sampling scatter of a mean over L lines and R
repeats is about 1 / sqrt(L R).
"""

import argparse
import time

import as_commands  # noqa: F401  (BLAS on one thread, as the commands run it)
import numpy as np
from scipy.signal import lfilter

from plant.data.recordings import Block, Recording, TimeRecording
from plant.estimate.frf_estimation import periodic_response
from plant.estimate.lockin import estimate_response
from plant.experiment.excitation import (
    STEPPED_SETTLE_S,
    THESIS_BLOCK_S,
    design_multisine,
    predicted_variance,
    thesis_frequencies,
)
from plant.physics.models import Plant

MASS_KG = 20.0
DAMPING_N_S_PER_M = 400.0
FS_HZ = 2000.0
BAND_HZ = (1.0, 75.0)
PEAK_A = 0.5
#: ratio stepped sine / multisine of the FRF error per second that was asked for
TARGET_RATIO = 10.0
#: multisine designs compared: label and keyword arguments of ``design_multisine``
DESIGNS = (
    ("log 25/decade, 5 s period", dict(period_s=5.0, lines_per_decade=25.0)),
    ("every odd harmonic of 1 Hz", dict(period_s=1.0, lines_per_decade=None)),
)


def mass_damper():
    """ZOH discretisation (a, b) of the Stage X mass-damper and its discrete response G(f_hz) (m/s per A)."""
    kt = Plant("x").force_constant_n_per_a
    a = np.exp(-DAMPING_N_S_PER_M / MASS_KG / FS_HZ)
    b = kt * (1 - a) / DAMPING_N_S_PER_M

    def response(f_hz):
        zi = np.exp(-2j * np.pi * np.asarray(f_hz) / FS_HZ)
        return b * zi / (1 - a * zi)

    return a, b, response


def stepped_sine(a, b, response, noise, repeats, rng):
    """Actual errors and reported variances (repeats, lines) of the lock-in, the machine time (s) and the
    mean seconds per block the lock-in kept after settling."""
    f_hz = thesis_frequencies(*BAND_HZ)
    t = np.arange(int(round(THESIS_BLOCK_S * FS_HZ))) / FS_HZ
    currents = [PEAK_A * np.sin(2 * np.pi * f * t) for f in f_hz]
    clean = [lfilter([0.0, b], [1.0, -a], i) for i in currents]
    err, var, used = [], [], []
    for _ in range(repeats):
        blocks = tuple(Block(f, t, i, (v + noise * rng.standard_normal(v.size))[None, :])
                       for f, i, v in zip(f_hz, currents, clean))
        m = estimate_response(Recording(blocks, ("velocity_m_per_s",)))
        err.append(np.abs(m.response[0] - response(m.f_hz)) ** 2)
        var.append(m.variance[0])
        used.append(np.mean(np.array(m.metadata["periods_used"]) / m.f_hz))
    return np.array(err), np.array(var), f_hz.size * THESIS_BLOCK_S, float(np.mean(used))


def multisine(ms, a, b, response, noise, repeats, rng):
    """Actual errors and reported variances (repeats, lines) of ``periodic_response``."""
    clean = lfilter([0.0, b], [1.0, -a], ms.current_a)
    err, var = [], []
    for _ in range(repeats):
        rec = TimeRecording(ms.time_s, ms.current_a, (clean + noise * rng.standard_normal(clean.size))[None, :],
                            "velocity", ("velocity_m_per_s",))
        m = periodic_response(rec, period_s=ms.period_s, transient_periods=1)
        if not np.allclose(m.f_hz, ms.f_hz):
            raise RuntimeError(f"periodic_response found lines {m.f_hz} instead of the design's {ms.f_hz}")
        err.append(np.abs(m.response[0] - response(m.f_hz)) ** 2)
        var.append(m.variance[0])
    return np.array(err), np.array(var)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=100)
    parser.add_argument("--noise-m-per-s", type=float, default=1e-3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    a, b, response = mass_damper()
    start = time.perf_counter()
    ss_err, ss_var, ss_time, ss_used = stepped_sine(a, b, response, args.noise_m_per_s, args.repeats, rng)
    print(f"band {BAND_HZ[0]:g}-{BAND_HZ[1]:g} Hz, peak current {PEAK_A:g} A, velocity noise "
          f"{args.noise_m_per_s:g} m/s at {FS_HZ:g} Hz, {args.repeats} repeats; Stage X mass-damper "
          f"{MASS_KG:g} kg, {DAMPING_N_S_PER_M:g} N s/m")
    print("figures: mean over lines and repeats x machine time, (m/s per A)^2 s")
    print(f"{'method':<44}{'lines':>6}{'time s':>8}{'CF':>7}{'actual':>11}{'reported':>11}"
          f"{'predicted':>11}{'act/pred':>9}{'ratio':>7}")
    ss_pred, ratios = None, []
    for label, kw in DESIGNS:
        ms = design_multisine(f_min_hz=BAND_HZ[0], f_max_hz=BAND_HZ[1], peak_a=PEAK_A, sample_rate_hz=FS_HZ,
                              periods=round(ss_time / kw["period_s"]), phases="optimised", seed=args.seed, **kw)
        pred = predicted_variance(ms, noise_m_per_s=args.noise_m_per_s, stepped_f_hz=thesis_frequencies(*BAND_HZ),
                                  settle_s=STEPPED_SETTLE_S)
        if ss_pred is None:
            ss_pred = pred.stepped_variance_s
            ss_act = ss_err.mean() * ss_time
            print(f"{'stepped sine, 50 x 5 s blocks, lock-in':<44}{ss_err.shape[1]:>6}{ss_time:>8.0f}"
                  f"{np.sqrt(2):>7.3f}{ss_act:>11.4g}{ss_var.mean() * ss_time:>11.4g}{ss_pred:>11.4g}"
                  f"{ss_act / ss_pred:>9.3f}{'':>7}")
        err, var = multisine(ms, a, b, response, args.noise_m_per_s, args.repeats, rng)
        act = err.mean() * ms.duration_s
        print(f"{'multisine, ' + label:<44}{ms.f_hz.size:>6}{ms.duration_s:>8.0f}{ms.crest_factor:>7.3f}"
              f"{act:>11.4g}{var.mean() * ms.duration_s:>11.4g}{pred.multisine_variance_s:>11.4g}"
              f"{act / pred.multisine_variance_s:>9.3f}{ss_act / act:>7.3f}")
        ratios.append(ss_act / act)
    print("ratio: stepped-sine actual / multisine actual per second (> 1: multisine better; predicted "
          "2 K T_block / ((T_block - settle) F CF^2) for K blocks, F lines)")
    lines_for_target = 2 * ss_err.shape[1] / (TARGET_RATIO * 2.0)     # 2 K / (ratio CF^2) at CF^2 = 2
    print(f"target ratio >= {TARGET_RATIO:g}: {'met' if max(ratios) >= TARGET_RATIO else 'not met'} (best "
          f"{max(ratios):.3g}); at the same peak current it needs F <= 2 K / ({TARGET_RATIO:g} CF^2) = "
          f"{lines_for_target:g} lines even at crest factor sqrt 2")
    print(f"stepped sine predicted with {STEPPED_SETTLE_S:g} s of settling per block; the lock-in kept "
          f"{ss_used:.3f} s of {THESIS_BLOCK_S:g} s on average (settling estimated from the data), which "
          f"accounts for act/pred = {(THESIS_BLOCK_S - STEPPED_SETTLE_S) / ss_used:.3f}")
    print(f"wall time {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
