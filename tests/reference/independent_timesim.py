"""Independent time-domain simulator of a linear-motor axis (numpy/scipy only).

Shares no code with ``plant`` or ``design``: the recordings it makes are an independent truth
for ``plant.estimate.frf_estimation``.

Plant
    A motor mass m1 (kg) on rails with viscous damping b (N s/m), driven by the force Kt i
    (N; Kt in N/A, i in A), optionally carrying a second mass m2 (kg) on a spring k (N/m) with
    damper c (N s/m). State x = [positions, velocities], x' = A x + B i; the sensed output is the
    motor mass's velocity (m/s) or position (m), y = C x.

Two ways of driving it
    * ``multisine_record``: a multisine current is a sum of sinusoids in continuous time; the
      response from rest is the steady state sum_k Re(a_k C (j w_k I - A)^-1 B e^{j w_k t}) plus
      the homogeneous solution -C e^{A t} x_p(0) (by the eigenvectors of A), both exact at the
      sample instants. The truth is the continuous-time response C (j w I - A)^-1 B
      (``Axis.response``).
    * ``zoh_record`` and ``closed_loop_record``: the current is held constant over each sample
      interval (zero-order hold), x[k+1] = Ad x[k] + Bd i[k] with Ad = e^{A T},
      Bd = int_0^T e^{A s} ds B; the output is sampled at the same instants, y[k] = C x[k]. The
      truth is the discrete response C (z I - Ad)^-1 Bd at z = e^{j w T} (``Axis.zoh_response``),
      exact for what the DFT of the samples sees.

Noise: white or first-order coloured Gaussian noise on the sensed output, optional white noise
on the measured current. Closed loop: a discrete PI velocity controller
u[k] = Kp e[k] + Ki z[k], z[k+1] = z[k] + T e[k], e = r - (y + n), so the sensor noise n is fed
back into the current.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm
from scipy.signal import lfilter

KT_N_PER_A = 20.0
MASS_KG = 35.0
DAMPING_N_S_PER_M = 440.0


@dataclass(frozen=True)
class Axis:
    """Motor mass with an optional flexible second mass (see the module doc)."""

    mass_kg: float = MASS_KG
    damping_n_s_per_m: float = DAMPING_N_S_PER_M
    kt_n_per_a: float = KT_N_PER_A
    mode_mass_kg: float = 0.0
    mode_stiffness_n_per_m: float = 0.0
    mode_damping_n_s_per_m: float = 0.0

    def matrices(self, output: str = "velocity"):
        """(A, B, C) with x = [x1, (x2), v1, (v2)]."""
        m1, b, kt = self.mass_kg, self.damping_n_s_per_m, self.kt_n_per_a
        if self.mode_mass_kg > 0:
            m2, k, c = self.mode_mass_kg, self.mode_stiffness_n_per_m, self.mode_damping_n_s_per_m
            mass = np.diag([m1, m2])
            damp = np.array([[b + c, -c], [-c, c]])
            stiff = np.array([[k, -k], [-k, k]])
            force = np.array([kt, 0.0])
        else:
            mass, damp, stiff, force = np.array([[m1]]), np.array([[b]]), np.array([[0.0]]), np.array([kt])
        n = mass.shape[0]
        minv = np.linalg.inv(mass)
        a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ stiff, -minv @ damp]])
        bvec = np.concatenate([np.zeros(n), minv @ force])
        c = np.zeros(2 * n)
        c[0 if output == "position" else n] = 1.0
        return a, bvec, c

    def response(self, f_hz, output: str = "velocity") -> np.ndarray:
        """Continuous-time C (j w I - A)^-1 B: m/s per A (velocity) or m per A (position)."""
        a, b, c = self.matrices(output)
        eye = np.eye(a.shape[0])
        return np.array([c @ np.linalg.solve(2j * np.pi * f * eye - a, b) for f in np.atleast_1d(f_hz)])

    def discretise(self, fs_hz: float, output: str = "velocity"):
        """Zero-order-hold (Ad, Bd, C) at sample rate ``fs_hz``: expm of [[A, B], [0, 0]] T."""
        a, b, c = self.matrices(output)
        n = a.shape[0]
        aug = np.zeros((n + 1, n + 1))
        aug[:n, :n], aug[:n, n] = a, b
        e = expm(aug / fs_hz)
        return e[:n, :n], e[:n, n], c

    def zoh_response(self, f_hz, fs_hz: float, output: str = "velocity") -> np.ndarray:
        """C (z I - Ad)^-1 Bd at z = e^{j 2 pi f / fs}."""
        ad, bd, c = self.discretise(fs_hz, output)
        eye = np.eye(ad.shape[0])
        return np.array([c @ np.linalg.solve(np.exp(2j * np.pi * f / fs_hz) * eye - ad, bd)
                         for f in np.atleast_1d(f_hz)])


@dataclass(frozen=True)
class Record:
    """A simulated record: time (s), measured current (A), sensed output, optional reference."""

    time_s: np.ndarray
    current_a: np.ndarray
    output: np.ndarray
    reference: np.ndarray | None = None


# --- excitations ------------------------------------------------------------------------------
def odd_multisine_lines(k_max: int, skip_every: int = 3) -> np.ndarray:
    """Odd lines 1, 3, 5, ... <= k_max, leaving out every ``skip_every``-th odd line (detection
    lines for odd nonlinear distortion); ``skip_every=0`` keeps them all."""
    odd = np.arange(1, k_max + 1, 2)
    if skip_every:
        odd = odd[np.arange(odd.size) % skip_every != skip_every - 1]
    return odd


def schroeder_phases(n_lines: int) -> np.ndarray:
    """Schroeder phases -pi k (k + 1) / n_lines (low crest factor for a flat amplitude spectrum)."""
    k = np.arange(n_lines)
    return -np.pi * k * (k + 1) / n_lines


def multisine(t_s: np.ndarray, f0_hz: float, lines: np.ndarray, rms_a: float) -> np.ndarray:
    """Sum of cosines at lines x f0 with Schroeder phases, scaled to ``rms_a`` (A)."""
    amp = rms_a * np.sqrt(2.0 / lines.size)
    ph = schroeder_phases(lines.size)
    return amp * np.cos(2 * np.pi * f0_hz * np.outer(t_s, lines) + ph).sum(axis=1)


def chirp(t_s: np.ndarray, f1_hz: float, f2_hz: float, amplitude_a: float) -> np.ndarray:
    """Logarithmic sweep from f1 to f2 over the record."""
    duration = t_s[-1] + (t_s[1] - t_s[0])
    rate = np.log(f2_hz / f1_hz) / duration
    return amplitude_a * np.sin(2 * np.pi * f1_hz * (np.exp(rate * t_s) - 1) / rate)


def coloured(rng: np.random.Generator, n: int, std: float, pole: float = 0.0) -> np.ndarray:
    """Gaussian noise of standard deviation ``std``, white (pole 0) or through 1 / (1 - pole z^-1)."""
    w = rng.standard_normal(n)
    if pole:
        w = lfilter([np.sqrt(1 - pole ** 2)], [1.0, -pole], w)
    return std * w


# --- simulations --------------------------------------------------------------------------------
def multisine_record(axis: Axis, rng: np.random.Generator, *, fs_hz: float, period_samples: int,
                     periods: int, lines: np.ndarray, rms_a: float, noise_std: float, noise_pole: float = 0.0,
                     current_noise_std: float = 0.0, output: str = "velocity", quadratic: float = 0.0,
                     cubic: float = 0.0) -> Record:
    """Exact response from rest to a continuous multisine current (module doc), plus noise.

    Static output nonlinearity y + quadratic y^2 + cubic y^3 (y in the output's unit) before the noise.
    """
    n = period_samples * periods
    t = np.arange(n) / fs_hz
    f0 = fs_hz / period_samples
    amp = rms_a * np.sqrt(2.0 / lines.size)
    ph = schroeder_phases(lines.size)
    a, b, c = axis.matrices(output)
    eye = np.eye(a.shape[0])
    xk = np.array([np.linalg.solve(2j * np.pi * f0 * k * eye - a, b) for k in lines])  # (L, nx)
    phasor = amp * np.exp(1j * ph)
    x0 = np.real(phasor @ xk)
    steady = np.real(np.exp(2j * np.pi * f0 * np.outer(t, lines)) @ (phasor * (xk @ c)))
    lam, vec = np.linalg.eig(a)
    hom = np.real(np.exp(np.outer(t, lam)) @ ((c @ vec) * np.linalg.solve(vec, -x0)))
    y = steady + hom
    y = y + quadratic * y ** 2 + cubic * y ** 3
    current = multisine(t, f0, lines, rms_a)
    return Record(t, current + coloured(rng, n, current_noise_std), y + coloured(rng, n, noise_std, noise_pole))


def _filter_ss(ad, bd, c, u) -> np.ndarray:
    """y[k] = C x[k], x[k+1] = Ad x[k] + Bd u[k], from rest, by its transfer function: by the
    matrix determinant lemma C adj(zI - Ad) Bd = det(zI - Ad + Bd C) - det(zI - Ad)."""
    den = np.poly(ad)
    return lfilter(np.poly(ad - np.outer(bd, c)) - den, den, u)


def zoh_record(axis: Axis, rng: np.random.Generator, current: np.ndarray, *, fs_hz: float, noise_std: float,
               noise_pole: float = 0.0, current_noise_std: float = 0.0, output: str = "velocity") -> Record:
    """Response from rest to a zero-order-held current (module doc), plus noise."""
    n = current.size
    ad, bd, c = axis.discretise(fs_hz, output)
    y = _filter_ss(ad, bd, c, current)
    return Record(np.arange(n) / fs_hz, current + coloured(rng, n, current_noise_std),
                  y + coloured(rng, n, noise_std, noise_pole))


@dataclass(frozen=True)
class PI:
    """Discrete PI velocity controller: Kp (A per m/s), Ki (A per m), sample rate fs (Hz)."""

    kp: float
    ki: float
    fs_hz: float

    def response(self, f_hz) -> np.ndarray:
        """C(z) = Kp + Ki T / (z - 1) at z = e^{j w T}."""
        z = np.exp(2j * np.pi * np.asarray(f_hz) / self.fs_hz)
        return self.kp + self.ki / self.fs_hz / (z - 1)


def closed_loop_record(axis: Axis, controller: PI, rng: np.random.Generator, reference: np.ndarray, *,
                       noise_std: float, noise_pole: float = 0.0) -> Record:
    """Velocity loop from rest: the held current u[k] = Kp e[k] + Ki z[k] with e = r - (y + n);
    the record holds r, the measured velocity y + n and u (exact current)."""
    fs = controller.fs_hz
    ad, bd, c = axis.discretise(fs)
    nx = ad.shape[0]
    kp, ki, t = controller.kp, controller.ki, 1.0 / fs
    # closed-loop state [x; z], input e_in = r - n
    acl = np.zeros((nx + 1, nx + 1))
    acl[:nx, :nx] = ad - kp * np.outer(bd, c)
    acl[:nx, nx] = ki * bd
    acl[nx, :nx] = -t * c
    acl[nx, nx] = 1.0
    bcl = np.concatenate([kp * bd, [t]])
    n = reference.size
    noise = coloured(rng, n, noise_std, noise_pole)
    drive = reference - noise
    y = _filter_ss(acl, bcl, np.concatenate([c, [0.0]]), drive)
    u = kp * (drive - y) + ki * _filter_ss(acl, bcl, np.concatenate([np.zeros(nx), [1.0]]), drive)
    return Record(np.arange(n) / fs, u, y + noise, reference)
