"""Exact first harmonic of a rigid body with viscous and Coulomb friction under a sinusoidal force.

The body obeys m v' + b v + F_c sgn(v) = F sin(w t), sticking (v = 0) while |F sin(w t)| <= F_c
(static friction equal to the sliding one). Its periodic steady state is half-wave antisymmetric,
v(t + T/2) = -v(t), and on each half period the body either slides throughout (continuous sliding)
or breaks loose when the force reaches F_c, slides and sticks again (stick-slip). On a slide that
starts at t0 with v(t0) = 0,

    v(t) = v_p(t) - F_c / b + (F_c / b - v_p(t0)) exp(-(t - t0) / tau),      tau = m / b,

with v_p(t) = Re(P e^{jwt}), P = -j F / (b + j w m), the linear particular solution. Stick-slip:
t0 = asin(F_c / F) / w, and the slide ends at the first zero of v within half a period (then
|F sin| <= F_c there, so the body sticks). Continuous sliding: no such zero; then the zero
crossing t0 solves v_p(t0) = -(F_c / b) tanh(T / (4 tau)) (v(t0 + T/2) = -v(t0) = 0) with the
force above F_c. The first harmonic (4/T) * integral of v e^{-jwt} over the half period is in
closed form.

The describing function N(V) = 4 F_c / (pi V) assumes a sinusoidal velocity; it is off by 4.5 %
in magnitude at F_c / F = 0.3 and predicts no motion for F_c / F > pi / 4, where the body still
moves. This solution has neither error.
"""

from __future__ import annotations

import numpy as np

#: grid on which the first stop of a slide is bracketed: points t0 + (T/2) (k/K)^2, dense at the start
_GRID = 96
#: bisection steps on the stop of a slide: the bracket shrinks to 2^-_BISECTIONS of its grid step
_BISECTIONS = 60


def rigid_body_first_harmonic(mass_kg, damping_n_s_per_m, friction_n, force_amplitude_n, w_rad_s) -> np.ndarray:
    """Velocity per force (m/s per N) of the first harmonic in the periodic steady state: the complex
    ratio of the velocity's fundamental to the force's. Arguments broadcast; 0 where the force never
    exceeds the friction (the body does not move)."""
    m, b, fc, f, w = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in
                                          (mass_kg, damping_n_s_per_m, friction_n, force_amplitude_n, w_rad_s)))
    moves = f > fc
    f_safe = np.where(moves, f, 1.0)
    fc = np.where(moves, fc, 0.0)
    tau, half = m / b, np.pi / w
    p = -1j * f_safe / (b + 1j * w * m)
    drop = fc / b
    t_break = np.arcsin(fc / f_safe) / w
    stop, sticks = _first_stop(p, w, t_break, half, tau, drop)

    kappa = drop * np.tanh(half / (2 * tau))
    phase = np.arccos(np.clip(-kappa / np.abs(p), -1.0, 1.0))
    candidates = np.stack([(phase - np.angle(p)) / w, (-phase - np.angle(p)) / w])
    t_cross = np.take_along_axis(candidates, np.argmax(np.sin(w * candidates), axis=0)[None], axis=0)[0]

    t0 = np.where(sticks, t_break, t_cross)
    t1 = np.where(sticks, stop, t_cross + half)
    c = drop - np.real(p * np.exp(1j * w * t0))
    span = t1 - t0
    integral = (p / 2 * span
                + np.conj(p) / 2 * (np.exp(-2j * w * t1) - np.exp(-2j * w * t0)) / (-2j * w)
                - drop * (np.exp(-1j * w * t1) - np.exp(-1j * w * t0)) / (-1j * w)
                + c * np.exp(-1j * w * t0) * -np.expm1(-(1 / tau + 1j * w) * span) / (1 / tau + 1j * w))
    first = 2 / half * integral
    return np.where(moves, first / (-1j * f_safe), 0.0)


def _slide(t, pr, pi, w, t0, c0, tau, drop):
    """Velocity at ``t`` of the slide that starts at rest at ``t0``: v_p(t) - drop + c0 exp(-(t - t0) / tau)
    with v_p(t) = pr cos(wt) - pi sin(wt) and c0 = drop - v_p(t0) (parameters broadcast against ``t``)."""
    return pr * np.cos(w * t) - pi * np.sin(w * t) - drop + c0 * np.exp(-(t - t0) / tau)


def _first_stop(p, w, t0, half, tau, drop):
    """The first zero of the slide that starts at rest at ``t0`` within half a period, and whether one
    exists (stick-slip). The slide is positive just after ``t0`` (the force exceeds F_c there)."""
    pr, pi = p.real, p.imag
    c0 = drop - (pr * np.cos(w * t0) - pi * np.sin(w * t0))
    k = np.arange(1, _GRID + 1) / _GRID
    grid = t0[..., None] + half[..., None] * k**2
    below = _slide(grid, *(a[..., None] for a in (pr, pi, w, t0, c0, tau, drop))) <= 0
    sticks = below.any(axis=-1)
    first = np.argmax(below, axis=-1)
    hi = np.take_along_axis(grid, first[..., None], axis=-1)[..., 0]
    lo = np.where(first > 0, np.take_along_axis(grid, np.maximum(first - 1, 0)[..., None], axis=-1)[..., 0], t0)
    for _ in range(_BISECTIONS):
        mid = (lo + hi) / 2
        positive = _slide(mid, pr, pi, w, t0, c0, tau, drop) > 0
        lo, hi = np.where(positive, mid, lo), np.where(positive, hi, mid)
    return hi, sticks
