"""Speed of ``fit_plant`` and ``fit_rational`` on 50 frequencies (thesis section 4.1 grid, 1-75 Hz).

Prints the median wall time per call over seeded noisy data sets. Target (the diagnosis
refits every effect): tens of ms per ``fit_plant`` call.

    python benchmarks/fitting.py
"""

from __future__ import annotations

import time

import as_commands  # noqa: F401  (BLAS on one thread, as the commands run it)
import numpy as np

from plant import CoulombFriction, CurrentLoop, Delay, Resonance, stage_x, stage_y
from plant.data.frequency_response import MeasuredResponse
from plant.identify.fitting import fit_plant
from plant.identify.rational_fit import fit_rational

F_HZ = np.linspace(1.0, 75.0, 50)
W = 2 * np.pi * F_HZ
REPEATS = 20


def measured(plant, seed: int, noise: float = 0.02) -> MeasuredResponse:
    g = plant.frd_outputs(W)
    var = np.full(g.shape, (noise * np.abs(g[:, :1])) ** 2)
    rng = np.random.default_rng(seed)
    g = g + np.sqrt(var / 2) * (rng.standard_normal(g.shape) + 1j * rng.standard_normal(g.shape))
    return MeasuredResponse(f_hz=F_HZ, response=g, variance=var, output_names=plant.output_names,
                            current_amplitude_a=np.ones_like(F_HZ), snr_db=np.zeros(g.shape),
                            harmonic_distortion=np.zeros(g.shape + (2,)))


def median_ms(fn) -> float:
    times = []
    for seed in range(REPEATS):
        t0 = time.perf_counter()
        fn(seed)
        times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


def main() -> None:
    cases = [
        ("X + delay (3 free)", stage_x(mass_kg=40.0) * Delay(1e-3), stage_x() * Delay()),
        ("X + delay + current_loop (4 free, degenerate)", stage_x() * Delay(5e-4) * CurrentLoop(1000.0),
         stage_x() * Delay() * CurrentLoop()),
        ("Y 2 rails + current_loop + resonance (6 free)", stage_y(mass_kg=30.0) * CurrentLoop(150.0)
         * Resonance(45.0, 30.0, 0.05), stage_y() * CurrentLoop() * Resonance()),
        ("X + coulomb_friction (3 free)", stage_x(excitation_current_a=1.0) * CoulombFriction(15.0),
         stage_x(excitation_current_a=1.0) * CoulombFriction()),
    ]
    print(f"fit_plant, 50 frequencies, median of {REPEATS} seeded data sets:")
    for label, truth, model in cases:
        datas = [measured(truth, seed) for seed in range(REPEATS)]
        print(f"  {label:<50s} {median_ms(lambda s: fit_plant(model, datas[s])):7.1f} ms")
    base = fit_plant(stage_x(), measured(stage_x() * Delay(1e-3), 0))
    datas = [measured(stage_x() * Delay(1e-3), seed) for seed in range(REPEATS)]
    print(f"  {'refit previous result * Delay() (diagnosis step)':<50s} "
          f"{median_ms(lambda s: fit_plant(base.plant * Delay(), datas[s])):7.1f} ms")
    g = stage_x().frd(W) * np.exp(-1j * W * 1e-3)
    print("fit_rational, 50 frequencies:")
    print(f"  {'2 poles, 1 zero':<50s} {median_ms(lambda s: fit_rational(W, g, n_poles=2, n_zeros=1)):7.1f} ms")
    print(f"  {'1 pole + delay (41-point delay grid)':<50s} "
          f"{median_ms(lambda s: fit_rational(W, g, n_poles=1, n_zeros=0, delay=True)):7.1f} ms")


if __name__ == "__main__":
    main()
