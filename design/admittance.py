"""Admittance gains (m_v, b_v) for the mouse-following loop (thesis section 3.2, Figure 3.22).

Loop: the force sensor at the head clamp measures F_s; the virtual dynamics
Y_v = 1/(m_v s + b_v) (thesis Eq. 3.23 with k_v = 0; Eq. 3.24's m_v s^2 is a typo) turn it
into a velocity reference for the PI velocity loop C = kp + ki/s, which drives the current
loop and the gantry P; F_s also pushes the gantry directly (mechanical admittance
P_F = P / (K_t E), E the electrical lags). The gantry velocity is then v = H F_s with the
rendered admittance H = (P C Y_v + P_F) / (1 + P C).

The mouse is coupled at the clamp: head mass m_h beyond the sensor moves with the gantry,
the body m_b hangs on the neck (stiffness k_n, damping c_n) and is driven by the mouse's own
force F_m. With Z_n = k_n/s + c_n the clamp sees the impedance
Z_mouse = m_h s + m_b s Z_n / (m_b s + Z_n) and F_s = G F_m - Z_mouse v, so breaking the loop
at the force sensor gives the interaction loop gain L_int = Z_mouse H, whose phase and gain
margins (``design.margins``) must hold at every payload and every corner of the mouse ranges.

Objective: the peak resistance the mouse feels while running, m_v a_peak + b_v v_peak (the
virtual dynamics' force at the profile's peak acceleration and peak speed, an upper bound on
any profile reaching both). Constraints besides the margins: the motor force for the peak
mouse force, max_w |K_t E C (Y_v - H)| F_peak, within the motor's peak force; the current
caused by one force-sensor step, max_w |C (Y_v - H)| * resolution, below the spec limit.

Solution: for fixed b_v the margins and both hardware ratios improve monotonically with m_v
(a larger virtual mass lowers |Y_v| and with it the loop gain), so the least feasible m_v is
found by bisection, and the objective (increasing in both) is minimised over b_v by a scan
and a golden-section refinement on log b_v. The result is re-checked on 50 payloads x every
mouse corner on the 3000-point grid, and the coupled closed loop's poles are computed with
python-control (Pade for delays) at light, nominal and heavy payload.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass

import numpy as np

from design.margins import loop_margins
from design.spec import Spec, finite_or_none
from plant.errors import SpecError
from plant.grid import log_grid_rad_s

W_SEARCH = log_grid_rad_s(0.05, 5000.0, 400)
#: the search works a little inside the limits (margins + 0.5 deg / 0.2 dB, hardware ratios x 0.98)
#: so the design still meets them on the denser check grid
SEARCH_MARGIN = (0.5, 0.2, 0.98)
W_CHECK = log_grid_rad_s(1e-3, 1e4, 3000)
DENSE_PAYLOADS = 50


@dataclass(frozen=True)
class AdmittanceCheck:
    ok: bool
    worst_phase_margin_deg: float
    worst_gain_margin_db: float
    peak_motor_force_n: float
    current_per_sensor_step_a: float
    #: the tightest constraint and where
    binding: str


@dataclass(frozen=True)
class AdmittanceResult:
    status: str
    message: str
    m_v: float | None
    b_v: float | None
    kp: float
    ki: float
    peak_resistance_n: float | None
    rendered_bandwidth_hz: float | None
    check: AdmittanceCheck | None
    verified: bool
    max_pole_real_part: float | None
    seconds: float

    def to_dict(self) -> dict:
        c = self.check
        return {"status": self.status, "message": self.message, "m_v": self.m_v, "b_v": self.b_v,
                "kp": self.kp, "ki": self.ki, "peak_resistance_n": self.peak_resistance_n,
                "rendered_bandwidth_hz": finite_or_none(self.rendered_bandwidth_hz)
                if self.rendered_bandwidth_hz is not None else None,
                "worst_phase_margin_deg": finite_or_none(c.worst_phase_margin_deg) if c else None,
                "worst_gain_margin_db": finite_or_none(c.worst_gain_margin_db) if c else None,
                "peak_motor_force_n": c.peak_motor_force_n if c else None,
                "current_per_sensor_step_a": c.current_per_sensor_step_a if c else None,
                "binding": c.binding if c else None, "verified": self.verified,
                "max_closed_loop_pole_real_part": self.max_pole_real_part, "seconds": self.seconds,
                "method": "bisection on m_v (monotone margins) + golden-section search on log b_v; dense check"}


def mouse_corners(spec: Spec) -> np.ndarray:
    """Every corner of the mouse ranges: rows (m_h, m_b, k_n, c_n)."""
    m = spec.admittance.mouse
    ranges = [m.head_mass_kg, m.body_mass_kg, m.neck_stiffness_n_per_m, m.neck_damping_n_s_per_m]
    return np.array(list(itertools.product(*[(r.min, r.max) for r in ranges])))


def mouse_impedance(w_rad_s, corners: np.ndarray) -> np.ndarray:
    """Z_mouse(jw) = m_h s + m_b s Z_n / (m_b s + Z_n), Z_n = k_n/s + c_n; shape (n_corners, n_freq), N per m/s."""
    s = 1j * np.asarray(w_rad_s)
    mh, mb, kn, cn = (corners[:, k:k + 1] for k in range(4))
    zn = kn / s + cn
    return mh * s + mb * s * zn / (mb * s + zn)


def _grid(spec: Spec, base: np.ndarray, points: int) -> np.ndarray:
    """``base`` plus ``points`` points within +-15 % of every body-neck resonance sqrt(k_n / m_b)
    of the mouse corners (lightly damped: a coarse grid would step over them)."""
    c = mouse_corners(spec)
    wn = np.unique(np.sqrt(c[:, 2] / c[:, 1]))
    local = [wr * np.linspace(0.85, 1.15, points) for wr in wn]
    return np.unique(np.concatenate([base, *local]))


class _Loops:
    """Frequency responses that do not depend on (m_v, b_v), for a set of payloads."""

    def __init__(self, spec: Spec, kp: float, ki: float, payload_kg, w):
        plant = spec.plant.plant().with_payload(payload_kg)
        self.w = w
        s = 1j * w
        self.P = plant.frd(w)
        electrical = np.ones_like(w, dtype=complex)
        for e in plant.effects:
            if e.name in ("delay", "current_loop", "sampling"):
                electrical = electrical * e.frd(w)
        self.kt = float(spec.plant.force_constant_n_per_a)
        self.E = electrical
        self.PF = self.P / (self.kt * electrical)
        self.C = kp + ki / s
        self.Z = mouse_impedance(w, mouse_corners(spec))
        self.payload_kg = np.asarray(payload_kg, float)

    def responses(self, m_v: float, b_v: float):
        yv = 1.0 / (m_v * 1j * self.w + b_v)
        PC = self.P * self.C
        H = (PC * yv + self.PF) / (1 + PC)
        return yv, H

    def check(self, spec: Spec, m_v: float, b_v: float, *, inside: tuple = (0.0, 0.0, 1.0)) -> AdmittanceCheck:
        """Constraints at (m_v, b_v); ``inside`` tightens them (deg, dB, factor on the hardware limits)."""
        a = spec.admittance
        d_pm, d_gm, f_hw = inside
        yv, H = self.responses(m_v, b_v)
        L = self.Z[None, :, :] * H[:, None, :]
        mg = loop_margins(self.w, L)
        pm, gm = mg.phase_margin_deg, mg.gain_margin_db
        current = np.max(np.abs(self.C * (yv - H)), axis=-1) * a.force_sensor_resolution_n
        force = np.max(np.abs(self.kt * self.E * self.C * (yv - H)), axis=-1) * a.locomotion.peak_force_n
        slacks = {
            "interaction phase margin": (pm - a.phase_margin_deg - d_pm) / max(a.phase_margin_deg, 1.0),
            "interaction gain margin": (np.where(np.isfinite(gm), gm, np.inf) - a.gain_margin_db - d_gm)
            / max(a.gain_margin_db, 1.0),
            "motor peak force": (f_hw * a.motor_peak_force_n - force) / a.motor_peak_force_n,
            "current per force-sensor step": (f_hw * a.current_per_sensor_step_max_a - current)
            / a.current_per_sensor_step_max_a,
        }
        worst = {k: float(np.min(v)) for k, v in slacks.items()}
        name = min(worst, key=worst.get)
        idx = np.unravel_index(int(np.argmin(slacks[name])), np.shape(slacks[name]))
        where = f"{self.payload_kg[idx[0]]:.1f} kg"
        if np.ndim(slacks[name]) == 2:
            mh, mb, kn, cn = mouse_corners(spec)[idx[1]]
            where += f", mouse head {1e3 * mh:g} g, body {1e3 * mb:g} g, neck {kn:g} N/m, {cn:g} N*s/m"
        return AdmittanceCheck(all(v >= -1e-9 for v in worst.values()), float(np.min(pm)), float(np.min(gm)),
                               float(np.max(force)), float(np.max(current)), f"{name} at {where}")


def rendered_bandwidth_hz(loops: _Loops, m_v: float, b_v: float) -> float:
    """Lowest (over payloads) first frequency where H departs from Y_v by 3 dB or 30 deg."""
    yv, H = loops.responses(m_v, b_v)
    r = H / yv
    bad = (np.abs(20 * np.log10(np.abs(r))) > 3) | (np.abs(np.degrees(np.angle(r))) > 30)
    first = np.where(bad.any(axis=-1), loops.w[np.argmax(bad, axis=-1)], np.inf)
    return float(np.min(first)) / (2 * math.pi)


def _least_mass(loops: _Loops, spec: Spec, b_v: float) -> float | None:
    a = spec.admittance
    lo, hi = math.log(a.m_v.min), math.log(a.m_v.max)
    if not loops.check(spec, a.m_v.max, b_v, inside=SEARCH_MARGIN).ok:
        return None
    if loops.check(spec, a.m_v.min, b_v, inside=SEARCH_MARGIN).ok:
        return a.m_v.min
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        if loops.check(spec, math.exp(mid), b_v, inside=SEARCH_MARGIN).ok:
            hi = mid
        else:
            lo = mid
        if hi - lo < 2e-3:
            break
    return math.exp(hi)


def _coupled_poles(spec: Spec, kp: float, ki: float, m_v: float, b_v: float) -> float:
    """Largest real part of the coupled gantry-mouse closed-loop poles (python-control, Pade)."""
    import control

    s = control.tf("s")
    worst = -math.inf
    rng = spec.plant.payload_kg
    for m in sorted({rng.min, rng.nominal_kg, rng.max}):
        plant = spec.plant.plant().with_payload(m)
        P = plant.to_control()
        electrical = control.tf([1], [1])
        for e in plant.effects:
            if e.name in ("delay", "current_loop", "sampling"):
                electrical = electrical * e.to_tf()
        kt = float(spec.plant.force_constant_n_per_a)
        PF = control.minreal(P / (kt * electrical), verbose=False)
        C = (kp * s + ki) / s
        H = (P * C / (m_v * s + b_v) + PF) / (1 + P * C)
        for mh, mb, kn, cn in mouse_corners(spec):
            Zn = (cn * s + kn) / s
            Z = mh * s + mb * s * Zn / (mb * s + Zn)
            T = control.feedback(control.minreal(Z * H, verbose=False), 1)
            worst = max(worst, float(np.max(np.real(control.poles(T)))))
    return worst


def synthesise_admittance(spec: Spec, *, kp: float, ki: float) -> AdmittanceResult:
    """Least-resistance (m_v, b_v) meeting the interaction margins and hardware limits (module doc)."""
    if spec.admittance is None:
        raise SpecError("the spec has no [admittance] section")
    t0 = time.perf_counter()
    a = spec.admittance
    rng = spec.plant.payload_kg
    search = _Loops(spec, kp, ki, rng.grid() if rng.max > rng.min else [rng.min], _grid(spec, W_SEARCH, 60))
    cost = lambda m_v, b_v: m_v * a.locomotion.peak_acceleration_m_per_s2 + b_v * a.locomotion.peak_speed_m_per_s  # noqa: E731
    scan = np.geomspace(a.b_v.min, a.b_v.max, 12)
    results = [(b, _least_mass(search, spec, b)) for b in scan]
    feasible = [(cost(m, b), m, b) for b, m in results if m is not None]
    if not feasible:
        chk = search.check(spec, a.m_v.max, a.b_v.max)
        return AdmittanceResult("infeasible", f"no (m_v, b_v) within admittance.m_v / admittance.b_v meets the "
                                f"constraints; even m_v = {a.m_v.max:g} kg, b_v = {a.b_v.max:g} N*s/m fails: "
                                f"{chk.binding}", None, None, kp, ki, None, None, chk, False, None,
                                time.perf_counter() - t0)
    _, m_best, b_best = min(feasible)
    # golden-section refinement on log b_v around the best scan point
    k = int(np.argmin([abs(math.log(b / b_best)) for b in scan]))
    lo, hi = math.log(scan[max(k - 1, 0)]), math.log(scan[min(k + 1, len(scan) - 1)])

    def f(lb):
        m = _least_mass(search, spec, math.exp(lb))
        return math.inf if m is None else cost(m, math.exp(lb))

    g = (math.sqrt(5) - 1) / 2
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, f2 = f(x1), f(x2)
    for _ in range(8):
        if f1 <= f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - g * (hi - lo)
            f1 = f(x1)
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + g * (hi - lo)
            f2 = f(x2)
    for lb in (x1, x2):
        m = _least_mass(search, spec, math.exp(lb))
        if m is not None and cost(m, math.exp(lb)) < cost(m_best, b_best):
            m_best, b_best = m, math.exp(lb)
    seconds = time.perf_counter() - t0
    dense = _Loops(spec, kp, ki, np.linspace(rng.min, rng.max, DENSE_PAYLOADS) if rng.max > rng.min else [rng.min],
                   _grid(spec, W_CHECK, 300))
    chk = dense.check(spec, m_best, b_best)
    max_re = _coupled_poles(spec, kp, ki, m_best, b_best)
    verified = chk.ok and max_re < 0
    status = "optimal" if verified else "infeasible"
    message = "verified on the dense check and by the coupled closed-loop poles" if verified else (
        f"the design failed the dense check: {chk.binding} (worst PM {chk.worst_phase_margin_deg:.2f} deg), "
        f"largest pole real part {max_re:.3g}")
    return AdmittanceResult(status, message, m_best, b_best, kp, ki, cost(m_best, b_best),
                            rendered_bandwidth_hz(dense, m_best, b_best), chk, verified, max_re, seconds)
