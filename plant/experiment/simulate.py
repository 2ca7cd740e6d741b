"""Stepped-sine experiments simulated in time (thesis section 4.1: a sinusoidal current per
frequency, 5 s per block, velocity recorded), producing a ``Recording`` with known truth.

Signal chain of one block, starting from rest at t = 0::

    command i(t) = A sin(2 pi f t)                    (recorded, with noise/quantisation)
      -> delay        exact shift: i(t - tau), evaluated analytically
      -> sampling     zero-order hold at rate_hz + one sample of computation delay
      -> current_loop first-order lag w_c / (s + w_c)
      -> mechanics    the chain of bodies (Stage X Eq. 3.15, Stage Y Eq. 3.16 effective mass and
                      damping, split by the mode effects), or the Xie-Wang model (thesis
                      Eq. 2.14-2.15) with tilt_coupling; Coulomb friction on the rails with its
                      exact set-valued force
      -> sensor       sensor_filter as a filter on each recorded velocity
      -> velocity outputs sampled at sample_rate_hz   (recorded, with noise/quantisation)

Methods (all exact for the linear parts):

* linear plant without ``sampling``: closed form. The response to a sine switched on at
  t = tau from rest is the analytic steady state minus e^(A (t - tau)) times its initial value.
* ``sampling`` and/or ``coulomb_friction``: fixed-step integration at an internal rate that
  divides the recording and controller periods. Linear dynamics use the exact discretisation
  (matrix exponential), the sine input its exact steady state, the held controller output
  its exact zero-order-hold integral.
* Coulomb friction: Moreau time stepping. Over each internal step the friction force f is
  constant and chosen implicitly so that f lies in -F_c Sign(v_end), v_end being the velocity at
  the end of the step: the contact sticks (v_end = 0 exactly, |f| <= F_c) when the drive force
  cannot break it loose, and slides with |f| = F_c otherwise. This handles stick-slip without
  the artificial velocity band of Karnopp's model and without chattering at v = 0. With one
  contact, a slide that reaches zero inside a step keeps its friction until the crossing (located
  by linear interpolation of the velocity) and the rest of the step starts from rest, so reversals
  are second order in the step (a sticking or breakaway step already is); without this, each
  reversal left a velocity error of 2 F_c theta h / m (0.25 % of the fundamental at 30 Hz).
  Stage Y with tilt coupling has one contact per rail (F_c / 2 each, as in ``Plant.frd``),
  solved exactly by enumerating the stick/slide modes of the two rails, its switches resolved to
  one internal step (error O(h)).

The fundamental of a recording equals ``Plant.frd`` exactly for linear plants, except with ``sampling``:
the zero-order hold also makes images at k * rate_hz +- f, and those that sit at a multiple of
sample_rate_hz +- f alias onto f when the two clocks are synchronous (real, like on the test bench; relative size
~ 2 (f / rate_hz)^2 for the rigid-body plant, 1e-4 at 75 Hz with a 10 kHz controller).

The delay enters exactly for any value: the plant is time-invariant, so a block delayed by tau
is the undelayed block shifted by tau, and the internal grid is laid in the undelayed time.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import scipy.linalg

from plant.arguments import check_instance, check_number
from plant.data.recordings import Block, Recording
from plant.errors import EffectError, ParameterError
from plant.physics.models import Plant
from plant.physics.parameters import check_finite, check_positive
from plant.physics.realisation import realise
from plant.physics.state_space import hold_step

#: default internal integration rate when Coulomb friction is present (Hz): the fundamental then
#: agrees with a 5x finer step to 3e-3 (Stage X, 1-75 Hz, F_c = 2 N at 0.5 A; tests/plant/experiment/test_simulate.py)
FRICTION_RATE_HZ = 20000.0
#: most samples a simulated recording may have (all blocks; about 48 bytes each to simulate and write)
MAX_SAMPLES = 2e7
#: highest internal rate accepted (Hz): incommensurate controller and recording rates need more
MAX_INTERNAL_RATE_HZ = 2.0e6
_CHUNK = 2048


@dataclass(frozen=True)
class _Chain:
    """Linear part of the signal chain: x' = A x + b_u u + B_f f, outputs C_out x, contacts C_contact x."""

    A: np.ndarray            # (n, n)
    b_u: np.ndarray          # (n,): input = current command after delay and sampling (A)
    B_f: np.ndarray          # (n, n_contacts): friction forces (N) at the contacts
    C_out: np.ndarray        # (n_outputs, n): recorded velocities (after the resonance filter)
    C_contact: np.ndarray    # (n_contacts, n): sliding velocities of the friction contacts
    friction_n: np.ndarray   # (n_contacts,): Coulomb force at each contact (N)
    current: np.ndarray      # (n + 1,): the motor current over (x, u) (A)


def _scalar(name: str, value) -> float:
    arr = np.asarray(value, dtype=float)
    if arr.size != 1:
        raise ParameterError(f"{name} is a batch of {arr.size} values; the simulator needs one plant")
    return float(arr.reshape(()))


def _chain(plant: Plant) -> _Chain:
    """The plant's realisation (``plant.physics.realisation``: current loop -> mechanics -> sensor filters) with
    the Coulomb friction of each rail contact (F_c; F_c / 2 per rail with ``tilt_coupling``, as ``Plant.frd``)."""
    check_single(plant)
    if any(e.name == "encoder_velocity" for e in plant.effects):
        raise EffectError("effect encoder_velocity (plant.effects.encoder_velocity of the spec, or --effects) is "
                          "not simulated as a filter: record quantised positions (velocity_quantum_m_per_s) instead")
    r = realise(plant).one()
    friction = plant.effect("coulomb_friction")
    force_n = 0.0 if friction is None else _scalar("coulomb_friction.force_n", friction.force_n)
    return _Chain(r.A, r.B[:, 0], r.B[:, 1:], r.outputs, r.contacts, force_n * r.share, r.current)


def _steady_state(chain: _Chain, w_rad_s: np.ndarray) -> np.ndarray:
    """Complex state phasor X(w) = (j w I - A)^-1 b_u per unit input, shape (n_blocks, n)."""
    n = chain.A.shape[0]
    M = 1j * w_rad_s[:, None, None] * np.eye(n) - chain.A
    return np.linalg.solve(M, np.broadcast_to(chain.b_u, (len(w_rad_s), n))[..., None])[..., 0]


def _rate_fraction(name: str, rate_hz: float) -> Fraction:
    frac = Fraction(rate_hz).limit_denominator(1000)
    if abs(float(frac) - rate_hz) > 1e-12 * rate_hz:
        raise ParameterError(f"{name} = {rate_hz:g} Hz is not a ratio of small integers; the exact simulation "
                             "needs commensurate rates (use e.g. a whole number of Hz)")
    return frac


def _internal_rate(sample_rate_hz: float, controller_rate_hz: float | None, min_rate_hz: float) -> Fraction:
    """Smallest common multiple of the recording and controller rates that is >= ``min_rate_hz``."""
    rate = _rate_fraction("sample_rate_hz", sample_rate_hz)
    if controller_rate_hz is not None:
        c = _rate_fraction("sampling.rate_hz", controller_rate_hz)
        rate = Fraction(math.lcm(rate.numerator * c.denominator, c.numerator * rate.denominator),
                        rate.denominator * c.denominator)
    rate = rate * max(1, math.ceil(min_rate_hz / rate))
    if rate > MAX_INTERNAL_RATE_HZ and min_rate_hz > MAX_INTERNAL_RATE_HZ:
        raise ParameterError(f"friction_rate_hz {min_rate_hz:g} exceeds the highest internal rate "
                             f"{MAX_INTERNAL_RATE_HZ:g} Hz")
    if rate > MAX_INTERNAL_RATE_HZ:
        raise ParameterError(
            f"sample_rate_hz ({sample_rate_hz:g} Hz) and sampling.rate_hz ({controller_rate_hz:g} Hz) have no common "
            f"multiple below {MAX_INTERNAL_RATE_HZ:g} Hz; an exact simulation needs commensurate rates")
    return rate


def _linear_response(chain: _Chain, *, w_rad_s, amp_a, t_s, delay_s) -> np.ndarray:
    """Closed-form velocities (n_blocks, n_outputs, n_samples) of a linear chain, sine switched on at delay_s."""
    X = amp_a[:, None] * _steady_state(chain, w_rad_s)              # (nb, n)
    out = np.zeros((len(w_rad_s), chain.C_out.shape[0], len(t_s)))
    k0 = int(np.searchsorted(t_s, delay_s))
    if k0 == len(t_s):
        return out
    sigma = t_s[k0:] - delay_s
    steady = np.imag((X @ chain.C_out.T)[:, :, None] * np.exp(1j * w_rad_s[:, None, None] * sigma))
    # transient: -C e^(A sigma) Im(X); e^(A sigma_k) = e^(A sigma_k0) Phi^(k - k0) on the recording grid
    Phi = scipy.linalg.expm(chain.A * (t_s[1] - t_s[0]))
    E = np.empty((len(sigma), *chain.C_out.shape))
    E[0] = chain.C_out @ scipy.linalg.expm(chain.A * sigma[0])
    for k in range(1, len(sigma)):
        E[k] = E[k - 1] @ Phi
    out[:, :, k0:] = steady - np.einsum("kon,bn->bok", E, np.imag(X))
    return out


class _Contacts:
    """Implicit Coulomb friction of one step: f in -F Sign(v_free + G f) for every contact."""

    def __init__(self, G: np.ndarray, friction_n: np.ndarray):
        self.friction_n = friction_n
        self.n = len(friction_n)
        if self.n == 1:
            self.inv_g = 1.0 / float(G[0, 0])
            return
        modes = list(itertools.product((0, 1, -1), repeat=self.n))     # 0 stick, +1 slide v>0, -1 slide v<0
        P = np.zeros((len(modes), self.n, self.n))
        q = np.zeros((len(modes), self.n))
        for i, mode in enumerate(modes):
            m = np.array(mode)
            S, K = np.flatnonzero(m == 0), np.flatnonzero(m != 0)
            f_K = -m[K] * friction_n[K]
            q[i, K] = f_K
            if len(S):
                inv = np.linalg.inv(G[np.ix_(S, S)])
                P[i][np.ix_(S, S)] = -inv
                q[i, S] = -inv @ G[np.ix_(S, K)] @ f_K
        # flattened affine maps of v_free: forces and end-of-step velocities of every mode, (modes * n, n)
        n_m = len(modes)
        self.n_modes = n_m
        self.G = G
        self.P = P.reshape(n_m * self.n, self.n).T
        self.q = q.ravel()
        self.V = (np.eye(self.n) + G @ P).reshape(n_m * self.n, self.n).T
        self.vq = (q @ G.T).ravel()
        m = np.array(modes, dtype=float).ravel()
        self.stick = m == 0
        self.limit = np.tile(friction_n, n_m)
        # sliding-sign violation converted to force units with the contact's own compliance
        self.slide_weight = -m * np.tile(1.0 / np.diag(G), n_m)

    def forces(self, v_free: np.ndarray) -> np.ndarray:
        """Friction forces (n_blocks, n_contacts) for free end-of-step velocities (n_blocks, n_contacts)."""
        if self.n == 1:
            return -np.clip(v_free * self.inv_g, -self.friction_n, self.friction_n)
        # usual case first: every contact keeps sliding the way it is going
        f = -self.friction_n * np.sign(v_free)
        slide = np.all((v_free + f @ self.G.T) * v_free > 0, axis=1)
        if slide.all():
            return f
        rows = np.flatnonzero(~slide)
        vf = v_free[rows]
        fm = vf @ self.P + self.q                                          # (rows, modes * n)
        violation = np.where(self.stick, np.abs(fm) - self.limit, (vf @ self.V + self.vq) * self.slide_weight)
        np.maximum(violation, 0.0, out=violation)
        best = violation.reshape(len(rows), self.n_modes, self.n).sum(axis=-1).argmin(axis=1)
        f[rows] = fm.reshape(len(rows), self.n_modes, self.n)[np.arange(len(rows)), best]
        return f


def _stepped_response(chain: _Chain, *, w_rad_s, amp_a, n_samples, sample_rate_hz, delay_s,
                      controller_rate_hz, internal_rate: Fraction, progress=None) -> np.ndarray:
    """Velocities (n_blocks, n_outputs, n_samples) by exact-discretisation time stepping (see module doc);
    ``progress(done, total)`` hears the internal steps after each chunk of them.

    The state is x = p + z: p the analytic steady state of the sine input (zero with ``sampling``,
    whose held input drives z through its exact zero-order-hold integral), z everything else.
    """
    nb, n = len(w_rad_s), chain.A.shape[0]
    h = float(1 / internal_rate)
    q = int(internal_rate / _rate_fraction("sample_rate_hz", sample_rate_hz))     # internal steps per sample
    # internal real-time grid N h; the input reaches the chain at tau = delay_s (undelayed time sigma = t - tau)
    ratio = delay_s / h
    n_shift = round(ratio) if abs(ratio - round(ratio)) < 1e-9 else math.ceil(ratio)
    eps = max(n_shift * h - delay_s, 0.0)                # sigma of the grid point N = n_shift
    n_last = (n_samples - 1) * q
    out = np.zeros((nb, chain.C_out.shape[0], n_samples))
    if n_last < n_shift:
        return out
    friction = bool(np.any(chain.friction_n > 0))
    Phi, Gam = hold_step(chain.A, np.column_stack([chain.b_u, chain.B_f]), h)
    g_u, G_f = Gam[:, 0], Gam[:, 1:]
    contacts = _Contacts(chain.C_contact @ G_f, chain.friction_n) if friction else None
    held = controller_rate_hz is not None
    X = amp_a[:, None] * _steady_state(chain, w_rad_s)       # p(sigma) = Im(X e^(j w sigma)), sine input only
    Xc = X @ chain.C_contact.T

    def particular(phasor, sigma):
        return np.imag(phasor[:, :, None] * np.exp(1j * w_rad_s[:, None, None] * sigma))

    # z at N = n_shift (sigma = eps), from rest at sigma = 0
    z = np.zeros((nb, n))                    # held input: the controller outputs zero until it has sampled the sine
    if not held:
        z = -np.imag(X)
        if eps > 0:
            Phi_e, Gam_e = hold_step(chain.A, chain.B_f, eps)
            z = z @ Phi_e.T
            if friction:
                f = contacts.forces(z @ chain.C_contact.T + particular(Xc, np.array([eps]))[:, :, 0])
                z = z + f @ Gam_e.T
    rec_N = [k * q for k in range(n_samples)]
    first = int(np.searchsorted(rec_N, n_shift))
    Z = np.empty((n_samples - first, nb, n))
    r = first
    if rec_N[r] == n_shift:
        Z[0], r = z, r + 1
    next_rec = rec_N[r] if r < n_samples else -1
    PhiT, GfT, CcT = Phi.T, G_f.T, chain.C_contact.T
    if held:
        p_steps = round(float(internal_rate / _rate_fraction("sampling.rate_hz", controller_rate_hz)))
    single = contacts is not None and contacts.n == 1
    if single:
        c1, g1, k1, F1 = chain.C_contact[0], G_f[:, 0], -contacts.inv_g, float(contacts.friction_n[0])
        g_c = -1 / k1                        # contact velocity per unit friction impulse over a step
        v_prev = z @ c1 + (0.0 if held else particular(Xc, np.array([eps]))[:, 0, 0])
    N = n_shift
    while N < n_last:
        stop = min(N + _CHUNK, n_last)
        N_next = np.arange(N + 1, stop + 1)              # grid indices reached by the steps of this chunk
        if held:
            # the step into N holds the sample taken one controller period before the period containing N - 1
            t_sample = ((N_next - 1) // p_steps - 1) * p_steps * h - delay_s     # undelayed time of that sample
            u = np.where(t_sample >= 0, amp_a[:, None] * np.sin(w_rad_s[:, None] * t_sample), 0.0)
            drive = u.T[:, :, None] * g_u                # (steps, nb, n)
            v_ext = np.zeros((len(N_next), nb, contacts.n if friction else 0))
        else:
            v_ext = np.transpose(particular(Xc, N_next * h - delay_s), (2, 0, 1)) if friction else None
        for i in range(len(N_next)):
            z = z @ PhiT
            if held:
                z += drive[i]
            if single:
                v_free = z @ c1 + v_ext[i, :, 0]
                f = v_free * k1
                np.maximum(f, -F1, out=f)
                np.minimum(f, F1, out=f)
                v_old = v_free - np.copysign(F1 * g_c, v_prev)   # the end velocity had the old friction acted
                crosses = v_old * v_prev < 0                     # throughout (a contact at rest never crosses)
                if crosses.any():
                    # a slide reaching zero inside the step: the old friction acted until then (the fraction
                    # theta, the velocity linear over the step), then the rest of the step from rest
                    vp = v_prev[crosses]
                    theta = vp / (vp - v_old[crosses])
                    rest = np.clip((v_free[crosses] - vp) * k1, -F1, F1)
                    f[crosses] = -F1 * np.sign(vp) * theta + (1 - theta) * rest
                z += f[:, None] * g1
                v_prev = v_free - f / k1
            elif friction:
                z += contacts.forces(z @ CcT + v_ext[i]) @ GfT
            if N + 1 + i == next_rec:
                Z[r - first] = z
                r += 1
                next_rec = rec_N[r] if r < n_samples else -1
        N = stop
        if progress is not None:
            progress(N - n_shift, n_last - n_shift)
    x = np.transpose(Z, (1, 2, 0))                       # (nb, n, n_rec)
    if not held:
        x = x + particular(X, np.array(rec_N[first:]) * h - delay_s)
    out[:, :, first:] = np.einsum("on,bnk->bok", chain.C_out, x)
    return out


def _fundamental_amplitude(y: np.ndarray, w_rad_s: np.ndarray, t_s: np.ndarray) -> np.ndarray:
    """Least-squares amplitude of the sinusoid at w over the second half of each block; y (nb, no, ns)."""
    half = t_s >= t_s[-1] / 2
    t = t_s[half]
    amps = np.empty(y.shape[:2])
    for b, w in enumerate(w_rad_s):
        basis = np.column_stack([np.cos(w * t), np.sin(w * t)])
        coef, *_ = np.linalg.lstsq(basis, y[b][:, half].T, rcond=None)
        amps[b] = np.hypot(coef[0], coef[1])
    return amps


def _quantise(x: np.ndarray, quantum: float | None) -> np.ndarray:
    return x if quantum is None else np.round(x / quantum) * quantum


def output_column_names(plant: Plant) -> tuple[str, ...]:
    """CSV column names of the recorded velocities of ``plant``."""
    return ("velocity_m_per_s",) if plant.stage == "x" else ("velocity_y1_m_per_s", "velocity_y2_m_per_s")


def _check_plant(plant: Plant) -> None:
    """One plant, not a batch; no effect the stepped sine does not model."""
    for e in plant.effects:
        if not e.simulated:
            raise EffectError(f"{e.name}: the stepped-sine blocks do not model it (a force that depends on the "
                              "position or changes no frequency response); simulate one continuous run instead "
                              "(plant.experiment.simulate_time, gantry simulate --form continuous or chirp)")
    check_single(plant)


def check_single(plant: Plant) -> None:
    """One plant, not a batch: every parameter a single value (``ParameterError`` naming the first that is not)."""
    for name in plant.parameters():
        effect_name, _, field = name.rpartition(".")
        _scalar(name, getattr(plant.effect(effect_name), field) if effect_name else getattr(plant, name))


#: a block whose largest velocity stays below this fraction of the frictionless response never moved
STUCK_FRACTION = 1e-9


def _refuse_stuck_blocks(plant: Plant, f_hz: np.ndarray, amp_a: np.ndarray, velocity: np.ndarray) -> None:
    """``ParameterError`` when the stage never breaks loose from its Coulomb friction in a block: its
    velocity is zero throughout (the force of the drive stays below the friction), so the block records
    no dynamics, only that the friction exceeds the force; it names the blocks and the current that
    moves the stage in all of them."""
    w = 2 * np.pi * f_hz
    frictionless = plant.with_effects(*(e for e in plant.effects if e.linear))
    free = amp_a * np.max(np.abs(frictionless.frd_outputs(w)), axis=-2)          # (n_blocks,)
    stuck = np.flatnonzero(np.max(np.abs(velocity), axis=(1, 2)) <= STUCK_FRACTION * free)
    if stuck.size == 0:
        return
    friction_n = _scalar("coulomb_friction.force_n", plant.effect("coulomb_friction").force_n)
    drive = np.abs(np.broadcast_to(plant.chain_response(1j * w, "drive"), w.shape))
    breakaway_a = friction_n / (_scalar("force_constant_n_per_a", plant.force_constant_n_per_a) * drive)
    k = stuck[0]
    where, holds = (f"the block at {f_hz[k]:g} Hz", "it holds") if stuck.size == 1 else \
        (f"{stuck.size} blocks at {f_hz[k]:g}-{f_hz[stuck[-1]]:g} Hz", "they hold")
    raise ParameterError(f"current_amplitude_a {amp_a[k]:g} A: the stage never breaks loose from its Coulomb "
                         f"friction ({friction_n:g} N) in {where}: the velocity stays zero, so {holds} no dynamics "
                         f"to estimate; raise current_amplitude_a above {np.max(breakaway_a[stuck]):.3g} A (the drive "
                         "force then exceeds the friction) or lower coulomb_friction.force_n")


def _check_four_samples_per_period(f_max_hz: float, sample_rate_hz: float) -> None:
    if f_max_hz > sample_rate_hz / 4:
        raise ParameterError(f"f_hz {f_max_hz:g} Hz has fewer than 4 samples per period at sample_rate_hz "
                             f"{sample_rate_hz:g}; " + (f"raise sample_rate_hz to at least {4 * f_max_hz:g}"
                                                        if math.isfinite(4 * f_max_hz) else "lower f_hz"))


def check_stepped_sine_plan(f_hz, duration_s: float, sample_rate_hz: float) -> None:
    """Refuse a stepped sine the estimate cannot use or the machine cannot hold (``ParameterError`` naming the
    parameters): a block too short for the lock-in of ``fit`` and ``diagnose`` (``plant.estimate.lockin``: it
    drops the block's start-up transient, every simulated block starting from rest, and needs a period after
    it), or more than ``MAX_SAMPLES`` samples in all."""
    from plant.estimate.lockin import MIN_PERIODS, shortest_block_s

    f = np.asarray(f_hz, dtype=float).ravel()
    if f.size:
        _check_four_samples_per_period(float(np.max(f)), sample_rate_hz)
    short = [x for x in f if duration_s < shortest_block_s(x, sample_rate_hz) * (1 - 1e-9)]
    if short:
        need = shortest_block_s(short[0], sample_rate_hz)
        raise ParameterError(
            f"duration_s {duration_s:g}: the {short[0]:g} Hz block would hold {duration_s * short[0]:.3g} periods; "
            f"gantry fit and diagnose use a block from {MIN_PERIODS:g} period after its start-up transient "
            f"({need - MIN_PERIODS / short[0]:.3g} s at least), so it needs {need:.3g} s: give duration_s {need:.3g} "
            f"or more, or f_hz without the {len(short)} block(s) at and below {short[-1]:g} Hz")
    samples = f.size * duration_s * sample_rate_hz
    if samples > MAX_SAMPLES:
        raise ParameterError(f"f_hz, duration_s, sample_rate_hz: {f.size} blocks x {duration_s:g} s x "
                             f"{sample_rate_hz:g} Hz is {samples:.3g} samples (about {samples * 48 / 1e9:.2g} GB to "
                             f"simulate and write), more than the {MAX_SAMPLES:.0e} allowed")


def simulate_stepped_sine(
    plant: Plant,
    *,
    f_hz,
    current_amplitude_a,
    duration_s: float = 5.0,
    sample_rate_hz: float = 2000.0,
    current_noise_a: float = 0.0,
    velocity_noise_m_per_s: float = 0.0,
    noise_fraction: float | None = None,
    velocity_quantum_m_per_s: float | None = None,
    current_quantum_a: float | None = None,
    friction_rate_hz: float = FRICTION_RATE_HZ,
    seed: int = 0,
    progress: Callable[[int, int], None] | None = None,
) -> Recording:
    """Simulate a stepped-sine experiment: one block per frequency, each from rest (thesis section 4.1).

    ``f_hz``: excitation frequencies (Hz, any order, distinct, at most sample_rate_hz / 4); blocks come out
    in increasing frequency. ``current_amplitude_a``: command amplitude (A), one value or one per frequency
    (thesis: 0.5 A Stage X, 1.75 A Stage Y). ``duration_s`` per block (thesis 5 s), ``sample_rate_hz`` of
    the recording. Noise is white Gaussian, independent per sample and column: absolute standard deviations
    ``current_noise_a`` (A) and ``velocity_noise_m_per_s`` (m/s), or ``noise_fraction``, the standard
    deviation as a fraction of each block's fundamental amplitude (per column, from the noiseless signal's
    least-squares sine fit over the block's second half). Quantisation rounds to multiples of the quanta
    after the noise. The recorded current is the command (before delay, sampling and current loop), the
    input of ``Plant.frd``. ``friction_rate_hz``: minimum internal rate with Coulomb friction; a block in
    which the stage never breaks loose from the friction is a ``ParameterError``. The settings,
    true parameters, per-block noise levels and ``seed`` are in ``Recording.metadata``. ``progress(done, total)``
    hears the internal steps of the time stepping (with friction or ``sampling``; the closed form needs none).
    """
    check_instance("plant", plant, Plant, "plant.stage_x(...) makes one")
    check_positive("f_hz", f_hz)
    check_positive("current_amplitude_a", current_amplitude_a)
    f = np.asarray(f_hz, dtype=float).ravel()
    check_positive("sample_rate_hz", sample_rate_hz)
    duration_s = check_number("duration_s", duration_s, minimum=0.0)
    check_positive("duration_s", duration_s)
    check_positive("friction_rate_hz", friction_rate_hz)
    order = np.argsort(f, kind="stable")
    amp = np.asarray(current_amplitude_a, dtype=float).ravel()
    if amp.size == 1:
        amp = np.full(f.shape, amp[0])
    if amp.shape != f.shape:
        raise ParameterError(f"current_amplitude_a has {amp.size} values for {f.size} frequencies")
    f, amp = f[order], amp[order]
    if np.any(np.diff(f) == 0):
        raise ParameterError(f"f_hz lists {f[np.flatnonzero(np.diff(f) == 0)[0]]:g} Hz twice (duplicate block)")
    _check_four_samples_per_period(f[-1], sample_rate_hz)
    n_samples = int(round(duration_s * sample_rate_hz))
    if n_samples < 2:
        raise ParameterError(f"duration_s {duration_s:g} gives {n_samples} sample(s) at {sample_rate_hz:g} Hz")
    for name, value in [("current_noise_a", current_noise_a), ("velocity_noise_m_per_s", velocity_noise_m_per_s)]:
        check_positive(name, value, allow_zero=True)
    if noise_fraction is not None:
        check_positive("noise_fraction", noise_fraction, allow_zero=True)
        if current_noise_a or velocity_noise_m_per_s:
            raise ParameterError("give either noise_fraction or current_noise_a/velocity_noise_m_per_s, not both")
    for name, value in [("velocity_quantum_m_per_s", velocity_quantum_m_per_s),
                        ("current_quantum_a", current_quantum_a)]:
        if value is not None:
            check_positive(name, value)
    check_finite("seed", seed)
    if int(seed) != seed or seed < 0:
        raise ParameterError(f"seed must be a non-negative integer, got {seed!r}")
    _check_plant(plant)

    chain = _chain(plant)
    delay = plant.effect("delay")
    delay_s = 0.0 if delay is None else _scalar("delay.seconds", delay.seconds)
    sampling = plant.effect("sampling")
    controller_rate_hz = None if sampling is None else _scalar("sampling.rate_hz", sampling.rate_hz)
    friction = bool(np.any(chain.friction_n > 0))
    w = 2 * np.pi * f
    t = np.arange(n_samples) / sample_rate_hz
    if sampling is None and not friction:
        velocity = _linear_response(chain, w_rad_s=w, amp_a=amp, t_s=t, delay_s=delay_s)
        method, internal_rate_hz = "closed form (analytic steady state + matrix-exponential transient)", None
    else:
        rate = _internal_rate(sample_rate_hz, controller_rate_hz, friction_rate_hz if friction else 0.0)
        velocity = _stepped_response(chain, w_rad_s=w, amp_a=amp, n_samples=n_samples, sample_rate_hz=sample_rate_hz,
                                     delay_s=delay_s, controller_rate_hz=controller_rate_hz, internal_rate=rate,
                                     progress=progress)
        method = "exact-discretisation time stepping" + (" with Moreau implicit Coulomb friction" if friction else "")
        internal_rate_hz = float(rate)
    if friction:
        _refuse_stuck_blocks(plant, f, amp, velocity)
    current = amp[:, None] * np.sin(w[:, None] * t)

    if noise_fraction is not None:
        current_std = noise_fraction * amp
        velocity_std = noise_fraction * _fundamental_amplitude(velocity, w, t)
    else:
        current_std = np.full(f.shape, float(current_noise_a))
        velocity_std = np.full(velocity.shape[:2], float(velocity_noise_m_per_s))
    rng = np.random.default_rng(int(seed))
    current = current + current_std[:, None] * rng.standard_normal(current.shape)
    velocity = velocity + velocity_std[:, :, None] * rng.standard_normal(velocity.shape)
    current = _quantise(current, current_quantum_a)
    velocity = _quantise(velocity, velocity_quantum_m_per_s)

    names = output_column_names(plant)
    blocks = tuple(Block(float(fi), t.copy(), current[b], velocity[b]) for b, fi in enumerate(f))
    metadata = {
        "simulator": "plant.experiment.simulate.simulate_stepped_sine",
        "method": method,
        "internal_rate_hz": internal_rate_hz,
        "stage": plant.stage,
        "parameters": {k: p.value for k, p in plant.parameters().items()},
        "motor_length_m": float(plant.motor_length_m),
        "load_position_m": float(plant.load_position_m),
        "effects": list(plant.effect_names),
        "f_hz": f.tolist(),
        "current_amplitude_a": amp.tolist(),
        "duration_s": float(duration_s),
        "sample_rate_hz": float(sample_rate_hz),
        "recorded_current": "command current (before delay, sampling and current loop), plus noise",
        "noise_fraction": None if noise_fraction is None else float(noise_fraction),
        "current_noise_std_a": current_std.tolist(),
        "velocity_noise_std_m_per_s": velocity_std.tolist(),
        "current_quantum_a": current_quantum_a,
        "velocity_quantum_m_per_s": velocity_quantum_m_per_s,
        "seed": int(seed),
    }
    return Recording(blocks, names, source="<simulated>", metadata=metadata)


__all__ = ["FRICTION_RATE_HZ", "output_column_names", "simulate_stepped_sine"]
