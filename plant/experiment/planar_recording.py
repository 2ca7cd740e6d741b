"""A stepped sine of the X motor on the planar machine (``plant.physics.planar.PlanarGantry``) with every encoder
recorded: what ``plant.diagnose.coupling`` reads to find where X and Y meet.

The machine's linear model at rest with the carriage at ``carriage_position_m``, the X motor's force k_x E i through a
first-order current loop E, each block a sine of the current from rest, stepped exactly between samples
(``plant.physics.state_space.hold_step``: the current held over each sample interval); white noise (seeded) on the
current and on each velocity. Outputs: the rails' and the carriage's velocities (``OUTPUT_NAMES``).
"""

from __future__ import annotations

import math

import numpy as np

from plant.data.recordings import Block, Recording
from plant.errors import ParameterError
from plant.physics.planar import PlanarGantry
from plant.physics.state_space import hold_step

#: the outputs, as ``plant.diagnose.coupling`` reads them
OUTPUT_NAMES = ("velocity_y1_m_per_s", "velocity_y2_m_per_s", "velocity_x_m_per_s")


def x_motor_recording(machine: PlanarGantry, carriage_position_m: float, f_hz, *, force_constant_n_per_a: float = 20.0,
                      current_loop_hz: float = 1000.0, amplitude_a: float = 1.0, sample_rate_hz: float = 4000.0,
                      periods: int = 30, min_block_s: float = 1.0, velocity_noise_m_per_s: float = 1e-5,
                      current_noise_a: float = 1e-3, seed: int = 0) -> Recording:
    """The recording of the module doc, one block per frequency of ``f_hz`` (Hz, each below a quarter of the
    sample rate), each ``periods`` periods long and at least ``min_block_s``."""
    f = np.asarray(f_hz, float).ravel()
    if f.size == 0 or not np.all(np.isfinite(f)) or np.any(f <= 0) or np.any(f > sample_rate_hz / 4):
        raise ParameterError(f"f_hz: frequencies must be positive and at most a quarter of the sample rate "
                             f"({sample_rate_hz / 4:g} Hz), got {f_hz!r}")
    A, B, C = machine.linearised(carriage_position_m)
    n = A.shape[0]
    wc = 2 * math.pi * current_loop_hz
    # states (q, q', the current loop's force); input the commanded current
    Af = np.zeros((n + 1, n + 1))
    Af[:n, :n], Af[:n, n] = A, B[:, 2]
    Af[n, n] = -wc
    Bf = np.zeros((n + 1, 1))
    Bf[n, 0] = wc * force_constant_n_per_a
    Cf = np.hstack([C[:3], np.zeros((3, 1))])             # y1', y2', p'
    h = 1.0 / sample_rate_hz
    Phi, Gamma = hold_step(Af, Bf, h)
    rng = np.random.default_rng(seed)
    blocks = []
    for fk in f:
        m = int(math.ceil(max(periods / fk, min_block_s) * sample_rate_hz))
        t = np.arange(m) * h
        i = amplitude_a * np.sin(2 * math.pi * fk * t)
        x = np.zeros(n + 1)
        y = np.empty((3, m))
        for k in range(m):
            y[:, k] = Cf @ x
            x = Phi @ x + Gamma[:, 0] * i[k]
        blocks.append(Block(float(fk), t, i + current_noise_a * rng.standard_normal(m),
                            y + velocity_noise_m_per_s * rng.standard_normal(y.shape)))
    return Recording(tuple(blocks), OUTPUT_NAMES, source="<planar x-motor simulation>",
                     metadata={"carriage_position_m": float(carriage_position_m), "seed": seed,
                               "beam_skew_rad": machine.beam_skew_rad, "carriage_offset_m": machine.carriage_offset_m})
