"""Time-domain experiments simulated as one continuous run, the motion carried over from one part of the
excitation to the next: the recording the forces that depend on where the carriage is (force ripple, a force
constant profile), on its speed near rest (Stribeck friction) or on the drive's limit need, since a stepped sine
from rest averages or hides them. Produces a ``TimeRecording`` of positions (an encoder) with known truth.

Signal chain, starting from rest at x = 0::

    command i(t)  (recorded, with noise)
      -> delay          exact: i(t - tau), the command being a function of time
      -> current_limit  the drive clips its command: force K_f u - c (K_f u - clip(K_f u, +-F_L))
      -> sampling       zero-order hold at rate_hz, one controller period of computation delay
      -> current_loop, mechanics (the chain of bodies), sensor filters: exact discretisation
      -> forces on the rails (body 0): each effect's ``rail_force_n`` at the position, the velocity and the motor force
         (a force-constant profile K_f (K(x)/K_f - 1) i, a ripple, an offset), and the friction
      -> positions: the integrals of the recorded velocities (sampled at sample_rate_hz, with noise)

Method: fixed internal steps of h (a common multiple of the recording's and the controller's rates).
The linear chain is discretised exactly, the input with a first-order hold (exact for the piecewise-linear
command on the internal grid; a zero-order hold, exact, with ``sampling``). The forces that depend on the
position and the current are held over each step at its midpoint, predicted from the state's derivative at
the step's start (error O(h^2) per unit time). Friction is Moreau's implicit step as in
``plant.experiment.simulate``: the force in -(F_c + F_s exp(-(v/v_s)^2)) Sign(v_end), the Stribeck magnitude at
the velocity the step starts from (and a cable's drag where the carriage is, ``rail_friction_n``), so the contact
sticks exactly at rest when the drive cannot break it loose.
Checked against ``tests/reference/independent_linear_motor.py`` (Runge-Kutta, no shared code).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from plant.data.recordings import TimeRecording
from plant.errors import EffectError, ParameterError
from plant.experiment.simulate import MAX_SAMPLES, _chain, _internal_rate, _rate_fraction, _scalar, check_single
from plant.physics.models import Plant
from plant.physics.parameters import check_finite, check_positive
from plant.physics.state_space import hold_step

#: lowest internal rate (Hz): 10 substeps of the default 1 kHz recording (checked against an independent
#: Runge-Kutta simulation in tests/plant/experiment/test_simulate_time.py)
INTERNAL_RATE_HZ = 10000.0
_CHUNK = 4096
#: effects the continuous run cannot model (the Xie-Wang tilt has one friction contact per rail; a drift is defined
#: over a recording's own span, which a run does not declare)
_NOT_MODELLED = {"tilt_coupling": "two friction contacts (one per rail); simulate Stage Y without it or use "
                                  "the stepped-sine blocks",
                 "force_constant_drift": "a force constant drifting over a recording's span; scale the recorded "
                                         "current by K(t) / K to simulate one",
                 "damping_drift": "a damping drifting over a recording's span",
                 "yaw_coupling": "the beam's yaw in a recording's force balance, fitted from both rails; the yaw "
                                 "itself is tilt_coupling's"}


@dataclass(frozen=True)
class Excitation:
    """A command current (A) as a function of time (s), its description and its duration (s)."""

    current_a: Callable[[np.ndarray], np.ndarray]
    duration_s: float
    description: dict


def stepped_sine(f_hz, *, amplitude_a: float, block_s: float) -> Excitation:
    """Sines of ``f_hz`` (Hz, in the given order) one after another, ``block_s`` each, in one run:
    A sin(2 pi f_k t) during block k (the thesis's stepped sine, section 4.1, without the stops)."""
    f = np.asarray(f_hz, float).ravel()
    check_positive("f_hz", f)
    check_positive("amplitude_a", amplitude_a)
    check_positive("block_s", block_s)

    def current(t):
        k = np.minimum((np.asarray(t) // block_s).astype(int), f.size - 1)
        return amplitude_a * np.sin(2 * np.pi * f[k] * t)

    return Excitation(current, block_s * f.size, {"form": "stepped sine, continuous", "f_hz": f.tolist(),
                                                   "amplitude_a": float(amplitude_a), "block_s": float(block_s)})


def chirp(*, f0_hz: float, f1_hz: float, amplitude_a: float, duration_s: float) -> Excitation:
    """Logarithmic chirp A sin(2 pi f0 T (r^(t/T) - 1) / ln r), r = f1 / f0, T = ``duration_s``."""
    for name, value in [("f0_hz", f0_hz), ("f1_hz", f1_hz), ("amplitude_a", amplitude_a), ("duration_s", duration_s)]:
        check_positive(name, value)
    if not f1_hz > f0_hz:
        raise ParameterError(f"chirp: f1_hz ({f1_hz:g}) must exceed f0_hz ({f0_hz:g})")
    r = f1_hz / f0_hz

    def current(t):
        return amplitude_a * np.sin(2 * np.pi * f0_hz * duration_s * (r ** (np.asarray(t) / duration_s) - 1)
                                    / math.log(r))

    return Excitation(current, float(duration_s), {"form": "logarithmic chirp", "f0_hz": float(f0_hz),
                                                   "f1_hz": float(f1_hz), "amplitude_a": float(amplitude_a)})


def _augmented(plant: Plant):
    """(A, b_u, b_f, c_contact, current, C_position, C_velocity, n_chain): the chain of
    ``plant.experiment.simulate`` with the rails' position (state n_chain) and one position per recorded velocity
    appended as states; ``current`` the motor current as a row over (states, command)."""
    for name, why in _NOT_MODELLED.items():
        if plant.effect(name) is not None:
            raise EffectError(f"effect {name}: the continuous simulation does not model it ({why})")
    chain = _chain(plant)
    n, n_out = chain.A.shape[0], chain.C_out.shape[0]
    N = n + 1 + n_out
    A = np.zeros((N, N))
    A[:n, :n] = chain.A
    A[n] = chain.C_contact[0, :] @ np.eye(n, N)
    A[n + 1:, :n] = chain.C_out
    b_u = np.concatenate([chain.b_u, np.zeros(1 + n_out)])
    b_f = np.concatenate([chain.B_f[:, 0], np.zeros(1 + n_out)])
    c_contact = A[n].copy()                      # the rails' velocity: the derivative of their position
    current = np.concatenate([chain.current[:n], np.zeros(1 + n_out), chain.current[n:]])
    return A, b_u, b_f, c_contact, current, np.eye(N)[n + 1:], chain.C_out @ np.eye(n, N), n


def simulate_time_domain(plant: Plant, excitation: Excitation, *, sample_rate_hz: float = 1000.0,
                         internal_rate_hz: float = INTERNAL_RATE_HZ, current_noise_a: float = 0.0,
                         noise: float = 0.0, output: str = "position", seed: int = 0,
                         progress: Callable[[int, int], None] | None = None) -> TimeRecording:
    """Simulate ``excitation`` on ``plant`` in one continuous run from rest (module doc) and record the command
    current and the ``output`` ("position": the integrals of the recorded velocities, as an encoder gives them;
    "velocity") at ``sample_rate_hz``, with white Gaussian noise of ``current_noise_a`` (A) and
    ``noise`` (m or m/s) standard deviation. ``internal_rate_hz``: the lowest internal rate (raised to a common
    multiple of the recording's and, with ``sampling``, the controller's). ``progress(done, total)`` hears the
    samples simulated. The settings, true parameters and ``seed`` are in ``TimeRecording.metadata``."""
    check_positive("sample_rate_hz", sample_rate_hz)
    check_positive("current_noise_a", current_noise_a, allow_zero=True)
    check_positive("noise", noise, allow_zero=True)
    check_positive("internal_rate_hz", internal_rate_hz)
    check_finite("seed", seed)
    if int(seed) != seed or seed < 0:
        raise ParameterError(f"seed must be a non-negative integer, got {seed!r}")
    n_samples = int(round(excitation.duration_s * sample_rate_hz))
    if n_samples < 2:
        raise ParameterError(f"the excitation's {excitation.duration_s:g} s give {n_samples} sample(s) at "
                             f"{sample_rate_hz:g} Hz")
    if n_samples > MAX_SAMPLES / 4:
        raise ParameterError(f"{excitation.duration_s:g} s at {sample_rate_hz:g} Hz is {n_samples:.3g} samples, "
                             f"more than the {MAX_SAMPLES / 4:.0e} a continuous run may have")
    check_single(plant)
    if output not in ("position", "velocity"):
        raise ParameterError(f"output must be position or velocity, got {output!r}")
    A, b_u, b_f, c_contact, current, C_pos, C_vel, n_chain = _augmented(plant)
    kt = _scalar("force_constant_n_per_a", plant.force_constant_n_per_a)
    sampling = plant.effect("sampling")
    controller_hz = None if sampling is None else _scalar("sampling.rate_hz", sampling.rate_hz)
    rate = _internal_rate(sample_rate_hz, controller_hz, internal_rate_hz)
    h = float(1 / rate)
    q = int(rate / _rate_fraction("sample_rate_hz", sample_rate_hz))
    n_steps = (n_samples - 1) * q
    t_int = np.arange(n_steps + 1) * h

    delay = plant.effect("delay")
    delay_s = 0.0 if delay is None else _scalar("delay.seconds", delay.seconds)
    if controller_hz is None:
        t_cmd = t_int - delay_s
    else:
        period = round(float(rate / _rate_fraction("sampling.rate_hz", controller_hz)))
        # the step from N to N + 1 holds the sample taken one controller period before the period containing N
        t_cmd = (np.arange(n_steps + 1) // period - 1) * period * h - delay_s
    command = np.where(t_cmd >= 0, excitation.current_a(np.maximum(t_cmd, 0.0)), 0.0)
    limit = plant.effect("current_limit")
    u = command if limit is None else np.asarray(limit.delivered(kt * command)) / kt

    Phi, G0, G1 = hold_step(A, np.column_stack([b_u, b_f]), h, linear=True)
    g_u0, g_u1 = G0[:, 0], (G1[:, 0] if controller_hz is None else np.zeros(A.shape[0]))
    g_f = G0[:, 1]
    forces = [e for e in plant.effects if e.rail_force]
    coulomb, stribeck = plant.effect("coulomb_friction"), plant.effect("stribeck_friction")
    fc = 0.0 if coulomb is None else _scalar("coulomb_friction.force_n", coulomb.force_n)
    fs = 0.0 if stribeck is None else float(stribeck.excess_n)
    vs = 1.0 if stribeck is None else float(stribeck.velocity_m_per_s)
    g_contact = float(c_contact @ g_f)                 # contact velocity per unit friction force over a step
    along = [e for e in plant.effects if e.rail_friction]
    friction = fc > 0 or fs > 0 or bool(along)
    position = np.eye(A.shape[0])[n_chain]

    # the rails' position and velocity and the motor current at a step's midpoint, predicted from its start: rows
    # dotted with z, and the command's terms
    r_x = np.eye(A.shape[0])[n_chain] + c_contact * (h / 2)
    # (the velocity's with the rail force of the step before: a force that depends on the velocity stays second order)
    r_v = c_contact + (c_contact @ A) * (h / 2)
    v_u, v_f = float(c_contact @ b_u) * (h / 2), float(c_contact @ b_f) * (h / 2)
    f = 0.0
    c_i, d_i = current[:-1], float(current[-1])
    r_i = c_i + (c_i @ A) * (h / 2)
    i_u = float(c_i @ b_u) * (h / 2)
    z = np.zeros(A.shape[0])
    Z = np.empty((n_samples, A.shape[0]))
    v_prev = 0.0
    report_every = max(1, n_samples // 100)
    for start in range(0, n_steps, _CHUNK):
        stop = min(start + _CHUNK, n_steps)
        drive = np.outer(u[start:stop], g_u0) + np.outer(u[start + 1:stop + 1] - u[start:stop], g_u1)
        for k in range(start, stop):
            if k % q == 0:
                Z[k // q] = z
                if progress is not None and (k // q) % report_every == 0:
                    progress(k // q, n_samples - 1)
            if forces:
                x_mid = float(r_x @ z)
                i_mid = float(r_i @ z) + i_u * u[k] + d_i * 0.5 * (u[k] + u[k + 1])
                v_mid = float(r_v @ z) + v_u * u[k] + v_f * f
                f = sum(e.rail_force_n(x_mid, v_mid, kt * i_mid) for e in forces)
                z = Phi @ z + drive[k - start] + g_f * f
            else:
                z = Phi @ z + drive[k - start]
            if friction:
                v_free = float(c_contact @ z)
                magnitude = fc + fs * math.exp(-(v_prev / vs) ** 2)
                if along:                   # a friction cannot push: none where a drag would make it negative
                    x_now = float(position @ z)
                    magnitude = max(magnitude + sum(e.rail_friction_n(x_now) for e in along), 0.0)
                impulse = -min(max(v_free / g_contact, -magnitude), magnitude)
                z = z + g_f * impulse
                v_prev = v_free + g_contact * impulse
    Z[-1] = z
    if progress is not None:
        progress(n_samples - 1, n_samples - 1)

    t = np.arange(n_samples) / sample_rate_hz
    rng = np.random.default_rng(int(seed))
    current = excitation.current_a(t) + current_noise_a * rng.standard_normal(n_samples)
    C = C_pos if output == "position" else C_vel
    recorded = (Z @ C.T).T + noise * rng.standard_normal((C.shape[0], n_samples))
    unit = "m" if output == "position" else "m_per_s"
    names = (f"{output}_{unit}",) if plant.stage == "x" else (f"{output}_y1_{unit}", f"{output}_y2_{unit}")
    metadata = {
        "simulator": "plant.experiment.simulate_time.simulate_time_domain",
        "method": "exact discretisation (first-order hold of the command), forces held at each step's predicted "
                  "midpoint, Moreau implicit friction",
        "internal_rate_hz": float(rate),
        "stage": plant.stage,
        "parameters": {key: p.value for key, p in plant.parameters().items()},
        "effects": list(plant.effect_names),
        "excitation": excitation.description,
        "duration_s": float(excitation.duration_s),
        "sample_rate_hz": float(sample_rate_hz),
        "recorded_current": "command current (before delay, limit, sampling and current loop), plus noise",
        "current_noise_std_a": float(current_noise_a),
        "output": output,
        "noise_std": float(noise),
        "seed": int(seed),
    }
    return TimeRecording(t, current, recorded, output, names, source="<simulated>", metadata=metadata)


def travel_notes(recording: TimeRecording) -> list[str]:
    """What the travel a simulated run covered cannot show: a ripple seen over fewer than 2 of its pitches, a
    force-constant profile over less than a tenth of its span (read from ``recording.metadata``)."""
    if recording.output_kind != "position":
        return []
    travel = float(np.ptp(recording.output[0]))
    parameters = recording.metadata["parameters"]
    notes = []
    pitch = parameters.get("force_ripple.pitch_m")
    if pitch is not None and travel < 2 * pitch:
        notes.append(f"force_ripple: the carriage covered {1e3 * travel:.3g} mm, less than 2 pitches "
                     f"({1e3 * pitch:.3g} mm): the recording can hardly show the ripple; raise the amplitude or lower "
                     "the frequencies")
    span = parameters.get("force_constant_profile.half_span_m")
    if span is not None and travel < 0.2 * span:
        notes.append(f"force_constant_profile: the carriage covered {1e3 * travel:.3g} mm, less than a tenth of the "
                     f"profile's span ({2e3 * span:.3g} mm): the recording can hardly show it")
    return notes


__all__ = ["Excitation", "INTERNAL_RATE_HZ", "chirp", "simulate_time_domain", "stepped_sine", "travel_notes"]
