"""Benchmark of ``gantry sweep``: 71 payloads x 1000 Monte Carlo samples (target: < 10 s
on a 2-core machine), and the accuracy of the fast path (``design.loop.fast``) against the
default-grid computation (``design.loop.analysis.analyse_loop``, 3000 points) and a 30 000-point grid.

Plant: thesis Stage X (Eq. 3.15) with a 0.5 ms delay and a 1 kHz current loop, thesis PI gains
(Kp = 236, Ki = 47); uniform uncertainty in damping (330-550 N*s/m, thesis section 3.1), force
constant (18-22 N/A), delay (0.25-1 ms) and current-loop bandwidth (0.5-2 kHz).

Run: ``python benchmarks/bench_sweep.py``; exits 1 if the accuracy check fails.
"""

from __future__ import annotations

import sys
import time

import as_commands  # noqa: F401  (BLAS on one thread, as the commands run it)
import numpy as np

from design.loop.analysis import analyse_loop
from design.loop.controller import PI
from design.loop.sweep import batch_plant, monte_carlo_sweep
from design.spec.schema import parse_spec
from plant.grid import log_grid_rad_s

PAYLOADS = np.linspace(5.0, 40.0, 71)
SAMPLES = 1000
SUBSET = 2000  # plants checked against the default grid
TRUTH_SUBSET = 300  # plants checked against a 30 000-point grid
#: fast path against the default grid: relative bandwidth, PM (deg), GM (dB)
TOLERANCE = {"closed_loop_bandwidth_hz": 1e-4, "phase_margin_deg": 5e-3, "gain_margin_db": 5e-3}

SPEC = parse_spec({
    "name": "benchmark: Stage X with delay and current loop",
    "plant": {
        "stage": "x", "force_constant_n_per_a": 20.0, "damping_n_s_per_m": 440.0,
        "payload_kg": {"min": 5.0, "max": 40.0, "points": 71, "nominal": 35.0},
        "effects": {"delay": {"seconds": 5e-4}, "current_loop": {"bandwidth_hz": 1000.0}},
        "uncertainty": {
            "damping_n_s_per_m": {"min": 330.0, "max": 550.0},
            "force_constant_n_per_a": {"min": 18.0, "max": 22.0},
            "delay.seconds": {"min": 2.5e-4, "max": 1.0e-3},
            "current_loop.bandwidth_hz": {"min": 500.0, "max": 2000.0},
        },
    },
    "controller": {"kp": 236.0, "ki": 47.0},
}, source="benchmark")


def _errors(fast: dict, ref) -> dict[str, float]:
    return {
        "closed_loop_bandwidth_hz": float(np.nanmax(np.abs(fast["closed_loop_bandwidth_hz"]
                                                           / ref.closed_loop_bandwidth_hz - 1))),
        "phase_margin_deg": float(np.max(np.abs(fast["phase_margin_deg"] - ref.margins.phase_margin_deg))),
        "gain_margin_db": float(np.max(np.abs(fast["gain_margin_db"] - ref.margins.gain_margin_db))),
    }


def _show(label: str, err: dict[str, float]) -> None:
    print(f"  {label}: bandwidth {err['closed_loop_bandwidth_hz']:.2e} (relative), "
          f"PM {err['phase_margin_deg']:.2e} deg, GM {err['gain_margin_db']:.2e} dB")


def main() -> int:
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        result = monte_carlo_sweep(SPEC, payload_kg=PAYLOADS, samples=SAMPLES, seed=0)
        times.append(time.perf_counter() - t0)
    best, median = min(times), float(np.median(times))
    print(f"sweep {PAYLOADS.size} payloads x {SAMPLES} samples = {PAYLOADS.size * SAMPLES} plants: "
          f"wall time best {best:.2f} s, median {median:.2f} s of {len(times)} runs "
          f"(target < 10 s: {'met' if median < 10 else 'MISSED'})")

    kp, ki = result.controller.kp, result.controller.ki
    rng = np.random.default_rng(1)
    rows = np.sort(rng.choice(PAYLOADS.size * SAMPLES, SUBSET, replace=False))
    fast = {q: d.samples.ravel()[rows] for q, d in
            zip(("closed_loop_bandwidth_hz", "phase_margin_deg", "gain_margin_db"), result.distributions)}
    plants = batch_plant(SPEC.problem().plant.plant(), PAYLOADS, result.parameter_samples, rows=rows)
    err = _errors(fast, analyse_loop(plants, PI(kp, ki)))
    print(f"accuracy on {SUBSET} random plants (max over the subset):")
    _show("fast path vs default grid (3000 points)", err)

    few = rows[:TRUTH_SUBSET]
    fine = log_grid_rad_s(1e-3, 1e4, 30000)
    few_plants = batch_plant(SPEC.problem().plant.plant(), PAYLOADS, result.parameter_samples, rows=few)
    truth = analyse_loop(few_plants, PI(kp, ki), w_rad_s=fine)
    default = analyse_loop(few_plants, PI(kp, ki))
    _show(f"fast path vs 30000-point grid ({TRUTH_SUBSET} plants)",
          _errors({q: v[:TRUTH_SUBSET] for q, v in fast.items()}, truth))
    _show(f"default grid vs 30000-point grid ({TRUTH_SUBSET} plants)",
          _errors({"closed_loop_bandwidth_hz": default.closed_loop_bandwidth_hz,
                   "phase_margin_deg": default.margins.phase_margin_deg,
                   "gain_margin_db": default.margins.gain_margin_db}, truth))
    failed = [q for q, tol in TOLERANCE.items() if not err[q] <= tol]
    print("accuracy check:", f"FAILED for {', '.join(failed)}" if failed else f"passed (tolerances {TOLERANCE})")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
