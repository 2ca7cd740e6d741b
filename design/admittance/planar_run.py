"""A mouse walking on the floor in two dimensions through the admittance of both axes at once, on the planar
gantry (``plant.physics.planar.PlanarGantry``): the carriage moves along the beam while the beam moves on its
two rails, so what one axis does is felt on the other (the beam's yaw as the carriage's weight moves, the
lateral force when the axes lag differently).

Model (SI units; the drive's rate an integer multiple of the law's):

Continuous part, integrated by the classical Runge-Kutta method with the commands held over each drive tick
(``substeps`` steps per tick, as many as keep w h <= ``MAX_W_H`` for the fastest rate w: the current loops, the
mouse's body on neck and legs, the beam's yaw mode; the tests hold it to a run with 4x the steps and to an
independent simulator):

* the planar mechanics with the carriage free to move (Lagrange's equations, ``PlanarGantry``): rails Y1, Y2,
  carriage position p along the beam, the rotation stage (passive here: no motor torque, no mouse torque); the
  head (m_h) rides the clamp on the carriage, so it is part of the carriage's mass;
* each motor's current loop (first order at the plant's ``current_loop.bandwidth_hz``, or ideal) from its
  command, force K i: Y1, Y2 on the rails, X on the carriage (reaction on the beam, held by the rails);
* the clamp at c = (p, y_c), y_c = y1 + p theta, theta = (y2 - y1) / L; the neck force on it
  F_n = k_n (b - c) + c_n (b' - c') (isotropic), the sensed force F_s = F_n - m_h c'';
* the mouse's body m_b b'' = F_leg - F_n, its legs a force-limited walker on its intended path (x_d, v_d, a_d):
  F_leg = G min(1, F_max / |G|), G = m_b a_d + F_ff + k_l (x_d - b) + c_l (v_d - b') (the limit on the vector:
  a mouse pushes at most F_max in any direction), F_ff = m_v a_d + b_v v_d per axis when it has learned the laws.

Drives at rate f_d: Stage X's PI on the carriage's velocity; Stage Y's structure C = T_in diag(PI_j) T_out
(``design.loop.dual``) on the rail velocities against the Y reference on both rails; each PI trapezoidal, its
integrator held while a motor it drives is at its current limit in the direction it pushes; each axis's
commands ``delay_ticks`` ticks late. Admittance laws at rate f_a (``design.admittance.rig.DiscreteAdmittance``,
one per axis, each its spec's rule and gains) on each axis's sensed force, quantised to the sensor's
resolution, with its bias and deadband, ``computation_delay_samples`` late. Order within a tick as
``design.admittance.mouse_run``: sample, the laws (on their ticks), the drives, then the continuous step.

Refused by name (never dropped): a plant effect other than the drive's delay, current loop and sampling, a
force filter, a Stage X whose mechanics is not one rigid body.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property

import casadi as ca
import numpy as np

from design.admittance.model import admittance_problem
from design.admittance.mouse_run import nominal_mouse
from design.admittance.planar_path import PlanarPath
from design.admittance.rig import DiscreteAdmittance, ForceSensor, RigTiming
from design.loop.controller import PI
from design.loop.dual import Controller
from plant.errors import ParameterError, SpecError
from plant.physics.planar import PlanarGantry

#: steps per drive tick at least, and the largest w h of a step (module docstring)
SUBSTEPS = 2
MAX_W_H = 0.5
#: the effects of a plant the planar run simulates
SIMULATED = ("delay", "current_loop", "sampling")
#: the drive's velocity-loop rate when the plant declares no ``sampling`` (Hz): as the one-axis run
DEFAULT_DRIVE_RATE_HZ = 4000.0
#: state layout: q (y1, y2, p, phi), q', the motor currents (Y1, Y2, X), the body's position and velocity (x, y)
Q, DQ, CURRENT, BODY, BODY_V = slice(0, 4), slice(4, 8), slice(8, 11), slice(11, 13), slice(13, 15)
N_STATES = 15


@dataclass(frozen=True)
class MotorDrive:
    """One motor's drive: force constant (N/A), current-loop bandwidth (Hz; None: ideal), the command's
    delay in drive ticks, the motor's peak force (N)."""

    force_constant_n_per_a: float
    current_loop_hz: float | None
    delay_ticks: int
    peak_force_n: float

    @property
    def current_limit_a(self) -> float:
        return self.peak_force_n / self.force_constant_n_per_a


@dataclass(frozen=True)
class PlanarMouse:
    """The mouse at the clamp (kg, N/m, N*s/m, N): head on the clamp, body behind the neck, legs to the floor."""

    head_mass_kg: float
    body_mass_kg: float
    neck_stiffness_n_per_m: float
    neck_damping_n_s_per_m: float
    leg_stiffness_n_per_m: float
    leg_damping_n_s_per_m: float
    peak_force_n: float
    feedforward: bool = True


@dataclass(frozen=True)
class PlanarRunSettings:
    """Everything a planar run needs (SI units). ``machine``'s carriage mass is the carriage with its payload
    (the head is added by the run); ``carriage_position_m`` where the run starts (m from rail Y1)."""

    machine: PlanarGantry
    carriage_position_m: float
    drive_rate_hz: float
    x_drive: MotorDrive
    y_drives: tuple[MotorDrive, MotorDrive]
    x_controller: PI
    y_controller: Controller
    x_law: DiscreteAdmittance
    y_law: DiscreteAdmittance
    x_sensor: ForceSensor
    y_sensor: ForceSensor
    mouse: PlanarMouse

    def __post_init__(self):
        if not 0 < self.carriage_position_m < self.machine.rail_separation_m:
            raise SpecError(f"carriage_position_m: {self.carriage_position_m:g} m is not between the rails "
                            f"(0, {self.machine.rail_separation_m:g}) m")
        if self.x_law.update_rate_hz != self.y_law.update_rate_hz:
            raise SpecError(f"admittance.rig.update_rate_hz: the X law runs at {self.x_law.update_rate_hz:g} Hz and "
                            f"the Y law at {self.y_law.update_rate_hz:g} Hz; the rig runs both in one loop")
        ratio = self.drive_rate_hz / self.x_law.update_rate_hz
        if ratio < 1 or abs(ratio - round(ratio)) > 1e-9:
            raise SpecError(f"the drive rate ({self.drive_rate_hz:g} Hz) must be a whole multiple of the admittance "
                            f"update rate ({self.x_law.update_rate_hz:g} Hz)")

    @property
    def law_ticks(self) -> int:
        """Drive ticks per law update."""
        return int(round(self.drive_rate_hz / self.x_law.update_rate_hz))

    @cached_property
    def fastest_rad_s(self) -> float:
        """The fastest rate of the continuous part (rad/s): current loops, the body on neck and legs, the
        machine's modes at the start."""
        m = self.mouse
        bands = [2 * math.pi * d.current_loop_hz for d in (self.x_drive, *self.y_drives) if d.current_loop_hz]
        machine = replace(self.machine, carriage_mass_kg=self.machine.carriage_mass_kg + m.head_mass_kg)
        A, _, _ = machine.linearised(self.carriage_position_m)
        return max(bands + [float(np.max(np.abs(np.linalg.eigvals(A)))),
                            math.sqrt((m.neck_stiffness_n_per_m + m.leg_stiffness_n_per_m) / m.body_mass_kg),
                            (m.neck_damping_n_s_per_m + m.leg_damping_n_s_per_m) / m.body_mass_kg])


@dataclass(frozen=True)
class PlanarTrace:
    """The run at every drive tick: time (s); clamp position and velocity (n, 2: x, y; m, m/s), the body's,
    the sensed force and the legs' (N); the motor currents (n, 3: Y1, Y2, X; A); the laws' velocity
    references (n, 2); the beam's yaw (rad)."""

    time_s: np.ndarray
    clamp_m: np.ndarray
    clamp_m_per_s: np.ndarray
    body_m: np.ndarray
    sensed_force_n: np.ndarray
    leg_force_n: np.ndarray
    current_a: np.ndarray
    reference_m_per_s: np.ndarray
    yaw_rad: np.ndarray


def substeps(settings: PlanarRunSettings) -> int:
    """Runge-Kutta steps per drive tick (module docstring)."""
    return max(SUBSTEPS, math.ceil(settings.fastest_rad_s / settings.drive_rate_hz / MAX_W_H))


def tick_functions(settings: PlanarRunSettings, steps: int) -> tuple[ca.Function, ca.Function]:
    """casadi functions (z, drive) -> the signals [F_s (2), F_leg (2), c (2), c' (2)] at z with the legs' path terms
    ``drive`` (N: x, y), and (z, i_c, drive, next drive) -> (z after one drive tick, the signals there): ``steps``
    Runge-Kutta steps with the commands i_c (A: Y1, Y2, X) and ``drive`` held."""
    s, m = settings, settings.mouse
    machine = replace(s.machine, carriage_mass_kg=s.machine.carriage_mass_kg + m.head_mass_kg)
    mass, rest = machine._lagrange
    L = machine.rail_separation_m
    drives = (*s.y_drives, s.x_drive)
    z, ic, drive, after = ca.SX.sym("z", N_STATES), ca.SX.sym("ic", 3), ca.SX.sym("drive", 2), ca.SX.sym("after", 2)

    def parts(x, drive):
        q, dq, cur, b, vb = x[Q], x[DQ], x[CURRENT], x[BODY], x[BODY_V]
        theta, dtheta = (q[1] - q[0]) / L, (dq[1] - dq[0]) / L
        c = ca.vertcat(q[2], q[0] + q[2] * theta)
        vc = ca.vertcat(dq[2], dq[0] + dq[2] * theta + q[2] * dtheta)
        fn = m.neck_stiffness_n_per_m * (b - c) + m.neck_damping_n_s_per_m * (vb - vc)
        u = ca.vertcat(*(d.force_constant_n_per_a * cur[j] for j, d in enumerate(drives)), 0.0)
        acc = ca.solve(mass(q), rest(q, dq, u, ca.vertcat(fn, 0.0)))
        ddtheta = (acc[1] - acc[0]) / L
        ac = ca.vertcat(acc[2], acc[0] + acc[2] * theta + 2 * dq[2] * dtheta + q[2] * ddtheta)
        pull = drive - m.leg_stiffness_n_per_m * b - m.leg_damping_n_s_per_m * vb
        scale = ca.fmin(1.0, m.peak_force_n / ca.sqrt(ca.sumsqr(pull) + 1e-30))
        fleg = pull * scale
        dcur = ca.vertcat(*(2 * math.pi * d.current_loop_hz * (ic[j] - cur[j]) if d.current_loop_hz else 0.0
                            for j, d in enumerate(drives)))
        rate = ca.vertcat(dq, acc, dcur, vb, (fleg - fn) / m.body_mass_kg)
        return rate, ca.vertcat(fn - m.head_mass_kg * ac, fleg, c, vc)

    h = 1.0 / s.drive_rate_hz / steps
    x = z
    for _ in range(steps):
        k1 = parts(x, drive)[0]
        k2 = parts(x + h / 2 * k1, drive)[0]
        k3 = parts(x + h / 2 * k2, drive)[0]
        k4 = parts(x + h * k3, drive)[0]
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return (ca.Function("planar_signals", [z, drive], [parts(z, drive)[1]]),
            ca.Function("planar_tick", [z, ic, drive, after], [x, parts(x, after)[1]]))


class _Channels:
    """A loop structure at the drive's rate (Stage Y's, or one PI on Stage X's motor): trapezoidal PIs between
    T_out and T_in, each integrator held while a motor it drives sits at its limit in the direction the channel
    pushes (for one PI: while the command is beyond its limit in the error's direction), the currents clipped."""

    def __init__(self, t_in, t_out, pis, limits_a, period_s: float):
        self.t_in, self.t_out = np.asarray(t_in, float), np.asarray(t_out, float)
        self.kp = np.array([float(c.kp) for c in pis])
        self.ki = np.array([float(c.ki) for c in pis])
        self.limits = np.asarray(limits_a, float)
        self.T = period_s
        self.integ = np.zeros(self.kp.size)
        self.e_prev = np.zeros(self.kp.size)

    def __call__(self, error_rails) -> np.ndarray:
        e = self.t_out @ error_rails
        trial = self.integ + self.ki * self.T * (e + self.e_prev) / 2
        u = self.t_in @ (self.kp * e + trial)
        over = np.sign(u) * (np.abs(u) > self.limits)
        for j in range(e.size):
            push = np.sign(self.t_in[:, j] * e[j])
            if np.any((over != 0) & (over == push)):
                trial[j] = self.integ[j]
        self.integ, self.e_prev = trial, e
        return np.clip(self.t_in @ (self.kp * e + trial), -self.limits, self.limits)


def simulate_planar_run(settings: PlanarRunSettings, path: PlanarPath, *, steps: int | None = None) -> PlanarTrace:
    """Run the loops over the path's ticks (uniform, 1 / drive_rate_hz apart, from 0), the clamp starting at
    rest at ``carriage_position_m`` with the mouse at it; ``steps`` Runge-Kutta steps per tick (default
    ``substeps``)."""
    s, m = settings, settings.mouse
    t = np.asarray(path.time_s, float)
    T = 1.0 / s.drive_rate_hz
    signals, tick = tick_functions(s, steps or substeps(s))
    xd, vd, ad = path.position_m, path.velocity_m_per_s, path.acceleration_m_per_s2
    start = np.array([s.carriage_position_m, 0.0])
    z = np.zeros(N_STATES)
    z[2] = s.carriage_position_m
    z[BODY] = start
    laws = (s.x_law, s.y_law)
    sensors = (s.x_sensor, s.y_sensor)
    ff = np.array([[s.x_law.m_v, s.x_law.b_v], [s.y_law.m_v, s.y_law.b_v]]) if m.feedforward else np.zeros((2, 2))
    x_loop = _Channels(np.eye(1), np.eye(1), [s.x_controller], [s.x_drive.current_limit_a], T)
    y_loop = _Channels(s.y_controller.t_in, s.y_controller.t_out, s.y_controller.channels(),
                       [d.current_limit_a for d in s.y_drives], T)
    ideal = np.array([d.current_loop_hz is None for d in (*s.y_drives, s.x_drive)])
    delay = s.x_law.computation_delay_samples
    queues = [[0.0] * (delay + 1) for _ in laws]
    y_ticks = s.y_drives[0].delay_ticks
    x_cmd, y_cmd = [0.0] * (s.x_drive.delay_ticks + 1), [np.zeros(2)] * (y_ticks + 1)
    v_a, r_prev, v_ref = np.zeros(2), np.zeros(2), np.zeros(2)
    ic = np.zeros(3)
    n = t.size
    rec = {k: np.empty((n, w)) for k, w in (("c", 2), ("vc", 2), ("b", 2), ("fs", 2), ("fl", 2), ("i", 3),
                                             ("ref", 2), ("yaw", 1))}
    # the legs' path terms at every tick (and after the last)
    drives = m.body_mass_kg * ad + m.leg_stiffness_n_per_m * (start + xd) + m.leg_damping_n_s_per_m * vd + \
        ff[:, 0] * ad + ff[:, 1] * vd
    drives = np.vstack([drives, drives[-1:]])
    out = np.asarray(signals(z, drives[0])).ravel()
    L_m = s.machine.rail_separation_m
    for k in range(n):
        fs = out[0:2]
        if k % s.law_ticks == 0:
            for a, (law, sensor) in enumerate(zip(laws, sensors)):
                r = sensor.reading(float(fs[a]))
                v_a[a] = law.alpha * v_a[a] + law.beta_m_per_s_per_n * r + law.beta_prev_m_per_s_per_n * r_prev[a]
                r_prev[a] = r
                queues[a] = queues[a][1:] + [float(v_a[a])]
                v_ref[a] = queues[a][0]
        x_cmd = x_cmd[1:] + [float(x_loop(np.array([v_ref[0] - z[6]]))[0])]
        y_cmd = y_cmd[1:] + [y_loop(v_ref[1] - z[4:6])]
        rec["c"][k], rec["vc"][k], rec["fs"][k], rec["fl"][k] = out[4:6], out[6:8], fs, out[2:4]
        rec["b"][k], rec["i"][k], rec["ref"][k], rec["yaw"][k] = z[BODY], z[CURRENT], v_ref, (z[1] - z[0]) / L_m
        ic = np.array([*y_cmd[0], x_cmd[0]])
        z[CURRENT] = np.where(ideal, ic, z[CURRENT])         # an ideal current loop: the current is its command
        nxt, sig = tick(z, ic, drives[k], drives[k + 1])
        z, out = np.asarray(nxt).ravel(), np.asarray(sig).ravel()
    return PlanarTrace(t, rec["c"] - start, rec["vc"], rec["b"] - start, rec["fs"], rec["fl"], rec["i"], rec["ref"],
                       rec["yaw"][:, 0])


@dataclass(frozen=True)
class PlanarRun:
    """A simulated planar run and what it means for the mouse (N, m, m/s, A; while the mouse moves)."""

    settings: PlanarRunSettings
    path: PlanarPath
    trace: PlanarTrace
    #: the sensed force's magnitude: peak and RMS
    peak_force_n: float
    rms_force_n: float
    #: the sensed force across the mouse's intended direction (peak): what it feels sideways
    peak_lateral_force_n: float
    #: intended peak speed minus the clamp's (m/s)
    speed_shortfall_m_per_s: float
    #: the largest distance between the clamp and the intended path, and the largest angle between the clamp's
    #: velocity and the intended one where both are faster than a tenth of the intended peak (deg)
    max_lag_m: float
    max_heading_error_deg: float
    #: each motor's peak force (Y1, Y2, X) and the fraction of ticks any motor is at its limit
    motor_peak_force_n: tuple[float, float, float]
    saturated_fraction: float
    #: the beam's peak yaw (urad) and the fraction of ticks the mouse pushes at its limit
    peak_yaw_urad: float
    legs_at_limit_fraction: float

    @property
    def mouse_keeps_up(self) -> bool:
        """The force felt within the mouse's budget and the clamp's peak speed within 5 % of the intended one (as
        the one-axis run judges it)."""
        return bool(self.peak_force_n <= self.settings.mouse.peak_force_n * 1.001
                    and self.speed_shortfall_m_per_s <= 0.05 * float(np.max(self.path.speed_m_per_s)))


def planar_run(settings: PlanarRunSettings, path: PlanarPath, *, steps: int | None = None) -> PlanarRun:
    """Simulate ``path`` and summarise it (``PlanarRun``)."""
    tr = simulate_planar_run(settings, path, steps=steps)
    speed = path.speed_m_per_s
    moving = speed > 1e-9
    fs = tr.sensed_force_n[moving] if moving.any() else tr.sensed_force_n
    mag = np.hypot(*fs.T)
    heading = path.velocity_m_per_s[moving] / np.maximum(speed[moving], 1e-12)[:, None]
    lateral = fs[:, 0] * heading[:, 1] - fs[:, 1] * heading[:, 0]
    top = 0.1 * float(np.max(speed))
    fast = (speed > top) & (np.hypot(*tr.clamp_m_per_s.T) > top) if moving.any() else moving
    vc, vd = tr.clamp_m_per_s[fast], path.velocity_m_per_s[fast]
    angle = np.degrees(np.abs(np.arctan2(vc[:, 0] * vd[:, 1] - vc[:, 1] * vd[:, 0], np.sum(vc * vd, axis=1))))
    drives = (*settings.y_drives, settings.x_drive)
    force = np.abs(tr.current_a) * np.array([d.force_constant_n_per_a for d in drives])
    limits = np.array([d.current_limit_a for d in drives])
    legs = np.hypot(*tr.leg_force_n.T) >= settings.mouse.peak_force_n * (1 - 1e-6)
    return PlanarRun(settings, path, tr, float(np.max(mag)), float(np.sqrt(np.mean(mag**2))),
                     float(np.max(np.abs(lateral))),
                     float(np.max(speed) - np.max(np.hypot(*tr.clamp_m_per_s.T))),
                     float(np.max(np.hypot(*(tr.clamp_m - path.position_m).T))),
                     float(np.max(angle)) if angle.size else 0.0, tuple(float(v) for v in force.max(axis=0)),
                     float(np.mean(np.any(np.abs(tr.current_a) >= limits * (1 - 1e-9), axis=1))),
                     float(1e6 * np.max(np.abs(tr.yaw_rad))), float(np.mean(legs[moving])) if moving.any() else 0.0)


# --- a run from the two axes' specs and designs -------------------------------------------------------------
def _drive_effects(plant_effects, where: str) -> dict:
    names = [e.name for e in plant_effects]
    dropped = [n for n in names if n not in SIMULATED]
    if dropped:
        raise SpecError(f"{where}: the planar run simulates {', '.join(SIMULATED)}; it cannot simulate "
                        f"{', '.join(dropped)}: remove {'it' if len(dropped) == 1 else 'them'} for the run")
    return {e.name: e for e in plant_effects}


def _law(problem, m_v: float, b_v: float, where: str) -> tuple[DiscreteAdmittance, ForceSensor]:
    adm = admittance_problem(problem)
    timing = RigTiming.of(adm.rig)
    if not timing.sampled:
        raise SpecError(f"{where}: admittance.rig.update_rate_hz: the planar run simulates the sampled law; declare "
                        "the rate")
    if timing.filter_hz is not None:
        raise SpecError(f"{where}: admittance.rig.force_filter: the planar run does not simulate a force filter; "
                        "run the axis alone with gantry mouse-run")
    law = DiscreteAdmittance.of(m_v, b_v, 1.0 / timing.period_s, timing.delays[-1], rule=timing.rule)
    sensor = ForceSensor(adm.hardware.force_sensor_resolution_n, adm.sensor.bias_after_tare_n, adm.sensor.deadband_n)
    return law, sensor


def _within(what: str, value: float, bounds, key: str, unit: str) -> None:
    """A design's value inside the spec's bounds for it (ParameterError naming the key otherwise)."""
    if not bounds.min <= value <= bounds.max:
        raise ParameterError(f"{what} = {value:g} {unit} lies outside the spec's {key} bounds [{bounds.min:g}, "
                             f"{bounds.max:g}]: not a design of this spec")


def planar_settings(x_problem, y_problem, *, x_controller: PI, x_virtual: tuple[float, float],
                    y_controller: Controller, y_virtual: tuple[float, float], payload_kg: float | None = None,
                    carriage_position_m: float | None = None,
                    leg_stiffness_n_per_m: float | None = None) -> PlanarRunSettings:
    """``PlanarRunSettings`` from Stage X's spec (a ``LoopProblem``: the carriage's mass at ``payload_kg``,
    default the heaviest, its damping, X's drive, law and sensor, the mouse: mid-range masses and neck, the legs
    at their least stiffness unless given) and Stage Y's two-motor spec (a ``design.results.DesignProblem`` with
    ``[dual_drive]``: the beam, the rails, the yaw stiffness, both Y drives, Y's law and sensor), with each axis's
    gains and virtual dynamics (m_v kg, b_v N*s/m). The carriage starts mid-travel unless given."""
    spec = y_problem.spec
    if spec.dual_drive is None:
        raise SpecError(f"{y_problem.spec_path}: the planar run needs Stage Y's [dual_drive] section (the beam on "
                        "its two rails)")
    plant = x_problem.plant.plant(x_problem.plant.payload_kg.max if payload_kg is None else payload_kg)
    x_effects = _drive_effects(plant.effects, "Stage X plant.effects")
    mech = plant.mechanics()
    if len(mech.masses_kg) != 1:
        raise SpecError("Stage X plant.effects: the planar run takes Stage X as one rigid carriage; remove the "
                        "payload or structural modes for the run")
    model = spec.dual_model()
    y_effects = _drive_effects(model.effects, f"{y_problem.spec_path}: plant.effects")
    sampling = x_effects.get("sampling")
    x_law, x_sensor = _law(x_problem, *x_virtual, "Stage X")
    y_law, y_sensor = _law(y_problem.loop, *y_virtual, str(y_problem.spec_path))
    if x_law.computation_delay_samples != y_law.computation_delay_samples:
        raise SpecError("admittance.rig.computation_delay_samples: the two axes' laws run in one loop; their "
                        f"delays ({x_law.computation_delay_samples}, {y_law.computation_delay_samples}) must agree")
    period = 1.0 / x_law.update_rate_hz
    rate = float(sampling.rate_hz) if sampling is not None else DEFAULT_DRIVE_RATE_HZ
    rate = round(rate * period) / period

    def drive(effects, force_constant, peak):
        delay, loop = effects.get("delay"), effects.get("current_loop")
        return MotorDrive(float(force_constant), None if loop is None else float(loop.bandwidth_hz),
                          0 if delay is None else int(round(float(delay.seconds) * rate)), float(peak))

    x_adm, y_adm = admittance_problem(x_problem), admittance_problem(y_problem.loop)
    axes = (("Stage X", x_problem, x_adm, [x_controller], x_virtual),
            ("Stage Y", y_problem.loop, y_adm, y_controller.channels(), y_virtual))
    for axis, problem, adm, pis, (m_v, b_v) in axes:
        _within(f"{axis}'s design: m_v", m_v, adm.m_v, "admittance.m_v", "kg")
        _within(f"{axis}'s design: b_v", b_v, adm.b_v, "admittance.b_v", "N*s/m")
        for pi in pis:
            _within(f"{axis}'s design: kp", float(pi.kp), problem.controller.kp, "controller.kp", "A/(m/s)")
            _within(f"{axis}'s design: ki", float(pi.ki), problem.controller.ki, "controller.ki", "A/m")
    y_peak = y_adm.hardware.motor_peak_force_n
    machine = PlanarGantry(beam_mass_kg=float(model.beam_mass_kg), beam_inertia_kg_m2=float(model.beam_inertia_kg_m2),
                           carriage_mass_kg=float(mech.masses_kg[0]),
                           carriage_inertia_kg_m2=float(model.carriage_inertia_kg_m2),
                           rail_separation_m=float(model.rail_separation_m),
                           damping1_n_s_per_m=float(model.damping1_n_s_per_m),
                           damping2_n_s_per_m=float(model.damping2_n_s_per_m),
                           damping_x_n_s_per_m=float(mech.rail_damping_n_s_per_m),
                           yaw_stiffness_n_m_per_rad=float(model.yaw_stiffness_n_m_per_rad))
    travel = spec.dual_drive.carriage_position_m
    return PlanarRunSettings(
        machine, 0.5 * (travel.min + travel.max) if carriage_position_m is None else float(carriage_position_m),
        rate, drive(x_effects, plant.force_constant_n_per_a, x_adm.hardware.motor_peak_force_n),
        tuple(drive(y_effects, k, y_peak) for k in (model.force_constant1_n_per_a, model.force_constant2_n_per_a)),
        x_controller, y_controller, x_law, y_law, x_sensor, y_sensor,
        PlanarMouse(*nominal_mouse(x_adm.mouse, leg_stiffness_n_per_m)))
