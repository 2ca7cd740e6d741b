"""Admittance benchmark on ``specs/stage_x_admittance.toml`` (the walking mouse, the 100 Hz law, co-design):
what a user waits for and how good the design is against brute force, side by side in one run.

Run:  python benchmarks/bench_admittance.py [--quick]

* The command: ``gantry synth specs/stage_x_admittance.toml --json`` as a user runs it, in a fresh process
  under ``/usr/bin/time``: wall seconds, CPU seconds (user + system) and peak memory (max RSS), the median of
  ``RUNS`` runs (1 with ``--quick``); the same on one thread (``GANTRY_THREADS=1``: the array chunks of
  ``design.parallel`` in the calling thread) and for the synthesis of the PI loop alone
  (``specs/stage_x_synth.toml``) beside it.
* (m_v, b_v) at the design's PI gains against an independent brute force: a log grid over a decade each way
  around the design (12 x 12, 8 x 8 with ``--quick``) and a 10 x 10 grid over the best point's neighbourhood, every
  point checked on the design scenarios (payload
  points x uncertainty corners x every mouse) by ``tests/reference/independent_admittance.py`` (Newton's-law
  state space, scipy's zero-order-hold discretisation, the law and its delay in series, the closed-loop
  eigenvalues, margins read on a dense grid to the Nyquist frequency: nothing of the tool's evaluator) and scored
  by the force the mouse feels on the profile (``design.admittance.profile.FeltForce``); the best grid point
  beside the design: the ratio design / brute force should not exceed 1.05.
* The co-design against a grid of PI gains: Kp x {0.5, 0.7, 1, 1.4, 2} and Ki x {1e-2, 0.1, 1, 10, 100} of the
  chosen gains (3 x 3 with ``--quick``), each with its own best virtual dynamics (the ray search on the same
  reduced set the co-design scores with) and the force felt there.
"""

import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from design.loop.controller import PI

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "specs" / "stage_x_admittance.toml"
QUICK = "--quick" in sys.argv
RUNS = 1 if QUICK else 3


def timed(args: list[str], env: dict | None = None) -> tuple[float, float, float, int, str]:
    """(wall s, CPU s, peak MB, exit status, stdout) of ``gantry ARGS`` in a fresh process (``env``: variables
    added to the environment)."""
    with tempfile.NamedTemporaryFile(suffix=".time") as f:
        t0 = time.perf_counter()
        out = subprocess.run(["/usr/bin/time", "-f", "%U %S %M", "-o", f.name, sys.executable, "-m", "design", *args],
                             capture_output=True, text=True, cwd=ROOT, env={**os.environ, **(env or {})})
        wall = time.perf_counter() - t0
        user, system, rss_kb = Path(f.name).read_text().split()[-3:]
    return wall, float(user) + float(system), int(rss_kb) / 1024, out.returncode, out.stdout


def command_figures() -> dict:
    rows = {}
    for name, args, env in (
            ("admittance (walking mouse, 100 Hz law, co-design)", ["synth", str(SPEC), "--json"], None),
            ("the same on one thread (GANTRY_THREADS=1)", ["synth", str(SPEC), "--json"], {"GANTRY_THREADS": "1"}),
            ("PI loop alone (stage_x_synth.toml)", ["synth", str(ROOT / "specs" / "stage_x_synth.toml"), "--json"],
             None)):
        runs = [timed(args, env) for _ in range(RUNS)]
        wall, cpu, mb = (float(np.median([r[k] for r in runs])) for k in range(3))
        rows[name] = runs[-1]
        print(f"  {name}: {wall:.1f} s wall, {cpu:.1f} s CPU, {mb:.0f} MB peak (median of {RUNS}; exit "
              f"{runs[-1][3]})")
    return json.loads(rows["admittance (walking mouse, 100 Hz law, co-design)"][4])


def reference_curves(spec, kp: float, ki: float, scenarios, corners, w):
    """The independent model's discretised path of every (scenario, mouse) and its response on ``w`` (rad/s)."""
    sys.path.insert(0, str(ROOT / "tests" / "reference"))
    import independent_admittance as ref
    from scipy.signal import cont2discrete

    T = spec.admittance.rig.sample_period_s
    z = np.exp(1j * w * T)
    paths, responses = [], []
    for j in range(len(scenarios)):
        row = scenarios.row(j).as_dict()
        for m in corners:
            path = ref.coupled_path(mass_kg=row["payload_kg"], damping=row["damping_n_s_per_m"], kt=20.0, kp=kp, ki=ki,
                                    delay_s=row["delay.seconds"], current_hz=row["current_loop.bandwidth_hz"],
                                    head_kg=m.head_mass_kg, body_kg=m.body_mass_kg, neck_k=m.neck_stiffness_n_per_m,
                                    neck_c=m.neck_damping_n_s_per_m, leg_k=m.leg_stiffness_n_per_m,
                                    leg_c=m.leg_damping_n_s_per_m)
            Ad, Bd, Cd, Dd, _ = cont2discrete(path, T, method="zoh")
            paths.append((Ad, Bd, Cd, Dd))
            responses.append(ref.response((Ad, Bd, Cd, Dd), z))
    return paths, np.array(responses)


def reference_meets(paths, responses, w, m_v, b_v, T, pm_req, gm_req) -> bool:
    """Forward-Euler law v[k] = v[k-1] + T (F[k] - b_v v[k-1]) / m_v, no computation delay: every curve's discrete
    closed loop stable and its grid margins held (crossings interpolated, the Nyquist end a phase crossover; a
    phase crossover above |L| = 1 counts by the gain reduction it allows)."""
    a, c = 1.0 - b_v * T / m_v, T / m_v
    z = np.exp(1j * w * T)
    L = responses * (c / (1 - a / z))[None, :]
    lm, ph = np.log(np.abs(L)), np.unwrap(np.angle(L), axis=1)
    for k in range(L.shape[0]):
        up = np.flatnonzero((lm[k, :-1] > 0) != (lm[k, 1:] > 0))
        t = lm[k, up] / (lm[k, up] - lm[k, up + 1])
        # the phase at each gain crossover, its distance to -180 deg either way
        pm = np.abs(np.degrees(np.mod(ph[k, up] + t * (ph[k, up + 1] - ph[k, up]), 2 * np.pi) - np.pi))
        if pm.size and pm.min() < pm_req:
            return False
        wrapped = np.mod(ph[k], 2 * np.pi) - np.pi                  # phase relative to -180 deg
        cross = np.flatnonzero((np.sign(wrapped[:-1]) != np.sign(wrapped[1:])) & (np.abs(np.diff(wrapped)) < np.pi))
        g = lm[k, cross] - wrapped[cross] / (wrapped[cross + 1] - wrapped[cross]) * (lm[k, cross + 1] - lm[k, cross])
        gms = list(np.abs(20 * g / np.log(10)))                     # a gain increase or reduction margin
        if L[k, -1].real < 0:
            gms.append(abs(20 * np.log10(-L[k, -1].real)))
        if gms and min(gms) < gm_req:
            return False
        Ad, Bd, Cd, Dd = paths[k]
        n = Ad.shape[0]
        # law state s = v[k-1]: v[k] = a s + c F[k], F[k] = -(Cd x + Dd v[k])
        g0 = 1.0 / (1.0 + c * Dd[0, 0])
        vx, vs = -c * g0 * Cd[0], a * g0
        M = np.zeros((n + 1, n + 1))
        M[:n, :n], M[:n, n] = Ad + Bd @ vx[None, :], Bd[:, 0] * vs
        M[n, :n], M[n, n] = vx, vs
        if np.max(np.abs(np.linalg.eigvals(M))) >= 1.0:
            return False
    return True


def virtual_grid(doc: dict) -> None:
    from design.admittance.feel import feel_scenarios
    from design.admittance.model import PiLoops, mice
    from design.admittance.profile import FeltForce
    from design.admittance.rig import RigTiming
    from design.spec.schema import load_spec
    from design.synth.scenarios import design_scenarios

    adm = doc["admittance"]
    spec = load_spec(SPEC).problem()
    timing = RigTiming.of(spec.admittance.rig, filter_hz=adm["rig"]["force_filter_hz"])
    corners = mice(spec)
    loops = PiLoops.of(spec, PI(adm["kp"], adm["ki"]))
    felt = FeltForce(spec, feel_scenarios(spec), corners, loops=loops, timing=timing)
    scenarios = design_scenarios(spec)
    T = timing.period_s
    w = np.geomspace(2 * math.pi * 1e-3, math.pi / T, 1500)
    t0 = time.perf_counter()
    paths, responses = reference_curves(spec, adm["kp"], adm["ki"], scenarios, corners, w)
    n = 8 if QUICK else 12
    req = (spec.admittance.phase_margin_deg, spec.admittance.gain_margin_db)

    def lightest(m_grid, b_grid, best):
        for m in m_grid:
            for b in b_grid:
                f = felt(m, b)
                if f < best[0] and m > b * T / 2 and reference_meets(paths, responses, w, m, b, T, *req):
                    best = (f, m, b)
        return best

    step = 10 ** (2 / (n - 1))
    m0, b0 = adm["m_v"], adm["b_v"]
    none = (math.inf, math.nan, math.nan)
    best = lightest(np.geomspace(m0 / 10, m0 * 10, n), np.geomspace(b0 / 10, b0 * 10, n), none)
    if math.isfinite(best[0]):            # a finer grid over the best point's neighbourhood (not through the design)
        m1, b1 = best[1], best[2]
        best = lightest(np.geomspace(m1 / step, m1 * step, 10), np.geomspace(b1 / step, b1 * step, 10), best)
    design = felt(adm["m_v"], adm["b_v"])
    ok = reference_meets(paths, responses, w, adm["m_v"], adm["b_v"], T, spec.admittance.phase_margin_deg - 0.05,
                         spec.admittance.gain_margin_db - 0.05)
    print(f"  (m_v, b_v) independent brute force, {n} x {n} points and 10 x 10 around the best, on {len(scenarios)} "
          f"scenarios x {len(corners)} mice "
          f"({time.perf_counter() - t0:.0f} s): best meeting every margin m_v {best[1]:.4g} kg, b_v {best[2]:.4g} "
          f"N*s/m, force felt {best[0]:.4f} N; the design {design:.4f} N (meets them on the reference: {ok}); ratio "
          f"design / brute force {design / best[0]:.4f} (target <= 1.05)")


def pi_grid(doc: dict) -> None:
    from design.admittance.codesign import codesign_score
    from design.spec.schema import load_spec

    adm = doc["admittance"]
    spec = load_spec(SPEC).problem()
    kp_f = (0.7, 1.0, 1.4) if QUICK else (0.5, 0.7, 1.0, 1.4, 2.0)
    ki_f = (0.1, 1.0, 10.0) if QUICK else (1e-2, 0.1, 1.0, 10.0, 100.0)
    t0 = time.perf_counter()
    scores = {(fp, fi): codesign_score(spec, controller=PI(adm["kp"] * fp, adm["ki"] * fi))
              for fp in kp_f for fi in ki_f}
    (fp, fi), best = min(scores.items(), key=lambda kv: kv[1])
    chosen = scores[(1.0, 1.0)]
    print(f"  PI grid around the co-design ({len(scores)} points, {time.perf_counter() - t0:.0f} s, the co-design's "
          f"reduced set): best Kp x{fp:g}, Ki x{fi:g} at {best:.4f} N; the co-design's gains {chosen:.4f} N; ratio "
          f"{chosen / best:.4f} (lower is better; inf: the velocity loop misses its requirements)")


if __name__ == "__main__":
    print("== specs/stage_x_admittance.toml")
    doc = command_figures()
    adm = doc["admittance"]
    print(f"  design: {adm['status']}, Kp {adm['kp']:.4g}, Ki {adm['ki']:.4g}, m_v {adm['m_v']:.4g} kg, b_v "
          f"{adm['b_v']:.4g} N*s/m; force felt {adm['mouse']['force_felt_peak_n']:.3f} N (the mouse: "
          f"{adm['limits']['mouse_peak_force_n']:g} N); worst PM floating "
          f"{adm['margins_by_mouse']['floating']['phase_margin_deg']:.1f} deg, braced "
          f"{adm['margins_by_mouse']['grounded']['phase_margin_deg']:.1f} deg; passive up to "
          f"{adm['passive_up_to_hz']:.3g} Hz; stiffest contact {adm['stiffest_contact_n_per_m']:.4g} N/m")
    virtual_grid(doc)
    pi_grid(doc)
