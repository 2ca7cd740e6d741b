"""Permanent-magnet linear synchronous motor (PMLSM), thesis section 2.2.

Thrust constant (Eq. 2.27): K_t = 3/2 * pi/tau * P * lambda_f.
q-axis winding (Eq. 2.23-2.24 with i_d = 0): V_q = R_s i_q + L_s di_q/dt + (P pi/tau) lambda_f v,
so the winding is 1/(L_s s + R_s) from voltage to current, with back-EMF constant
K_e = (P pi/tau) lambda_f = 2/3 K_t.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from plant.errors import ParameterError
from plant.physics.parameters import check_positive

if TYPE_CHECKING:
    import control


def thrust_constant_n_per_a(*, pole_pitch_m: float, pole_number: float, magnet_flux_wb: float) -> float:
    """K_t = 3/2 * pi / tau * P * lambda_f in N/A (thesis Eq. 2.27)."""
    check_positive("pole_pitch_m", pole_pitch_m)
    check_positive("pole_number", pole_number)
    check_positive("magnet_flux_wb", magnet_flux_wb)
    return 1.5 * np.pi / pole_pitch_m * pole_number * magnet_flux_wb


def back_emf_constant_v_s_per_m(*, pole_pitch_m: float, pole_number: float, magnet_flux_wb: float) -> float:
    """K_e = P * pi / tau * lambda_f in V*s/m (speed term of thesis Eq. 2.23)."""
    return thrust_constant_n_per_a(pole_pitch_m=pole_pitch_m, pole_number=pole_number,
                                   magnet_flux_wb=magnet_flux_wb) * 2.0 / 3.0


def winding_tf(*, resistance_ohm: float, inductance_h: float) -> control.TransferFunction:
    """q-axis winding admittance I/V = 1/(L_s s + R_s) (thesis Eq. 2.23-2.24, back-EMF excluded)."""
    import control

    check_positive("resistance_ohm", resistance_ohm)
    check_positive("inductance_h", inductance_h)
    return control.tf([1.0], [inductance_h, resistance_ohm])


def current_loop_tf(*, resistance_ohm: float, inductance_h: float, kp_v_per_a: float,
                    ki_v_per_a_s: float) -> control.TransferFunction:
    """Closed current loop (kp s + ki) / (L s^2 + (R + kp) s + ki) of a PI driving the winding."""
    import control

    check_positive("kp_v_per_a", kp_v_per_a)
    check_positive("ki_v_per_a_s", ki_v_per_a_s, allow_zero=True)
    pi = control.tf([kp_v_per_a, ki_v_per_a_s], [1.0, 0.0])
    return control.feedback(pi * winding_tf(resistance_ohm=resistance_ohm, inductance_h=inductance_h), 1)


def current_loop_bandwidth_hz(*, resistance_ohm: float, inductance_h: float, kp_v_per_a: float,
                              ki_v_per_a_s: float) -> float:
    """-3 dB (1/sqrt 2) bandwidth in Hz of ``current_loop_tf``."""
    import control

    loop = current_loop_tf(resistance_ohm=resistance_ohm, inductance_h=inductance_h,
                           kp_v_per_a=kp_v_per_a, ki_v_per_a_s=ki_v_per_a_s)
    bw = control.bandwidth(loop, dbdrop=-20 * np.log10(np.sqrt(2)))
    if not np.isfinite(bw):
        raise ParameterError("current loop has no finite bandwidth with these gains")
    return float(bw) / (2 * np.pi)
