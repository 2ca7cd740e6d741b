"""The exact stage of ``design.synth.pi`` (casadi + IPOPT): margins and bandwidth through crossing variables
per scenario, the plant written symbolically from its parameters (``_casadi_frd``), multi-start."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from design.loop.controller import PI
from design.problem import LoopProblem
from design.synth.evaluation import MARGIN_HAIR, high_frequency_rows, requirement_circles
from design.synth.scan import W_OPT
from design.synth.scenarios import Scenarios
from design.synth.solvers import raise_if_interrupted
from plant.physics.algebra import CASADI, Pair
from plant.physics.drive_filters import FILTERS, KINDS
from plant.physics.effect_base import replace_unchecked
from plant.physics.models import Plant

#: IPOPT's initial barrier parameter when the filters are variables too. The joint step starts from a design
#: the pipeline verified; with IPOPT's default (0.1) the first barrier steps throw the iterate far from it and
#: the basin it ends in changes with the last bits of the start (``benchmarks/bench_joint_sensitivity.py``).
#: A small one keeps the iterates near the start, as IPOPT's warm-start advice has it.
JOINT_MU_INIT = 1e-3


def _casadi_frd(plant: Plant, w, symbolic: bool = False):
    """(Re, Im) of P(jw) as casadi expressions of w: the plant's own response formula (``Plant.response``)
    built with casadi arithmetic; a numeric plant's once (``_frd_function``), a plant with symbolic
    parameters afresh."""
    if symbolic:
        out = plant.response(Pair(0.0, w), CASADI)
        return out.re, out.im
    return _frd_function(plant)(w)


@lru_cache(maxsize=512)
def _frd_function(plant: Plant):
    """casadi Function w -> (Re, Im) of P(jw) of a numeric plant: every crossing of every start and
    round of a design meets the same scenario plants."""
    import casadi as ca

    w = ca.SX.sym("w")
    out = plant.response(Pair(0.0, w), CASADI)
    return ca.Function("frd", [w], [out.re, out.im])


def _first_crossing(w, f):
    """w where f changes sign first (linear interpolation in log w), or None."""
    ok = np.isfinite(f[:-1]) & np.isfinite(f[1:])
    s = np.flatnonzero(ok & (np.sign(f[:-1]) != np.sign(f[1:])))
    if s.size == 0:
        return None
    i = s[0]
    lw = np.log(w)
    return float(np.exp(lw[i] + (lw[i + 1] - lw[i]) * f[i] / (f[i] - f[i + 1])))


def _circle_rows(numeric: Plant, plant: Plant, symbolic: dict, circles, kp, ki, u, theta):
    """The sampled circles |L - centre|^2 >= radius^2 of one scenario whose designed filters are variables,
    as (f, data): f a casadi Function of one row, mapped over the rows, and its data (w, Re P_0, Im P_0,
    centre, radius^2 per row; P_0 the numeric response without the designed filters). One row's expression
    mapped over a few thousand rows keeps the derivatives IPOPT needs the size of one row: written out
    element by element (SX), the rows and their Hessian take hundreds of MB."""
    import casadi as ca

    rest = replace(numeric, effects=tuple(e for e in numeric.effects if e.name not in symbolic))
    wg = np.concatenate([c[2] for c in circles])
    p0 = np.concatenate([rest.frd(c[2]) for c in circles])
    centre = np.concatenate([np.full(c[2].size, c[0]) for c in circles])
    r2 = np.concatenate([np.full(c[2].size, (c[1] * 1.003) ** 2) for c in circles])
    w, pr, pi_, cc, rr = (ca.SX.sym(n) for n in ("w", "p0re", "p0im", "centre", "r2"))
    pf = Pair(pr, pi_)
    for e in plant.effects:
        if e.name in symbolic:
            pf = pf * e.response(Pair(0.0, w), CASADI)
    cre, cim = kp, -ki / w          # kp + ki/(jw) = kp - j ki/w
    re = pf.re * cre - pf.im * cim - cc
    im = pf.re * cim + pf.im * cre
    z = ca.vertcat(u, *theta)
    row = ca.Function("circle_row", [z, w, pr, pi_, cc, rr], [re**2 + im**2 - rr])
    data = [ca.DM(v).T for v in (wg, p0.real, p0.imag, centre, r2)]
    return row.map(wg.size), data


@dataclass(frozen=True)


class ExactDesign:
    controller: PI
    success: bool
    note: str
    #: the designed filters' parameters, one dict per filter of ``problem.controller.filters`` (None: left out)
    filter_values: tuple[dict | None, ...] = ()


def exact_design(problem: LoopProblem, scenarios: Scenarios, start: PI, *,
                 high_circle: bool = False, design_filters: bool = False, solvers: dict | None = None) -> ExactDesign:
    """IPOPT on the exact crossings from the PI ``start``; ``high_circle`` also keeps the Nyquist curve
    outside the margin circle above twice the first crossover (see the module doc). ``design_filters``:
    the parameters with ranges of ``problem.controller.filters`` are variables too, started from the values
    the problem's plant carries. ``solvers``: a dict kept by the caller across starts on the same problem and
    scenarios; a start whose crossings are those of an earlier one reuses its IPOPT instance (the gains'
    scales are parameters)."""
    import casadi as ca


    req, c = problem.requirements, problem.controller
    kp0, ki0 = float(start.kp), float(start.ki)
    g = 10 ** ((req.gain_margin_db + MARGIN_HAIR) / 20)
    cos_phi = math.cos(math.radians(req.phase_margin_deg + MARGIN_HAIR))
    base = problem.plant.plant()
    kps, kis = max(kp0, 1e-9 * c.kp.max, 1e-12), max(ki0, 1e-9 * c.ki.max, 1e-12)
    u = ca.SX.sym("u", 2)           # gains relative to the start
    t = ca.SX.sym("t")              # log of the worst-case bandwidth (rad/s)
    xs, x0, lbx, ubx = [u, t], [kp0 / kps, ki0 / kis], [c.kp.min / kps, c.ki.min / kis], [c.kp.max / kps,
                                                                                          c.ki.max / kis]
    # designed filter parameters: x = value / start (depth: the value itself)
    symbolic: dict[str, dict[str, object]] = {}
    variables: list[tuple[int, str, float]] = []
    if design_filters:
        for i, f in enumerate(c.filters):
            name = KINDS[f.kind].name
            start = base.effect(name)
            if start is None:       # left out of this design
                continue
            for field, (lo, hi) in f.ranges.items():
                s0 = float(getattr(start, field))
                scale = 1.0 if field == "depth" or s0 <= 0 else s0
                v = ca.SX.sym(f"{name}_{field}")
                xs.append(v)
                x0.append(s0 / scale)
                lbx.append(lo / scale)
                ubx.append(hi / scale)
                symbolic.setdefault(name, {})[field] = v * scale
                variables.append((i, field, scale))
    # the gains' scales: parameters of the NLP (one IPOPT instance serves several starts), numbers in the
    # joint step (its circle rows are functions of the variables alone)
    scales = ca.DM([kps, kis]) if symbolic else ca.SX.sym("scales", 2)
    kp, ki = u[0] * scales[0], u[1] * scales[1]
    gs, lbg, ubg, t_start = [], [], [], []
    theta = [xs[2 + j] for j in range(len(variables))]
    rows: list[tuple] = []
    P = scenarios.plants(base).frd(W_OPT)
    crossings = []
    for k in range(len(scenarios)):
        L0 = P[k] * (kp0 + ki0 / (1j * W_OPT))
        crossings.append({"c": _first_crossing(W_OPT, np.abs(L0) ** 2 - 1),
                          "p": _first_crossing(W_OPT, np.where(np.real(L0) < 0, np.imag(L0), np.nan)),
                          "b": _first_crossing(W_OPT, np.abs(L0) ** 2 - req.level2 * np.abs(1 + L0) ** 2)})
    key = tuple(tuple(w0 is not None for w0 in starts.values()) for starts in crossings)
    reuse = solvers is not None and not symbolic and not high_circle
    build = not (reuse and key in solvers)
    for k, starts in enumerate(crossings):
        if build:
            numeric = scenarios.plant(base, k)
            plant = numeric if not symbolic else replace(numeric, effects=tuple(
                replace_unchecked(e, symbolic[e.name]) if e.name in symbolic else e for e in numeric.effects))
        for kind, w0 in starts.items():
            if w0 is None:
                continue
            x0.append(math.log(w0))
            lbx.append(max(math.log(w0) - 1.5, math.log(W_OPT[0])))
            ubx.append(min(math.log(w0) + 1.5, math.log(W_OPT[-1])))
            if kind == "b":
                t_start.append(math.log(w0))
            if not build:
                continue
            lw = ca.SX.sym(f"lw_{kind}{k}")
            xs.append(lw)
            w = ca.exp(lw)
            pr, pi_ = _casadi_frd(plant, w, bool(symbolic))
            lr = pr * kp + pi_ * ki / w         # L = P (kp - j ki / w)
            li = pi_ * kp - pr * ki / w
            if kind == "c":
                gs += [lr**2 + li**2 - 1, lr + cos_phi]
                lbg += [0.0, 0.0]
                ubg += [0.0, math.inf]
            elif kind == "p":
                gs += [li, lr + 1 / g]
                lbg += [0.0, 0.0]
                ubg += [0.0, math.inf]
            else:
                g2 = req.level2     # |L|^2 = g2 |1 + L|^2
                gs += [(1 - g2) * (lr**2 + li**2) - 2 * g2 * lr - g2, lw - t]
                lbg += [0.0, 0.0]
                ubg += [0.0, math.inf]
        if not build:
            continue
        # sampled circles |L - centre|^2 >= radius^2: Ms and disk margin on W_OPT; the margin circle
        # from twice the first crossover on (resonances can cross again up there: the exact crossings
        # above track only the first ones)
        circles = [(c_, r_, W_OPT) for c_, r_ in requirement_circles(problem)[1:]]
        if high_circle and starts["c"] is not None and 2 * starts["c"] < W_OPT[-1]:
            high = np.geomspace(2 * starts["c"], W_OPT[-1], max(int(100 * np.log10(W_OPT[-1] / starts["c"] / 2)), 2))
            circles.append((*requirement_circles(problem)[0], high))
        if symbolic:
            rows.append(_circle_rows(numeric, plant, symbolic, circles, kp, ki, u, theta))
            continue
        for centre, radius, wg in circles:
            a = numeric.frd(wg) if wg is not W_OPT else P[k]
            b = a / (1j * wg)
            re = ca.DM(a.real) * kp + ca.DM(b.real) * ki - centre
            im = ca.DM(a.imag) * kp + ca.DM(b.imag) * ki
            gs.append(re**2 + im**2 - radius**2 * 1.003**2)
            lbg += [0.0] * wg.size
            ubg += [math.inf] * wg.size
    hf = high_frequency_rows(problem)
    if hf is not None and build:    # the noise limit |(kp + ki/jw) F(jw)|^2 <= limit^2, F symbolic where designed
        w_hf, a, _ = hf
        fixed = np.ones(w_hf.size, complex)
        f_sym = Pair(ca.DM(np.ones(w_hf.size)), ca.DM(np.zeros(w_hf.size)))
        for e in base.effects:
            if e.name in symbolic:
                f_sym = f_sym * replace_unchecked(e, symbolic[e.name]).response(Pair(0.0, ca.DM(w_hf)), CASADI)
            elif e.name in FILTERS:
                fixed = fixed * e.response(1j * w_hf)
        f = f_sym * Pair(ca.DM(fixed.real), ca.DM(fixed.imag))
        cre, cim = kp, -ki / ca.DM(w_hf)
        gs.append((f.re * cre - f.im * cim) ** 2 + (f.re * cim + f.im * cre) ** 2)
        lbg += [0.0] * w_hf.size
        ubg += [(req.max_high_frequency_gain * (1 - MARGIN_HAIR / 100)) ** 2] * w_hf.size
    if not t_start:
        return ExactDesign(start, False, "no bandwidth crossing at the start")
    x0.insert(2, min(t_start))
    lbx.insert(2, math.log(W_OPT[0]))
    ubx.insert(2, math.log(W_OPT[-1]))
    if build:
        # the vector: the gains, t, the filter variables, then the crossings
        nlp = {"x": ca.vertcat(*xs), "f": -t, "g": ca.vertcat(*gs)}
        if symbolic:    # the designed filters' circle rows: one row's function mapped over them (_circle_rows)
            x = ca.MX.sym("x", nlp["x"].numel())
            z = ca.vertcat(x[0], x[1], x[3:3 + len(variables)])
            g = ca.Function("rows", [nlp["x"]], [nlp["g"]])(x)
            nlp = {"x": x, "f": -x[2], "g": ca.vertcat(g, *[f(z, *data).T for f, data in rows])}
            n = sum(data[0].numel() for _, data in rows)
            lbg += [0.0] * n
            ubg += [math.inf] * n
        else:
            nlp["p"] = scales
        options = {"print_level": 0, "sb": "yes", "max_iter": 200, "tol": 1e-9}
        if symbolic:
            options["mu_init"] = JOINT_MU_INIT
        solver = ca.nlpsol("exact_pi", "ipopt", nlp, {"print_time": False, "ipopt": options})
        if reuse:
            solvers[key] = (solver, lbg, ubg)
    else:
        solver, lbg, ubg = solvers[key]
    sol = solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, **({} if symbolic else {"p": [kps, kis]}))
    stats = raise_if_interrupted(solver)
    x = np.asarray(sol["x"]).ravel()
    # IPOPT may leave a bound by its relaxation (1e-8 relative): clip onto the box
    present = [base.effect(KINDS[f.kind].name) for f in c.filters] if design_filters else []
    values = [None if e is None else {k: float(getattr(e, k)) for k in KINDS[f.kind].bounds}
              for e, f in zip(present, c.filters)]
    for j, (i, field, scale) in enumerate(variables):
        lo, hi = c.filters[i].ranges[field]
        values[i][field] = float(np.clip(x[3 + j] * scale, lo, hi))
    return ExactDesign(PI(float(np.clip(x[0] * kps, c.kp.min, c.kp.max)),
                          float(np.clip(x[1] * kis, c.ki.min, c.ki.max))), bool(stats["success"]),
                       stats["return_status"], tuple(values))
