"""A force-limited mouse walking a trajectory through the sampled, nonlinear admittance loop.

Model (SI units; every rate an integer multiple of the admittance rate is required):

Continuous part (integrated by fixed-step RK4, at least ``SUBSTEPS`` steps per drive period and as many
more as keep w h <= ``MAX_W_H`` for the fastest rate w of the continuous part):

* gantry with the head on its clamp: (M + m_h) dv/dt = F_m + F_n - b v - F_f,  dx/dt = v;
  Coulomb friction regularised F_f = F_c tanh(v / v_s);
* mouse body: m_b dv_b/dt = F_leg - F_n,  dx_b/dt = v_b;
  neck force on the head F_n = k_n (x_b - x) + c_n (v_b - v);
* the mouse's legs, a force-limited walker tracking its intended path (x_d, v_d, a_d):
  F_leg = clip(m_b a_d + F_ff + k_l (x_d - x_b) + c_l (v_d - v_b), -F_max, F_max), with the feed-forward
  F_ff = m_v a_d + b_v v_d of a mouse that has learned the virtual dynamics (0 when ``feedforward`` is off);
* sensed force (head on gantry) F_s = F_n - m_h dv/dt;
* current loop di/dt = w_c (i_c - i) (i = i_c when ideal), motor force F_m = K_t i;
* force filter (optional) on F_s: Butterworth of order 1 or 2 at f_f, its output F_sf.

Drive (velocity loop) at rate f_d, tick k at t_k = k / f_d: e[k] = v_ref(t_k) - v(t_k);
I[k] = I[k-1] + (k_i / f_d) (e[k] + e[k-1]) / 2 (trapezoidal, not updated while the output is saturated
in the direction of e[k]); u[k] = k_p e[k] + I[k]; the command clip(u[k], -F_mot / K_t, F_mot / K_t) reaches
the current loop ``delay_ticks`` ticks later and is held.

Admittance law at rate f_a, tick j at the drive ticks k = j f_d / f_a: the reading
r[j] = res round((F_sf(t) + bias) / res); a deadband zeroes |r| <= d;
v_a[j] = alpha v_a[j-1] + beta r_db[j] + beta_prev r_db[j-1] (``design.admittance.rig.DiscreteAdmittance``, backward or
forward Euler or Tustin); v_ref = v_a[j - computation_delay]
from that tick on (held).

Order within a tick: the continuous states are sampled, the admittance law updates (on its ticks), then
the drive, then the continuous part is integrated to the next tick with the held commands.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from design.admittance.model import admittance_problem
from design.admittance.profile import trapezoid
from design.admittance.rig import DiscreteAdmittance, RigTiming
from design.loop.controller import PI
from plant.errors import DataError, SpecError
from plant.host.text_io import read_text

#: RK4 steps per drive period at least, and the largest w h (w the fastest rate of the continuous part: the
#: current loop, the force filter, the body on neck and legs) a step may take (RK4 is stable to 2.79)
SUBSTEPS = 2
MAX_W_H = 0.5


@dataclass(frozen=True)
class RunSettings:
    """Everything a mouse run needs (SI units)."""

    gantry_mass_kg: float
    damping_n_s_per_m: float
    force_constant_n_per_a: float
    current_loop_hz: float | None
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


def simulate_mouse_run(settings: RunSettings, time_s, x_d, v_d, a_d) -> RunTrace:
    """Run the loop over the drive ticks ``time_s`` (uniform, 1 / drive_rate_hz apart, from 0) with the
    intended path (x_d, v_d, a_d) given at those ticks (held between them)."""
    s = settings
    n_a = _check_rates(s)
    t = np.asarray(time_s, float)
    xd_, vd_, ad_ = (np.asarray(a, float) for a in (x_d, v_d, a_d))
    T = 1.0 / s.drive_rate_hz
    fastest = max(2 * math.pi * (s.current_loop_hz or 0.0), 2 * math.pi * (s.force_filter_hz or 0.0),
                  math.sqrt((s.neck_stiffness_n_per_m + s.leg_stiffness_n_per_m) / s.body_mass_kg),
                  (s.neck_damping_n_s_per_m + s.leg_damping_n_s_per_m) / s.body_mass_kg)
    substeps = max(SUBSTEPS, math.ceil(fastest * T / MAX_W_H))
    h = T / substeps
    m_total = s.gantry_mass_kg + s.head_mass_kg
    mh, mb = s.head_mass_kg, s.body_mass_kg
    kn, cn = s.neck_stiffness_n_per_m, s.neck_damping_n_s_per_m
    kl, cl = s.leg_stiffness_n_per_m, s.leg_damping_n_s_per_m
    b, kt, fc, vs = s.damping_n_s_per_m, s.force_constant_n_per_a, s.friction_n, s.friction_velocity_m_per_s
    fmax = s.mouse_peak_force_n
    wc = None if s.current_loop_hz is None else 2 * math.pi * s.current_loop_hz
    wf = None if s.force_filter_hz is None else 2 * math.pi * s.force_filter_hz
    order = s.force_filter_order
    imax = s.motor_peak_force_n / kt
    law = DiscreteAdmittance.of(s.m_v, s.b_v, s.admittance_rate_hz, rule=s.law)
    alpha, beta, beta_prev = law.alpha, law.beta_m_per_s_per_n, law.beta_prev_m_per_s_per_n

    def forces(z, ic, xd, vd, ad):
        x, v, xb, vb, i = z[0], z[1], z[2], z[3], z[4]
        fn = kn * (xb - x) + cn * (vb - v)
        fm = kt * (i if wc is not None else ic)
        ff = fc * math.tanh(v / vs) if fc > 0 else 0.0
        dv = (fm + fn - b * v - ff) / m_total
        push = mb * ad + kl * (xd - xb) + cl * (vd - vb) + ((s.m_v * ad + s.b_v * vd) if s.feedforward else 0.0)
        return fn, dv, fn - mh * dv, min(max(push, -fmax), fmax)

    def deriv(z, ic, xd, vd, ad):
        fn, dv, fs, fleg = forces(z, ic, xd, vd, ad)
        out = [z[1], dv, z[3], (fleg - fn) / mb, 0.0 if wc is None else wc * (ic - z[4]), 0.0, 0.0]
        if wf is not None:
            if order == 1:
                out[5] = wf * (fs - z[5])
            else:
                out[5], out[6] = z[6], wf * wf * (fs - z[5]) - math.sqrt(2.0) * wf * z[6]
        return out

    n = t.size
    z = [float(xd_[0]), 0.0, float(xd_[0]), 0.0, 0.0, 0.0, 0.0]
    rec = np.empty((9, n))
    queue = [0.0] * (s.computation_delay_samples + 1)
    commands = [0.0] * (s.delay_ticks + 1)
    v_a = v_ref = integ = e_prev = ic = r_prev = 0.0
    for k in range(n):
        xd, vd, ad = float(xd_[k]), float(vd_[k]), float(ad_[k])
        _, _, fs, fleg = forces(z, ic, xd, vd, ad)
        if k % n_a == 0:
            reading = z[5] if wf is not None else fs
            r = s.resolution_n * float(np.round((reading + s.bias_n) / s.resolution_n))
            r_db = r if abs(r) > s.deadband_n else 0.0
            v_a = alpha * v_a + beta * r_db + beta_prev * r_prev
            r_prev = r_db
            queue = queue[1:] + [v_a]
            v_ref = queue[0]
        e = v_ref - z[1]
        trial = integ + s.ki * T * (e + e_prev) / 2
        u = s.kp * e + trial
        if (u > imax and e > 0) or (u < -imax and e < 0):
            trial = integ
            u = s.kp * e + trial
        integ, e_prev = trial, e
        commands = commands[1:] + [min(max(u, -imax), imax)]
        rec[:, k] = (z[0], z[1], z[2], z[3], fs, fleg, z[4] if wc is not None else ic, v_ref, 0.0)
        ic = commands[0]
        for _ in range(substeps):
            k1 = deriv(z, ic, xd, vd, ad)
            k2 = deriv([a + 0.5 * h * d for a, d in zip(z, k1)], ic, xd, vd, ad)
            k3 = deriv([a + 0.5 * h * d for a, d in zip(z, k2)], ic, xd, vd, ad)
            k4 = deriv([a + h * d for a, d in zip(z, k3)], ic, xd, vd, ad)
            z = [a + h / 6 * (d1 + 2 * d2 + 2 * d3 + d4) for a, d1, d2, d3, d4 in zip(z, k1, k2, k3, k4)]
    return RunTrace(t, rec[0], rec[1], rec[2], rec[3], rec[4], rec[5], rec[6], rec[7], xd_, vd_)


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
#: the plant's effects a run simulates (any other is refused by name, never dropped)
SIMULATED_EFFECTS = ("sampling", "delay", "current_loop")


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


def run_settings(problem, *, controller: PI, m_v: float, b_v: float, timing=None, payload_kg: float | None = None,
                 friction_n: float = 0.0, leg_stiffness_n_per_m: float | None = None,
                 drive_rate_hz: float | None = None) -> RunSettings:
    """``RunSettings`` of the spec's plant (at ``payload_kg``, default the heaviest) and its nominal mouse
    (mid-range masses and neck, the legs at their least stiffness unless given) with the design's gains, at the
    largest computation delay of a range."""
    adm = admittance_problem(problem)
    timing = timing or RigTiming.of(adm.rig)
    if not timing.sampled:
        raise ValueError("admittance.rig.update_rate_hz: a mouse run simulates the sampled law; declare the rate")
    plant = problem.plant.plant(problem.plant.payload_kg.max if payload_kg is None else payload_kg)
    dropped = [e.name for e in plant.effects if e.name not in SIMULATED_EFFECTS]
    if dropped:
        raise SpecError(f"plant.effects: the mouse run simulates {', '.join(SIMULATED_EFFECTS)} and the rigid body; "
                        f"it cannot simulate {', '.join(dropped)}: remove {'it' if len(dropped) == 1 else 'them'} "
                        "for the run, or check the design with the frequency-domain figures of gantry synth")
    sampling, delay, loop = plant.effect("sampling"), plant.effect("delay"), plant.effect("current_loop")
    rate = drive_rate_hz or (float(sampling.rate_hz) if sampling is not None else DEFAULT_DRIVE_RATE_HZ)
    rate = round(rate * timing.period_s) / timing.period_s
    mouse = adm.mouse

    def mid(r):
        return 0.5 * (r.min + r.max)

    body = plant.mechanics()          # the rigid body the plant's model has: Stage Y's both rails' damping
    return RunSettings(float(np.sum(np.asarray(body.masses_kg, float))), float(body.rail_damping_n_s_per_m),
                       float(plant.force_constant_n_per_a),
                       None if loop is None else float(loop.bandwidth_hz),
                       0 if delay is None else int(round(float(delay.seconds) * rate)), rate,
                       float(controller.kp), float(controller.ki),
                       adm.hardware.motor_peak_force_n, friction_n, FRICTION_VELOCITY_M_PER_S, 1.0 / timing.period_s,
                       timing.delays[-1], m_v, b_v, timing.filter_hz, timing.filter_order,
                       adm.hardware.force_sensor_resolution_n, adm.sensor.bias_after_tare_n, adm.sensor.deadband_n,
                       mid(mouse.head_mass_kg), mid(mouse.body_mass_kg), mid(mouse.neck_stiffness_n_per_m),
                       mid(mouse.neck_damping_n_s_per_m),
                       mouse.leg_stiffness_n_per_m.min if leg_stiffness_n_per_m is None else leg_stiffness_n_per_m,
                       mid(mouse.leg_damping_n_s_per_m), mouse.peak_force_n,
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
