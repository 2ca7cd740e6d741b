"""The least scale of the virtual dynamics along a ray that keeps a curve's margins, in closed form.

On the ray m_v / b_v = tau the law's virtual impedance is t q(tau) (t = b_v; ``design.admittance.rig``), so the
interaction loop of a curve (a scenario and a mouse) is L = p / t with p = K_eff / q. Coming down from t = inf
(L = 0) the loop keeps phase margin phi and gain margin g for every scale above t exactly when t > |p|
wherever the phase of p lies within phi of -180 deg, and t >= g |p| wherever it is -180 deg (``curve_bounds``);
the curves are read from float32 tables of log |K_eff| and its phase (``polar``). The rays
(``design.admittance.ray``), the dense check's screen (``design.admittance.model``) and the Monte Carlo use it.
"""

from __future__ import annotations

import math

import numpy as np

#: the margin bounds are strict (t = max |p| puts a crossover on the window's edge): t is kept this much above
HAIR_SCALE = 1.002
#: values per block in ``polar``
POLAR_BLOCK = 262_144


def polar(gain: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(log |K|, phase of K relative to -180 deg in degrees) as float32: what ``curve_bounds`` reads (computed
    in blocks of rows, so the temporaries stay small beside a large ``gain``)."""
    gain = np.asarray(gain)
    log_mag, psi = np.empty(gain.shape, np.float32), np.empty(gain.shape, np.float32)
    flat, lm, ps = (a.reshape(-1, gain.shape[-1]) if gain.ndim else a.reshape(1, 1) for a in (gain, log_mag, psi))
    step = max(1, POLAR_BLOCK // max(flat.shape[-1], 1))
    for i in range(0, len(flat), step):
        g = flat[i:i + step]
        lm[i:i + step] = np.log(np.maximum(np.abs(g), 1e-300))
        ps[i:i + step] = np.degrees(np.angle(-g))
    return log_mag, psi


def curve_bounds(log_mag: np.ndarray, psi: np.ndarray, q: np.ndarray, phase_margin_deg: float, gain_margin: float,
                 sampled: bool, *, parts: bool = False):
    """The least scale t of each curve (rows of ``polar(K_eff)``) for the margins on the ray q: t > |p| where
    the phase of p = K_eff / q lies within the phase-margin window of -180 deg, at the grid points and at
    the window's edges (interpolated in log |p| between grid points), and t >= g |p| at the -180 deg
    crossings (and at the Nyquist frequency when sampled and p is real negative there). With ``parts``, the
    phase-margin and gain-margin bounds separately."""
    shape, n_f = np.broadcast_shapes(np.shape(log_mag), np.shape(q))[:-1], np.shape(q)[-1]
    a = (log_mag - np.log(np.abs(q)).astype(np.float32)).reshape(-1, n_f)
    d = (psi - np.degrees(np.angle(q)).astype(np.float32)).reshape(-1, n_f)
    d -= np.float32(360.0) * (d > 180)      # into (-180, 180]: arithmetic, not masked writes (8x faster)
    d += np.float32(360.0) * (d <= -180)
    t_pm = np.where(np.abs(d) < phase_margin_deg, a, -np.inf).max(axis=-1)
    t_gm = np.full(t_pm.shape, -np.inf, np.float32)
    # the pairs of neighbouring grid points whose phase segment holds one of the edges -phi, 0, phi (the count of
    # edges at or below the phase changes between them, or a point lies on an edge), without wrapping through
    # +-180 deg (p near the positive real axis): a small part of the table, where the edges are interpolated
    phi = np.float32(phase_margin_deg)
    below = (d >= -phi).view(np.uint8) + (d >= 0).view(np.uint8) + (d >= phi).view(np.uint8)
    on_edge = (d == 0) | (np.abs(d) == phi)
    pair = np.flatnonzero((below[:, :-1] != below[:, 1:]) | on_edge[:, :-1] | on_edge[:, 1:])
    if pair.size:
        rows = pair // (n_f - 1)
        at0 = pair + rows                   # the pair's first point in the flat table (1-D takes: 4x faster)
        d_flat, a_flat = d.ravel(), a.ravel()
        d0, d1 = d_flat[at0], d_flat[at0 + 1]
        keep = np.abs(d1 - d0) < 180.0
        pair, rows, at0, d0, d1 = pair[keep], rows[keep], at0[keep], d0[keep], d1[keep]
    if pair.size:
        a0, a1 = a_flat[at0], a_flat[at0 + 1]
        step = d1 - d0
        starts = np.flatnonzero(np.r_[True, rows[1:] != rows[:-1]])
        for edge in (-phase_margin_deg, phase_margin_deg, 0.0):
            cross = ((d0 - edge) * (d1 - edge) <= 0) & (step != 0)
            x = (edge - d0) / np.where(cross, step, 1.0)
            at = np.full(t_pm.shape, -np.inf, np.float32)
            at[rows[starts]] = np.maximum.reduceat(np.where(cross, a0 + x * (a1 - a0), -np.inf), starts)
            if edge == 0.0:
                t_gm = np.maximum(t_gm, at + math.log(gain_margin))
            else:
                t_pm = np.maximum(t_pm, at)
    if sampled:
        end = np.abs(d[:, -1]) < 1e-4
        t_gm = np.maximum(t_gm, np.where(end, a[:, -1] + math.log(gain_margin), -np.inf))
    t_pm = HAIR_SCALE * np.exp(t_pm.astype(float)).reshape(shape)
    t_gm = HAIR_SCALE * np.exp(t_gm.astype(float)).reshape(shape)
    return (t_pm, t_gm) if parts else np.maximum(t_pm, t_gm)
