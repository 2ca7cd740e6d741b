"""A force-limited mouse walking a trajectory through the sampled, nonlinear admittance loop.

Model (SI units; every rate an integer multiple of the admittance rate is required):

Continuous part: the plant's own linear model (``gantry_model``: every effect the run simulates enters by the
realisation the frequency-domain design uses, ``plant.physics.realisation``):

* the drive chain E (the current loop, any rational drive factor; the delay and the drive's sampling act on
  the discrete part below) from the current command i_c to the motor current i, motor force F_m = K_t i;
* the mechanics (the chain of bodies: the rails' body, a payload or carriage mode, Stage
  Y's both rails' damping) driven by F_m + F_r + F_s at the motor's body, the clamp's velocity v the chain's
  sensed velocity (as ``design.admittance.sampled.free_gantry``), dx/dt = v, the rails' position x_0 the
  integral of the motor body's velocity v_0; F_r = -F_f + the forces the plant's effects put on the rails
  (``rail_force_n`` at x_0 and F_m: an offset, a force ripple, a force-constant profile, a cable's pull; a cable's
  spring is the mechanics', its state set to the run's start), Coulomb friction
  regularised F_f = F_c tanh(v_0 / v_s), F_c with a cable's drag where the rails are (``rail_friction_n``);
* the head (m_h) rides the clamp: F_s = F_n - m_h dv/dt (with the mechanics' instantaneous dv/dt, solved);
  for a rigid Stage X that is (M + m_h) dv/dt = F_m + F_n - b v - F_f;
* the sensor chain H (a sensor filter) from v to the velocity the drive measures, v_m;
* mouse body: m_b dv_b/dt = F_leg - F_n,  dx_b/dt = v_b;
  neck force on the head F_n = k_n (x_b - x) + c_n (v_b - v);
* the mouse's legs, a force-limited walker tracking its intended path (x_d, v_d, a_d):
  F_leg = clip(m_b a_d + F_ff + k_l (x_d - x_b) + c_l (v_d - v_b), -F_max, F_max), with the feed-forward
  F_ff = m_v a_d + b_v v_d of a mouse that has learned the virtual dynamics (0 when ``feedforward`` is off);
* force filter (optional) on F_s: Butterworth of order 1 or 2 at f_f, its output F_sf.

Drive (velocity loop) at rate f_d, tick k at t_k = k / f_d: e[k] = v_ref(t_k) - v_m(t_k);
I[k] = I[k-1] + (k_i / f_d) (e[k] + e[k-1]) / 2 (trapezoidal, not updated while the output is saturated
in the direction of e[k]); u[k] = k_p e[k] + I[k]; the command clip(u[k], -F_mot / K_t, F_mot / K_t) reaches
the drive chain ``delay_ticks`` ticks later and is held.

Admittance law at rate f_a, tick j at the drive ticks k = j f_d / f_a: the reading
r[j] = res round((F_sf(t) + bias) / res); a deadband zeroes |r| <= d;
v_a[j] = alpha v_a[j-1] + beta r_db[j] + beta_prev r_db[j-1] (``design.admittance.rig.DiscreteAdmittance``, backward or
forward Euler or Tustin); v_ref = v_a[j - computation_delay]
from that tick on (held).

Order within a tick: the continuous states are sampled, the admittance law updates (on its ticks), then
the drive, then the continuous part is stepped to the next tick with the held commands.

Method: at least ``SUBSTEPS`` steps per drive period, and as many more as keep w h <= ``MAX_W_H`` for the
fastest rate w of the continuous part. Each step is the exact discretisation of the linear part with its inputs
held (``plant.physics.state_space.hold_step``, the same step as the continuous experiments of
``plant.experiment.simulate_time``): the legs' spring and damper to the path inside it while they are free, their
force held at +-F_max while at the limit (a step in which they reach or leave it is taken again in ``REFINE``),
the rails' forces held at their value at the step's midpoint, predicted from its start (error O(h^2)).
Checked against ``tests/reference/independent_mouse_run.py`` (DOP853, no shared code).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from design.admittance.model import admittance_problem
from design.admittance.profile import trapezoid
from design.admittance.rig import DiscreteAdmittance, ForceSensor, RigTiming
from design.loop.controller import PI
from plant.errors import DataError, SpecError
from plant.host.text_io import read_text
from plant.physics.effects import EFFECTS
from plant.physics.models import Plant
from plant.physics.realisation import realise
from plant.physics.state_space import hold_step

#: steps per drive period at least, and the largest w h (w the fastest rate of the continuous part: the
#: current loop, the force filter, the body on neck and legs) a step may take: what the forces held over a step
#: change in it
SUBSTEPS = 2
MAX_W_H = 0.5
#: a step in which the legs reach or leave the mouse's limit is taken again in this many
REFINE = 16


@dataclass(frozen=True)
class RunSettings:
    """Everything a mouse run needs (SI units): the plant (one plant, its payload applied) and the rig, the
    design and the mouse."""

    plant: Plant
    delay_ticks: int
    drive_rate_hz: float
    kp: float
    ki: float
    motor_peak_force_n: float
    friction_n: float
    friction_velocity_m_per_s: float
    admittance_rate_hz: float
    computation_delay_samples: int
    m_v: float
    b_v: float
    force_filter_hz: float | None
    force_filter_order: int
    resolution_n: float
    bias_n: float
    deadband_n: float
    head_mass_kg: float
    body_mass_kg: float
    neck_stiffness_n_per_m: float
    neck_damping_n_s_per_m: float
    leg_stiffness_n_per_m: float
    leg_damping_n_s_per_m: float
    mouse_peak_force_n: float
    feedforward: bool = True
    #: the law's rule (``design.admittance.rig.RULES``)
    law: str = "backward_euler"

    @property
    def gantry_mass_kg(self) -> float:
        """The moving mass of the plant's bodies (kg)."""
        return float(np.sum(np.asarray(self.plant.mechanics().masses_kg, float)))

    @property
    def force_constant_n_per_a(self) -> float:
        return float(self.plant.force_constant_n_per_a)


@dataclass(frozen=True)
class RunTrace:
    """The run sampled at every drive tick: time (s), gantry position (m) and velocity (m/s), body position and
    velocity, sensed force (N), leg force (N), motor current (A), velocity reference (m/s), intended path."""

    time_s: np.ndarray
    x_m: np.ndarray
    v_m_per_s: np.ndarray
    body_x_m: np.ndarray
    body_v_m_per_s: np.ndarray
    sensed_force_n: np.ndarray
    leg_force_n: np.ndarray
    current_a: np.ndarray
    reference_m_per_s: np.ndarray
    intended_x_m: np.ndarray
    intended_v_m_per_s: np.ndarray


@dataclass(frozen=True)
class GantryModel:
    """The run's continuous linear part (module docstring) as dz/dt = A z + b_c i_c + b_r F_r + b_l F_leg, with
    F_r the forces on the rails besides the motor's (the friction's -F_f and each effect's ``rail_force_n``) and
    F_leg the legs' clipped force; states z = (drive chain, mechanics, sensor chain, clamp position x, body
    position x_b, body velocity v_b, force filter, the rails' position x_0); each signal a row over
    (z, i_c, F_r, F_leg)."""

    A: np.ndarray
    inputs: np.ndarray          # columns: i_c, F_r, F_leg
    legs: np.ndarray            # row over z: the legs' drive without the path's terms
    velocity: np.ndarray        # clamp velocity v (row over z)
    measured: np.ndarray        # the drive's measured velocity v_m (row over z)
    rail: np.ndarray            # the motor body's velocity v_0 (row over z)
    motor_force: np.ndarray     # K_t i, row over (z, i_c)
    sensed: np.ndarray          # F_s, row over (z, i_c, F_r, F_leg)
    current: np.ndarray         # motor current i, row over (z, i_c)
    reading: np.ndarray         # the force the law reads (F_sf, or F_s without filter), row over (z, i_c, F_r, F_leg)
    position: int
    rail_position: int
    body: tuple[int, int]
    fastest_rad_s: float
    ground: np.ndarray          # the realisation's ground spring position (row over z, zero without one)


def gantry_model(s: RunSettings) -> GantryModel:
    """``GantryModel`` of the settings' plant (its realisation, ``plant.physics.realisation``, the delay and the
    drive's sampling left to the discrete part), mouse and force filter (module docstring)."""
    r = realise(s.plant).one()
    nr = r.order
    nf = 0 if s.force_filter_hz is None else s.force_filter_order
    ix, ixb, ivb = nr, nr + 1, nr + 2
    f0 = ivb + 1
    ixr = f0 + nf
    n = ixr + 1
    IC, FR, FL = n, n + 1, n + 2          # columns of the inputs after the states
    eye = np.eye(n + 3)
    v = np.zeros(n + 3)
    v[:nr] = r.velocity[0]
    fm = np.zeros(n + 3)
    fm[:nr], fm[IC] = r.motor_force[:nr], r.motor_force[nr]
    fn = s.neck_stiffness_n_per_m * (eye[ixb] - eye[ix]) + s.neck_damping_n_s_per_m * (eye[ivb] - v)
    dynamics = np.zeros((nr, n + 3))       # the realisation's rows, its force on the rails' body left out
    dynamics[:, :nr], dynamics[:, IC] = r.A, r.B[:, 0]
    push = r.B[:, 1]
    beta = float(v[:nr] @ push)            # dv/dt per force on the rails' body (1 / M for a rigid body)
    accel = (v[:nr] @ dynamics + beta * (eye[FR] + fn)) / (1 + beta * s.head_mass_kg)
    fs = fn - s.head_mass_kg * accel
    rows = np.zeros((n, n + 3))
    rows[:nr] = dynamics + np.outer(push, eye[FR] + fs)
    rows[ix], rows[ixb] = v, eye[ivb]
    rows[ivb] = (eye[FL] - fn) / s.body_mass_kg
    if nf:
        wf = 2 * math.pi * s.force_filter_hz
        if nf == 1:
            rows[f0] = wf * (fs - eye[f0])
        else:
            rows[f0], rows[f0 + 1] = eye[f0 + 1], wf * wf * (fs - eye[f0]) - math.sqrt(2.0) * wf * eye[f0 + 1]
    measured = np.zeros(n + 3)
    measured[:nr] = r.outputs[0]
    current = np.zeros(n + 3)
    current[:nr], current[IC] = r.current[:nr], r.current[nr]
    legs = -s.leg_stiffness_n_per_m * eye[ixb] - s.leg_damping_n_s_per_m * eye[ivb]
    rail = np.zeros(n + 3)
    rail[:nr] = r.contacts[0]
    rows[ixr] = rail
    fastest = max([float(np.max(np.abs(np.linalg.eigvals(r.A))))] + [
        2 * math.pi * (s.force_filter_hz or 0.0),
        math.sqrt((s.neck_stiffness_n_per_m + s.leg_stiffness_n_per_m) / s.body_mass_kg),
        (s.neck_damping_n_s_per_m + s.leg_damping_n_s_per_m) / s.body_mass_kg])
    return GantryModel(rows[:, :n], rows[:, n:], legs[:n], v[:n], measured[:n], rail[:n], fm[:n + 1], fs, current,
                       eye[f0] if nf else fs, ix, ixr, (ixb, ivb), fastest, np.pad(r.ground, (0, n - nr)))


def simulate_mouse_run(settings: RunSettings, time_s, x_d, v_d, a_d) -> RunTrace:
    """Run the loop over the drive ticks ``time_s`` (uniform, 1 / drive_rate_hz apart, from 0) with the
    intended path (x_d, v_d, a_d) given at those ticks (held between them)."""
    s = settings
    n_a = _check_rates(s)
    t = np.asarray(time_s, float)
    xd_, vd_, ad_ = (np.asarray(a, float) for a in (x_d, v_d, a_d))
    T = 1.0 / s.drive_rate_hz
    g = gantry_model(s)
    substeps = max(SUBSTEPS, math.ceil(g.fastest_rad_s * T / MAX_W_H))
    h = T / substeps
    kl, cl, mb = s.leg_stiffness_n_per_m, s.leg_damping_n_s_per_m, s.body_mass_kg
    fc, vs, fmax = s.friction_n, s.friction_velocity_m_per_s, s.mouse_peak_force_n
    imax = s.motor_peak_force_n / s.force_constant_n_per_a
    law = DiscreteAdmittance.of(s.m_v, s.b_v, s.admittance_rate_hz, rule=s.law)
    sensor = ForceSensor(s.resolution_n, s.bias_n, s.deadband_n)
    alpha, beta, beta_prev = law.alpha, law.beta_m_per_s_per_n, law.beta_prev_m_per_s_per_n
    n_z = g.A.shape[0]
    start, start_ic = _reads(g)
    coarse = (_ExactStep.of(g, h, legs=True), _ExactStep.of(g, h, legs=False))
    fine = (_ExactStep.of(g, h / REFINE, legs=True), _ExactStep.of(g, h / REFINE, legs=False))

    def free_legs(pull):
        return -fmax <= pull <= fmax

    def step(z, ic, drive, maps):
        """One exact step: the legs free (their spring and damper to the path inside it) or at the mouse's limit
        (a held force) as they are at its start; the rails' forces at its midpoint predicted from there."""
        v0, legs, x0, motor_n = start @ z + start_ic * ic
        pull = legs + drive
        m, held = (maps[0], drive) if free_legs(pull) else (maps[1], math.copysign(fmax, pull))
        v0, _, x0, motor_n = m.mid @ z + m.mid_u @ (ic, on_rails(v0, x0, motor_n), held)
        return m.Phi @ z + m.Gamma @ (ic, on_rails(v0, x0, motor_n), held)
    pushing = [e for e in s.plant.effects if e.rail_force]
    along = [e for e in s.plant.effects if e.rail_friction]

    def on_rails(v0, x0, motor_n):
        """F_r: the friction against the rails' velocity (with any drag along the travel, none where it would make
        the friction negative) and every effect's rail force."""
        magnitude = fc
        for e in along:
            magnitude += e.rail_friction_n(x0)
        out = -magnitude * math.tanh(v0 / vs) if magnitude > 0 else 0.0
        for e in pushing:
            out += e.rail_force_n(x0, v0, motor_n)
        return out

    def nonlinear(z, ic, drive):
        motor_n = float(g.motor_force[:n_z] @ z + g.motor_force[n_z] * ic)
        return (on_rails(float(g.rail @ z), float(z[g.rail_position]), motor_n),
                min(max(float(g.legs @ z) + drive, -fmax), fmax))

    def signal(row, z, ic, fr, fleg):
        return float(row[:n_z] @ z + row[n_z] * ic + row[n_z + 1] * fr + row[n_z + 2] * fleg)

    n = t.size
    z = np.zeros(n_z)
    z[g.position] = z[g.body[0]] = z[g.rail_position] = float(xd_[0])
    z += g.ground * float(xd_[0])                      # a ground spring's state: the rails' position
    rec = np.empty((9, n))
    queue = [0.0] * (s.computation_delay_samples + 1)
    commands = [0.0] * (s.delay_ticks + 1)
    v_a = v_ref = integ = e_prev = ic = r_prev = 0.0
    for k in range(n):
        xd, vd, ad = float(xd_[k]), float(vd_[k]), float(ad_[k])
        drive = mb * ad + kl * xd + cl * vd + ((s.m_v * ad + s.b_v * vd) if s.feedforward else 0.0)
        fr, fleg = nonlinear(z, ic, drive)
        fs = signal(g.sensed, z, ic, fr, fleg)
        if k % n_a == 0:
            reading = signal(g.reading, z, ic, fr, fleg)
            r_db = sensor.reading(reading)
            v_a = alpha * v_a + beta * r_db + beta_prev * r_prev
            r_prev = r_db
            queue = queue[1:] + [v_a]
            v_ref = queue[0]
        e = v_ref - float(g.measured @ z)
        trial = integ + s.ki * T * (e + e_prev) / 2
        u = s.kp * e + trial
        if (u > imax and e > 0) or (u < -imax and e < 0):
            trial = integ
            u = s.kp * e + trial
        integ, e_prev = trial, e
        commands = commands[1:] + [min(max(u, -imax), imax)]
        rec[:, k] = (z[g.position], float(g.velocity @ z), z[g.body[0]], z[g.body[1]], fs, fleg,
                     signal(g.current, z, ic, 0.0, 0.0), v_ref, 0.0)
        ic = commands[0]
        for _ in range(substeps):
            after = step(z, ic, drive, coarse)
            if free_legs(float(g.legs @ after) + drive) != free_legs(float(g.legs @ z) + drive):
                for _ in range(REFINE):          # the legs reach or leave the mouse's limit: that step finer
                    z = step(z, ic, drive, fine)
            else:
                z = after
    return RunTrace(t, rec[0], rec[1], rec[2], rec[3], rec[4], rec[5], rec[6], rec[7], xd_, vd_)


def _reads(g: GantryModel) -> tuple[np.ndarray, np.ndarray]:
    """Rows reading (v_0, the legs' force without the path's terms, x_0, the motor's force) over z, and the motor's
    i_c term."""
    n = g.A.shape[0]
    return np.vstack([g.rail, g.legs, np.eye(n)[g.rail_position], g.motor_force[:n]]), g.motor_force[n] * np.eye(4)[3]


@dataclass(frozen=True)
class _ExactStep:
    """The exact step over h of dz/dt = A' z + b_c i_c + b_r F_r + b_l X, every input held
    (``plant.physics.state_space.hold_step``): with the legs free, A' = A + b_l (legs' row) and X the path's drive
    (exact while the legs stay free); at the mouse's limit, A' = A and X = F_leg = +-F_max. ``mid``, ``mid_u``: the
    rows of ``_reads`` at the step's midpoint z + h/2 dz/dt, over z and over (i_c, F_r, X)."""

    Phi: np.ndarray
    Gamma: np.ndarray
    mid: np.ndarray
    mid_u: np.ndarray

    @classmethod
    def of(cls, g: GantryModel, h: float, *, legs: bool) -> _ExactStep:
        n = g.A.shape[0]
        A = g.A + np.outer(g.inputs[:, 2], g.legs) if legs else g.A
        Phi, Gamma = hold_step(A, g.inputs, h)
        read, ic = _reads(g)
        return cls(Phi, Gamma, read @ (np.eye(n) + h / 2 * A), read @ (h / 2 * g.inputs) + np.outer(ic, np.eye(3)[0]))


def _check_rates(s: RunSettings) -> int:
    ratio = s.drive_rate_hz / s.admittance_rate_hz
    if abs(ratio - round(ratio)) > 1e-9 or ratio < 1:
        raise ValueError(f"the drive rate ({s.drive_rate_hz:g} Hz) must be a whole multiple of the admittance "
                         f"update rate ({s.admittance_rate_hz:g} Hz)")
    return int(round(ratio))


# --- a run from a spec and a design ------------------------------------------------------------------------
#: the drive's velocity-loop rate when the spec declares none (Hz), and the rest simulated around the path (s)
DEFAULT_DRIVE_RATE_HZ = 4000.0
REST_S = 1.0
#: the friction model's velocity scale (m/s): F_c tanh(v / v_s)
FRICTION_VELOCITY_M_PER_S = 1e-3
#: the plant's effects a run simulates (any other is refused by name, never dropped), by what each declares
#: (``Effect.realised_as``, ``Effect.rail_force``): what the delay and the drive's sampling do to the command on
#: the discrete part, every effect the realisation holds exactly by the plant's own linear model
#: (``gantry_model``), every force on the rails by its ``rail_force_n``, and the Coulomb friction regularised (the
#: one effect the run models by its own law); a new effect of those kinds is simulated without a change here
SIMULATED_EFFECTS = tuple(n for n, c in EFFECTS.items()
                          if c.realised_as in ("applied", "state_space") or c.rail_force or n == "coulomb_friction")


@dataclass(frozen=True)
class IntendedPath:
    """Where the mouse means to go, at the drive ticks: time (s), position (m), velocity (m/s), acceleration."""

    time_s: np.ndarray
    x_m: np.ndarray
    v_m_per_s: np.ndarray
    a_m_per_s2: np.ndarray
    source: str


def trapezoid_path(locomotion, rate_hz: float, *, rest_s: float = REST_S) -> IntendedPath:
    """The spec's trapezoid (``design.admittance.profile.trapezoid``) at ``rate_hz``, ``rest_s`` before and after."""
    prof = trapezoid(locomotion, dt_s=1.0 / rate_hz, rest_s=rest_s)
    v = prof.velocity_m_per_s
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]))]) / rate_hz
    return IntendedPath(prof.time_s, x, v, prof.acceleration_m_per_s2,
                        f"trapezoid {locomotion.travel_m:g} m, {locomotion.peak_speed_m_per_s:g} m/s, "
                        f"{locomotion.peak_acceleration_m_per_s2:g} m/s^2")


def path_from_csv(path, rate_hz: float, *, rest_s: float = REST_S) -> IntendedPath:
    """A recorded path (CSV with columns ``time_s`` and ``position_m``), resampled to ``rate_hz`` by
    interpolation after a 5 ms moving average (the differentiation to velocity and acceleration would
    otherwise amplify the recording's steps), with ``rest_s`` of rest before and after."""
    p = Path(path)
    lines = [ln for ln in read_text(p, what="path file").splitlines() if ln.strip()]
    if not lines:
        raise DataError(f"{p}: empty; expected a header time_s,position_m and rows")
    header = [h.strip() for h in lines[0].split(",")]
    for col in ("time_s", "position_m"):
        if col not in header:
            raise DataError(f"{p}: missing column {col!r} (header: {', '.join(header)})")
    it, ix = header.index("time_s"), header.index("position_m")
    t, x = [], []
    for row, line in enumerate(lines[1:], start=2):
        cells = line.split(",")
        try:
            tv, xv = float(cells[it]), float(cells[ix])
        except (IndexError, ValueError):
            raise DataError(f"{p}: row {row}: expected numbers in columns time_s and position_m, got "
                            f"{line[:60]!r}") from None
        if not (math.isfinite(tv) and math.isfinite(xv) and abs(xv) < 1e3):
            raise DataError(f"{p}: row {row}: {line[:60]!r} is not a finite time and a position within 1 km")
        t.append(tv)
        x.append(xv)
    t, x = np.asarray(t), np.asarray(x)
    if t.size < 3 or np.any(np.diff(t) <= 0):
        raise DataError(f"{p}: need at least 3 rows with strictly increasing time_s")
    if t[-1] - t[0] > 600:
        raise DataError(f"{p}: {t[-1] - t[0]:.0f} s of path; at most 600 s can be simulated")
    grid = np.arange(0.0, t[-1] - t[0] + 2 * rest_s, 1.0 / rate_hz)
    xs = np.interp(grid - rest_s, t - t[0], x - x[0])
    width = max(int(round(0.005 * rate_hz)), 1)
    kernel = np.ones(2 * width + 1) / (2 * width + 1)
    xs = np.convolve(np.pad(xs, width, mode="edge"), kernel, mode="same")[width:-width]
    v = np.gradient(xs, 1.0 / rate_hz)
    return IntendedPath(grid, xs, v, np.gradient(v, 1.0 / rate_hz), f"recorded path {p.name}")


@dataclass(frozen=True)
class MouseRun:
    """A simulated run and what it means for the mouse and the experiment."""

    settings: RunSettings
    path: IntendedPath
    trace: RunTrace
    #: the sensed force while the mouse moves: peak and RMS (N)
    peak_force_n: float
    rms_force_n: float
    #: intended peak speed minus the reached one (m/s), and the largest lag behind the intended path (m)
    speed_shortfall_m_per_s: float
    max_lag_m: float
    #: the fraction of drive ticks at the motor's force limit
    saturated_fraction: float
    #: free gantry at rest (mouse not touching the ground, not pushing) under the offset: its speed (mm/s)
    drift_mm_per_s: float
    #: the standing mouse at rest: peak-to-peak motion of the gantry over the last second (um)
    limit_cycle_um: float


def nominal_mouse(mouse, leg_stiffness_n_per_m: float | None = None) -> tuple[float, ...]:
    """The run's mouse from the spec's ranges (``admittance.mouse``): mid-range head and body masses, neck stiffness
    and damping and leg damping, the legs at their least stiffness unless given, its peak force; as (head kg, body
    kg, neck N/m, neck N*s/m, legs N/m, legs N*s/m, peak N)."""
    def mid(r):
        return 0.5 * (r.min + r.max)

    legs = mouse.leg_stiffness_n_per_m.min if leg_stiffness_n_per_m is None else float(leg_stiffness_n_per_m)
    return (mid(mouse.head_mass_kg), mid(mouse.body_mass_kg), mid(mouse.neck_stiffness_n_per_m),
            mid(mouse.neck_damping_n_s_per_m), legs, mid(mouse.leg_damping_n_s_per_m), mouse.peak_force_n)


def run_settings(problem, *, controller: PI, m_v: float, b_v: float, timing=None, payload_kg: float | None = None,
                 friction_n: float | None = None, leg_stiffness_n_per_m: float | None = None,
                 drive_rate_hz: float | None = None) -> RunSettings:
    """``RunSettings`` of the spec's plant (at ``payload_kg``, default the heaviest) and its nominal mouse
    (mid-range masses and neck, the legs at their least stiffness unless given) with the design's gains, at the
    largest computation delay of a range. ``friction_n``: the rails' Coulomb force (N), default the plant's
    ``coulomb_friction`` (0 without one)."""
    adm = admittance_problem(problem)
    timing = timing or RigTiming.of(adm.rig)
    if not timing.sampled:
        raise ValueError("admittance.rig.update_rate_hz: a mouse run simulates the sampled law; declare the rate")
    plant = problem.plant.plant(problem.plant.payload_kg.max if payload_kg is None else payload_kg)
    dropped = [e.name for e in plant.effects if e.name not in SIMULATED_EFFECTS]
    if dropped:
        raise SpecError(f"plant.effects: the mouse run simulates {', '.join(SIMULATED_EFFECTS)} on the plant's bodies; "
                        f"it cannot simulate {', '.join(dropped)}: remove {'it' if len(dropped) == 1 else 'them'} "
                        "for the run, or check the design with the frequency-domain figures of gantry synth")
    sampling, delay, coulomb = plant.effect("sampling"), plant.effect("delay"), plant.effect("coulomb_friction")
    rate = drive_rate_hz or (float(sampling.rate_hz) if sampling is not None else DEFAULT_DRIVE_RATE_HZ)
    rate = round(rate * timing.period_s) / timing.period_s
    if friction_n is None:
        friction_n = 0.0 if coulomb is None else float(coulomb.force_n)
    return RunSettings(plant, 0 if delay is None else int(round(float(delay.seconds) * rate)), rate,
                       float(controller.kp), float(controller.ki),
                       adm.hardware.motor_peak_force_n, friction_n, FRICTION_VELOCITY_M_PER_S, 1.0 / timing.period_s,
                       timing.delays[-1], m_v, b_v, timing.filter_hz, timing.filter_order,
                       adm.hardware.force_sensor_resolution_n, adm.sensor.bias_after_tare_n, adm.sensor.deadband_n,
                       *nominal_mouse(adm.mouse, leg_stiffness_n_per_m),
                       law=timing.rule)


def mouse_run(settings: RunSettings, path: IntendedPath) -> MouseRun:
    """Simulate the run along ``path``, the free gantry at rest (drift) and the standing mouse at rest
    (limit cycle), and summarise them."""
    from dataclasses import replace

    trace = simulate_mouse_run(settings, path.time_s, path.x_m, path.v_m_per_s, path.a_m_per_s2)
    moving = np.abs(path.v_m_per_s) > 1e-9
    f = trace.sensed_force_n[moving] if moving.any() else trace.sensed_force_n
    imax = settings.motor_peak_force_n / settings.force_constant_n_per_a
    n_rest = int(round(3.0 * settings.drive_rate_hz))
    rest_t = np.arange(n_rest) / settings.drive_rate_hz
    zeros = np.zeros(n_rest)
    free = simulate_mouse_run(replace(settings, leg_stiffness_n_per_m=0.0, leg_damping_n_s_per_m=0.0,
                                      feedforward=False, mouse_peak_force_n=0.0), rest_t, zeros, zeros, zeros)
    standing = simulate_mouse_run(settings, rest_t, zeros, zeros, zeros)
    last = rest_t >= rest_t[-1] - 1.0
    return MouseRun(settings, path, trace, float(np.max(np.abs(f))), float(np.sqrt(np.mean(f**2))),
                    float(np.max(path.v_m_per_s) - np.max(trace.v_m_per_s)),
                    float(np.max(np.abs(path.x_m - trace.x_m))),
                    float(np.mean(np.abs(trace.current_a) >= imax * (1 - 1e-9))),
                    float(1e3 * abs(free.x_m[last][-1] - free.x_m[last][0]) / 1.0),
                    float(1e6 * np.ptp(standing.x_m[last])))
