"""The lightest admittance that holds every requirement, along rays of the virtual dynamics.

Write the law's virtual impedance 1/Y_v = t q(tau) (``design.admittance.rig.VirtualImpedance.ray``: every rule
scales with (m_v, b_v) together), with tau = m_v / b_v (s) fixing the ray and t = b_v its scale. Along a ray
every requirement of ``design.admittance.model`` is a bound on t alone, at each frequency, scenario and mouse,
in closed form:

* margins: with p = K_eff / q the interaction loop is L = p / t. Coming down from t = inf (L = 0, the
  coupled loop stable when the velocity loop with the mouse attached is), the loop keeps phase margin
  phi and gain margin g for every scale above t exactly when t > |p| wherever the phase of p lies
  within phi of -180 deg, and t >= g |p| wherever it is -180 deg; no closed-loop pole can cross into
  the right half plane on the way (it would need L = -1). The window's edges and the -180 deg crossings
  between grid points are interpolated (``curve_bounds``); the curves (scenario x mouse) are visited in
  the order of a cheap upper bound, so a ray costs a few curves' exact bounds;
* motor force (``motor_force_criterion = "worst_sinusoid"``; on the locomotion profile the dense check holds
  it) |S - 1 + R W / (G t q)| F_pk <= F_max and passivity Re(S G) + Re(R W / q) / t >= 0 are
  quadratic and linear in 1/t; the sensor-step current |C S W| res / (t |q|) <= i_max, the drift
  1e3 beta / t <= limit and the bounds of m_v = tau t and b_v = t are bounds on t directly.

The cost of a ray is t (a_pk tau + v_pk), the force the virtual dynamics ask on the locomotion
profile's corner (linear in (m_v, b_v)); ``best_ray`` scans tau on a log grid and refines around the
best. The resulting design is then polished and checked on the exact grid margins by the synthesis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from design.admittance.bounds import HAIR_SCALE, POLAR_BLOCK, curve_bounds, polar
from design.admittance.model import InteractionResponses
from design.admittance.rig import VirtualImpedance
from design.problem import AdmittanceProblem

#: the design keeps this much above the requirements, so the exact check (refined crossings) passes
HAIR_PM_DEG, HAIR_GM_DB, HAIR_HARDWARE = 0.05, 0.02, 0.002
#: curves (scenario x mouse) joining the active set per round, and the rays that seed it
ACTIVE_ADD = 24
SEED_TAUS_S = (0.003, 0.03, 0.3)


@dataclass(frozen=True)
class RayProblem:
    """Everything a ray needs, tabulated once from ``InteractionResponses`` and the spec."""

    impedance: VirtualImpedance            # the law's 1/Y_v on the grid: b_v q(tau) on a ray
    w_rad_s: np.ndarray
    log_mag: np.ndarray                    # log |K_eff| per curve (mouse x scenario), (n_c, n_f), float32
    psi: np.ndarray                        # phase of K_eff relative to -180 deg (deg)
    phase_margin_deg: float                # with its hair
    gain_margin: float                     # g (linear) with its hair
    sampled: bool
    current_peak: np.ndarray | None        # max over scenarios of |C S W| res / i_max, (n_f,)
    motor_force: np.ndarray                # motor force per sensed force at b_v = inf (S - 1), (n_motor x n_s, n_f)
    motor_reference: np.ndarray            # and the part times Y_v (R W / G), (n_motor x n_s, n_f)
    force_ratio: float                     # F_max / F_pk (inf: the motor is held on the locomotion profile)
    passive_re_sg: np.ndarray | None       # Re(S G) on the passivity band, (n_s, n_p)
    passive_rw: np.ndarray | None          # R W there
    passive_band: np.ndarray | None        # indices of the band's frequencies
    t_min: float                           # b_v lower bound, drift
    t_max: float
    m_min: float
    m_max: float
    tau_min: float                         # the least m_v / b_v the law is stable with (s)
    a_pk: float
    v_pk: float


def ray_problem(resp: InteractionResponses, adm: AdmittanceProblem, *, phase_margin_deg: float | None = None,
                gain_margin_db: float | None = None) -> RayProblem:
    """The data of the rays for ``resp`` (margins overridable, for a trade-off front)."""
    pm = adm.phase_margin_deg if phase_margin_deg is None else phase_margin_deg
    gm = adm.gain_margin_db if gain_margin_db is None else gain_margin_db
    hw, sensor = adm.hardware, adm.sensor
    current = None
    if hw.max_current_per_sensor_step_a is not None:
        current = resp.current_path.max(axis=0) * hw.force_sensor_resolution_n / (
            hw.max_current_per_sensor_step_a * (1 - HAIR_HARDWARE))
    band = re_sg = rw = None
    if adm.passivity is not None:
        top = math.inf if adm.passivity.up_to_hz is None else 2 * math.pi * adm.passivity.up_to_hz
        band = np.flatnonzero(resp.w_rad_s <= top)
        re_sg = resp.sensitivity_mobility[:, band].real
        rw = resp.reference_path[:, band]
    t_min = adm.b_v.min
    if sensor.max_drift_mm_per_s is not None and sensor.bias_after_tare_n > sensor.deadband_n:
        t_min = max(t_min, 1e3 * sensor.bias_after_tare_n / (sensor.max_drift_mm_per_s * (1 - HAIR_HARDWARE)))
    return RayProblem(resp.impedance, resp.w_rad_s, *polar(resp.gain.reshape(-1, resp.w_rad_s.size)),
                      pm + HAIR_PM_DEG, 10 ** ((gm + HAIR_GM_DB) / 20), resp.timing.sampled, current,
                      resp.motor_force.reshape(-1, resp.w_rad_s.size),
                      resp.motor_reference_path.reshape(-1, resp.w_rad_s.size),
                      hw.motor_peak_force_n * (1 - HAIR_HARDWARE) / adm.mouse.peak_force_n
                      if hw.motor_force_criterion == "worst_sinusoid" else math.inf, re_sg, rw, band,
                      t_min, adm.b_v.max, adm.m_v.min, adm.m_v.max, resp.timing.min_tau_s,
                      adm.locomotion.peak_acceleration_m_per_s2,
                      adm.locomotion.peak_speed_m_per_s)


@dataclass(frozen=True)
class RayBound:
    """The least scale t = b_v along the ray tau that holds every requirement, and which one binds;
    ``feasible`` False when an upper bound (m_v, b_v maximum, passivity) falls below it."""

    tau_s: float
    b_v: float
    binding: str
    feasible: bool

    @property
    def m_v(self) -> float:
        return self.tau_s * self.b_v

    def cost_n(self, a_pk: float, v_pk: float) -> float:
        return self.b_v * (a_pk * self.tau_s + v_pk) if self.feasible else math.inf


def margin_bounds(rp: RayProblem, tau_s: float, curves=None) -> np.ndarray:
    """``curve_bounds`` of the curves ``curves`` (indices; default all) on the ray ``tau_s``."""
    rows = np.arange(len(rp.log_mag)) if curves is None else np.asarray(curves, int)
    q = rp.impedance.ray(tau_s)
    return np.concatenate([np.zeros(0)] + [
        curve_bounds(rp.log_mag[block], rp.psi[block], q, rp.phase_margin_deg, rp.gain_margin, rp.sampled)
        for block in _row_blocks(rows, q.size)])


def _row_blocks(rows: np.ndarray, n_f: int) -> list[np.ndarray]:
    """``rows`` in blocks of ``POLAR_BLOCK`` table values (the temporaries of a pass stay small)."""
    step = max(1, POLAR_BLOCK // max(n_f, 1))
    return [rows[i:i + step] for i in range(0, rows.size, step)]


def _upper_bounds(rp: RayProblem, tau_s: float) -> np.ndarray:
    """An upper bound of each curve's ``curve_bounds`` on the ray ``tau_s``: max |p| times max(g, 1) (the
    interpolated points lie between grid points), for one pass over the table instead of ``curve_bounds``'s."""
    lq = np.log(np.abs(rp.impedance.ray(tau_s))).astype(np.float32)
    top = np.concatenate([np.max(rp.log_mag[block] - lq, axis=-1).astype(float)
                          for block in _row_blocks(np.arange(len(rp.log_mag)), lq.size)])
    return HAIR_SCALE * np.exp(top) * max(rp.gain_margin, 1.0)


def curves_over(rp: RayProblem, tau_s: float, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """(indices, bounds) of the curves whose ``curve_bounds`` on the ray ``tau_s`` exceed ``scale``; only the
    curves whose ``_upper_bounds`` do are computed exactly."""
    maybe = np.flatnonzero(_upper_bounds(rp, tau_s) > scale)
    t = margin_bounds(rp, tau_s, maybe) if maybe.size else np.zeros(0)
    return maybe[t > scale], t[t > scale]


def top_curves(rp: RayProblem, tau_s: float, k: int) -> np.ndarray:
    """The ``k`` curves of largest ``curve_bounds`` on the ray ``tau_s``, largest first: exact bounds are
    computed in order of ``_upper_bounds`` until no remaining curve's upper bound can reach the k-th."""
    ub = _upper_bounds(rp, tau_s)
    order = np.argsort(-ub)
    done = np.zeros(0, int)
    exact = np.zeros(0)
    chunk = 4 * k
    while done.size < order.size:
        nxt = order[done.size:done.size + chunk]
        done, exact = np.concatenate([done, nxt]), np.concatenate([exact, margin_bounds(rp, tau_s, nxt)])
        kth = np.sort(exact)[-k] if exact.size >= k else -math.inf
        if done.size == order.size or ub[order[done.size]] <= kth:
            break
        chunk *= 2
    return done[np.argsort(-exact, kind="stable")][:k]


#: grid values (taus x curves or scenarios x frequencies) of one vectorised batch of rays
RAY_BATCH_VALUES = 1_000_000


def ray_bounds(rp: RayProblem, taus, curves=None) -> list[RayBound]:
    """``RayBound`` of each ray of ``taus`` (module docstring), the margins on ``curves`` (default all),
    vectorised over the rays in batches of ``RAY_BATCH_VALUES`` grid values."""
    taus = np.asarray(taus, float)
    rows = max(len(rp.log_mag) if curves is None else len(curves), len(rp.motor_force))
    step = max(1, RAY_BATCH_VALUES // max(rows * rp.w_rad_s.size, 1))
    out = []
    for i in range(0, taus.size, step):
        out += _ray_bounds(rp, taus[i:i + step], curves)
    return out


def ray_bound(rp: RayProblem, tau_s: float, curves=None) -> RayBound:
    """``RayBound`` of the ray ``tau_s``."""
    return _ray_bounds(rp, np.array([tau_s]), curves)[0]


def _ray_bounds(rp: RayProblem, taus: np.ndarray, curves) -> list[RayBound]:
    rows = slice(None) if curves is None else curves
    q = rp.impedance.ray(taus[:, None])                                     # (n_tau, n_f)
    aq = np.abs(q)
    t_margin = curve_bounds(rp.log_mag[rows], rp.psi[rows], q[:, None, :], rp.phase_margin_deg, rp.gain_margin,
                            rp.sampled)
    lower = {"margins": np.max(t_margin, axis=-1, initial=0.0), "b_v_min": np.full(taus.size, rp.t_min),
             "m_v_min": rp.m_min / taus}
    if rp.current_peak is not None:
        lower["sensor_current"] = np.max(rp.current_peak / aq, axis=-1)
    # motor force: |a + b u| <= c with u = 1/t; u = 0 holds when |a| <= c, and the admissible u reach u2
    a, b, c = rp.motor_force, rp.motor_reference / q[:, None, :], rp.force_ratio
    bb, ab = np.abs(b) ** 2, (a * np.conj(b)).real
    disc = ab**2 - bb * (np.abs(a) ** 2 - c * c)
    u2 = np.where(disc > 0, (-ab + np.sqrt(np.maximum(disc, 0))) / np.maximum(bb, 1e-300), np.inf)
    u2 = u2.reshape(taus.size, -1)
    with np.errstate(divide="ignore"):
        lower["motor_force"] = np.where(np.all(u2 > 0, axis=-1), 1.0 / np.min(u2, axis=-1), np.inf)
    upper = {"b_v_max": np.full(taus.size, rp.t_max), "m_v_max": rp.m_max / taus}
    if rp.passive_band is not None:
        rw = (rp.passive_rw / q[:, None, rp.passive_band]).real
        re = rp.passive_re_sg
        # re + rw / t >= 0: a lower bound on t where re >= 0 > rw, an upper one where re < 0 < rw
        need_low = (re >= 0) & (rw < 0)
        lower["passivity"] = np.max(np.where(need_low, -rw / np.maximum(re, 1e-300), 0.0).reshape(taus.size, -1),
                                    axis=-1)
        need_high = re < 0
        ub = np.where(need_high & (rw > 0), rw / -re, np.where(need_high, 0.0, np.inf))
        upper["passivity"] = np.min(ub.reshape(taus.size, -1), axis=-1)
    names = list(lower)
    low = np.stack([lower[k] for k in names])
    pick = np.argmax(low, axis=0)                  # the first of equal bounds, as ``max`` over the names
    t = low[pick, np.arange(taus.size)]
    top = np.min(np.stack(list(upper.values())), axis=0)
    return [RayBound(float(tau), float(ti), names[k], bool(math.isfinite(ti) and ti <= hi * (1 + 1e-12)))
            for tau, ti, k, hi in zip(taus, t, pick, top)]


def _scan(rp: RayProblem, curves, objective, *, points: int, refine: int) -> tuple[RayBound, float]:
    """The ray of least ``objective`` with the margins on ``curves``: a log grid of tau over the bounds'
    range, then ``refine`` rounds of a finer grid between the best point's neighbours."""
    lo = max(rp.m_min / rp.t_max, rp.tau_min, 1e-7)
    hi = max(rp.m_max / rp.t_min, lo * 1.0001)
    taus = np.geomspace(lo, hi, points)
    best, best_cost = None, math.inf
    for _ in range(refine + 1):
        bounds = ray_bounds(rp, taus, curves)
        costs = np.array([objective(r) if r.feasible else math.inf for r in bounds])
        i = int(np.argmin(costs))
        if best is None or costs[i] < best_cost:
            best, best_cost = bounds[i], float(costs[i])
        if not math.isfinite(costs[i]):
            break
        taus = np.geomspace(taus[max(i - 1, 0)], taus[min(i + 1, taus.size - 1)], 9)
    return best, best_cost


def best_ray(rp: RayProblem, *, objective=None, points: int = 28, refine: int = 2, seed=None) -> RayBound:
    """The ray of least ``objective(ray)`` (default: the force the virtual dynamics ask on the profile's
    corner, ``RayBound.cost_n``) over every curve, by an active set of curves: seeded with the curves
    that bind most on a few rays (``SEED_TAUS_S``), the scan runs on the active curves, every curve is
    checked on the ray found, and those it violates join, until none does. For an objective that grows
    with the scale, the scan on a subset is a relaxation, so a ray that holds on every curve is the
    optimum of the full scan. ``seed``: curves to start the active set from instead (indices)."""
    objective = objective or (lambda r: r.cost_n(rp.a_pk, rp.v_pk))
    n = len(rp.log_mag)
    active = set() if seed is None else {int(i) for i in seed}
    for tau in SEED_TAUS_S if seed is None else ():
        active |= set(top_curves(rp, tau, ACTIVE_ADD).tolist())
    while True:
        curves = np.array(sorted(active))
        best, _ = _scan(rp, curves, objective, points=points, refine=refine)
        if not best.feasible or len(active) == n:
            return ray_bound(rp, best.tau_s) if len(active) < n else best
        over, t_over = curves_over(rp, best.tau_s, best.b_v * (1 + 1e-9))
        if not over.size:
            return best
        active |= set(over[np.argsort(-t_over)][:ACTIVE_ADD].tolist())


def front(rp_of_margin, margins_deg, *, points: int = 40) -> list[tuple[float, RayBound]]:
    """The least force felt for each required phase margin: (margin, best ray) pairs (``rp_of_margin(phi)``
    builds the ray problem with that phase margin)."""
    return [(float(m), best_ray(rp_of_margin(float(m)), points=points, refine=1)) for m in margins_deg]
