"""The LPM keeps only the lines the input excited, on records of the independent simulator
``tests/reference/independent_timesim.py``.

A logarithmic chirp that starts at 0.6 Hz, its current measured with noise: below the start the current's
spectrum is the smooth leakage of the record's ends (which the LPM's transient term takes) plus the
measurement noise, on which the output did not move. Evaluated there, the LPM returns confident estimates
biased towards zero (normalised errors of 10 to 35 before the excited band was enforced). The truth is the
simulator's zero-order-hold response.
"""

from __future__ import annotations

import independent_timesim as sim
import numpy as np
import pytest

from plant.data.recordings import TimeRecording
from plant.estimate.frf_estimation import closed_loop_response, lpm_response

FS = 1000.0
T_S = 60.0
F_START_HZ, F_END_HZ = 0.6, 100.0
AXIS = sim.Axis()


def _record(seed: int, current_noise_a: float, current: np.ndarray | None = None) -> TimeRecording:
    t = np.arange(int(T_S * FS)) / FS
    u = sim.chirp(t, F_START_HZ, F_END_HZ, 2.0) if current is None else current
    rec = sim.zoh_record(AXIS, np.random.default_rng(seed), u, fs_hz=FS, noise_std=1e-4,
                         current_noise_std=current_noise_a)
    return TimeRecording(rec.time_s, rec.current_a, rec.output[None, :], "velocity", ("v",), source=f"chirp{seed}")


def _z2(result) -> np.ndarray:
    truth = AXIS.zoh_response(result.f_hz, FS)
    return np.abs(result.response[0] - truth) ** 2 / result.variance[0]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_lpm_leaves_out_the_lines_below_a_chirp_whose_current_is_measured_with_noise(seed):
    result = lpm_response(_record(seed, current_noise_a=0.005))
    assert result.f_hz.min() >= F_START_HZ
    assert any("not excited, left out" in n and "below" in n for n in result.notes)
    z2 = _z2(result)
    assert z2.mean() < 2.0, f"mean normalised error {z2.mean():.2f}"
    assert z2.max() < 25.0


def test_a_band_asked_wider_than_the_excitation_does_not_bring_the_unexcited_lines_back():
    rec = _record(4, current_noise_a=0.005)
    wide = lpm_response(rec, f_range_hz=(0.05, 400.0))
    narrow = lpm_response(rec, f_range_hz=(2.0, 20.0))
    assert wide.f_hz.min() >= F_START_HZ and wide.f_hz.max() <= F_END_HZ
    assert 2.0 <= narrow.f_hz.min() and narrow.f_hz.max() <= 20.0


def test_broadband_noise_excitation_keeps_its_whole_band():
    """White-noise current over the whole record band: no floor below the excitation, nothing left out."""
    n = int(T_S * FS)
    current = np.random.default_rng(7).standard_normal(n)
    result = lpm_response(_record(5, current_noise_a=0.01, current=current))
    assert not any("not excited" in note for note in result.notes)
    assert result.f_hz.max() > 0.8 * FS / 2
    assert _z2(result).mean() < 2.0


def test_closed_loop_estimation_keeps_the_band_its_chirp_reference_excited():
    t = np.arange(int(T_S * FS)) / FS
    reference = sim.chirp(t, F_START_HZ, F_END_HZ, 0.05)
    controller = sim.PI(kp=330.0, ki=330.0 * 2 * np.pi * 5, fs_hz=FS)
    rec = sim.closed_loop_record(AXIS, controller, np.random.default_rng(8), reference, noise_std=1e-4)
    result = closed_loop_response(TimeRecording(rec.time_s, rec.current_a, rec.output[None, :], "velocity", ("v",),
                                                reference=rec.reference, source="closed"))
    assert result.f_hz.min() >= F_START_HZ
    assert _z2(result).mean() < 2.0
