"""Lock-in estimation against the Cramer-Rao bound, and calibration of the reported variance.

Run:  python benchmarks/bench_estimation.py
For a known-frequency sinusoid in white Gaussian noise (sigma, N samples), each quadrature of
the complex amplitude has variance 2 sigma^2 / N, so E|a_hat - a|^2 >= 4 sigma^2 / N; with an
exact current of amplitude I, var(G_hat) >= 4 sigma^2 / (N I^2). 400 realisations per case.
"""

import numpy as np

from plant.lockin import estimate_response
from plant.recording import Block, Recording

FS, SECONDS, AMP_I = 2000.0, 5.0, 0.5
T = np.arange(int(FS * SECONDS)) / FS
G = 0.04 * np.exp(-0.7j)

for f in (1.0, 5.0, 20.0, 75.0):
    for noise in (0.01, 0.05):
        sigma = noise * abs(G) * AMP_I
        rng = np.random.default_rng(0)
        est, rep = [], []
        for _ in range(400):
            wt = 2 * np.pi * f * T
            v = np.real(G * AMP_I * np.exp(1j * wt)) + rng.normal(0, sigma, T.size)
            m = estimate_response(Recording((Block(f, T, AMP_I * np.cos(wt), v[None, :]),), ("velocity_m_per_s",)))
            est.append(m.response[0, 0])
            rep.append(m.variance[0, 0])
            settle = m.metadata["settle_s"][0]
        n = np.floor((T[-1] - settle) * f + 1e-9) / f * FS
        crb = 4 * sigma**2 / (n * AMP_I**2)
        scatter = np.mean(np.abs(np.asarray(est) - G) ** 2)
        print(f"f {f:5.1f} Hz, noise {100 * noise:.0f} %: scatter / CRB = {scatter / crb:.3f} (target <= 1.5), "
              f"reported / actual variance = {np.mean(rep) / scatter:.3f}")
