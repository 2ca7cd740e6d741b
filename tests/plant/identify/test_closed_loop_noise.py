"""The time-domain noise estimate followed through differentiation, filtering and a closed position loop.

References: white noise of a known level and an encoder's quantisation error (uniform over one quantum q, standard
deviation q / sqrt(12): Widrow & Kollar, "Quantization Noise", 2008), added to smooth motions; and
``independent_friction_sim``, a closed-loop axis with a quantised encoder simulated without the tool's code, whose
true model (Coulomb friction and a constant force) leaves only the noise.
"""

from __future__ import annotations

import numpy as np
import pytest
from independent_friction_sim import Axis, simulate

from plant.data.recordings import TimeRecording
from plant.diagnose.time_diagnosis import diagnose_time
from plant.identify.inverse_model import Preprocessing, difference_noise_std, inverse_model_data
from plant.identify.time_fit import CHAIN_PRECISION
from plant.physics.models import Plant

HOLD = Preprocessing(input_hold=True)
FS_HZ = 1000.0


def _motion(accel_m_per_s2: float, n: int = 20_000) -> np.ndarray:
    """A smooth back-and-forth position (m) at ``FS_HZ`` whose acceleration peaks near ``accel_m_per_s2``."""
    t = np.arange(n) / FS_HZ
    return sum(accel_m_per_s2 / (2 * np.pi * f) ** 2 / 3 * np.sin(2 * np.pi * f * t + p)
               for f, p in ((0.7, 0.3), (2.3, 1.1), (6.1, 2.0)))


@pytest.mark.parametrize("accel", [0.1, 3.0, 30.0])
@pytest.mark.parametrize("sigma", [1e-7, 1e-6])
def test_white_noise_level_is_read_through_fast_motion(accel, sigma):
    """The fourth differences leave (omega h)^4 of the motion: at 30 m/s^2 the second differences' estimate (the
    earlier one) would read several times the noise; this one stays within 5 % of it."""
    x = _motion(accel) + sigma * np.random.default_rng(3).standard_normal(20_000)
    assert difference_noise_std(x) == pytest.approx(sigma, rel=0.05)


@pytest.mark.parametrize("quantum", [1e-7, 1e-6, 1e-5])
def test_encoder_quantisation_is_read_as_q_over_sqrt12(quantum):
    x = np.round(_motion(3.0) / quantum) * quantum
    assert difference_noise_std(x) == pytest.approx(quantum / np.sqrt(12), rel=0.05)


def _recording(encoder_m: float, kp: float, kd: float, drive_noise_v: float = 0.02, axis: Axis = Axis()):
    log = simulate(axis, seed=0, encoder_m=encoder_m, drive_noise_v=drive_noise_v, kp_n_per_m=kp, kd_n_s_per_m=kd)
    return TimeRecording(log.time_s, log.command_v, log.position_m[None], "position", ("position_m",),
                         reference=log.reference_m)


def test_the_command_of_a_closed_loop_is_taken_as_exact():
    """The controller's reaction to the encoder's noise and its own dither are forces the axis feels: no force
    noise is predicted from the command of a closed loop, while the same current without a reference is measured."""
    rec = _recording(1e-6, 6e4, 1.5e3)
    open_rec = TimeRecording(rec.time_s, rec.current_a, rec.output, "position", ("position_m",))
    assert inverse_model_data(rec, 35.0, HOLD).force_noise_n == 0.0
    assert inverse_model_data(open_rec, 35.0, HOLD).force_noise_n > 0.1


def test_the_chain_is_exact_to_its_stated_precision():
    """A noise-free recording (1 nm encoder, no dither) of the true model: the residual of the true parameters where
    the axis moves is below ``CHAIN_PRECISION`` of the force's rms."""
    axis = Axis()
    data = inverse_model_data(_recording(1e-9, 6e4, 1.5e3, 0.0, axis), axis.gain_n_per_v, HOLD)
    e = (data.force_n - axis.mass_kg * data.acceleration_m_per_s2 - axis.viscous_n_s_per_m * data.velocity_m_per_s
         - axis.coulomb_n * data.decimate(np.sign(data.full_rate_velocity_m_per_s)) - axis.offset_n)
    speed = np.abs(data.velocity_m_per_s)
    moving = speed > 0.05 * np.percentile(speed, 99)
    assert np.sqrt(np.mean(e[moving] ** 2)) < CHAIN_PRECISION * np.sqrt(np.mean(data.force_n**2))


@pytest.mark.parametrize("kp, kd, encoder_m, drive_noise_v", [(2e4, 5e2, 1e-5, 0.005), (6e5, 8e3, 1e-6, 0.02),
                                                            (2e4, 5e2, 1e-7, 0.05), (6e5, 8e3, 1e-7, 0.05)])
def test_closed_loop_with_nothing_missing_is_explained(kp, kd, encoder_m, drive_noise_v):
    """Soft and stiff loops, coarse to fine encoders: explained, and where the encoder's noise is larger than the
    chain's precision (1 and 10 um) the residual is the predicted noise within 15 %."""
    axis = Axis()
    diag = diagnose_time(Plant("x", force_constant_n_per_a=axis.gain_n_per_v),
                         _recording(encoder_m, kp, kd, drive_noise_v, axis), prep=HOLD)
    assert diag.verdict == "explained"
    assert set(diag.selected) == {"coulomb_friction", "offset"}
    if encoder_m >= 1e-6:
        assert diag.final.noise_ratio == pytest.approx(1.0, abs=0.15)
    else:
        assert diag.final.noise_ratio < 1.0
