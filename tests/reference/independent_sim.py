"""Independent simulator of stepped-sine experiments on the gantry (numpy/scipy only).

This module shares no code with the packages under test (``plant``, ``design``): the physics
is derived here from first principles, so recordings written by it are an independent truth
for ``gantry diagnose``.

Mechanics
    A network of rigid bodies with generalised coordinates q (m or rad) obeys
    ``M q'' + D q' + K q = f * Kt * i_force`` with mass matrix M (kg, kg m^2), damping D
    (N s/m), stiffness K (N/m), input direction f (dimensionless share of the motor force),
    force constant Kt (N/A) and the force-producing current i_force (A). The state is
    x = [q, q'] and x' = A x + B i_force.

Drive and sensors
    The recorded current i(t) = A sin(2 pi f t) (A) starts at t = 0. The force follows
    ``Kt * i_force`` where i_force is i delayed by the transport delay tau (s) and, optionally,
    lagged by a first-order current loop of bandwidth f_c (Hz): i_force' = w_c (i(t - tau) -
    i_force). Velocity (m/s) is read directly, optionally through a second-order Butterworth
    low-pass (corner f_s, Hz), or by differencing a quantised encoder position at the
    logging rate.

Exact responses
    Each block is a separate experiment from rest. For s = t - tau >= 0 the state is the
    particular (steady-state) solution x_p(s) = A Im((j w I - A)^-1 B e^{j w s}) plus the
    homogeneous term -e^{A s} x_p(0); before the delay has elapsed the state is zero. The
    matrix exponential is evaluated at the sample times (no numerical integration).
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.linalg import expm
from scipy.optimize import least_squares

KT_N_PER_A = 20.0                 # thesis: motor force constant
STAGE_X_MASS_KG = 35.0            # thesis: Stage X nominal mass (range 20-45 kg)
RAIL_DAMPING_N_S_PER_M = 440.0    # thesis: rail damping (range 330-550 N s/m)
BEAM_LENGTH_M = 0.8               # thesis: Stage Y beam / motor length L


@dataclass(frozen=True)
class Network:
    """Linear mechanical network ``M q'' + D q' + K q = input_n_per_a * i_force``.

    ``mass`` (n x n; kg or kg m^2), ``damping`` (n x n; N s/m), ``stiffness`` (n x n; N/m or
    N m/rad), ``input_n_per_a`` (n; generalised force per ampere of force-producing current,
    i.e. Kt times the share of the motor force), ``velocity_output`` (p x n; sensed
    velocities, m/s, as rows of generalised velocities), ``labels`` (p output names).
    """

    mass: np.ndarray
    damping: np.ndarray
    stiffness: np.ndarray
    input_n_per_a: np.ndarray
    velocity_output: np.ndarray
    labels: tuple[str, ...] = ("velocity_m_per_s",)

    @property
    def n_dof(self) -> int:
        return self.mass.shape[0]

    def mode_frequencies_hz(self) -> tuple[float, ...]:
        """Undamped mode frequencies (Hz): eigenvalues of M^-1 K without the rigid zero(s)."""
        lam = np.linalg.eigvals(np.linalg.solve(self.mass, self.stiffness)).real
        scale = max(float(np.max(np.abs(lam))), 1.0)
        return tuple(float(np.sqrt(v) / (2 * np.pi)) for v in np.sort(lam) if v > 1e-9 * scale)


@dataclass(frozen=True)
class Drive:
    """Drive and sensor chain.

    ``delay_s``: transport delay between recorded current and force (s).
    ``current_loop_hz``: first-order current-loop bandwidth (Hz), None = ideal.
    ``sensor_filter_hz``: corner of a second-order Butterworth velocity filter (Hz), None = none.
    ``encoder_quantum_m``: encoder resolution (m); when set, velocity is the difference of the
    quantised position times the sample rate (and no sensor filter is allowed).
    """

    delay_s: float = 0.0
    current_loop_hz: float | None = None
    sensor_filter_hz: float | None = None
    encoder_quantum_m: float | None = None

    def __post_init__(self) -> None:
        if self.delay_s < 0:
            raise ValueError(f"delay_s must be >= 0, got {self.delay_s}")
        if self.encoder_quantum_m is not None and self.sensor_filter_hz is not None:
            raise ValueError("an encoder-differenced velocity has no analogue sensor filter")


@dataclass(frozen=True)
class Protocol:
    """Stepped-sine protocol: frequencies (Hz), block length (s), sample rate (Hz), amplitude (A).

    ``first_block_periods``: if set, the lowest-frequency block lasts only this many periods
    (a short low-frequency block, e.g. 2-2.5 periods of 1 Hz).
    """

    f_hz: tuple[float, ...] = tuple(np.geomspace(1.0, 75.0, 40))
    block_s: float = 4.0
    sample_rate_hz: float = 1000.0
    amplitude_a: float = 0.5
    first_block_periods: float | None = None

    def block_lengths_s(self) -> np.ndarray:
        """Length of every block (s)."""
        lengths = np.full(len(self.f_hz), self.block_s)
        if self.first_block_periods is not None:
            k = int(np.argmin(self.f_hz))
            lengths[k] = self.first_block_periods / self.f_hz[k]
        return lengths


@dataclass(frozen=True)
class Truth:
    """What the recording contains, in the vocabulary of ``gantry diagnose``.

    ``effects``: effect names the tool should name; ``parameters``: main parameters
    (e.g. ``delay.seconds``, ``current_loop.bandwidth_hz``, ``sensor_filter.frequency_hz``);
    ``modes_hz``: undamped mode frequencies of the mechanics (Hz); ``mass_kg``: total moving
    mass (kg); ``outside_library``: no combination of library effects explains the data.
    """

    effects: tuple[str, ...]
    parameters: dict[str, float]
    modes_hz: tuple[float, ...]
    mass_kg: float
    stage: str
    outside_library: bool
    seed: int
    description: str = ""
    conditions: dict[str, float | bool] = field(default_factory=dict)


@dataclass
class Recording:
    """Sampled stepped-sine experiment: one entry per block.

    ``f_hz`` (Hz); ``time_s`` (s, restarting at 0 per block); ``current_a`` (A);
    ``velocity_m_per_s`` (arrays of shape (n_samples, n_outputs), m/s); ``labels`` column names.
    """

    f_hz: np.ndarray
    time_s: list[np.ndarray]
    current_a: list[np.ndarray]
    velocity_m_per_s: list[np.ndarray]
    labels: tuple[str, ...]
    truth: Truth | None = None


# --- networks --------------------------------------------------------------------------------

def _chain(masses_kg, springs_n_per_m, couplings_n_s_per_m, rail_damping_n_s_per_m, sensed: int) -> Network:
    """Masses in a line joined by springs/dampers; the motor drives mass 0, which has the rail damping."""
    n = len(masses_kg)
    K = np.zeros((n, n))
    D = np.zeros((n, n))
    for i, (k, c) in enumerate(zip(springs_n_per_m, couplings_n_s_per_m)):
        for mat, val in ((K, k), (D, c)):
            mat[i, i] += val
            mat[i + 1, i + 1] += val
            mat[i, i + 1] -= val
            mat[i + 1, i] -= val
    D[0, 0] += rail_damping_n_s_per_m
    f = np.zeros(n)
    f[0] = KT_N_PER_A
    C = np.zeros((1, n))
    C[0, sensed] = 1.0
    return Network(np.diag(np.asarray(masses_kg, float)), D, K, f, C)


def rigid_stage(mass_kg: float = STAGE_X_MASS_KG, damping_n_s_per_m: float = RAIL_DAMPING_N_S_PER_M) -> Network:
    """Rigid stage: mass (kg) with rail damping (N s/m) to ground, G(jw) = Kt / (M jw + b)."""
    return _chain([mass_kg], [], [], damping_n_s_per_m, sensed=0)


def two_mass(motor_kg: float, payload_kg: float, spring_n_per_m: float, coupling_n_s_per_m: float,
             damping_n_s_per_m: float = RAIL_DAMPING_N_S_PER_M, sensed: str = "motor") -> Network:
    """Motor carriage (kg, rail damping N s/m) driving a payload (kg) through spring (N/m) and damper (N s/m).

    ``sensed``: "motor" (collocated: antiresonance sqrt(k/m2), then resonance
    sqrt(k (m1+m2)/(m1 m2))) or "payload" (no antiresonance).
    """
    if sensed not in ("motor", "payload"):
        raise ValueError(f"sensed must be 'motor' or 'payload', got {sensed!r}")
    return _chain([motor_kg, payload_kg], [spring_n_per_m], [coupling_n_s_per_m], damping_n_s_per_m,
                  sensed=0 if sensed == "motor" else 1)


def mass_chain(masses_kg, springs_n_per_m, couplings_n_s_per_m,
               damping_n_s_per_m: float = RAIL_DAMPING_N_S_PER_M) -> Network:
    """Chain m1-(k1,c1)-m2-(k2,c2)-m3...; the motor drives m1 (rail damping, N s/m) and velocity is sensed at m1."""
    if not len(masses_kg) == len(springs_n_per_m) + 1 == len(couplings_n_s_per_m) + 1:
        raise ValueError("a chain of n masses needs n - 1 springs and n - 1 couplings")
    return _chain(masses_kg, springs_n_per_m, couplings_n_s_per_m, damping_n_s_per_m, sensed=0)


def tuned_chain(masses_kg, modes_hz, damping_ratio: float,
                damping_n_s_per_m: float = RAIL_DAMPING_N_S_PER_M) -> Network:
    """Motor-sensed chain whose springs are solved so that its undamped modes are ``modes_hz`` (Hz).

    Coupling dampers are stiffness-proportional, c_i = 2 zeta k_i / w_1, so the lowest mode has
    damping ratio ``damping_ratio`` and the higher ones proportionally more.
    """
    masses_kg = np.asarray(masses_kg, float)
    target = np.sort(np.asarray(modes_hz, float))
    if len(target) != len(masses_kg) - 1:
        raise ValueError("a chain of n masses has n - 1 modes")
    w1 = 2 * np.pi * target[0]
    k0 = np.full(len(target), float(np.mean(masses_kg)) * w1 ** 2)

    def modes(log_k):
        k = np.exp(log_k)
        return np.array(mass_chain(masses_kg, k, np.zeros_like(k), damping_n_s_per_m).mode_frequencies_hz())

    def residual(log_k):
        m = modes(log_k)
        return np.log(m / target) if len(m) == len(target) else np.full(len(target), 10.0)

    k = np.exp(least_squares(residual, np.log(k0), xtol=1e-14, ftol=1e-14).x)
    return mass_chain(masses_kg, k, 2 * damping_ratio * k / w1, damping_n_s_per_m)


def stage_y_beam(mass_kg: float, inertia_kg_m2: float, rail1_m: float, tilt_stiffness_n_m_per_rad: float,
                 beam_length_m: float = BEAM_LENGTH_M,
                 damping_n_s_per_m: float = RAIL_DAMPING_N_S_PER_M) -> Network:
    """Stage Y: rigid beam with load on rails Y1, Y2; coordinates (y_c in m, alpha in rad).

    The load sits ``rail1_m`` (l1) from rail Y1 and l2 = L - l1 from rail Y2; rail positions
    y1 = y_c - l1 alpha, y2 = y_c + l2 alpha. Each rail has damping b (N s/m) to ground and
    receives half of the motor force (Kt i / 2). A torsional stiffness Ka (N m/rad) acts on
    alpha, so the tilt mode is sqrt(Ka/J)/2pi with J the inertia about the load (kg m^2).
    Outputs: rail velocities v1, v2 (m/s).
    """
    l1 = rail1_m
    l2 = beam_length_m - rail1_m
    if not 0 < l1 < beam_length_m:
        raise ValueError(f"rail1_m must lie inside the beam (0, {beam_length_m}), got {rail1_m}")
    T = np.array([[1.0, -l1], [1.0, l2]])      # rail positions from (y_c, alpha)
    return Network(
        mass=np.diag([mass_kg, inertia_kg_m2]),
        damping=damping_n_s_per_m * T.T @ T,
        stiffness=np.diag([0.0, tilt_stiffness_n_m_per_rad]),
        input_n_per_a=T.T @ np.array([KT_N_PER_A / 2, KT_N_PER_A / 2]),
        velocity_output=T,
        labels=("velocity_y1_m_per_s", "velocity_y2_m_per_s"))


# --- state space -----------------------------------------------------------------------------

@dataclass(frozen=True)
class StateSpace:
    """x' = A x + B i(t - tau); velocity (m/s) = C_velocity x, position (m) = C_position x."""

    A: np.ndarray
    B: np.ndarray
    C_velocity: np.ndarray   # sensed velocity (after the optional sensor filter)
    C_position: np.ndarray   # sensed position (for the encoder)


def state_space(net: Network, drive: Drive) -> StateSpace:
    """Augmented state [i_force?, q, q', filter states?] driven by the delayed current (A)."""
    n = net.n_dof
    p = net.velocity_output.shape[0]
    Minv = np.linalg.inv(net.mass)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ net.stiffness, -Minv @ net.damping]])
    B = np.concatenate([np.zeros(n), Minv @ net.input_n_per_a])[:, None]
    Cv = np.hstack([np.zeros((p, n)), net.velocity_output])
    Cq = np.hstack([net.velocity_output, np.zeros((p, n))])
    if drive.current_loop_hz is not None:
        wc = 2 * np.pi * drive.current_loop_hz
        A = np.block([[np.full((1, 1), -wc), np.zeros((1, 2 * n))], [B, A]])
        B = np.concatenate([[wc], np.zeros(2 * n)])[:, None]
        Cv = np.hstack([np.zeros((p, 1)), Cv])
        Cq = np.hstack([np.zeros((p, 1)), Cq])
    if drive.sensor_filter_hz is not None:
        # per output: s'' + sqrt(2) wf s' + wf^2 s = wf^2 v, states (s, s')
        wf = 2 * np.pi * drive.sensor_filter_hz
        m = A.shape[0]
        Af = np.zeros((2 * p, 2 * p))
        Bf = np.zeros((2 * p, m))
        Cf = np.zeros((p, 2 * p))
        for j in range(p):
            Af[2 * j, 2 * j + 1] = 1.0
            Af[2 * j + 1, 2 * j] = -wf ** 2
            Af[2 * j + 1, 2 * j + 1] = -math.sqrt(2) * wf
            Bf[2 * j + 1] = wf ** 2 * Cv[j]
            Cf[j, 2 * j] = 1.0
        A = np.block([[A, np.zeros((m, 2 * p))], [Bf, Af]])
        B = np.vstack([B, np.zeros((2 * p, 1))])
        Cq = np.hstack([Cq, np.zeros((p, 2 * p))])
        Cv = np.hstack([np.zeros((p, m)), Cf])
    return StateSpace(A, B, Cv, Cq)


def frequency_response(net: Network, drive: Drive, f_hz) -> np.ndarray:
    """Steady-state velocity per current (m/s per A), shape (len(f_hz), n_outputs), including delay.

    ``C (j w I - A)^-1 B e^{-j w tau}``; for an encoder drive the analogue velocity (before
    differencing and quantisation) is returned.
    """
    ss = state_space(net, drive)
    out = []
    for f in np.atleast_1d(np.asarray(f_hz, float)):
        w_rad_s = 2 * np.pi * f
        g = np.linalg.solve(1j * w_rad_s * np.eye(ss.A.shape[0]) - ss.A, ss.B)[:, 0]
        out.append(ss.C_velocity @ g * np.exp(-1j * w_rad_s * drive.delay_s))
    return np.array(out)


def _propagate(A: np.ndarray, x0: np.ndarray, s0_s: float, dt_s: float, n: int) -> np.ndarray:
    """e^{A s_k} x0 at s_k = s0 + k dt for k < n (columns), by exact matrix exponentials."""
    cols = (expm(A * s0_s) @ x0)[:, None]
    step = expm(A * dt_s)
    while cols.shape[1] < n:
        cols = np.hstack([cols, step @ cols])
        step = step @ step
    return cols[:, :n]


def block_response(ss: StateSpace, f_hz: float, amplitude_a: float, delay_s: float, time_s: np.ndarray):
    """Exact state-derived (velocity, position) at ``time_s`` for i(t) = A sin(2 pi f t), t >= 0, from rest.

    Returns arrays (n_samples, n_outputs): velocity (m/s) and position (m). The system sees
    the current shifted by ``delay_s`` and is at rest before.
    """
    w_rad_s = 2 * np.pi * f_hz
    dim = ss.A.shape[0]
    g = np.linalg.solve(1j * w_rad_s * np.eye(dim) - ss.A, ss.B)[:, 0]
    s_s = np.asarray(time_s, float) - delay_s
    started = s_s >= 0
    x = np.zeros((dim, len(s_s)))
    if started.any():
        s_on = s_s[started]
        xp = amplitude_a * (np.outer(g.imag, np.cos(w_rad_s * s_on)) + np.outer(g.real, np.sin(w_rad_s * s_on)))
        dt_s = s_on[1] - s_on[0] if len(s_on) > 1 else 0.0
        x[:, started] = xp - _propagate(ss.A, amplitude_a * g.imag, s_on[0], dt_s, len(s_on))
    return (ss.C_velocity @ x).T, (ss.C_position @ x).T


# --- noise and recordings --------------------------------------------------------------------

def _force_disturbance(ss: StateSpace, net: Network, force_n: float, dt_s: float, n: int, rng) -> np.ndarray:
    """Position response (n, p) to a white disturbance force (N, std per sample, held over each sample).

    The disturbance acts where the motor force acts (the rails), on top of it.
    """
    dim = ss.A.shape[0]
    ndof = net.n_dof
    Bd = np.zeros((dim, 1))
    # an encoder drive has no filter states: the generalised velocities are the last n_dof states
    Bd[dim - ndof:, 0] = np.linalg.solve(net.mass, net.input_n_per_a / KT_N_PER_A)
    # exact zero-order-hold discretisation via the augmented exponential
    aug = np.zeros((dim + 1, dim + 1))
    aug[:dim, :dim] = ss.A
    aug[:dim, dim:] = Bd
    E = expm(aug * dt_s)
    Ad, Gd = E[:dim, :dim], E[:dim, dim:]
    w = rng.normal(0.0, force_n, (n, 1))
    x = np.zeros(dim)
    pos = np.empty((n, ss.C_position.shape[0]))
    for k in range(n):
        pos[k] = ss.C_position @ x
        x = Ad @ x + Gd @ w[k]
    return pos


def simulate(net: Network, drive: Drive = Drive(), protocol: Protocol = Protocol(), noise: float = 0.0,
             seed: int = 0, truth: Truth | None = None) -> Recording:
    """Stepped-sine recording: every block an experiment from rest, sampled exactly.

    ``noise`` (relative, e.g. 0.05): white Gaussian noise of ``noise`` times A on the current
    and, for directly read velocity, ``noise`` times the block's steady velocity amplitude on
    each velocity column. With an encoder the velocity column carries no added noise; a white
    force disturbance of std ``noise * Kt * A`` (N per sample) acts on every body instead, and
    velocities stay on the lattice quantum * sample rate.
    """
    rng = np.random.default_rng(seed)
    ss = state_space(net, drive)
    fs = protocol.sample_rate_hz
    dt_s = 1.0 / fs
    f_hz = np.asarray(protocol.f_hz, float)
    gains = np.abs(frequency_response(net, drive, f_hz))
    times, currents, velocities = [], [], []
    for f, length_s, gain in zip(f_hz, protocol.block_lengths_s(), gains):
        t = np.arange(int(round(length_s * fs))) * dt_s
        v, q = block_response(ss, f, protocol.amplitude_a, drive.delay_s, t)
        i = protocol.amplitude_a * np.sin(2 * np.pi * f * t)
        if drive.encoder_quantum_m is not None:
            if noise > 0:
                q = q + _force_disturbance(ss, net, noise * KT_N_PER_A * protocol.amplitude_a, dt_s, len(t), rng)
            quantum = drive.encoder_quantum_m
            q_counts = np.round(q / quantum)
            steps = np.diff(np.vstack([np.zeros((1, q.shape[1])), q_counts]), axis=0)
            v = steps * (quantum * fs)
        elif noise > 0:
            v = v + rng.normal(0.0, 1.0, v.shape) * (noise * protocol.amplitude_a * gain)
        if noise > 0:
            i = i + rng.normal(0.0, noise * protocol.amplitude_a, len(t))
        times.append(t)
        currents.append(i)
        velocities.append(v)
    return Recording(f_hz, times, currents, velocities, net.labels, truth)


def write_csv(rec: Recording, path: str | Path) -> Path:
    """Write the stepped-sine CSV: frequency_hz, time_s, current_a, velocity column(s); one row per sample."""
    path = Path(path)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(("frequency_hz", "time_s", "current_a") + tuple(rec.labels))
        for f, t, i, v in zip(rec.f_hz, rec.time_s, rec.current_a, rec.velocity_m_per_s):
            for k in range(len(t)):
                w.writerow([f"{f:.10g}", f"{t[k]:.10g}", f"{i[k]:.10g}"] + [f"{x:.12g}" for x in v[k]])
    return path
