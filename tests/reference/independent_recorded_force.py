"""The motor's force while a recorded force pushes the gantry, simulated at a fine step from Newton's law, with
the admittance law at its rate, a true (buffered) drive delay and no Pade, sharing no code with ``plant`` or
``design``.

Model (SI units): M v' = K_t i + F(t) - b v (F the record, linear between its samples); the PI velocity loop
c = K_p (u - v) + K_i xi, xi' = u - v; the drive delays c by tau and its current loop follows, i' = w_c (c(t - tau)
- i); the force reading is F through an optional Butterworth low-pass (order 1 or 2); the law runs at 1/T on the
reading, ``delay_samples`` later its output u is held for a period. The simulation starts in the steady state of the
record's first value. Classical Runge-Kutta at ``step_s`` (T and tau whole numbers of it), the delayed command read
from a buffer of the command at every step (linear between the buffer's points at the half step).
"""

import math

import numpy as np


def law_coefficients(m_v, b_v, period_s, law):
    """(alpha, beta, beta_prev) of v[k] = alpha v[k-1] + beta F[k] + beta_prev F[k-1]."""
    T = period_s
    if law == "forward_euler":
        return 1.0 - b_v * T / m_v, T / m_v, 0.0
    if law == "zoh":
        a = math.exp(-b_v * T / m_v)
        return a, (1.0 - a) / b_v, 0.0
    if law == "tustin":
        c = T / (2 * m_v + b_v * T)
        return (2 * m_v - b_v * T) / (2 * m_v + b_v * T), c, c
    return m_v / (m_v + b_v * T), T / (m_v + b_v * T), 0.0


def motor_force(time_s, force_n, *, mass_kg, damping, kt, kp, ki, delay_s, current_hz, m_v, b_v, period_s,
                law="backward_euler", delay_samples=0, filter_hz=None, filter_order=2, step_s=2.5e-5):
    """(t, K_t i) at every step over the record (the module docstring)."""
    t_rec, f_rec = np.asarray(time_s, float), np.asarray(force_n, float)
    h = step_s
    per_law = int(round(period_s / h))
    lag = int(round(delay_s / h))
    if abs(per_law * h - period_s) > 1e-9 * period_s or abs(lag * h - delay_s) > 1e-12:
        raise ValueError("the law's period and the delay must be whole numbers of steps")
    n = int(math.floor((t_rec[-1] - t_rec[0]) / h * (1 + 1e-12))) + 1
    t = t_rec[0] + h * np.arange(n)
    f_half = np.interp(t + h / 2, t_rec, f_rec)
    f = np.interp(t, t_rec, f_rec)
    wc = 2 * math.pi * current_hz
    wf = 0.0 if filter_hz is None else 2 * math.pi * filter_hz
    alpha, beta, beta_prev = law_coefficients(m_v, b_v, period_s, law)
    f0 = f[0]
    # the steady state of F = f0: u = v = f0 / b_v, K_t i = b v - f0, c = i = K_i xi
    u0 = f0 / b_v
    i0 = (damping * u0 - f0) / kt
    v, xi, i = u0, i0 / ki, i0
    y1, y2 = f0, 0.0                         # the filter's output and its derivative (order 2)
    v_law, r_prev = u0, f0
    outputs = [u0] * (delay_samples + 1)
    commands = [i0] * (lag + 1)              # c at the last lag + 1 steps, oldest first
    u = u0
    out = np.empty(n)
    M = mass_kg

    def rhs(v, xi, i, y1, y2, fk, c_del):
        dv = (kt * i + fk - damping * v) / M
        dxi = u - v
        di = wc * (c_del - i)
        if filter_hz is None:
            return dv, dxi, di, 0.0, 0.0
        if filter_order == 1:
            return dv, dxi, di, wf * (fk - y1), 0.0
        return dv, dxi, di, y2, wf * wf * (fk - y1) - math.sqrt(2.0) * wf * y2

    for j in range(n):
        if j % per_law == 0:
            reading = f[j] if filter_hz is None else y1
            v_law = alpha * v_law + beta * reading + beta_prev * r_prev
            r_prev = reading
            outputs = outputs[1:] + [v_law]
            u = outputs[0]
        out[j] = kt * i
        c = kp * (u - v) + ki * xi
        commands = commands[1:] + [c]
        if j == n - 1:
            break
        c0 = commands[0]
        c1 = commands[1] if lag > 0 else None
        # the delayed command over the step: c(t - tau) at t, t + h/2, t + h (the newest is the current one)
        if lag == 0:
            c_a = c_b = c_c = c
        else:
            c_a, c_c = c0, c1
            c_b = 0.5 * (c0 + c1)
        fa, fb, fc = f[j], f_half[j], f[j + 1]
        k1 = rhs(v, xi, i, y1, y2, fa, c_a)
        s2 = [x + 0.5 * h * k for x, k in zip((v, xi, i, y1, y2), k1)]
        k2 = rhs(*s2, fb, c_b)
        s3 = [x + 0.5 * h * k for x, k in zip((v, xi, i, y1, y2), k2)]
        k3 = rhs(*s3, fb, c_b)
        s4 = [x + h * k for x, k in zip((v, xi, i, y1, y2), k3)]
        k4 = rhs(*s4, fc, c_c)
        v, xi, i, y1, y2 = (x + h / 6 * (a + 2 * b + 2 * c_ + d)
                            for x, a, b, c_, d in zip((v, xi, i, y1, y2), k1, k2, k3, k4))
    return t, out
