"""Time recordings of Stage Y's beam on its two rails, each rail with its own motor, damper and encoder; nothing from
``plant`` or ``design``.

The beam and carriage move by Lagrange's equations in rail coordinates (``independent_dual_drive.Rig``: the
yaw spring of the joints, each rail's damper b1, b2 and force constant k1, k2, the carriage anywhere along the
beam). One current command drives both motors, as the thesis's Stage Y is wired. The command is held between
samples, so the recording is the exact zero-order-hold sampling of the linear system (the matrix exponential
of the augmented matrix [[A, B], [0, 0]], van Loan 1978). Encoder Y2 reads ``y2_scale`` times its rail's true
position (a scale error); both encoders carry white noise, the command too. In open loop the command is a given
current; in closed loop (``closed_loop``) a PI velocity loop computes it each sample from the encoders' mean
velocity (positions differenced over one sample), and the command is logged as computed.
"""

from __future__ import annotations

import independent_dual_drive
import numpy as np
import scipy.linalg


def _held(rig: independent_dual_drive.Rig, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(Phi, Gamma) of the rig's mechanics under one command to both motors held for ``dt`` (van Loan)."""
    A, B, _ = independent_dual_drive._mechanics_matrices(rig)
    n = A.shape[0]
    aug = np.zeros((n + 1, n + 1))
    aug[:n, :n], aug[:n, n] = A, B @ np.ones(2)
    step = scipy.linalg.expm(aug * dt)
    return step[:n, :n], step[:n, n]


def record(rig: independent_dual_drive.Rig, current, duration_s: float, *, sample_rate_hz: float = 1000.0,
           y2_scale: float = 1.0, current_noise_a: float = 0.005, position_noise_m: float = 1e-6, seed: int = 0,
           velocity_noise_m_per_s: float | None = None):
    """(t s, command A with noise, Y1, Y2) of ``current(t)`` (A) applied to both motors from rest at y1 = y2 = 0
    (module doc): the rails' positions (m), or with ``velocity_noise_m_per_s`` their velocities (m/s) with that
    noise."""
    dt = 1.0 / sample_rate_hz
    Phi, Gamma = _held(rig, dt)
    n = Phi.shape[0]
    t = np.arange(int(round(duration_s * sample_rate_hz))) * dt
    u = current(t)
    x = np.zeros(n)
    states = np.empty((t.size, n))
    for k in range(t.size):
        states[k] = x
        x = Phi @ x + Gamma * u[k]
    rng = np.random.default_rng(seed)
    first, noise = (0, position_noise_m) if velocity_noise_m_per_s is None else (2, velocity_noise_m_per_s)
    return (t, u + rng.normal(0.0, current_noise_a, t.size),
            states[:, first] + rng.normal(0.0, noise, t.size),
            y2_scale * states[:, first + 1] + rng.normal(0.0, noise, t.size))


def closed_loop(rig: independent_dual_drive.Rig, reference, duration_s: float, *, kp: float = 150.0,
                ki: float = 3000.0, sample_rate_hz: float = 1000.0, y2_scale: float = 1.0,
                position_noise_m: float = 1e-6, velocity_noise_m_per_s: float | None = None, seed: int = 0):
    """(t s, command A, Y1, Y2, reference m/s) of a PI velocity loop on the encoders' mean velocity following
    ``reference(t)`` (m/s) from rest: each sample the loop reads both encoders (positions, or with
    ``velocity_noise_m_per_s`` velocities), takes their mean velocity (a position differenced over one sample),
    and commands i = kp e + ki sum(e) dt, e = reference - mean velocity (A per m/s, A per m), held to the next
    sample and logged as computed."""
    dt = 1.0 / sample_rate_hz
    Phi, Gamma = _held(rig, dt)
    t = np.arange(int(round(duration_s * sample_rate_hz))) * dt
    r = reference(t)
    rng = np.random.default_rng(seed)
    velocity = velocity_noise_m_per_s is not None
    first, noise = (2, velocity_noise_m_per_s) if velocity else (0, position_noise_m)
    x = np.zeros(Phi.shape[0])
    u, y1, y2 = (np.empty(t.size) for _ in range(3))
    integral, last = 0.0, np.zeros(2)
    for k in range(t.size):
        y = np.array([x[first], y2_scale * x[first + 1]]) + rng.normal(0.0, noise, 2)
        y1[k], y2[k] = y
        v = y if velocity else (y - last) / dt if k else np.zeros(2)
        last = y
        e = r[k] - float(np.mean(v))
        integral += e * dt
        u[k] = kp * e + ki * integral
        x = Phi @ x + Gamma * u[k]
    return t, u, y1, y2, r


def chirp(rig: independent_dual_drive.Rig, *, amplitude_a: float = 3.0, f0_hz: float = 0.3, f1_hz: float = 12.0,
          duration_s: float = 20.0, **kw):
    """``record`` of a logarithmic chirp A sin(2 pi f0 T (r^(t/T) - 1) / ln r), r = f1 / f0, T the duration."""
    r = f1_hz / f0_hz
    return record(rig, lambda s: amplitude_a * np.sin(2 * np.pi * f0_hz * duration_s * (r ** (s / duration_s) - 1)
                                                      / np.log(r)), duration_s, **kw)


def write_csv(path, t, current, y1, y2, kind: str = "position"):
    """The recording as the tool reads a Stage Y time recording: time, current, both rails' positions (or
    velocities, ``kind``)."""
    unit = "m" if kind == "position" else "m_per_s"
    np.savetxt(path, np.column_stack([t, current, y1, y2]), delimiter=",", fmt="%.10g",
               header=f"time_s,current_a,{kind}_y1_{unit},{kind}_y2_{unit}", comments="")
    return path


def sweep(rig: independent_dual_drive.Rig, *, duration_s: float = 16.0, **kw):
    """``record`` of a multisine: 3 A at 0.25 Hz with 0.8 A at 3.1 Hz and 0.5 A at 7.3 Hz on top."""
    return record(rig, lambda s: 3.0 * np.sin(2 * np.pi * 0.25 * s) + 0.8 * np.sin(2 * np.pi * 3.1 * s)
                  + 0.5 * np.sin(2 * np.pi * 7.3 * s + 1.0), duration_s, **kw)


def stepped(rig: independent_dual_drive.Rig, f_hz=(0.25, 0.5, 1.0, 2.0, 4.0, 8.0), *, amplitude_a: float = 3.0,
            block_s: float = 4.0, **kw):
    """``record`` of a stepped sine in one run: A sin(2 pi f_k t) during block k, the motion carried over."""
    f = np.asarray(f_hz, float)

    def current(s):
        k = np.minimum((np.asarray(s) // block_s).astype(int), f.size - 1)
        return amplitude_a * np.sin(2 * np.pi * f[k] * s)

    return record(rig, current, block_s * f.size, **kw)
