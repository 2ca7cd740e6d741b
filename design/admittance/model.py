"""The coupled gantry-mouse system of admittance control, and its exact evaluation on a grid.

Physics (thesis section 3.2, Eq. 3.21-3.23 with k_v = 0, Figure 3.22; SI units, s = jw)
--------------------------------------------------------------------------------------
Gantry (one axis): physical velocity v of the moving mass, G its mechanical mobility (velocity per
force, 1/(M s + b) for Stage X; resonances included), motor force F_m = K_t E i (E: the drive's
effects: delay, current loop, sampling), the drive measures H v (H: the sensor's effects), and the
sensed force F_s at the head clamp is a physical force on the gantry. The plant as identified is
P = K_t E G H (current in, measured velocity out)::

    v = G (F_s + F_m),   F_m = K_t E C (v_ref - H v),   C = Kp + Ki/s (PI velocity loop)

With S = 1/(1 + P C) and the physical velocity per reference R = K_t E C G S (R = T = P C S when
H = 1): v = S G F_s + R v_ref. The admittance law turns the sensed force into the reference,
v_ref = W Y_v F_s, with Y_v = 1/(m_v s + b_v) (continuous) or the law's rule at the rig's update rate, and
W the force filter, hold and computation delay (``design.admittance.rig``).
The rendered admittance is Y_r = v / F_s = S G + R W Y_v (its fundamental when sampled).

Mouse at the clamp (``design.admittance.mouse``): F_s = F_mouse - Z_m v. Broken at the force-sensor
*signal* (the controller's input), a reference u moves the gantry, which, loaded by the mouse,
returns F_s = -K u with::

    K = Z_m R / (1 + S G Z_m),   L = W K Y_v   (continuous)

and, sampled, L = e^(-jwdT) K_d Y_v with K_d the step-invariant transform of H_f K.
(1 + P C)(1 + S G Z_m) = 1 + P C + G Z_m is the velocity loop with the mouse attached, which the
Nyquist test of the interaction loop assumes stable (checked here on the grid and on the rational
model by ``design.admittance.verify``). Scaling L scales 1/(m_v, b_v): the gain margin is the factor
by which m_v and b_v could shrink together.

Hardware and sensor (peaks over frequency, i.e. the steady amplitude at the worst sinusoid):
* motor force per sensed force F_m / F_s = Y_r / G - 1, times the mouse's peak force, within the
  motor's peak force;
* a force-reading error n drives the controller but no physical force: i / n = C S W Y_v
  (free gantry); times one resolution step, within the optional current limit;
* drift at rest: an offset beta left after taring, beyond the deadband d (readings within it are
  zero, beyond it pass unchanged), is integrated by the law to the steady speed beta / b_v (the DC
  value of Y_r is 1/b_v: integral action, and W = 1 at DC).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from design.admittance.bounds import curve_bounds, polar
from design.admittance.mouse import MouseModel, mouse_set, stack
from design.admittance.profile import FeltForce
from design.admittance.recorded import RecordedMotor
from design.admittance.rig import RigTiming, VirtualImpedance, force_filter_frd
from design.admittance.sampled import (
    SampledPaths,
    closed_loop_radius,
    free_gantry,
    mice_paths,
    pade_order_for,
    sampled_gain,
)
from design.loop.controller import PI
from design.loop.margins import loop_margins, nyquist_stable, unwrapped_phase_deg
from design.loop.requirement import Binding
from design.parallel import thread_map, workers
from design.problem import AdmittanceProblem, LoopProblem
from design.synth.scenarios import Scenarios
from plant.errors import SpecError
from plant.grid import check_grid, log_grid_rad_s
from plant.physics.effects import EFFECTS
from plant.physics.models import Plant

#: the continuous loop's check grid: 1 mHz - 3 kHz, 1200 points (plus points around the mouse's modes)
W_CHECK = log_grid_rad_s(1e-3, 3000.0, 1200)
#: the grid of the attached velocity loop's Nyquist test and of the passive band (plus the mouse's modes)
W_ATTACHED = log_grid_rad_s(1e-3, 3000.0, 500)
#: the rendered admittance departs from the virtual dynamics by this much at its bandwidth
BANDWIDTH_GAIN_DB = 3.0
BANDWIDTH_PHASE_DEG = 30.0
#: points per decade of the sampled loop's grid, which ends at the Nyquist frequency
SAMPLED_POINTS_PER_DECADE = 120
#: scenarios are evaluated in blocks of at most this many mice x scenarios x frequencies over all threads
#: working at once (memory)
CHUNK_ELEMENTS = 2_000_000
#: the screened check computes exact margins for the SCREEN_TOP mice with the largest ray bound at each
#: scenario and for every curve whose bound is within SCREEN_RATIO of the design's b_v; the screen's grid (its
#: fifth of slack covers the interpolation between its points)
SCREEN_TOP, SCREEN_RATIO = 2, 0.8
SCREEN_POINTS_PER_DECADE = 60
#: curves (mouse x scenario) whose exact K_eff an evaluator keeps between evaluations (memory: each is one grid)
KEPT_CURVES = 12_000


def admittance_problem(problem: LoopProblem) -> AdmittanceProblem:
    """The spec's ``[admittance]`` section; SpecError when missing or the plant is nonlinear."""
    if problem.admittance is None:
        raise SpecError("spec has no [admittance] section")
    nonlinear = [n for n in problem.plant.effects if n in EFFECTS and not EFFECTS[n].linear]
    if nonlinear:
        raise SpecError(f"plant.effects.{nonlinear[0]}: nonlinear, not supported by admittance synthesis "
                        "(design on the linear plant; check friction with gantry mouse-run)")
    return problem.admittance


def mice(problem: LoopProblem) -> tuple[MouseModel, ...]:
    """The mice every design holds for (``design.admittance.mouse.mouse_set``)."""
    return mouse_set(admittance_problem(problem).mouse)


def as_scenarios(scenarios):
    """A scenario set as given, or payloads (kg: a number, list or array) with the nominal parameters."""
    if isinstance(scenarios, (int, float, list, tuple, np.ndarray)):
        return Scenarios(np.atleast_1d(np.asarray(scenarios, float)))
    return scenarios


def with_mode_points(w_rad_s, corners, timing: RigTiming, *, points: int = 16) -> np.ndarray:
    """``w_rad_s`` plus ``points`` points within +-20 % of every mouse mode (lightly damped: a log grid of
    a few points per decade steps over its peak), folded below the Nyquist frequency when sampled."""
    w = np.asarray(w_rad_s, float)
    modes = np.unique([m.mode_rad_s() for m in corners])
    local = (modes[:, None] * np.linspace(0.8, 1.2, points)).ravel()
    local = timing.folded_rad_s(local)
    local = local[(local > w[0]) & (local < w[-1])]
    return np.unique(np.concatenate([w, local]))


def check_grid_for(timing: RigTiming, *, per_decade: int = SAMPLED_POINTS_PER_DECADE) -> np.ndarray:
    """The interaction loop's grid: ``W_CHECK`` (continuous), or 1 mHz up to the Nyquist frequency with
    ``per_decade`` points per decade."""
    if not timing.sampled:
        return W_CHECK
    top = timing.nyquist_rad_s
    n = int(per_decade * math.log10(top / 2e-3 / math.pi)) + 2
    return np.geomspace(2e-3 * math.pi, top, n)


@dataclass(frozen=True)
class GantryLoop:
    """The free gantry under its velocity loops, seen from the head clamp, at complex frequencies ``s``
    (shape (n,)), batch over scenarios (axis 0): arrays (n_scenario, n), and per motor (n_motor, n_scenario, n).
    One motor (Stage X, PI C): S G, R = K_t E C G S, current C S, motor force S - 1 and K_t E C S; several
    (``design.admittance.dual``): the same quantities of the multivariable loop."""

    s: np.ndarray
    scenarios: object
    #: clamp velocity per sensed force with the velocity reference held at 0 (m/s per N)
    sensitivity_mobility: np.ndarray
    #: clamp velocity per velocity reference
    reference: np.ndarray
    #: each motor's current command per velocity reference (A per m/s)
    current: np.ndarray
    #: each motor's force per sensed force with the reference held at 0, and per velocity reference (N per m/s)
    motor_force: np.ndarray
    motor_reference: np.ndarray

    @property
    def payload_kg(self) -> np.ndarray:
        return self.scenarios.payload_kg

    @property
    def w_rad_s(self) -> np.ndarray:
        return self.s.imag

    def rows(self, index: np.ndarray) -> GantryLoop:
        """The loop with its scenario axis taken at ``index`` (repeats allowed; ``scenarios`` left as it is)."""
        return replace(self, sensitivity_mobility=self.sensitivity_mobility[index], reference=self.reference[index],
                       current=self.current[:, index], motor_force=self.motor_force[:, index],
                       motor_reference=self.motor_reference[:, index])


def gantry_loop_at(plants: Plant, s, scenarios: Scenarios, *, controller: PI) -> GantryLoop:
    """``GantryLoop`` of a (n, 1) batch of plants under the PI ``controller`` at complex ``s``."""
    s = np.asarray(s, complex)
    kt = np.asarray(plants.force_constant_n_per_a, float)
    G = plants.mechanics().velocity_per_force(s)
    E, H = plants.chain_response(s, "drive"), plants.chain_response(s, "sensor")
    C = float(controller.kp) + float(controller.ki) / s
    shape = (len(scenarios), s.size)
    G = np.broadcast_to(G, shape)
    force = np.broadcast_to(kt * E * C, shape)
    S = 1.0 / (1.0 + force * G * H)
    return GantryLoop(s, scenarios, S * G, force * G * S, (C * S)[None], (S - 1.0)[None], (force * S)[None])


@dataclass(frozen=True)
class PiLoops:
    """The spec's one-motor plant under the PI velocity loop ``controller``."""

    base: Plant
    controller: PI

    @classmethod
    def of(cls, problem: LoopProblem, controller: PI) -> PiLoops:
        return cls(problem.plant.plant(), controller)

    def at(self, s, scenarios: Scenarios) -> GantryLoop:
        """``GantryLoop`` of ``scenarios`` at complex ``s``."""
        return gantry_loop_at(scenarios.plants(self.base), s, scenarios, controller=self.controller)

    def free_state_space(self, scenarios: Scenarios, *, period_s: float | None = None, motor: bool = False):
        """The free gantries of ``scenarios`` as one state-space batch (``design.admittance.sampled.free_gantry``;
        ``motor``: the motor's force as a third output), the delays' Pade order chosen for a path sampled every
        ``period_s``."""
        plants = scenarios.plants(self.base)
        return free_gantry(plants, len(scenarios), controller=self.controller,
                           pade_order=pade_order_for(plants, period_s), motor=motor)


def gantry_loop(loops, w_rad_s, scenarios) -> GantryLoop:
    """The loops (``PiLoops`` or ``design.admittance.dual.DualLoops``) of ``scenarios`` (for ``PiLoops`` also
    payloads in kg with the nominal parameters) on the grid ``w_rad_s``."""
    w = check_grid(w_rad_s)
    return loops.at(1j * w, as_scenarios(scenarios))


def _mouse_impedance(loop: GantryLoop, mouse: MouseModel, paired: bool) -> np.ndarray:
    """Z_m at the loop's frequencies: a batch of mice ((n_m, 1) fields) on a new leading axis (every mouse at
    every scenario), or ``paired``, row k the mouse of scenario k."""
    zm = mouse.impedance(loop.s)
    return zm[:, None, :] if zm.ndim == 2 and not paired else zm


def interaction_gain(loop: GantryLoop, mouse: MouseModel, *, weight=1.0, paired: bool = False) -> np.ndarray:
    """K = Z_m R / (1 + S G Z_m) = R / (1/Z_m + S G): sensed force per velocity reference with the mouse
    attached (times ``weight``, an array over the frequencies); a batch of mice ((n_m, 1) fields) gives
    (n_m, n_scenario, n), or with ``paired`` (n_scenario, n), scenario k with mouse k."""
    den = 1.0 / _mouse_impedance(loop, mouse, paired) + loop.sensitivity_mobility
    return np.divide(loop.reference * weight, den, out=den)


def coupled_gain(loops, scenarios, mouse: MouseModel, w_rad_s, timing: RigTiming, *,
                 paired: bool = False) -> np.ndarray:
    """K_eff, the interaction loop over Y_v, of a batch of mice ((n_m, 1) fields) at every
    scenario, (n_m, n_s, n_f), or ``paired`` (mouse k at scenario k), (n_s, n_f): continuous, H_f K; sampled, the
    exact discretisation e^(-jwdT) K_d of ``design.admittance.sampled`` (``loops.free_state_space``)."""
    w = np.asarray(w_rad_s, float)
    if not timing.sampled:
        s = 1j * w
        return interaction_gain(loops.at(s, scenarios), mouse,
                                weight=force_filter_frd(s, timing.filter_hz, timing.filter_order) * np.ones(w.size),
                                paired=paired)
    n_s = len(scenarios)
    n_m = n_s if paired else int(np.asarray(mouse.head_mass_kg).size)
    out = np.empty((n_s if paired else n_m * n_s, w.size), complex)
    for curves, paths in mice_paths(loops, scenarios, mouse, timing, paired=paired):
        out[curves] = sampled_gain(paths, w, timing)
    return out if paired else out.reshape(n_m, n_s, w.size)


def paired_margins(loops, scenarios, mouse: MouseModel, w_rad_s, timing: RigTiming, m_v: float, b_v: float):
    """(PM deg, GM dB, stable) of mouse k at scenario k (a batch of n each) on the grid ``w_rad_s``: grid
    margins with refined crossings (``design.loop.margins.loop_margins``); sampled with a state space, stability
    from the coupled discrete loop's poles (``design.admittance.sampled.closed_loop_radius``)."""
    w = np.asarray(w_rad_s, float)
    z = timing.impedance(w, m_v, b_v)
    if not timing.sampled:
        m = loop_margins(w, coupled_gain(loops, scenarios, mouse, w, timing, paired=True) / z)
        return m.phase_margin_deg, m.gain_margin_db, m.closed_loop_stable
    n = len(scenarios)
    pm, gm, st = np.empty(n), np.empty(n), np.empty(n, bool)
    law = timing.law(m_v, b_v)
    for idx, paths in mice_paths(loops, scenarios, mouse, timing, paired=True):
        m = loop_margins(w, sampled_gain(paths, w, timing) / z, sampled=True)
        pm[idx], gm[idx] = m.phase_margin_deg, m.gain_margin_db
        st[idx] = closed_loop_radius(paths, law, timing.delay_samples) < 1.0
    return pm, gm, st


def attached_loop(loop: GantryLoop, mouse: MouseModel, *, paired: bool = False) -> np.ndarray:
    """S G Z_m: the loop whose Nyquist test says whether the velocity loop with the mouse attached,
    (1 + P C)(1 + S G Z_m), is stable (given the free velocity loop is); shapes as ``interaction_gain``."""
    return loop.sensitivity_mobility * _mouse_impedance(loop, mouse, paired)


def virtual_impedance_frd(w_rad_s, m_v, b_v) -> np.ndarray:
    """m_v jw + b_v: the continuous virtual dynamics' inverse (N*s/m)."""
    return RigTiming(None).impedance(w_rad_s, m_v, b_v)


def rendered_admittance(loop: GantryLoop, m_v: float, b_v: float, timing: RigTiming | None = None) -> np.ndarray:
    """Y_r = v / F_s = S G + R W Y_v (m/s per N): at the input frequency when sampled."""
    timing = timing or RigTiming(None)
    w = loop.w_rad_s
    return loop.sensitivity_mobility + loop.reference * timing.fundamental(w) / timing.impedance(w, m_v, b_v)


def admittance_bandwidth_hz(w_rad_s, rendered, virtual) -> np.ndarray:
    """First frequency (Hz) where ``rendered`` departs from ``virtual`` by 3 dB or 30 deg
    (interpolated in log-frequency); nan when it never does on the grid. Shapes (..., n_freq)."""
    w = check_grid(w_rad_s)
    ratio = np.asarray(rendered) / np.asarray(virtual)
    dev = np.maximum(np.abs(20 * np.log10(np.abs(ratio))) / BANDWIDTH_GAIN_DB,
                     np.abs(unwrapped_phase_deg(ratio)) / BANDWIDTH_PHASE_DEG) - 1.0
    return _first_rise_hz(w, dev)


def _first_rise_hz(w: np.ndarray, dev: np.ndarray) -> np.ndarray:
    """First frequency (Hz) where ``dev`` reaches 0 (interpolated in log w); nan when never."""
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


def drift_mm_per_s(adm: AdmittanceProblem, b_v) -> np.ndarray:
    """Steady speed (mm/s) of the free gantry at rest under the offset left after taring: beta / b_v when
    the offset exceeds the deadband, else 0."""
    s = adm.sensor
    beta = s.bias_after_tare_n if s.bias_after_tare_n > s.deadband_n else 0.0
    return 1e3 * beta / np.asarray(b_v, float)


def breakaway_force_n(adm: AdmittanceProblem) -> float:
    """The smallest push (N) the gantry answers at rest in either direction: the deadband plus the offset
    left after taring (in the direction the offset opposes)."""
    return adm.sensor.deadband_n + adm.sensor.bias_after_tare_n


# --- the interaction loop's responses on a set of scenarios and mice ---------------------------------------
@dataclass(frozen=True)
class InteractionResponses:
    """What does not depend on (m_v, b_v), on one grid: K_eff (the interaction loop over Y_v), for every mouse
    and scenario (n_m, n_s, n_f); the law's 1/Y_v there; and the free gantry's hardware paths."""

    w_rad_s: np.ndarray
    timing: RigTiming
    scenarios: object
    mice: tuple[MouseModel, ...]
    gain: np.ndarray            # K_eff, (n_m, n_s, n_f)
    impedance: VirtualImpedance     # 1/Y_v on the grid
    #: the largest motor's |current per force-reading error| over Y_v (|C S W| for one motor), (n_s, n_f)
    current_path: np.ndarray
    #: R W and S G, (n_s, n_f)
    reference_path: np.ndarray
    sensitivity_mobility: np.ndarray
    #: per motor, the motor force per sensed force is motor_force + motor_reference_path Y_v,
    #: (n_motor, n_s, n_f)
    motor_force: np.ndarray
    motor_reference_path: np.ndarray


def interaction_responses(problem: LoopProblem, scenarios, w_rad_s, *, loops, timing: RigTiming, corners=None,
                          dtype=complex) -> InteractionResponses:
    """K_eff for every mouse of ``corners`` (default: the spec's mouse set) and scenario on ``w_rad_s`` (which
    must end at or below the Nyquist frequency when sampled): the continuous K times the force filter, or
    the exactly sampled path (``coupled_gain``), stored as ``dtype`` (``np.complex64`` halves the memory and
    keeps the precision of the rays' float32 tables)."""
    sc = as_scenarios(scenarios)
    corners = mice(problem) if corners is None else tuple(corners)
    w = check_grid(w_rad_s)
    gain = np.empty((len(corners), len(sc), w.size), dtype)
    batch = stack(corners)

    def block(rows: np.ndarray) -> None:
        gain[:, rows] = coupled_gain(loops, sc.take(rows), batch, w, timing)

    thread_map(block, _blocks(len(sc), len(corners) * w.size))
    loop = loops.at(1j * w, sc)
    W = timing.fundamental(w)
    return InteractionResponses(w, timing, sc, corners, gain, timing.impedance_on(1j * w),
                                current_path(loop, W), loop.reference * W, loop.sensitivity_mobility,
                                loop.motor_force, loop.motor_reference * W)


def current_path(loop: GantryLoop, W) -> np.ndarray:
    """The largest motor's |current per velocity reference| times |W|, (n_s, n_f)."""
    return np.abs(loop.current).max(axis=0) * np.abs(W)


def motor_force_peak(motor_force, motor_reference_path, z) -> np.ndarray:
    """Peak over frequency and motors of |motor force per sensed force| for the virtual impedance ``z``, (n_s,)."""
    return np.abs(motor_force + motor_reference_path / z).max(axis=(0, -1))


# --- exact evaluation ------------------------------------------------------------------------------
@dataclass(frozen=True)
class AdmittanceCheck:
    """(m_v, b_v) evaluated exactly on a grid: scenarios (payload x uncertain parameters) x mice x
    frequencies."""

    m_v: float
    b_v: float
    scenarios: Scenarios
    mice: tuple[MouseModel, ...]
    #: grid margins (refined crossings) of the interaction loop, (n_mouse, n_scenario); nan where the screened
    #: check certified the curve by its ray bound instead (``AdmittanceEvaluator.evaluate``)
    phase_margin_deg: np.ndarray
    gain_margin_db: np.ndarray
    #: the coupled loop and the velocity loop with the mouse attached are stable (Nyquist), (n_mouse, n_scenario)
    stable: np.ndarray
    #: each curve's ray bound over b_v (``design.admittance.ray.curve_bounds``): <= 1 certifies its margins
    bound_ratio: np.ndarray
    #: motor current per force-sensor step, peak over frequency (A), (n_scenario,)
    sensor_current_a: np.ndarray
    #: the motor's peak force (N), (n_scenario,): on the locomotion profile, or for the spec's peak mouse force at
    #: the worst frequency (``admittance.hardware.motor_force_criterion``)
    motor_force_n: np.ndarray
    #: the rendered admittance stays within 3 dB / 30 deg of the virtual dynamics up to here (Hz)
    rendered_bandwidth_hz: np.ndarray
    #: Re Y_r >= 0 from DC up to here (Hz; inf: on the whole grid), (n_scenario,)
    passive_up_to_hz: np.ndarray
    #: frequencies (Hz) of the hardware peaks (the motor's nan on the locomotion profile), (n_scenario,)
    sensor_peak_hz: np.ndarray
    motor_peak_hz: np.ndarray
    #: steady drift at rest (mm/s) under the offset left after taring
    drift_mm_per_s: float
    #: each violated requirement, with its payload, scenario, mouse, value, limit and detail
    violations: tuple[Binding[MouseModel], ...]
    #: the motor's peak force on the spec's force record (N) and when in the record it comes (s), (n_scenario,);
    #: None without a record (``design.admittance.recorded``)
    recorded_motor_force_n: np.ndarray | None = None
    recorded_motor_at_s: np.ndarray | None = None

    @property
    def meets(self) -> bool:
        return not self.violations

    @property
    def payload_kg(self) -> np.ndarray:
        return self.scenarios.payload_kg

    def per_payload(self) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """The payloads and, at each, the worst over its scenarios and the mice of: phase_margin_deg,
        gain_margin_db (min over the mice computed), rendered_bandwidth_hz, passive_up_to_hz (min) and
        sensor_current_a, motor_force_n (max)."""
        m = np.unique(self.payload_kg)
        idx = [np.flatnonzero(self.payload_kg == mk) for mk in m]
        worst = {"phase_margin_deg": (np.nanmin(self.phase_margin_deg, axis=0), np.min),
                 "gain_margin_db": (np.nanmin(self.gain_margin_db, axis=0), np.min),
                 "rendered_bandwidth_hz": (np.nan_to_num(self.rendered_bandwidth_hz, nan=np.inf), np.min),
                 "passive_up_to_hz": (self.passive_up_to_hz, np.min),
                 "sensor_current_a": (self.sensor_current_a, np.max), "motor_force_n": (self.motor_force_n, np.max)}
        return m, {name: np.array([f(v[i]) for i in idx]) for name, (v, f) in worst.items()}

    def recorded_worst(self) -> tuple[float, float, int] | None:
        """(peak N, time into the record s, scenario index) of the motor's largest force on the force record; None
        without one."""
        if self.recorded_motor_force_n is None:
            return None
        j = int(np.argmax(self.recorded_motor_force_n))
        return float(self.recorded_motor_force_n[j]), float(self.recorded_motor_at_s[j]), j

    def worst_by_legs(self) -> dict[str, tuple[float, float]]:
        """Worst (phase margin deg, gain margin dB) over the scenarios of the floating and of the grounded mice."""
        out = {}
        for name, keep in (("floating", [not m.grounded for m in self.mice]),
                           ("grounded", [m.grounded for m in self.mice])):
            k = np.asarray(keep)
            if k.any():
                out[name] = (float(np.nanmin(self.phase_margin_deg[k])), float(np.nanmin(self.gain_margin_db[k])))
        return out


class AdmittanceEvaluator:
    """Evaluation of any (m_v, b_v) for fixed velocity loops and rig timing on scenarios x mice: what does not depend
    on (m_v, b_v) is computed once. Every curve (scenario, mouse) is screened by its ray bound on a coarse grid
    (``SCREEN_POINTS_PER_DECADE`` points per decade of the exactly sampled loop); the curves a check must compute
    exactly are computed anew on the check grid (``evaluate``)."""

    def __init__(self, problem: LoopProblem, scenarios, *, loops, timing: RigTiming | None = None, corners=None,
                 w_rad_s=None):
        self.problem = problem
        self.adm = admittance_problem(problem)
        self.timing = timing or RigTiming.of(self.adm.rig)
        self.loops = loops
        self._kept: dict[int, np.ndarray] = {}
        self.corners = mice(problem) if corners is None else tuple(corners)
        grounded = np.array([m.grounded for m in self.corners])
        self._leg_groups = [g for g in (np.flatnonzero(~grounded), np.flatnonzero(grounded)) if g.size]
        self.scenarios = as_scenarios(scenarios)
        base = check_grid_for(self.timing) if w_rad_s is None else np.asarray(w_rad_s, float)
        self.w = with_mode_points(base, self.corners, self.timing)
        self.blocks = _blocks(len(self.scenarios), len(self.corners) * self.w.size)
        # the screen: polar K on a coarse grid, every curve
        coarse = with_mode_points(check_grid_for(self.timing, per_decade=SCREEN_POINTS_PER_DECADE), self.corners,
                                  self.timing, points=8)
        self._screen_impedance = self.timing.impedance_on(1j * coarse)

        def screen(rows):
            r = interaction_responses(problem, self.scenarios.take(rows), coarse, loops=loops, timing=self.timing,
                                      corners=self.corners)
            return rows, *polar(r.gain.reshape(-1, coarse.size))

        self._screen = thread_map(screen, _blocks(len(self.scenarios), len(self.corners) * coarse.size))
        # the free gantry's hardware paths on the check grid (one per scenario)
        loop = loops.at(1j * self.w, self.scenarios)
        W = self.timing.fundamental(self.w)
        self._current_path = current_path(loop, W)
        self._motor_force, self._motor_reference_path = loop.motor_force, loop.motor_reference * W
        # the velocity loop with the mouse attached, on a continuous grid (it is a continuous loop)
        wc = with_mode_points(W_ATTACHED, self.corners, RigTiming(None))
        self.attached_stable = np.ones((len(self.corners), len(self.scenarios)), bool)
        batch = stack(self.corners)

        def attached(rows):
            loop = gantry_loop(loops, wc, self.scenarios.take(rows))
            self.attached_stable[:, rows] = nyquist_stable(attached_loop(loop, batch))
            return loop

        self._free = thread_map(attached, self.blocks)
        # the motor on the locomotion profile (``admittance.hardware.motor_force_criterion``)
        self._profile = (FeltForce(problem, self.scenarios, self.corners, loops=loops, timing=self.timing)
                         if self.adm.hardware.motor_force_criterion == "locomotion" else None)
        self._recorded: RecordedMotor | None = None

    def exact_margins(self, m_v: float, b_v: float, k_idx: np.ndarray, j_idx: np.ndarray):
        """(PM deg, GM dB, stable) of the curves (mouse k_idx[i], scenario j_idx[i]) on the check grid, sampled
        exactly (``design.admittance.sampled``; stability from the coupled discrete loop's poles). A curve's
        K_eff does not depend on (m_v, b_v): the curves computed are kept (up to ``KEPT_CURVES``) for the next
        evaluations."""
        n = k_idx.size
        pm, gm, st = np.empty(n), np.empty(n), np.empty(n, bool)
        z = self.timing.impedance(self.w, m_v, b_v)
        key = k_idx * len(self.scenarios) + j_idx
        new = np.setdiff1d(key, np.fromiter(self._kept, int, len(self._kept)))
        batch = stack(self.corners)
        step = max(1, CHUNK_ELEMENTS // (self.w.size * 2 * workers()))
        kept = {}

        def chunk(start: int) -> None:
            keys = new[start:start + step]
            k, j = np.divmod(keys, len(self.scenarios))
            mouse = MouseModel(*(np.asarray(getattr(batch, f))[k] for f in MouseModel.__dataclass_fields__))
            sc = self.scenarios.take(j)
            if not self.timing.sampled:
                gain = coupled_gain(self.loops, sc, mouse, self.w, self.timing, paired=True)
                kept.update((c, (g, None)) for c, g in zip(keys.tolist(), gain))
                return
            for idx, paths in mice_paths(self.loops, sc, mouse, self.timing, paired=True):
                gain = sampled_gain(paths, self.w, self.timing)
                kept.update((int(keys[i]), (gain[r], paths.take(r))) for r, i in enumerate(idx))

        thread_map(chunk, range(0, new.size, step))
        lookup = {**self._kept, **kept}
        if len(self._kept) + len(kept) > KEPT_CURVES:
            self._kept.clear()
        self._kept.update(kept)
        law = self.timing.law(m_v, b_v) if self.timing.sampled else None

        def margins(start: int) -> None:
            part = np.arange(start, min(start + step, n))
            entries = [lookup[c] for c in key[part].tolist()]
            gain = np.stack([e[0] for e in entries])
            m = loop_margins(self.w, gain / z, sampled=self.timing.sampled)
            pm[part], gm[part], st[part] = m.phase_margin_deg, m.gain_margin_db, m.closed_loop_stable
            for order in {e[1].order for e in entries if e[1] is not None}:
                rows = [i for i, e in enumerate(entries) if e[1] is not None and e[1].order == order]
                paths = SampledPaths.stack(entries[i][1] for i in rows)
                radius = closed_loop_radius(paths, law, self.timing.delay_samples)
                st[part[rows]] = radius < 1.0

        thread_map(margins, range(0, n, step))
        return pm, gm, st

    @property
    def recorded_motor(self) -> RecordedMotor | None:
        """The motor on the spec's force record at these scenarios (``design.admittance.recorded``; None without
        one), set up when first asked."""
        record = self.adm.locomotion.force_record
        if self._recorded is None and record is not None and self.timing.sampled:
            self._recorded = RecordedMotor(record, self.scenarios, loops=self.loops, timing=self.timing)
        return self._recorded

    def evaluate(self, m_v: float, b_v: float, *, bandwidth: bool = True, screen: bool = True,
                 recorded: bool = False) -> AdmittanceCheck:
        """Margins, stability, hardware peaks, passivity band, rendered bandwidth and drift of (m_v, b_v); with
        ``recorded`` also the motor on the spec's force record (``recorded_motor``).

        The margins are computed exactly (``loop_margins``, Nyquist; ``exact_margins``) for every curve without
        ``screen``, and with it for the curves (mouse x scenario) nearest their limits: at each scenario the
        ``SCREEN_TOP`` floating and grounded mice with the largest phase- and the largest gain-margin ray bound
        (``design.admittance.ray.curve_bounds``: the least b_v along the ray m_v / b_v that keeps the margin;
        the gain margin's orders the curves exactly as their gain margins) and every curve whose bound is within
        ``SCREEN_RATIO`` of b_v; the others are certified by their bound (margins and stability hold all along
        the ray down to it) and their entries are nan."""
        adm = self.adm
        n_m, n_s = len(self.corners), len(self.scenarios)
        pm, gm, ratio = (np.full((n_m, n_s), np.nan) for _ in range(3))
        stable = np.ones((n_m, n_s), bool)
        g = 10 ** (adm.gain_margin_db / 20)
        q = self._screen_impedance.ray(m_v / b_v)
        pick = np.zeros((n_m, n_s), bool)
        for rows, log_mag, psi in self._screen:
            parts = [b.reshape(n_m, len(rows)) for b in curve_bounds(log_mag, psi, q, adm.phase_margin_deg, g,
                                                                     self.timing.sampled, parts=True)]
            ratio[:, rows] = np.maximum(*parts) / b_v
            if not screen:
                pick[:, rows] = True
                continue
            pick[:, rows] = ratio[:, rows] >= SCREEN_RATIO
            for bound in parts:
                for group in self._leg_groups:
                    top = group[np.argsort(-bound[group], axis=0)[:SCREEN_TOP]]
                    pick[top, rows[None, :]] = True
        k_idx, j_idx = np.nonzero(pick)
        pm[k_idx, j_idx], gm[k_idx, j_idx], stable[k_idx, j_idx] = self.exact_margins(m_v, b_v, k_idx, j_idx)
        hw, fpk = adm.hardware, adm.mouse.peak_force_n
        fhz = self.w / (2 * np.pi)
        z = self.timing.impedance(self.w, m_v, b_v)
        i_resp = self._current_path / np.abs(z) * hw.force_sensor_resolution_n
        f_resp = np.abs(self._motor_force + self._motor_reference_path / z).max(axis=0) * fpk
        if self._profile is None:
            motor, motor_hz = f_resp.max(-1), fhz[f_resp.argmax(-1)]
        else:
            motor, motor_hz = self._profile.motor_peak_n(m_v, b_v), np.full(n_s, np.nan)
        stable &= self.attached_stable
        bw, passive = np.full(n_s, np.nan), np.empty(n_s)
        for rows, loop in zip(self.blocks, self._free):
            yr = rendered_admittance(loop, m_v, b_v, self.timing)
            passive[rows] = passive_up_to_hz(loop.w_rad_s, yr)
            if bandwidth:
                virtual = 1.0 / virtual_impedance_frd(loop.w_rad_s, m_v, b_v)
                bw[rows] = admittance_bandwidth_hz(loop.w_rad_s, yr, virtual)
        recorded = self.recorded_motor.peaks(m_v, b_v) if recorded and self.recorded_motor is not None else None
        check = AdmittanceCheck(float(m_v), float(b_v), self.scenarios, self.corners, pm, gm, stable, ratio,
                                i_resp.max(-1), motor, bw, passive, fhz[i_resp.argmax(-1)], motor_hz,
                                float(drift_mm_per_s(adm, b_v)), (), None if recorded is None else recorded.peak_n,
                                None if recorded is None else recorded.at_s)
        return replace(check, violations=violations(adm, check))


def passive_up_to_hz(w_rad_s, rendered) -> np.ndarray:
    """The top (Hz) of the band from DC where Re Y_r >= 0 (interpolated); inf when Re Y_r never drops below
    0 on the grid."""
    w = np.asarray(w_rad_s, float)
    re = np.asarray(rendered).real
    scale = np.max(np.abs(rendered), axis=-1, keepdims=True)
    f = _first_rise_hz(w, -re / scale)
    return np.where(np.isnan(f), np.inf, f)


def _blocks(n_scenarios: int, per_scenario: int) -> list[np.ndarray]:
    size = max(1, CHUNK_ELEMENTS // max(per_scenario * workers(), 1))
    return [np.arange(i, min(i + size, n_scenarios)) for i in range(0, n_scenarios, size)]


def violations(adm: AdmittanceProblem, c: AdmittanceCheck) -> tuple[Binding[MouseModel], ...]:
    """Every requirement ``c`` misses, each naming its spec key, scenario and mouse."""
    hw, out = adm.hardware, []

    def add(constraint, j, mouse, value, limit, detail, source=None):
        out.append(Binding(constraint, None if j is None else float(c.payload_kg[j]),
                           None if j is None else c.scenarios.row(j), mouse, float(value), float(limit),
                           detail=detail, source=source))

    drift_limit = adm.sensor.max_drift_mm_per_s
    if drift_limit is not None and c.drift_mm_per_s > drift_limit * (1 + 1e-6):
        add("drift", None, None, c.drift_mm_per_s, drift_limit,
            f"the {1e3 * adm.sensor.bias_after_tare_n:g} mN offset left after taring (admittance.sensor."
            f"bias_after_tare_n, deadband {1e3 * adm.sensor.deadband_n:g} mN) makes the gantry creep at "
            f"{c.drift_mm_per_s:.3g} mm/s with b_v = {c.b_v:.4g} N*s/m (admittance.sensor.max_drift_mm_per_s = "
            f"{drift_limit:g})")
    for j in range(len(c.scenarios)):
        where = c.scenarios.describe(j)
        limit = hw.max_current_per_sensor_step_a
        if limit is not None and c.sensor_current_a[j] > limit * (1 + 1e-6):
            add("sensor_current", j, None, c.sensor_current_a[j], limit,
                f"one force-sensor step ({hw.force_sensor_resolution_n * 1e3:g} mN) drives {c.sensor_current_a[j]:.4g}"
                f" A (admittance.hardware.max_current_per_sensor_step_a = {limit:g} A) at {where}, "
                f"{c.sensor_peak_hz[j]:.3g} Hz")
        if c.motor_force_n[j] > hw.motor_peak_force_n * (1 + 1e-6):
            loc = adm.locomotion
            asked = (f"the mouse running the locomotion profile ({loc.peak_speed_m_per_s:g} m/s, "
                     f"{loc.peak_acceleration_m_per_s2:g} m/s^2)" if hw.motor_force_criterion == "locomotion" else
                     f"a {adm.mouse.peak_force_n:g} N mouse force at {c.motor_peak_hz[j]:.3g} Hz")
            add("motor_force", j, None, c.motor_force_n[j], hw.motor_peak_force_n,
                f"{asked} asks {c.motor_force_n[j]:.4g} N of the motor (admittance.hardware.motor_peak_force_n = "
                f"{hw.motor_peak_force_n:g} N, motor_force_criterion = {hw.motor_force_criterion}) at {where}")
        if c.recorded_motor_force_n is not None and c.recorded_motor_force_n[j] > hw.motor_peak_force_n * (1 + 1e-6):
            record = adm.locomotion.force_record
            add("motor_force", j, None, c.recorded_motor_force_n[j], hw.motor_peak_force_n,
                f"the recorded force (admittance.locomotion.force_record = {record.file}, {record.duration_s:g} s) "
                f"asks {c.recorded_motor_force_n[j]:.4g} N of the motor at {c.recorded_motor_at_s[j]:.4g} s into "
                f"it (admittance.hardware.motor_peak_force_n = {hw.motor_peak_force_n:g} N) at {where}",
                source="force_record")
        if adm.passivity is not None:
            top = adm.passivity.up_to_hz
            need = np.inf if top is None else top
            if c.passive_up_to_hz[j] < need * (1 - 1e-6):
                add("passivity", j, None, c.passive_up_to_hz[j], need,
                    f"Re Y_r < 0 from {c.passive_up_to_hz[j]:.3g} Hz at {where} (admittance.passivity.up_to_hz = "
                    f"{'everywhere' if top is None else f'{top:g} Hz'}): the controller injects energy there")
        for k, mouse in enumerate(c.mice):
            if not c.stable[k, j]:
                add("stability", j, mouse, math.nan, math.nan,
                    f"the coupled gantry-mouse loop is unstable at {where} with mouse ({mouse.label()})")
                continue
            for name, val, req, unit in (("phase_margin", c.phase_margin_deg[k, j], adm.phase_margin_deg, "deg"),
                                         ("gain_margin", c.gain_margin_db[k, j], adm.gain_margin_db, "dB")):
                if val < req - 1e-6:
                    add(name, j, mouse, val, req,
                        f"interaction-loop {name.replace('_', ' ')} {val:.3g} {unit} (admittance.{name}_"
                        f"{unit.lower()} = {req:g}) at {where} with mouse ({mouse.label()})")
    return tuple(out)


def relative_slack(violation: Binding) -> float:
    """How far a violation misses its requirement, relative to it (more negative: worse)."""
    if violation.constraint == "stability":
        return -math.inf
    value, limit = violation.value, violation.limit
    if violation.constraint in ("phase_margin", "gain_margin", "passivity"):
        return (value - limit) / max(abs(limit), 1e-12) if math.isfinite(limit) else -1.0
    return (limit - value) / max(abs(limit), 1e-12)
