"""The motor's force while the mouse pushes as a recording says (``admittance.locomotion.force_record``): the
recorded force on the clamp taken as given, whatever the gantry does (the mouse reproduces its record), and the
motor's force computed exactly on it for any (m_v, b_v).

The force is taken linear between the law's instants kT (the record interpolated there: exact for a record whose
interval is a whole number of law periods, as the lab's 20 Hz record is for the 100 Hz law). The law reads it
through the force filter (discretised exactly for that force), runs its difference equation
(``design.admittance.rig.law_coefficients``) and, ``computation_delay_samples`` later, holds its output u for a
period. Over a period the gantry's states (the free gantry under its PI loop, ``design.admittance.sampled``) then
follow exactly (Van Loan's block exponential):

    x(kT + theta) = E(theta) x_k + G_u(theta) u_k + G_0(theta) F_k + G_1(theta) (F_(k+1) - F_k) / T

from the state at the law's instants, stepped by theta = T, and the motor's force F_m = C x + D [u, F] is read at
the offsets ``offsets`` within every period: every ``FINE_STEP_S`` over the first ``PEAK_WINDOW_S`` (where the motor
answers a step of the held reference through the drive's delay and current loop, a peak a millisecond wide) and
every ``COARSE_STEP_S`` after. The gantry starts in the steady state of the record's first value (as if the mouse
had pushed so since long before), so a record that starts mid-push starts no transient the mouse never made.
Against a fine-step time simulation of the sampled loop with a true delay (tests) the peak agrees within 0.12 % at
the bundled spec's corners, where a uniform grid of 8 points per period is up to 18 % low.

May import: ``design.admittance.rig``, ``design.admittance.sampled``, ``design.problem``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from design.admittance.rig import RigTiming, force_filter_polys
from design.problem import ForceRecord
from plant.physics.state_space import expm, tf_ss

#: the offsets within a period at which the motor's force is read (module docstring)
PEAK_WINDOW_S = 4e-3
FINE_STEP_S = 1e-4
COARSE_STEP_S = 1e-3
#: law instants whose forces are read together (memory: scenarios x instants x offsets), in blocks of this many
#: (``CHUNK`` a multiple of ``BLOCK``)
CHUNK = 128
BLOCK = 16


def offsets(period_s: float) -> np.ndarray:
    """The offsets (s) in [0, T) at which the motor's force is read within each period."""
    fine = min(FINE_STEP_S, period_s / 10)
    window = min(PEAK_WINDOW_S, period_s)
    near = np.arange(0.0, window - 1e-12 * period_s, fine)
    far = np.arange(window, period_s - 1e-12 * period_s, max(COARSE_STEP_S, fine))
    return np.concatenate([near, far])


def hold_exponentials(A: np.ndarray, Bu: np.ndarray, Bf: np.ndarray, theta: float):
    """(E, G_u, G_0, G_1) of the module docstring at the offset ``theta`` for a batch (A (n_s, n, n), B (n_s, n, 1)):
    the state transition and the responses to a held u, a held F and a unit slope of F, from one exponential."""
    n = A.shape[-1]
    M = np.zeros((A.shape[0], n + 3, n + 3))
    M[:, :n, :n] = A
    M[:, :n, n:n + 1] = Bu
    M[:, :n, n + 1:n + 2] = Bf
    M[:, n + 1, n + 2] = 1.0
    X = expm(M * theta)
    return X[:, :n, :n], X[:, :n, n], X[:, :n, n + 1], X[:, :n, n + 2]


def at_instants(record: ForceRecord, period_s: float) -> np.ndarray:
    """The record linearly interpolated at its start + k T over its duration."""
    t = np.asarray(record.time_s, float)
    n = int(math.floor((t[-1] - t[0]) / period_s * (1 + 1e-12))) + 1
    return np.interp(t[0] + period_s * np.arange(n), t, np.asarray(record.force_n, float))


def filtered_readings(force: np.ndarray, slope: np.ndarray, timing: RigTiming) -> np.ndarray:
    """The force filter's output at the law's instants for a force linear between them (``slope`` N/s over each
    period; its exact discretisation for that force), from the steady state of the first value."""
    if timing.filter_hz is None:
        return force.copy()
    f = tf_ss(*force_filter_polys(timing.filter_hz, timing.filter_order))
    E, _, G0, G1 = hold_exponentials(f.A[None], np.zeros_like(f.B[None]), f.B[None], timing.period_s)
    E, G0, G1 = E[0], G0[0], G1[0]
    x = np.linalg.solve(np.eye(f.order) - E, G0 * force[0])
    out = np.empty(force.size)
    for k, (fk, gk) in enumerate(zip(force, slope)):
        out[k] = f.C[0] @ x + f.D[0, 0] * fk
        x = E @ x + G0 * fk + G1 * gk
    return out


@dataclass(frozen=True)
class RecordedMotorPeak:
    """The largest motor force on the record at one design: per scenario (N) and the time it occurs (s from the
    record's start)."""

    peak_n: np.ndarray
    at_s: np.ndarray


class RecordedMotor:
    """The motor's force on a force record for any (m_v, b_v) at ``scenarios`` (module docstring): the gantry's
    exponentials at the offsets are computed once; each design runs the law, the states at the law's instants and
    the force at the offsets."""

    def __init__(self, record: ForceRecord, scenarios, *, loops, timing: RigTiming):
        if not timing.sampled:
            raise ValueError("the recorded-force motor check needs a sampled law (admittance.rig.update_rate_hz)")
        self.timing = timing
        T = timing.period_s
        self.force_n = at_instants(record, T)
        self.slope = np.append(np.diff(self.force_n), 0.0) / T
        self.readings = filtered_readings(self.force_n, self.slope, timing)
        self.offsets_s = offsets(T)
        free = loops.free_state_space(scenarios, motor=True)          # the Pade order for a transient
        A, Bu, Bf = free.A, free.B[:, :, 0:1], free.B[:, :, 1:2]
        C, Du, Df = free.C[:, 2, :], free.D[:, 2, 0], free.D[:, 2, 1]
        self.step = hold_exponentials(A, Bu, Bf, T)
        # the force at offset theta: C E x + (C G_u + D_u) u + (C G_0 + D_f) F_k + (C G_1 + D_f theta) slope
        rows = [[], [], [], []]
        for theta in self.offsets_s:
            E, Gu, G0, G1 = hold_exponentials(A, Bu, Bf, theta) if theta > 0 else (
                np.broadcast_to(np.eye(A.shape[-1]), A.shape), *(np.zeros(A.shape[:-1]),) * 3)
            rows[0].append(np.einsum("sn,snm->sm", C, E))
            rows[1].append(np.einsum("sn,sn->s", C, Gu) + Du)
            rows[2].append(np.einsum("sn,sn->s", C, G0) + Df)
            rows[3].append(np.einsum("sn,sn->s", C, G1) + Df * theta)
        # (n_s, n + 3, n_theta): the force at every offset from [x_k, u_k, F_k, slope_k]
        self.out = np.concatenate([np.stack(rows[0], axis=2), *(np.stack(r, axis=1)[:, None, :] for r in rows[1:])],
                                  axis=1)

    def law_output(self, m_v: float, b_v: float) -> np.ndarray:
        """The held velocity reference over each period (m/s): the law on the readings from its steady state,
        ``delay_samples`` late."""
        # scipy.signal on first use: importing it costs 0.54 s of every command's start (measured with -X importtime)
        # and only a design on a force record needs it
        from scipy.signal import lfilter

        alpha, beta, beta_prev = (float(c) for c in self.timing.law(m_v, b_v))
        r = self.readings
        steady = r[0] / b_v
        v = lfilter([beta, beta_prev], [1.0, -alpha], r - r[0]) + steady
        d = self.timing.delay_samples
        return np.concatenate([np.full(d, steady), v[:v.size - d]]) if d else v

    def peaks(self, m_v: float, b_v: float) -> RecordedMotorPeak:
        """The motor's peak per scenario over the record, every scenario at once, ``CHUNK`` law instants at a time:
        the states of a chunk from its blocks of ``BLOCK`` instants (each block's response from rest, stepped for
        all blocks together; the states at the blocks' starts, stepped block to block by E^BLOCK; each state the
        block's start carried by E^j plus the response from rest), then the force at every offset."""
        u = self.law_output(m_v, b_v)
        E, Gu, G0, G1 = self.step
        n_s, n = E.shape[0], E.shape[-1]
        inputs = np.stack([u, self.force_n, self.slope], axis=1)                     # (k, 3)
        G = np.stack([Gu, G0, G1], axis=-1)                                           # (n_s, n, 3)
        powers = np.empty((n_s, BLOCK + 1, n, n))                                     # E^0 .. E^BLOCK
        powers[:, 0] = np.eye(n)
        for j in range(BLOCK):
            powers[:, j + 1] = powers[:, j] @ E
        x = np.linalg.solve(np.eye(n) - E, (Gu * u[0] + G0 * self.force_n[0])[..., None])[..., 0]     # (n_s, n)
        Et, Lt = E.transpose(0, 2, 1), powers[:, BLOCK].transpose(0, 2, 1)
        peak, at = np.full(n_s, -1.0), np.zeros(n_s)
        for start in range(0, u.size, CHUNK):           # every chunk but the last is whole blocks
            m = min(CHUNK, u.size - start)
            blocks = -(-m // BLOCK)
            w = np.zeros((blocks * BLOCK, 3))
            w[:m] = inputs[start:start + m]
            drive = (G @ w.T).transpose(0, 2, 1).reshape(n_s, blocks, BLOCK, n)        # (n_s, blocks, BLOCK, n)
            rest = np.empty_like(drive)                                               # each block from rest
            y = np.zeros((n_s, blocks, n))
            for j in range(BLOCK):
                rest[:, :, j] = y
                y = y @ Et + drive[:, :, j]
            starts = np.empty((n_s, blocks, n))                                        # the state at each block
            for b in range(blocks):
                starts[:, b] = x
                x = (x[:, None] @ Lt)[:, 0] + y[:, b]
            states = np.empty((n_s, blocks * BLOCK, n + 3))
            carried = (powers[:, :BLOCK] @ starts.transpose(0, 2, 1)[:, None]).transpose(0, 3, 1, 2)
            states[..., :n] = (carried + rest).reshape(n_s, -1, n)
            states[..., n:] = w
            force = np.abs(np.matmul(states[:, :m], self.out))                      # (n_s, m, n_theta)
            flat = force.reshape(n_s, -1)
            best = np.argmax(flat, axis=1)
            value = flat[np.arange(n_s), best]
            better = value > peak
            k, o = np.divmod(best, force.shape[2])
            peak = np.where(better, value, peak)
            at = np.where(better, (start + k) * self.timing.period_s + self.offsets_s[o], at)
        return RecordedMotorPeak(peak, at)
