"""Speed of ``simulate_stepped_sine`` on the thesis experiment: 50 frequencies 1-75 Hz (log),
5 s per block at 2 kHz (section 4.1), 1 % noise. Prints the best of 3 wall times per case.

    python benchmarks/simulate.py
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import as_commands  # noqa: F401  (BLAS on one thread, as the commands run it)
import numpy as np

from plant import (
    CoulombFriction,
    CurrentLoop,
    Delay,
    Sampling,
    TiltCoupling,
    stage_x,
    stage_y,
)
from plant.data.writers import write_recording_csv
from plant.experiment.simulate import simulate_stepped_sine

F_HZ = np.geomspace(1.0, 75.0, 50)
CASES = {
    "X delay+current_loop (closed form)": (stage_x(mass_kg=40.0) * Delay(0.001) * CurrentLoop(200.0), 0.5),
    "Y tilt off-centre (closed form)": (stage_y(load_position_m=0.25) * TiltCoupling(), 1.75),
    "X sampling 10 kHz+delay (stepping)": (stage_x() * Sampling(10000.0) * Delay(0.001), 0.5),
    "X Coulomb 2 N (stepping, 20 kHz)": (stage_x(excitation_current_a=0.5) * CoulombFriction(2.0), 0.5),
    "Y tilt+Coulomb 5 N (two contacts)": (
        stage_y(load_position_m=0.25, excitation_current_a=1.75).with_effects(TiltCoupling(), CoulombFriction(5.0)),
        1.75),
}


def best_of(fn, repeats: int = 3) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    print(f"{len(F_HZ)} blocks x 5 s at 2 kHz ({len(F_HZ) * 10000} samples per output)")
    for name, (plant, amp) in CASES.items():
        repeats = 1 if "contacts" in name else 3
        t = best_of(lambda: simulate_stepped_sine(plant, f_hz=F_HZ, current_amplitude_a=amp, noise_fraction=0.01),
                    repeats)
        print(f"  {name:45s} {t:7.2f} s")
    rec = simulate_stepped_sine(stage_x() * Delay(0.001), f_hz=F_HZ, current_amplitude_a=0.5, noise_fraction=0.01)
    with tempfile.TemporaryDirectory() as tmp:
        t = best_of(lambda: write_recording_csv(rec, Path(tmp) / "rec.csv"), 1)
    print(f"  {'write_recording_csv (for comparison)':45s} {t:7.2f} s")


if __name__ == "__main__":
    main()
