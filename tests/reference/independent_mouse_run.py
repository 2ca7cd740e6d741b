"""An independent reference simulator of a force-limited mouse walking through the sampled admittance loop.

Nothing here imports the tool (``plant``, ``design``): only numpy and scipy. The continuous part is integrated
by ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-10) from one drive tick to the next with every discrete
signal held, so it shares no integration code with the tool's exact fixed step. It is the reference the tests
hold ``design.admittance.mouse_run.simulate_mouse_run`` against.

Model (SI units), written out from the forces on each body:

* gantry with the head on its clamp, mass M + m_h:  (M + m_h) dv/dt = F_m + F_n - b v - F_c tanh(v / v_s),
  dx/dt = v (no friction term at all when F_c = 0);
* mouse body m_b:  m_b dv_b/dt = F_leg - F_n,  dx_b/dt = v_b;  neck F_n = k_n (x_b - x) + c_n (v_b - v)
  (zero length at rest: the body starts where the head is);
* legs:  F_leg = clip(m_b a_d + F_ff + k_l (x_d - x_b) + c_l (v_d - v_b), -F_max, F_max),
  F_ff = m_v a_d + b_v v_d with ``feedforward``, else 0;
* sensed force F_s = F_n - m_h dv/dt (algebraic: dv/dt from the gantry equation at the same instant);
* motor force F_m = K_t i; current loop di/dt = w_c (i_c - i), w_c = 2 pi f_c, or i = i_c (ideal, f_c None);
* a payload mode (optional, ``payload_mass_kg`` > 0): a second body m_2 on a spring k_2 and damper c_2 to the
  gantry (mass ``gantry_mass_kg`` the gantry's own, the head on it), its force k_2 (x - x_2) + c_2 (v - v_2) added
  to the gantry's equation with a minus sign, m_2 dv_2/dt = k_2 (x - x_2) + c_2 (v - v_2);
* forces on the gantry (optional): a constant force the motor must supply, ``offset_n`` (the gantry's equation
  gets -offset_n); a ripple the motor must supply, ``ripple`` = (s1, c1, s2, c2, pitch): -(s1 sin p + c1 cos p +
  s2 sin 2p + c2 cos 2p), p = 2 pi x / pitch; a force constant that varies along the travel, ``profile`` =
  (centre, half span, slope, curvature): the motor's force K_t i (1 + slope u + curvature u^2), u = (x - centre) /
  half span; a cable chain, ``cable`` = (stiffness k_c, rest x_c): -k_c (x - x_c);
* a sensor filter (optional) on the velocity the drive measures, v_m'' = w_s^2 (v - v_m) - 2 zeta_s w_s v_m'
  (none: v_m = v);
* force filter (optional) on F_s, output F_sf, extra continuous states:
  order 1  H(s) = 1 / (1 + s/w_f):                  dF_sf/dt = w_f (F_s - F_sf);
  order 2  H(s) = 1 / (1 + sqrt2 s/w_f + (s/w_f)^2): F_sf'' = w_f^2 (F_s - F_sf) - sqrt2 w_f F_sf'.

Discrete part (drive ticks t_k = k / f_d; admittance ticks at k = j n_a, n_a = f_d / f_a a whole number):

* admittance reading r[j] = res * np.round((F + bias) / res), numpy's rounding (half to even) of the float
  quotient; deadband: r_db = 0 when |r| <= d, else r; law v_a[j] = alpha v_a[j-1] + beta r_db[j] with
  backward Euler alpha = m_v / (m_v + b_v T_a), beta = T_a / (m_v + b_v T_a) or forward Euler
  alpha = 1 - b_v T_a / m_v, beta = T_a / m_v (T_a = 1 / f_a); v_a[-1] = 0;
  the drive's reference v_ref = v_a[j - computation_delay] (0 for j < delay) from tick k = j n_a on, held;
* velocity PI at every drive tick: e[k] = v_ref - v(t_k), e[-1] = 0, I[-1] = 0;
  trial I = I[k-1] + (k_i / f_d) (e[k] + e[k-1]) / 2, u = k_p e[k] + trial;
  if u > i_max and e[k] > 0, or u < -i_max and e[k] < 0 (the unclipped output, computed with the trial
  integral, beyond a limit with e[k] pushing further out): I[k] = I[k-1] and u = k_p e[k] + I[k];
  else I[k] = trial; e[k-1] <- e[k] in either case; i_max = F_mot / K_t;
  command clip(u, -i_max, i_max) reaches the current loop (as i_c) ``delay_ticks`` ticks later
  (at tick k + delay_ticks; 0 before) and is held until the next one arrives.
* the intended path (x_d, v_d, a_d) sample k is held over [t_k, t_{k+1}).

Timing choices (where the model's statement leaves room), all at tick k:

1. the continuous states are sampled at t_k (the end of the previous interval);
2. the sensed force F_s(t_k) is computed from those states with the inputs held over the interval just ended
   (the current command i_c in force before this tick's update; it matters only for an ideal current loop,
   where dv/dt jumps at a tick). The admittance reads this F_s(t_k) (or the filter state F_sf(t_k));
3. the admittance updates (on its ticks), giving v_ref for this tick; then the PI reads v_m(t_k) (the sampled
   state, before anything is integrated) and the command queue advances;
4. recorded at tick k: x, v, x_b, v_b, F_s from step 2, the current i(t_k) (ideal loop: the command held over
   the interval just ended, i.e. the one F_s used), v_ref after this tick's update, and F_leg evaluated with
   the states at t_k and the path sample k (the leg force that acts right after the tick);
5. the continuous part is integrated to t_{k+1} with the new held command and path sample k (not after the last
   tick).

Initial state: x = x_b = x_d[0], v = v_b = 0, i = 0, filter states 0, every discrete memory 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

RTOL = 1e-10
ATOL = 1e-14


@dataclass(frozen=True)
class ReferenceTrace:
    """The run at every drive tick (timing choices in the module docstring), plus the PI's internals."""

    time_s: np.ndarray
    x: np.ndarray
    v: np.ndarray
    x_b: np.ndarray
    v_b: np.ndarray
    F_s: np.ndarray
    F_leg: np.ndarray
    i: np.ndarray
    v_ref: np.ndarray
    #: the filter output at the tick (F_s when unfiltered), the clipped command issued, the integrator after the tick
    F_read: np.ndarray
    command: np.ndarray
    integral: np.ndarray


def reading(force, res, bias, deadband):
    """The admittance law's input: res * np.round((F + bias) / res) (numpy rounds half to even), zeroed when
    its magnitude is at most the deadband."""
    r = res * np.round((np.asarray(force, float) + bias) / res)
    return np.where(np.abs(r) <= deadband, 0.0, r)


def law_coefficients(m_v, b_v, admittance_rate_hz, law="backward_euler"):
    """(alpha, beta) of v[j] = alpha v[j-1] + beta F[j] (``law``: backward_euler, forward_euler, or zoh: the
    exact response of 1/(m_v s + b_v) over one period to the force held at F[j])."""
    T = 1.0 / admittance_rate_hz
    if law == "forward_euler":
        return 1.0 - b_v * T / m_v, T / m_v
    if law == "zoh":
        a = math.exp(-b_v * T / m_v)
        return a, (1.0 - a) / b_v
    return m_v / (m_v + b_v * T), T / (m_v + b_v * T)


def tustin_coefficients(m_v, b_v, admittance_rate_hz):
    """(alpha, c) of Tustin's v[j] = alpha v[j-1] + c (F[j] + F[j-1]): m_v s + b_v with s = 2 (z - 1) / (T (z + 1))."""
    T = 1.0 / admittance_rate_hz
    return (2 * m_v - b_v * T) / (2 * m_v + b_v * T), T / (2 * m_v + b_v * T)


def simulate(time_s, x_d, v_d, a_d, *, gantry_mass_kg, damping_n_s_per_m, force_constant_n_per_a, current_loop_hz,
             delay_ticks, drive_rate_hz, kp, ki, motor_peak_force_n, friction_n, friction_velocity_m_per_s,
             admittance_rate_hz, computation_delay_samples, m_v, b_v, force_filter_hz, force_filter_order,
             resolution_n, bias_n, deadband_n, head_mass_kg, body_mass_kg, neck_stiffness_n_per_m,
             neck_damping_n_s_per_m, leg_stiffness_n_per_m, leg_damping_n_s_per_m, mouse_peak_force_n,
             feedforward=True, law="backward_euler", payload_mass_kg=0.0, payload_stiffness_n_per_m=0.0,
             payload_damping_n_s_per_m=0.0, sensor_filter_hz=None, sensor_damping_ratio=0.7, offset_n=0.0,
             ripple=None, profile=None, cable=None, method="DOP853") -> ReferenceTrace:
    """Simulate the model of the module docstring at the drive ticks ``time_s`` (k / drive_rate_hz) with the
    intended path sampled there. Keyword names follow the quantities (SI units; rates in Hz)."""
    t = np.asarray(time_s, float)
    xd_, vd_, ad_ = (np.asarray(a, float) for a in (x_d, v_d, a_d))
    n = t.size
    ratio = drive_rate_hz / admittance_rate_hz
    n_a = int(round(ratio))
    if n_a < 1 or abs(ratio - n_a) > 1e-9:
        raise ValueError("the drive rate must be a whole multiple of the admittance rate")
    if force_filter_hz is not None and force_filter_order not in (1, 2):
        raise ValueError("force filter order 1 or 2")
    T = 1.0 / drive_rate_hz
    M = gantry_mass_kg + head_mass_kg
    mh, mb = head_mass_kg, body_mass_kg
    kn, cn, kl, cl = neck_stiffness_n_per_m, neck_damping_n_s_per_m, leg_stiffness_n_per_m, leg_damping_n_s_per_m
    b, kt, fc, vs = damping_n_s_per_m, force_constant_n_per_a, friction_n, friction_velocity_m_per_s
    fmax = mouse_peak_force_n
    ideal = current_loop_hz is None
    wc = 0.0 if ideal else 2.0 * math.pi * current_loop_hz
    filtered = force_filter_hz is not None
    wf = 2.0 * math.pi * force_filter_hz if filtered else 0.0
    sqrt2 = math.sqrt(2.0)
    imax = motor_peak_force_n / kt
    alpha, beta = law_coefficients(m_v, b_v, admittance_rate_hz, law)
    beta_prev = 0.0
    if law == "tustin":
        alpha, beta = tustin_coefficients(m_v, b_v, admittance_rate_hz)
        beta_prev = beta
    r_prev = 0.0

    m2, k2, c2 = payload_mass_kg, payload_stiffness_n_per_m, payload_damping_n_s_per_m
    ws = 2.0 * math.pi * sensor_filter_hz if sensor_filter_hz is not None else 0.0
    zs = sensor_damping_ratio

    # state y = [x, v, x_b, v_b, i, f, f', v_2, x - x_2, v_m, v_m'] (i unused when ideal, f' unused for order 1,
    # the filters unused when off, v_2 and x - x_2 without a payload mode)
    def payload_force(y):
        return k2 * y[8] + c2 * (y[1] - y[7]) if m2 > 0 else 0.0

    def along_travel(x, fm):
        """The forces that depend on where the gantry is: offset, ripple, and the force constant's variation."""
        out = -offset_n
        if ripple is not None:
            s1, c1, s2, c2, pitch = ripple
            p = 2 * math.pi * x / pitch
            out -= s1 * math.sin(p) + c1 * math.cos(p) + s2 * math.sin(2 * p) + c2 * math.cos(2 * p)
        if profile is not None:
            centre, half, slope, curvature = profile
            u = (x - centre) / half
            out += fm * (slope * u + curvature * u * u)
        if cable is not None:
            out -= cable[0] * (x - cable[1])
        return out

    def accel(y, ic):
        x, v, xb, vb, i = y[0], y[1], y[2], y[3], y[4]
        fn = kn * (xb - x) + cn * (vb - v)
        fm = kt * (ic if ideal else i)
        friction = fc * math.tanh(v / vs) if fc != 0.0 else 0.0
        return fn, (fm + along_travel(x, fm) + fn - b * v - friction - payload_force(y)) / M

    def measured(y):
        return y[9] if sensor_filter_hz is not None else y[1]

    def leg(y, xd, vd, ad):
        push = mb * ad + kl * (xd - y[2]) + cl * (vd - y[3])
        if feedforward:
            push += m_v * ad + b_v * vd
        return min(max(push, -fmax), fmax)

    def rhs(_t, y, ic, xd, vd, ad):
        fn, dv = accel(y, ic)
        fs = fn - mh * dv
        out = [y[1], dv, y[3], (leg(y, xd, vd, ad) - fn) / mb, 0.0 if ideal else wc * (ic - y[4]), 0.0, 0.0,
               payload_force(y) / m2 if m2 > 0 else 0.0, y[1] - y[7] if m2 > 0 else 0.0,
               y[10], ws * ws * (y[1] - y[9]) - 2 * zs * ws * y[10] if sensor_filter_hz is not None else 0.0]
        if filtered:
            if force_filter_order == 1:
                out[5] = wf * (fs - y[5])
            else:
                out[5] = y[6]
                out[6] = wf * wf * (fs - y[5]) - sqrt2 * wf * y[6]
        return out

    y = np.array([xd_[0], 0.0, xd_[0], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    rec = np.zeros((12, n))
    v_a_hist = [0.0] * (computation_delay_samples + 1)      # v_a[j - d], ..., v_a[j]
    cmd_queue = [0.0] * delay_ticks                          # commands issued, not yet arrived
    v_a = v_ref = integ = e_prev = 0.0
    ic = 0.0                                                 # the current command in force
    for k in range(n):
        xd, vd, ad = float(xd_[k]), float(vd_[k]), float(ad_[k])
        fn, dv = accel(y, ic)
        fs = fn - mh * dv
        f_read = y[5] if filtered else fs
        current = ic if ideal else y[4]
        if k % n_a == 0:
            r = float(reading(f_read, resolution_n, bias_n, deadband_n))
            v_a = alpha * v_a + beta * r + beta_prev * r_prev
            r_prev = r
            v_a_hist = v_a_hist[1:] + [v_a]
            v_ref = v_a_hist[0]
        e = v_ref - measured(y)
        trial = integ + ki * T * (e + e_prev) / 2.0
        u = kp * e + trial
        if (u > imax and e > 0) or (u < -imax and e < 0):
            trial = integ
            u = kp * e + integ
        integ, e_prev = trial, e
        cmd = min(max(u, -imax), imax)
        rec[:, k] = (y[0], y[1], y[2], y[3], fs, leg(y, xd, vd, ad), current, v_ref, f_read, cmd, integ, 0.0)
        cmd_queue.append(cmd)
        ic = cmd_queue.pop(0)
        if k == n - 1:
            break
        sol = solve_ivp(rhs, (t[k], t[k + 1]), y, method=method, rtol=RTOL, atol=ATOL, args=(ic, xd, vd, ad))
        if not sol.success:
            raise RuntimeError(f"solve_ivp failed at tick {k}: {sol.message}")
        y = sol.y[:, -1].copy()
    return ReferenceTrace(t, rec[0], rec[1], rec[2], rec[3], rec[4], rec[5], rec[6], rec[7], rec[8], rec[9], rec[10])


def trapezoid_path(travel_m, peak_speed_m_per_s, acceleration_m_per_s2, rate_hz, rest_s, rest_after_s=None):
    """The intended path sampled at k / rate_hz: ``rest_s`` of rest, accelerate, run, decelerate, ``rest_after_s``
    (default ``rest_s``) of rest; exact positions; the acceleration at a tick is the one that holds right after
    it. Returns (t, x, v, a)."""
    a, vp, d = acceleration_m_per_s2, peak_speed_m_per_s, travel_m
    ta = vp / a
    if a * ta**2 > d:
        ta = math.sqrt(d / a)
        vp = a * ta
    tr = (d - a * ta**2) / vp
    total = 2 * ta + tr
    rest_after_s = rest_s if rest_after_s is None else rest_after_s
    n = int(round((total + rest_s + rest_after_s) * rate_hz)) + 1
    t = np.arange(n) / rate_hz
    tau = t - rest_s
    x, v, acc = np.zeros(n), np.zeros(n), np.zeros(n)
    for k, s in enumerate(tau):
        if s < 0:
            continue
        if s < ta:
            x[k], v[k], acc[k] = 0.5 * a * s * s, a * s, a
        elif s < ta + tr:
            x[k], v[k] = 0.5 * a * ta * ta + vp * (s - ta), vp
        elif s < total:
            q = total - s
            x[k], v[k], acc[k] = d - 0.5 * a * q * q, a * q, -a
        else:
            x[k] = d
    return t, x, v, acc
