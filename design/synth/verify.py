"""Independent verification of PI gains with python-control at every dense payload.

Nothing here reuses the synthesis' own margin code: the plant is turned into a rational model
(``Plant.to_control``, Pade for delays), the loop closed with ``control.feedback``, and

* the closed-loop poles must lie in the open left half-plane,
* ``control.stability_margins`` must give PM and GM at or above the requirements,
* the bandwidth of T as ``control.bandwidth`` defines it (against |T| = 1, ``_bandwidth_hz``): the worst case over the
  payloads must agree with the worst-case bandwidth the synthesis claims (within ``BANDWIDTH_RTOL``), so the
  reported objective is checked too; the largest per-payload disagreement is reported,
* when the spec asks for them, the peak sensitivity max|S| and the balanced disk margin
  1 / max|S - 1/2| (Seiler, Packard & Gahinet 2020) from ``control.frequency_response`` of S.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from design.loop.controller import PI
from design.problem import LoopProblem
from design.synth.scenarios import Scenarios
from plant.physics.drive_filters import FILTERS
from plant.physics.effect_base import series_tf

#: margins may fall short of the requirement by this much (deg, dB) and still pass (rounding)
MARGIN_TOLERANCE = 0.05


#: claimed and python-control bandwidths must agree to this relative tolerance
BANDWIDTH_RTOL = 0.01


#: frequency grid for Ms / disk margin (rad/s): 1 mHz - 10 kHz, 4000 points
_W_SENSITIVITY = 2 * np.pi * np.logspace(-3, 4, 4000)

#: grid bracketing the bandwidth (rad/s): 1 mHz - 100 kHz, 125 points per decade (python-control's
#: ``bandwidth`` brackets on 1000 points over the decades its poles and zeros span)
_W_BANDWIDTH = 2 * np.pi * np.logspace(-3, 5, 1001)


@dataclass(frozen=True)


class Verification:
    """Independent check with python-control on a set of plants (payloads x uncertainty scenarios)."""

    verified: bool
    n_plants: int
    max_pole_real_part: float
    min_phase_margin_deg: float
    min_gain_margin_db: float
    min_bandwidth_hz: float
    #: largest |claimed - python-control| / python-control bandwidth over the payloads (informative)
    max_bandwidth_rel_error: float
    failures: tuple[str, ...]
    pade_order: int


def _bandwidth_hz(T, level2: float, integral: bool) -> float:
    """Bandwidth (Hz) of python-control's T against the reference |T| = 1: the first frequency where |T(jw)|
    falls below sqrt(level2), as ``control.bandwidth`` finds it (its drop below |T(0)| moved by |T(0)|;
    T(0) = 1 with integral action): the first grid point below the level (``_W_BANDWIDTH``) brackets the
    root, which Brent's method then locates on ``T(jw)`` (``control.bandwidth`` bisects it, 4x the
    evaluations). nan when |T(0)| is already below the level (a P-only loop), inf when |T| never falls."""
    from scipy.optimize import brentq

    level = math.sqrt(level2)
    dc = 1.0 if integral else abs(float(np.real(T.dcgain())))
    if not dc > level:
        return math.nan
    below = np.flatnonzero(np.abs(T(1j * _W_BANDWIDTH)) < level)
    if below.size == 0:
        return math.inf
    k = int(below[0])
    if k == 0:
        return float(_W_BANDWIDTH[0]) / (2 * math.pi)
    lo, hi = float(_W_BANDWIDTH[k - 1]), float(_W_BANDWIDTH[k])
    return brentq(lambda w: abs(T(1j * w)) - level, lo, hi, xtol=1e-12 * hi) / (2 * math.pi)


def verify(problem: LoopProblem, controller: PI, scenarios: Scenarios | None = None, *,
           claimed_worst_bandwidth_hz: float | None = None, pade_order: int = 6) -> Verification:
    """python-control check of the PI ``controller`` on every scenario (default: the dense payloads of
    ``PayloadRange.check_points`` at the nominal parameters); ``claimed_worst_bandwidth_hz`` is compared
    with the lowest ``control.bandwidth`` over them."""
    import control

    req = problem.requirements
    if scenarios is None:
        scenarios = Scenarios(problem.plant.payload_kg.check_points())
    base = problem.plant.plant()
    C = controller.tf()
    failures: list[str] = []
    max_re, pms, gms, bws, errs = -math.inf, [], [], [], [0.0]
    for k in range(len(scenarios)):
        m = scenarios.describe(k)
        L = series_tf(scenarios.plant(base, k).to_control(pade_order=pade_order), C)
        T = control.feedback(L, 1)
        re = float(np.max(np.real(control.poles(T))))
        max_re = max(max_re, re)
        # its stability-margin (sm) polynomial may overflow for the high orders of two Pade factors;
        # PM and GM come from other polynomials and are unaffected
        with np.errstate(over="ignore", invalid="ignore"):
            gm, pm, _, _, _, _ = control.stability_margins(L)
        gm_db = 20 * math.log10(gm) if np.isfinite(gm) and gm > 0 else math.inf
        pm = float(pm) if np.isfinite(pm) else math.inf
        pms.append(pm)
        gms.append(gm_db)
        if re >= 0:
            failures.append(f"unstable closed loop at {m} (pole real part {re:.3g})")
            bws.append(math.nan)
            continue
        bw = _bandwidth_hz(T, req.level2, controller.ki > 0)
        bws.append(bw)
        if pm < req.phase_margin_deg - MARGIN_TOLERANCE:
            failures.append(f"phase margin {pm:.2f} deg < {req.phase_margin_deg:g} at {m}")
        if gm_db < req.gain_margin_db - MARGIN_TOLERANCE:
            failures.append(f"gain margin {gm_db:.2f} dB < {req.gain_margin_db:g} at {m}")
        if req.peak_sensitivity is not None or req.disk_margin is not None:
            S = control.frequency_response(control.feedback(1, L), _W_SENSITIVITY).complex.ravel()
            ms, alpha = float(np.max(np.abs(S))), float(1.0 / np.max(np.abs(S - 0.5)))
            if req.peak_sensitivity is not None and ms > req.peak_sensitivity * 1.001:
                failures.append(f"peak sensitivity {ms:.3f} > {req.peak_sensitivity:g} at {m}")
            if req.disk_margin is not None and alpha < req.disk_margin * 0.999:
                failures.append(f"disk margin {alpha:.3f} < {req.disk_margin:g} at {m}")
    if req.max_high_frequency_gain is not None:   # the noise limit on python-control's C(s) F(s)

        w = 2 * math.pi * np.geomspace(req.high_frequency_hz, 20 * req.high_frequency_hz, 2000)
        CF = C
        for e in base.effects:
            if e.name in FILTERS:
                CF = CF * e.to_tf()
        peak = float(np.max(np.abs(CF(1j * w))))
        if peak > req.max_high_frequency_gain * 1.001:
            failures.append(f"controller gain {peak:.4g} A/(m/s) above {req.high_frequency_hz:g} Hz exceeds "
                            f"requirements.max_high_frequency_gain = {req.max_high_frequency_gain:g}")
    errs = [0.0]
    if claimed_worst_bandwidth_hz is not None and np.all(np.isfinite(bws)):
        # the objective: the worst-case bandwidth must agree (per scenario the rational model may differ a
        # little from the exact response where it approximates, e.g. a zero-order hold far above crossover)
        ref = float(np.min(bws))
        errs.append(abs(claimed_worst_bandwidth_hz - ref) / ref)
        if not errs[-1] <= BANDWIDTH_RTOL:
            failures.append(f"claimed worst-case bandwidth {claimed_worst_bandwidth_hz:.3f} Hz differs from "
                            f"python-control's {ref:.3f} Hz")
    return Verification(not failures, len(scenarios), max_re, float(np.min(pms)), float(np.min(gms)),
                        float(np.nanmin(bws)) if np.any(np.isfinite(bws)) else math.nan, float(max(errs)),
                        tuple(failures), pade_order)
