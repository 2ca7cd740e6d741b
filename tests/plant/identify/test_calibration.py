"""Calibration of the whole chain: simulated recording -> lock-in estimate -> fit.

Over 60 seeded simulated recordings with known truth (Stage X, mass 40 kg, damping 440 N*s/m,
delay 1 ms, current loop 300 Hz, 2 % noise), each true parameter must lie inside its reported
+-2 sigma interval in at least 90 % of the fits (Gaussian theory: 95.4 %). The variance of
each point comes from the estimator's sub-blocks, so this checks estimator and fitter together.
"""

import numpy as np

from plant import CurrentLoop, Delay, stage_x
from plant.estimate.lockin import estimate_response
from plant.experiment.simulate import simulate_stepped_sine
from plant.identify.fitting import fit_plant

TRUTH = {"mass_kg": 40.0, "damping_n_s_per_m": 440.0, "delay.seconds": 1e-3, "current_loop.bandwidth_hz": 300.0}


def test_two_sigma_coverage_on_simulated_recordings():
    truth = stage_x(mass_kg=40.0) * Delay(1e-3) * CurrentLoop(300.0)
    model = stage_x() * Delay() * CurrentLoop()
    inside = {n: [] for n in TRUTH}
    for seed in range(60):
        rec = simulate_stepped_sine(truth, f_hz=np.geomspace(2, 75, 20), current_amplitude_a=0.5, duration_s=3.0,
                                    noise_fraction=0.02, seed=seed)
        r = fit_plant(model, estimate_response(rec))
        for name, true in TRUTH.items():
            inside[name].append(abs(r.values[name] - true) <= 2 * r.stderr[name])
    coverage = {n: float(np.mean(v)) for n, v in inside.items()}
    assert min(coverage.values()) >= 0.90, coverage
