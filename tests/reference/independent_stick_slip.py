"""Stepped-sine recordings of a rigid axis with viscous and Coulomb friction, simulated without the tool's
code (NumPy and SciPy only; a test checks that nothing from ``plant`` or ``design`` is imported).

Each block is a separate experiment from rest: the recorded current is i(t) = I sin(2 pi f t) and the
axis obeys m v' + b v + F_c sgn(v) = K_t i(t), sticking (v = 0) while |K_t i(t)| <= F_c (optionally with a
Stribeck rise of the friction towards rest, see ``velocity``). Slides are
integrated by SciPy's DOP853 at tolerance 1e-11 with the stops located as events; the velocity is
read from the dense output at the sample times, so the recording has no discretisation of its own.
Noise is white Gaussian, a fraction of each block's largest velocity and of the current amplitude.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp


def velocity(t_s: np.ndarray, *, mass_kg: float, damping_n_s_per_m: float, friction_n: float,
             force_n: float, f_hz: float, stribeck_n: float = 0.0, stribeck_m_per_s: float = 0.01) -> np.ndarray:
    """Velocity (m/s) at the times ``t_s`` (from 0, increasing) of the axis driven from rest at t = 0 by
    ``force_n`` sin(2 pi f t). With ``stribeck_n`` the sliding friction is
    (F_c + stribeck_n exp(-(v / stribeck_m_per_s)^2)) sgn(v) and the axis sticks while |K_t i| <= F_c + stribeck_n."""
    w, m, b, fc = 2 * math.pi * f_hz, mass_kg, damping_n_s_per_m, friction_n
    static = fc + stribeck_n
    v = np.zeros_like(t_s)
    if force_n <= static:
        return v
    rises = (math.asin(static / force_n), math.pi + math.asin(static / force_n))    # w t where |F sin| passes it
    t, t_end = rises[0] / w, float(t_s[-1])
    while t < t_end:
        sign = 1.0 if math.sin(w * t) > 0 else -1.0

        def rhs(s, x, sign=sign):
            rise = stribeck_n * math.exp(-(x[0] / stribeck_m_per_s) ** 2)
            return [(force_n * math.sin(w * s) - b * x[0] - (fc + rise) * sign) / m]

        def stop(s, x):
            return x[0]
        stop.terminal, stop.direction = True, -sign
        sol = solve_ivp(rhs, (t, t_end), [0.0], events=stop, dense_output=True, method="DOP853",
                        rtol=1e-11, atol=1e-14 * force_n / b)
        inside = (t_s >= t) & (t_s <= sol.t[-1])
        if inside.any():
            v[inside] = sol.sol(t_s[inside])[0]
        if sol.status != 1:
            break
        t = sol.t[-1]
        if abs(force_n * math.sin(w * t)) <= static:      # sticks until the force passes the static friction
            k = math.floor(w * t / (2 * math.pi))
            t = min(a + 2 * math.pi * j for j in (k, k + 1) for a in rises if a + 2 * math.pi * j > w * t) / w
    return v


def write_recording(path: Path, *, f_hz, mass_kg: float, damping_n_s_per_m: float, friction_n: float,
                    force_constant_n_per_a: float = 20.0, current_a: float = 0.5, duration_s: float = 5.0,
                    sample_rate_hz: float = 2000.0, noise_fraction: float = 0.01, seed: int = 0) -> Path:
    """A stepped-sine recording in the long CSV format (frequency_hz, time_s, current_a, velocity_m_per_s)."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(duration_s * sample_rate_hz))) / sample_rate_hz
    rows = []
    for f in f_hz:
        i = current_a * np.sin(2 * math.pi * f * t)
        v = velocity(t, mass_kg=mass_kg, damping_n_s_per_m=damping_n_s_per_m, friction_n=friction_n,
                     force_n=force_constant_n_per_a * current_a, f_hz=f)
        i = i + noise_fraction * current_a * rng.standard_normal(t.size)
        v = v + noise_fraction * np.max(np.abs(v)) * rng.standard_normal(t.size)
        rows.append(np.column_stack([np.full(t.size, f), t, i, v]))
    data = np.concatenate(rows)
    with open(path, "w") as out:
        out.write("frequency_hz,time_s,current_a,velocity_m_per_s\n")
        np.savetxt(out, data, fmt=["%.10g", "%.9f", "%.9g", "%.9g"], delimiter=",")
    return path
