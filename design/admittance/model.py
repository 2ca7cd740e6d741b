"""The coupled gantry-mouse system of admittance control, and its exact evaluation on a grid.

Physics (thesis section 3.2, Eq. 3.21-3.23 with k_v = 0, Figure 3.22; SI units, s = jw)
--------------------------------------------------------------------------------------
Gantry (one axis): velocity v of the moving mass, motor force F_m = K_t E i (E: the electrical
effects delay / current loop / sampling), sensed force F_s at the head clamp. The mechanical
mobility G = v / force on the moving mass (1/(M s + b) for Stage X, Eq. 3.15 divided by K_t;
resonances included) gives the plant P = K_t E G (current in, velocity out)::

    v = G (F_s + F_m)               the sensed force is a physical force on the gantry
    F_m = K_t E C (Y_v F_s - v)     PI velocity loop C = Kp + Ki/s on the reference Y_v F_s
    Y_v = 1 / (m_v s + b_v)         virtual dynamics (Eq. 3.23 with k_v = 0; Eq. 3.24 as printed,
                                    1/(m_v s^2 + b_v), is a typo)

With S = 1/(1 + P C), T = P C S the rendered admittance (velocity per sensed force) is
Y_r = S G + T Y_v (``design.loop.loops.rendered_admittance_frd``): Y_v where T = 1, the bare gantry G
where T = 0.

Mouse at the clamp: head mass m_h beyond the sensor (moves with the clamp), body mass m_b on the
neck (stiffness k_n, damping c_n), driven by its legs with F_leg. With Z_n = c_n + k_n/s::

    F_s = H_n F_leg - Z_m v,   Z_m = m_h s + m_b s Z_n / (m_b s + Z_n)    (N*s/m, passive)

Interaction loop, broken at the force-sensor *signal* (the controller's input): a signal u into
Y_v moves the gantry, which, loaded by the mouse (F_s = -Z_m v), returns F_s = -L u with::

    L = K / (m_v s + b_v),   K = Z_m P C / D,   D = 1 + P C + G Z_m

(D: the velocity loop with the mouse attached). 1 + L = 0 is the coupled system's characteristic
equation (D (1 + L) = (1 + P C)(1 + Y_r Z_m)); Nyquist needs D stable, checked on the rational
model (``design.admittance.verify``). Scaling L scales Y_v, so the gain margin is the factor by
which m_v and b_v could shrink together. In the band where T = 1, L = Z_m / (m_v s + b_v): the
mouse-to-virtual impedance ratio.

Hardware (peaks over frequency, i.e. the steady amplitude at the worst sinusoid):
* motor force per sensed force F_m / F_s = T (Y_v / G - 1) (~ M / m_v - 1 in band), times the
  mouse's peak force, within the motor's peak force;
* a force-reading error n of one resolution step drives the controller but no physical force:
  i / n = C S Y_v (free gantry); DC b / (K_t b_v), in band M / (K_t m_v); times the resolution,
  within the spec's current limit.
"""

from __future__ import annotations

import itertools
import math
import warnings
from dataclasses import dataclass

import numpy as np

from design.loop.analysis import ANALYSIS_GRID_RAD_S
from design.loop.loops import pi_frd
from design.loop.margins import loop_margins, nyquist_stable, unwrapped_phase_deg
from design.problem import AdmittanceProblem, LoopProblem
from design.synth.scenarios import Scenarios
from plant.effects import EFFECTS
from plant.errors import SpecError
from plant.grid import check_grid
from plant.models import Plant

#: the dense check's frequency grid: 1 mHz - 10 kHz, 3000 points (plus points around the neck modes)
W_DENSE = ANALYSIS_GRID_RAD_S
#: the rendered admittance departs from 1/(m_v s + b_v) by this much at its bandwidth
BANDWIDTH_GAIN_DB = 3.0
BANDWIDTH_PHASE_DEG = 30.0


@dataclass(frozen=True)
class MouseModel:
    """Mouse at the head clamp: head beyond the sensor, body through the neck (SI units)."""

    head_mass_kg: float
    body_mass_kg: float
    neck_stiffness_n_per_m: float
    neck_damping_n_s_per_m: float

    def impedance_frd(self, w_rad_s) -> np.ndarray:
        """Z_m = m_h s + m_b s Z_n / (m_b s + Z_n), Z_n = c_n + k_n/s: force per velocity (N*s/m)."""
        s = 1j * np.asarray(w_rad_s, float)
        zn = self.neck_damping_n_s_per_m + self.neck_stiffness_n_per_m / s
        return self.head_mass_kg * s + self.body_mass_kg * s * zn / (self.body_mass_kg * s + zn)

    def impedance_polys(self) -> tuple[np.ndarray, np.ndarray]:
        """Z_m as numerator / denominator polynomials in s (highest power first)."""
        mh, mb = self.head_mass_kg, self.body_mass_kg
        c, k = self.neck_damping_n_s_per_m, self.neck_stiffness_n_per_m
        return np.array([mh * mb, (mh + mb) * c, (mh + mb) * k, 0.0]), np.array([mb, c, k])

    def neck_mode_rad_s(self) -> float:
        """Natural frequency of the body on the neck, sqrt(k_n / m_b) (rad/s)."""
        return math.sqrt(self.neck_stiffness_n_per_m / self.body_mass_kg)

    def as_dict(self) -> dict:
        return {"head_mass_kg": self.head_mass_kg, "body_mass_kg": self.body_mass_kg,
                "neck_stiffness_n_per_m": self.neck_stiffness_n_per_m,
                "neck_damping_n_s_per_m": self.neck_damping_n_s_per_m}

    def label(self) -> str:
        return (f"head {self.head_mass_kg * 1e3:g} g, body {self.body_mass_kg * 1e3:g} g, neck "
                f"{self.neck_stiffness_n_per_m:g} N/m, {self.neck_damping_n_s_per_m:g} N*s/m")


def admittance_problem(problem: LoopProblem) -> AdmittanceProblem:
    """The spec's ``[admittance]`` section; SpecError when missing or the plant is nonlinear."""
    if problem.admittance is None:
        raise SpecError("spec has no [admittance] section")
    nonlinear = [n for n in problem.plant.effects if n in EFFECTS and not EFFECTS[n].linear]
    if nonlinear:
        raise SpecError(f"plant.effects.{nonlinear[0]}: nonlinear, not supported by admittance synthesis "
                        "(design on the linear plant; check friction with gantry simulate)")
    return problem.admittance


def mouse_corners(problem: LoopProblem) -> tuple[MouseModel, ...]:
    """Every corner of the spec's mouse ranges (up to 16)."""
    m = admittance_problem(problem).mouse
    return tuple(MouseModel(*c) for c in itertools.product(
        m.head_mass_kg.corners(), m.body_mass_kg.corners(), m.neck_stiffness_n_per_m.corners(),
        m.neck_damping_n_s_per_m.corners()))


def with_neck_modes(w_rad_s: np.ndarray, corners, *, points: int = 60) -> np.ndarray:
    """``w_rad_s`` plus ``points`` points within +-20 % of every neck mode (lightly damped: a log
    grid of a few points per decade would step over its peak)."""
    local = [mouse.neck_mode_rad_s() * np.linspace(0.8, 1.2, points) for mouse in corners]
    return np.unique(np.concatenate([np.asarray(w_rad_s, float), *local]))


def as_scenarios(scenarios) -> Scenarios:
    """``Scenarios`` as given, or payloads (kg) with the nominal parameters."""
    if isinstance(scenarios, Scenarios):
        return scenarios
    return Scenarios(np.atleast_1d(np.asarray(scenarios, float)))


@dataclass(frozen=True)
class GantryLoop:
    """Free gantry under the PI velocity loop on a grid, batch over scenarios (axis 0): payloads
    with the values of the uncertain parameters."""

    w_rad_s: np.ndarray
    scenarios: Scenarios
    plant: np.ndarray          # P, velocity per current (m/s per A), (n_scenario, n_freq)
    mobility: np.ndarray       # G, velocity per force on the moving mass (m/s per N)
    controller: np.ndarray     # C = Kp + Ki/s (A per m/s), (n_freq,)
    sensitivity: np.ndarray    # S = 1/(1 + P C)
    complementary: np.ndarray  # T = P C / (1 + P C)

    @property
    def payload_kg(self) -> np.ndarray:
        return self.scenarios.payload_kg


def mechanical_plant(plant: Plant) -> Plant:
    """The plant without its drive effects: K_t G (velocity per current before the drive)."""
    return plant.with_effects(*[e for e in plant.effects if e.place != "drive"])


def gantry_loop(problem: LoopProblem, w_rad_s, scenarios, *, kp: float, ki: float) -> GantryLoop:
    """P, G, C, S, T of the spec's plant in ``scenarios`` (``Scenarios``, or payloads in kg with the
    nominal parameters) on ``w_rad_s``."""
    w = check_grid(w_rad_s)
    s = as_scenarios(scenarios)
    plant = s.plants(problem.plant.plant())
    P = np.broadcast_to(plant.frd(w), (len(s), w.size))
    G = np.broadcast_to(mechanical_plant(plant).frd(w) / np.asarray(plant.force_constant_n_per_a, float), P.shape)
    C = pi_frd(w, kp, ki)
    S = 1.0 / (1.0 + P * C)
    return GantryLoop(w, s, P, G, C, S, 1.0 - S)


def virtual_impedance_frd(w_rad_s, m_v, b_v) -> np.ndarray:
    """z = m_v s + b_v, the inverse of the virtual dynamics Y_v (N*s/m)."""
    return np.asarray(m_v) * 1j * np.asarray(w_rad_s) + np.asarray(b_v)


def rendered_admittance(loop: GantryLoop, m_v: float, b_v: float) -> np.ndarray:
    """Y_r = v / F_s = S G + T / (m_v s + b_v) (m/s per N)."""
    return loop.sensitivity * loop.mobility + loop.complementary / virtual_impedance_frd(loop.w_rad_s, m_v, b_v)


def interaction_gain(loop: GantryLoop, mouse: MouseModel) -> np.ndarray:
    """K = Z_m P C / (1 + P C + G Z_m), so that the interaction loop is L = K / (m_v s + b_v)."""
    zm = mouse.impedance_frd(loop.w_rad_s)
    pc = loop.plant * loop.controller
    return zm * pc / (1.0 + pc + loop.mobility * zm)


def sensor_current_per_newton(loop: GantryLoop, m_v: float, b_v: float) -> np.ndarray:
    """Motor current per force-reading error, C S / (m_v s + b_v) (A per N)."""
    return loop.controller * loop.sensitivity / virtual_impedance_frd(loop.w_rad_s, m_v, b_v)


def motor_force_per_newton(loop: GantryLoop, m_v: float, b_v: float) -> np.ndarray:
    """Motor force per sensed force, T (Y_v / G - 1) (N per N)."""
    z = virtual_impedance_frd(loop.w_rad_s, m_v, b_v)
    return loop.complementary * (1.0 / (loop.mobility * z) - 1.0)


def peak_resistance_n(m_v: float, b_v: float, *, peak_speed_m_per_s: float, peak_acceleration_m_per_s2: float) -> float:
    """m_v a_pk + b_v v_pk: the virtual dynamics' force at the end of the acceleration phase of a
    trapezoidal profile, where peak acceleration and peak speed meet (N)."""
    return m_v * peak_acceleration_m_per_s2 + b_v * peak_speed_m_per_s


def admittance_bandwidth_hz(w_rad_s, rendered, virtual) -> np.ndarray:
    """First frequency (Hz) where ``rendered`` departs from ``virtual`` by 3 dB or 30 deg
    (interpolated in log-frequency); nan when it never does on the grid. Shapes (..., n_freq)."""
    w = check_grid(w_rad_s)
    ratio = np.asarray(rendered) / np.asarray(virtual)
    dev = np.maximum(np.abs(20 * np.log10(np.abs(ratio))) / BANDWIDTH_GAIN_DB,
                     np.abs(unwrapped_phase_deg(ratio)) / BANDWIDTH_PHASE_DEG) - 1.0
    over = dev >= 0
    i = np.argmax(over, axis=-1)
    found = np.take_along_axis(over, i[..., None], -1)[..., 0]
    i0 = np.maximum(i - 1, 0)
    d0 = np.take_along_axis(dev, i0[..., None], -1)[..., 0]
    d1 = np.take_along_axis(dev, i[..., None], -1)[..., 0]
    t = np.clip(np.divide(d0, d0 - d1, out=np.zeros_like(d0), where=d1 != d0), 0.0, 1.0)
    lw = np.log(w)
    f = np.exp(lw[i0] + t * (lw[i] - lw[i0])) / (2 * np.pi)
    return np.where(found & (i > 0), f, np.where(found, w[0] / (2 * np.pi), np.nan))


# --- exact evaluation ------------------------------------------------------------------------------
@dataclass(frozen=True)
class AdmittanceCheck:
    """(m_v, b_v) evaluated exactly on a grid: scenarios (payload x uncertain parameters) x mouse
    corners x frequencies."""

    m_v: float
    b_v: float
    scenarios: Scenarios
    #: grid margins (cubic-refined crossings) of the interaction loop, (n_corner, n_scenario)
    phase_margin_deg: np.ndarray
    gain_margin_db: np.ndarray
    #: the coupled loop and the velocity loop with the mouse attached are stable (Nyquist on the grid),
    #: (n_corner, n_scenario)
    stable: np.ndarray
    #: motor current per force-sensor step, peak over frequency (A), (n_scenario,)
    sensor_current_a: np.ndarray
    #: motor force for the spec's peak mouse force, peak over frequency (N), (n_scenario,)
    motor_force_n: np.ndarray
    rendered_bandwidth_hz: np.ndarray
    #: frequencies (Hz) of those peaks, (n_scenario,)
    sensor_peak_hz: np.ndarray
    motor_peak_hz: np.ndarray
    #: each violated requirement as {"constraint", "payload_kg", "scenario", "mouse", "value", "limit", "detail"}
    violations: tuple[dict, ...]

    @property
    def meets(self) -> bool:
        return not self.violations

    @property
    def payload_kg(self) -> np.ndarray:
        return self.scenarios.payload_kg

    def slack(self, adm: AdmittanceProblem) -> np.ndarray:
        """Least relative slack of every requirement per scenario (n_scenario,): < 0 violates."""
        hw = adm.hardware
        return np.min(np.stack([
            (np.min(self.phase_margin_deg, axis=0) - adm.phase_margin_deg) / max(adm.phase_margin_deg, 1.0),
            (np.min(self.gain_margin_db, axis=0) - adm.gain_margin_db) / max(adm.gain_margin_db, 1.0),
            1 - self.sensor_current_a / hw.max_current_per_sensor_step_a,
            1 - self.motor_force_n / hw.motor_peak_force_n]), axis=0)

    def per_payload(self) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """The payloads and, at each, the worst over its scenarios and the mouse corners of: phase_margin_deg,
        gain_margin_db, rendered_bandwidth_hz (min) and sensor_current_a, motor_force_n (max)."""
        m = np.unique(self.payload_kg)
        idx = [np.flatnonzero(self.payload_kg == mk) for mk in m]
        worst = {"phase_margin_deg": (np.min(self.phase_margin_deg, axis=0), np.min),
                 "gain_margin_db": (np.min(self.gain_margin_db, axis=0), np.min),
                 "rendered_bandwidth_hz": (self.rendered_bandwidth_hz, np.nanmin),
                 "sensor_current_a": (self.sensor_current_a, np.max), "motor_force_n": (self.motor_force_n, np.max)}
        out = {}
        for name, (v, f) in worst.items():
            with warnings.catch_warnings():      # all-nan bandwidth at a payload: nan
                warnings.simplefilter("ignore", RuntimeWarning)
                out[name] = np.array([f(v[i]) for i in idx])
        return m, out


class AdmittanceEvaluator:
    """Exact evaluation of any (m_v, b_v) for fixed PI gains: the responses that do not depend on
    (m_v, b_v) are computed once, so a search can evaluate many candidates cheaply."""

    def __init__(self, problem: LoopProblem, scenarios, w_rad_s, *, kp: float, ki: float):
        self.problem = problem
        self.adm = admittance_problem(problem)
        self.corners = mouse_corners(problem)
        self.loop = gantry_loop(problem, with_neck_modes(w_rad_s, self.corners), scenarios, kp=kp, ki=ki)
        self.gains = np.stack([interaction_gain(self.loop, mouse) for mouse in self.corners])
        # D = (1 + P C)(1 + S G Z_m): the velocity loop with the mouse attached, which the Nyquist test
        # of the interaction loop assumes stable
        self.attached_stable = np.stack([nyquist_stable(self.loop.sensitivity * self.loop.mobility
                                                        * mouse.impedance_frd(self.loop.w_rad_s))
                                         for mouse in self.corners])

    def evaluate(self, m_v: float, b_v: float, *, bandwidth: bool = True) -> AdmittanceCheck:
        loop, hw = self.loop, self.adm.hardware
        w = loop.w_rad_s
        z = virtual_impedance_frd(w, m_v, b_v)
        mg = loop_margins(w, self.gains / z)
        i_resp = np.abs(loop.controller * loop.sensitivity / z) * hw.force_sensor_resolution_n
        f_resp = np.abs(loop.complementary * (1.0 / (loop.mobility * z) - 1.0)) * self.adm.mouse.peak_force_n
        bw = (admittance_bandwidth_hz(w, rendered_admittance(loop, m_v, b_v), 1.0 / z) if bandwidth
              else np.full(loop.payload_kg.shape, np.nan))
        fhz = w / (2 * np.pi)
        check = AdmittanceCheck(float(m_v), float(b_v), loop.scenarios, mg.phase_margin_deg, mg.gain_margin_db,
                                mg.closed_loop_stable & self.attached_stable, i_resp.max(-1), f_resp.max(-1), bw,
                                fhz[i_resp.argmax(-1)], fhz[f_resp.argmax(-1)], ())
        return AdmittanceCheck(**{**check.__dict__, "violations": self._violations(check)})

    def _violations(self, c: AdmittanceCheck) -> tuple[dict, ...]:
        adm, hw = self.adm, self.adm.hardware
        out = []
        for j, mk in enumerate(c.payload_kg):
            where, row = c.scenarios.describe(j), c.scenarios.row(j)
            if c.sensor_current_a[j] > hw.max_current_per_sensor_step_a * (1 + 1e-6):
                out.append({"constraint": "sensor_current", "payload_kg": float(mk), "scenario": row, "mouse": None,
                            "value": float(c.sensor_current_a[j]), "limit": hw.max_current_per_sensor_step_a,
                            "detail": f"one force-sensor step ({hw.force_sensor_resolution_n * 1e3:g} mN) drives "
                                      f"{c.sensor_current_a[j]:.4g} A (admittance.hardware."
                                      f"max_current_per_sensor_step_a = {hw.max_current_per_sensor_step_a:g} A) at "
                                      f"{where}, {c.sensor_peak_hz[j]:.3g} Hz"})
            if c.motor_force_n[j] > hw.motor_peak_force_n * (1 + 1e-6):
                out.append({"constraint": "motor_force", "payload_kg": float(mk), "scenario": row, "mouse": None,
                            "value": float(c.motor_force_n[j]), "limit": hw.motor_peak_force_n,
                            "detail": f"a {adm.mouse.peak_force_n:g} N mouse force asks {c.motor_force_n[j]:.4g} N of "
                                      f"the motor (admittance.hardware.motor_peak_force_n = "
                                      f"{hw.motor_peak_force_n:g} N) at {where}, {c.motor_peak_hz[j]:.3g} Hz"})
            for k, mouse in enumerate(self.corners):
                if not c.stable[k, j]:
                    out.append({"constraint": "stability", "payload_kg": float(mk), "scenario": row,
                                "mouse": mouse.as_dict(), "value": float("nan"), "limit": float("nan"),
                                "detail": f"the coupled gantry-mouse loop is unstable at {where} with mouse "
                                          f"({mouse.label()})"})
                    continue
                for name, val, req, unit in (("phase_margin", c.phase_margin_deg[k, j], adm.phase_margin_deg, "deg"),
                                             ("gain_margin", c.gain_margin_db[k, j], adm.gain_margin_db, "dB")):
                    if val < req - 1e-6:
                        out.append({"constraint": name, "payload_kg": float(mk), "scenario": row,
                                    "mouse": mouse.as_dict(),
                                    "value": float(val), "limit": req,
                                    "detail": f"interaction-loop {name.replace('_', ' ')} {val:.3g} {unit} "
                                              f"(admittance.{name}_{unit.lower()} = {req:g}) at {where} with "
                                              f"mouse ({mouse.label()})"})
        return tuple(out)
