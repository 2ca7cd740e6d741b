"""Lock-in estimation against the Cramer-Rao bound, and calibration of the reported variance.

Run:  python benchmarks/bench_estimation.py [--realisations 400] [--seed 0]

For a known-frequency sinusoid in white Gaussian noise (sigma, N samples) each quadrature of the
complex amplitude has variance 2 sigma^2 / N, so E|a_hat - a|^2 >= 4 sigma^2 / N. G = V / I, with
noise sigma_v on the velocity and sigma_i on the current, has the bound
    CRB = 4 (sigma_v^2 + |G|^2 sigma_i^2) / (N |I|^2)
(G_hat = V_hat / I_hat is the ML estimate by invariance; first-order propagation). Printed per case:
  scatter/CRB(N)       mean |G_hat - G|^2 over the bound with N = every sample of the block (the
                       honest figure: what the data could give; target <= 1.5)
  scatter/CRB(N_used)  the same with N_used = the samples the estimator kept after settling
                       (efficiency of the fit itself; 1 for an efficient estimator)
  reported/scatter     mean reported variance over the scatter (calibration; 1 is calibrated)
Sampling scatter of the ratios with R realisations: about 1 / sqrt(R) (5 % for R = 400).
The noise-free transient case is not here: see tests/plant/estimate/test_lockin.py.
"""

import argparse
import time

import as_commands  # noqa: F401  (BLAS on one thread, as the commands run it)
import numpy as np

from plant.data.recordings import Block, Recording
from plant.estimate.lockin import estimate_response

AMP_I = 0.5
G = 0.04 * np.exp(-0.7j)


def run_case(f_hz, seconds, fs, snr_db, current_noise, realisations, seed):
    """Return scatter/CRB(N), scatter/CRB(N_used), reported/scatter, bias/sd, settle, sub-blocks."""
    t = np.arange(int(round(seconds * fs))) / fs
    e = np.exp(1j * (2 * np.pi * f_hz * t + 0.4))
    a_v = abs(G) * AMP_I
    sigma_v = a_v / np.sqrt(2) / 10 ** (snr_db / 20)          # per-sample SNR of the velocity (RMS / sigma)
    sigma_i = AMP_I / np.sqrt(2) / 10 ** (snr_db / 20) if current_noise else 0.0
    rng = np.random.default_rng(seed)
    est, rep, used, settle, sub = [], [], [], [], []
    for _ in range(realisations):
        i = AMP_I * e.real + sigma_i * rng.standard_normal(t.size)
        v = np.real(G * AMP_I * e) + sigma_v * rng.standard_normal(t.size)
        m = estimate_response(Recording((Block(f_hz, t, i, v[None, :]),), ("velocity_m_per_s",)))
        est.append(m.response[0, 0])
        rep.append(m.variance[0, 0])
        used.append(m.metadata["periods_used"][0] / f_hz * fs)
        settle.append(m.metadata["settle_s"][0])
        sub.append(m.metadata["subblocks"][0])
    est = np.asarray(est)
    crb_one = 4 * (sigma_v**2 + abs(G) ** 2 * sigma_i**2) / AMP_I**2       # times 1 / N
    scatter = np.mean(np.abs(est - G) ** 2)
    return (scatter / (crb_one / t.size), np.mean(scatter / (crb_one / np.asarray(used))),
            np.mean(rep) / scatter, abs(np.mean(est) - G) / np.sqrt(scatter / est.size),
            np.median(settle), int(np.median(sub)))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--realisations", type=int, default=400)
    parser.add_argument("--seed", type=int, default=0, help="case n uses seed + n")
    args = parser.parse_args()
    cases = [  # (f_hz, seconds, fs, snr_db, noise on the current too)
        (1.0, 5.0, 2000.0, 20.0, False),      # thesis blocks: 5 s, 1 to 75 Hz
        (2.0, 5.0, 2000.0, 20.0, False),
        (7.3, 5.0, 2000.0, 20.0, False),      # non-integer samples per period
        (75.0, 5.0, 2000.0, 20.0, False),
        (20.0, 5.0, 2000.0, -10.0, False),    # SNR per sample -10 dB, 40 dB
        (20.0, 5.0, 2000.0, 40.0, False),
        (20.0, 5.0, 2000.0, 20.0, True),      # noise on current and velocity
        (20.0, 5.0, 2000.0, -10.0, True),
        (20.0, 1.0, 2000.0, 20.0, False),     # shorter blocks
        (2.0, 1.5, 2000.0, 20.0, False),      # 3 periods only
        (5.0, 1.0, 2000.0, 20.0, False),
        (450.0, 1.0, 2000.0, 20.0, False),    # 4.4 samples per period
    ]
    print(f"seeds {args.seed} + case index, {args.realisations} realisations per case, |G| = {abs(G):g} m/s/A, "
          f"I = {AMP_I} A")
    print(f"{'f Hz':>6} {'T s':>4} {'fs Hz':>6} {'SNR dB':>6} {'i-noise':>7} | {'scat/CRB(N)':>11} "
          f"{'scat/CRB(Nu)':>12} {'rep/scat':>8} {'bias/sd':>7} {'settle s':>8} {'k':>3} {'time s':>6}")
    worst_crb, calib = 0.0, []
    for n, (f_hz, seconds, fs, snr, inoise) in enumerate(cases):
        t0 = time.perf_counter()
        r_all, r_used, cal, bias, settle, k = run_case(f_hz, seconds, fs, snr, inoise, args.realisations,
                                                       args.seed + n)
        worst_crb = max(worst_crb, r_all)
        calib.append(cal)
        print(f"{f_hz:6g} {seconds:4g} {fs:6g} {snr:6g} {'yes' if inoise else 'no':>7} | {r_all:11.3f} {r_used:12.3f} "
              f"{cal:8.3f} {bias:7.2f} {settle:8.3f} {k:3d} {time.perf_counter() - t0:6.1f}")
    print(f"worst scatter/CRB(N) = {worst_crb:.3f} (target <= 1.5); reported/scatter from {min(calib):.3f} "
          f"to {max(calib):.3f} (target 1, band [0.7, 1.4])")


if __name__ == "__main__":
    main()
