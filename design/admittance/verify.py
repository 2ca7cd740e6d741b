"""Independent verification of an admittance design on the rational (Pade) model.

The frequency-grid check of ``design.admittance.model`` and the optimiser share the grid responses;
this check does not: it builds the coupled gantry-mouse system as python-control state-space models
interconnected from their pieces (the mechanics with the head mass, the drive's and the sensor's
effects with Pade delays, the PI controller, the mouse's body through neck and legs, the force
filter), takes the eigenvalues of the closed loops at the tightest (scenario, mouse) pairs, and
recomputes the interaction loop's margins there with python-control. A rig that samples the
admittance law is verified as the discrete loop it is: the continuous path sampled by ``control.c2d``
(zero-order hold), times the backward-Euler law and its computation delay z^-d, margins of
L(e^(jwT)) up to the Nyquist frequency, and the closed-loop poles inside the unit circle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from design.admittance.model import AdmittanceCheck, admittance_problem
from design.admittance.mouse import MouseModel
from design.admittance.rig import RigTiming, force_filter_polys
from design.loop.controller import PI
from design.problem import LoopProblem
from plant.physics.chain import ChainEffect
from plant.physics.effect_base import balanced
from plant.physics.models import Plant

#: python-control margins may fall short of the requirement by this much (deg, dB): grid rounding
MARGIN_TOLERANCE = (0.1, 0.05)
PADE_ORDER = 6
#: a root of the attached velocity loop this close to the origin is the legs' marginal mode (1/s)
ORIGIN = 1e-7
#: the (scenario, mouse) pairs whose poles are computed: the tightest by their ray bound
VERIFY_PAIRS = 48
#: points of the grid python-control's margins are read on (its spline through them moves the bundled design's
#: margins by under 0.005 deg and 0.002 dB against 6,000 points: tests), and the worst pairs per margin and kind of
#: mouse they are computed at
MARGIN_POINTS = 500
MARGIN_PAIRS = 3


@dataclass(frozen=True)
class AdmittanceVerification:
    verified: bool
    #: largest real part (continuous, 1/s) or modulus (sampled) of the coupled closed-loop poles
    max_closed_loop_pole: float
    #: largest real part of the poles of the velocity loop with the mouse attached, 1 + P C + G Z_m, other
    #: than the one at the origin a grounded mouse gives (1/s)
    max_open_loop_pole_real_part: float
    #: python-control margins at the worst scenarios (PM, GM) of each mouse
    min_phase_margin_deg: float
    min_gain_margin_db: float
    cases: int
    sampled: bool
    failures: tuple[str, ...]


def _polys(tf) -> tuple[np.ndarray, np.ndarray]:
    return np.atleast_1d(np.asarray(tf.num[0][0], float)), np.atleast_1d(np.asarray(tf.den[0][0], float))


@dataclass(frozen=True)
class GantryParts:
    """The gantry's pieces as python-control state-space models (each realised on its own, so the
    interconnection stays well scaled): the mechanics' mobility as numerator/denominator, the drive's
    effects E (Pade for delays) and the sensor's H, and K_t."""

    nG: np.ndarray
    dG: np.ndarray
    drive: object
    sensor: object
    kt: float


def gantry_parts(plant: Plant) -> GantryParts:
    import control

    mech = replace(plant, effects=tuple(e for e in plant.effects if not isinstance(e, ChainEffect)))
    kt = float(np.asarray(plant.force_constant_n_per_a).reshape(()))
    nG, dG = _polys(mech.to_control())

    def chain(place):
        out = control.ss([], [], [], [[1.0]])
        for e in plant.effects:
            if isinstance(e, ChainEffect) and e.place == place:
                out = balanced(control.ss(e.to_tf(pade_order=PADE_ORDER))) * out
        return out

    return GantryParts(nG / kt, dG, chain("drive"), chain("sensor"), kt)


def mouse_parts(mouse: MouseModel):
    """(m_h, Z_b') with Z_b' = Z_n Z_b / (Z_n + Z_b) the body seen through the neck (proper), python-control."""
    import control

    mb, kn, cn = mouse.body_mass_kg, mouse.neck_stiffness_n_per_m, mouse.neck_damping_n_s_per_m
    kl, cl = mouse.leg_stiffness_n_per_m, mouse.leg_damping_n_s_per_m
    q = [mb, cn + cl, kn + kl]
    num = np.polymul([cn, kn], [mb, cl, kl])
    den = np.polymul([1.0, 0.0], q)
    if kl == 0:                                   # the factor s of a body off the ground cancels
        num, den = num[:-1], np.array(q, float)
    return mouse.head_mass_kg, control.tf(num, den)


def interaction_path(parts: GantryParts, mouse: MouseModel, *, controller: PI, timing: RigTiming):
    """The path from velocity reference u to the filtered sensed force (H_f K, sign: force the gantry feels
    against the motion), a state-space model interconnected from its blocks (``control.interconnect``):
    the head mass rides the clamp, v = G_h (F_m - f_b) with G_h = G / (1 + m_h s G) and f_b = Z_b' v the
    body through the neck, F_m = K_t E C (u - H v), and K = m_h dv/dt + f_b. Its state matrix is the
    velocity loop with the mouse attached."""
    import control

    m_h, zb = mouse_parts(mouse)
    gh = control.ss(control.tf(parts.nG, np.polyadd(parts.dG, m_h * np.polymul([1.0, 0.0], parts.nG))))
    A, B, C, D = (np.asarray(x, float) for x in (gh.A, gh.B, gh.C, gh.D))
    blocks = [control.ss(A, B, np.vstack([C, C @ A]), np.vstack([D, C @ B]), inputs="F", outputs=["v", "a"],
                         name="gantry"),
              control.ss(zb, inputs="v", outputs="fb", name="body"),
              control.ss(parts.kt * parts.drive * control.ss(controller.tf()), inputs="e", outputs="Fm", name="drive"),
              control.ss(parts.sensor, inputs="v", outputs="vm", name="sensor"),
              control.summing_junction(["u", "-vm"], "e", name="error"),
              control.summing_junction(["Fm", "-fb"], "F", name="force"),
              control.ss([], [], [], [[m_h, 1.0]], inputs=["a", "fb"], outputs="K", name="sensed")]
    if timing.filter_hz is not None:
        nF, dF = force_filter_polys(timing.filter_hz, timing.filter_order)
        blocks[-1] = control.ss([], [], [], [[m_h, 1.0]], inputs=["a", "fb"], outputs="Kraw", name="sensed")
        blocks.append(control.ss(control.tf(nF, dF), inputs="Kraw", outputs="K", name="filter"))
    return balanced(control.interconnect(blocks, inplist="u", outlist="K"))


def interaction_loop_model(parts: GantryParts, mouse: MouseModel, *, controller: PI, m_v: float, b_v: float,
                           timing: RigTiming):
    """(L, path): the interaction loop, continuous K_F / (m_v s + b_v) or discrete
    T z / ((m_v + b_v T) z - m_v) z^-d c2d(K_F) (zero-order hold), and the continuous path K_F, whose state
    matrix is the velocity loop with the mouse attached."""
    import control

    path = interaction_path(parts, mouse, controller=controller, timing=timing)
    if not timing.sampled:
        return path * control.ss(control.tf([1.0], [m_v, b_v])), path
    T = timing.period_s
    # Y_v = (beta z + beta_prev) / (z - alpha) (``design.admittance.rig.law_coefficients``)
    a, b, b_prev = (float(c) for c in timing.law(m_v, b_v))
    law = control.ss(control.tf([b, b_prev], [1.0, -a], T))
    delay = control.ss(control.tf([1.0], [1.0] + [0.0] * timing.delay_samples, T))
    return law * delay * control.c2d(path, T, method="zoh"), path


def frequency_response(sys, x) -> np.ndarray:
    """C (x I - A)^-1 B + D of a single-input single-output state-space model at the points ``x`` (s, or z
    when discrete), by the eigendecomposition of A (a dense grid in one pass), or point by point by LU when
    A is defective (a chain of unit delays: a Jordan block at z = 0)."""
    A, B, C, D = (np.asarray(m, float) for m in (sys.A, sys.B, sys.C, sys.D))
    x = np.asarray(x)
    lam, V = np.linalg.eig(A)
    if np.linalg.cond(V) < 1e10:
        left = (C @ V).ravel()
        right = np.linalg.solve(V, B).ravel()
        return (left * right) @ (1.0 / (x[None, :] - lam[:, None])) + D[0, 0]
    eye = np.eye(A.shape[0])
    out = np.empty(x.size, complex)
    for i in range(0, x.size, 512):
        xs = x[i:i + 512]
        out[i:i + 512] = (C @ np.linalg.solve(xs[:, None, None] * eye - A, np.broadcast_to(B, (xs.size, *B.shape))))[
            :, 0, 0]
    return out + D[0, 0]


def _margins(L, timing: RigTiming) -> tuple[float, float]:
    """python-control's (PM deg, GM dB) of the loop's frequency response on a dense grid (to the Nyquist
    frequency when sampled): its polynomial method finds spurious crossings in loops of this order."""
    import control

    top = 0.99999 * timing.nyquist_rad_s if timing.sampled else 2 * math.pi * 1e4
    w = np.geomspace(2 * math.pi * 1e-3, top, MARGIN_POINTS)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        resp = frequency_response(L, np.exp(1j * w * timing.period_s) if timing.sampled else 1j * w)
        gm, pm, *_ = control.stability_margins(control.frd(resp, w))
    gm_db = 20 * math.log10(gm) if np.isfinite(gm) and gm > 0 else math.inf
    return (float(pm) if np.isfinite(pm) else math.inf), gm_db


def worst_pairs(check: AdmittanceCheck, n: int = MARGIN_PAIRS) -> set[tuple[int, int]]:
    """The (mouse, scenario) index pairs of the ``n`` worst computed phase and the ``n`` worst gain margins of
    the floating and of the grounded mice."""
    pairs = set()
    for grounded in (False, True):
        rows = np.array([m.grounded == grounded for m in check.mice])
        for arr in (check.phase_margin_deg, check.gain_margin_db):
            a = np.where(rows[:, None] & np.isfinite(arr), arr, np.inf)
            for flat in np.argsort(a, axis=None)[:n]:
                k, j = np.unravel_index(flat, a.shape)
                if np.isfinite(a[k, j]):
                    pairs.add((int(k), int(j)))
    return pairs


def tightest_pairs(check: AdmittanceCheck, n: int = VERIFY_PAIRS) -> list[tuple[int, int]]:
    """The ``n`` (mouse, scenario) index pairs of ``check`` with the largest ray bound over b_v, and the
    ``worst_pairs``."""
    order = np.argsort(-check.bound_ratio, axis=None)[:n]
    pairs = {tuple(int(i) for i in np.unravel_index(k, check.bound_ratio.shape)) for k in order}
    return sorted(pairs | worst_pairs(check))


def verify_admittance(problem: LoopProblem, check: AdmittanceCheck, *, controller: PI,
                      timing: RigTiming | None = None, pairs=None) -> AdmittanceVerification:
    """Poles of the coupled closed loop and of the attached velocity loop at the (mouse, scenario) index
    ``pairs`` of ``check`` (default ``tightest_pairs``), and python-control's margins at the
    ``worst_pairs`` among them; ``check``'s violations count as failures too."""
    import control

    adm = admittance_problem(problem)
    timing = timing or RigTiming.of(adm.rig)
    base = problem.plant.plant()
    pairs = tightest_pairs(check) if pairs is None else pairs
    measure = worst_pairs(check)
    parts = {j: gantry_parts(check.scenarios.plant(base, j)) for j in sorted({j for _, j in pairs})}

    def pair(kj) -> tuple[float, float, float | None, float | None, list[str]]:
        """(closed-loop pole measure, attached-loop max real part, PM, GM, failures) of one pair."""
        k, j = kj
        mouse, scenarios = check.mice[k], check.scenarios
        L, attached = interaction_loop_model(parts[j], mouse, controller=controller, m_v=check.m_v, b_v=check.b_v,
                                             timing=timing)
        roots = np.linalg.eigvals(np.asarray(attached.A, float))
        roots = roots[np.abs(roots) > ORIGIN] if mouse.grounded else roots
        ol = float(np.max(roots.real))
        poles = np.linalg.eigvals(np.asarray(control.feedback(L, 1).A, float))
        cl = float(np.max(np.abs(poles))) if timing.sampled else float(np.max(poles.real))
        where = f"{scenarios.describe(j)} with mouse ({mouse.label()})"
        out = []
        if ol >= 0:
            out.append(f"velocity loop with the mouse attached unstable at {where}")
        if cl >= (1.0 if timing.sampled else 0.0):
            out.append(f"unstable coupled loop at {where}: pole {'modulus' if timing.sampled else 'real part'} "
                       f"{cl:.4g}")
            return cl, ol, None, None, out
        if (k, j) not in measure:
            return cl, ol, None, None, out
        pm, gm_db = _margins(L, timing)
        if pm < adm.phase_margin_deg - MARGIN_TOLERANCE[0] or gm_db < adm.gain_margin_db - MARGIN_TOLERANCE[1]:
            out.append(f"python-control margins PM {pm:.2f} deg, GM {gm_db:.2f} dB at {where}")
        return cl, ol, pm, gm_db, out

    results = [pair(kj) for kj in pairs]        # python-control holds the interpreter: threads only wait on it
    failures = [v.detail for v in check.violations] + [f for r in results for f in r[4]]
    max_cl = max((r[0] for r in results), default=-math.inf)
    max_ol = max((r[1] for r in results), default=-math.inf)
    pms = [r[2] for r in results if r[2] is not None]
    gms = [r[3] for r in results if r[3] is not None]
    return AdmittanceVerification(not failures, max_cl, max_ol, float(np.min(pms, initial=math.inf)),
                                  float(np.min(gms, initial=math.inf)), len(pairs), timing.sampled, tuple(failures))
