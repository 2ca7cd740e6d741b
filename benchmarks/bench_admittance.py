"""Admittance benchmark on ``specs/stage_x_admittance.toml`` (the walking mouse, the 100 Hz law, co-design):
what a user waits for and how good the design is against brute force, side by side in one run.

Run:  python benchmarks/bench_admittance.py [--quick]

* The command: ``gantry synth specs/stage_x_admittance.toml --json`` as a user runs it, in a fresh process
  under ``/usr/bin/time``: wall seconds, CPU seconds (user + system) and peak memory (max RSS), the median of
  ``RUNS`` runs (1 with ``--quick``); the same on one thread (``GANTRY_THREADS=1``: the array chunks of
  ``design.parallel`` in the calling thread) and for the synthesis of the PI loop alone
  (``specs/stage_x_synth.toml``) beside it.
* (m_v, b_v) at the design's PI gains against brute force: a log grid over a decade each way around the design
  (16 x 16, 10 x 10 with ``--quick``), every point checked exactly on the design scenarios (payload points x
  uncertainty corners x every mouse: screened grid margins and Nyquist stability, hardware limits) and scored
  by the force the mouse feels on the profile (``design.admittance.feel.FeltForce``); the best grid point beside
  the design.
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


def lightest_on_grid(ev, felt, m_v: float, b_v: float, n: int) -> tuple[float, float, float]:
    """(force felt N, m_v, b_v) of the lightest point of an n x n log grid a decade either side of (m_v, b_v) that
    the evaluator ``ev`` passes (``AdmittanceEvaluator``; ``felt``: ``FeltForce``)."""
    best = (math.inf, math.nan, math.nan)
    for m in np.geomspace(m_v / 10, m_v * 10, n):
        for b in np.geomspace(b_v / 10, b_v * 10, n):
            f = felt(m, b)
            if f < best[0] and ev.evaluate(m, b, bandwidth=False).meets:
                best = (f, m, b)
    return best


def virtual_grid(doc: dict) -> None:
    from design.admittance.feel import FeltForce, feel_scenarios
    from design.admittance.model import AdmittanceEvaluator, PiLoops, mice
    from design.admittance.rig import RigTiming
    from design.spec.schema import load_spec
    from design.synth.scenarios import design_scenarios

    adm = doc["admittance"]
    spec = load_spec(SPEC).problem()
    timing = RigTiming.of(spec.admittance.rig, filter_hz=adm["rig"]["force_filter_hz"])
    corners = mice(spec)
    loops = PiLoops.of(spec, adm["kp"], adm["ki"])
    ev = AdmittanceEvaluator(spec, design_scenarios(spec), loops=loops, timing=timing, corners=corners)
    felt = FeltForce(spec, feel_scenarios(spec), corners, loops=loops, timing=timing)
    n = 10 if QUICK else 16
    t0 = time.perf_counter()
    best = lightest_on_grid(ev, felt, adm["m_v"], adm["b_v"], n)
    design = felt(adm["m_v"], adm["b_v"])
    print(f"  (m_v, b_v) brute force, {n} x {n} points on {len(ev.scenarios)} scenarios x {len(corners)} mice "
          f"({time.perf_counter() - t0:.0f} s): best meeting every requirement m_v {best[1]:.4g} kg, b_v "
          f"{best[2]:.4g} N*s/m, force felt {best[0]:.4f} N; the design {design:.4f} N; ratio design / brute force "
          f"{design / best[0]:.4f} (lower is better)")


def pi_grid(doc: dict) -> None:
    from design.admittance.codesign import codesign_score
    from design.spec.schema import load_spec

    adm = doc["admittance"]
    spec = load_spec(SPEC).problem()
    kp_f = (0.7, 1.0, 1.4) if QUICK else (0.5, 0.7, 1.0, 1.4, 2.0)
    ki_f = (0.1, 1.0, 10.0) if QUICK else (1e-2, 0.1, 1.0, 10.0, 100.0)
    t0 = time.perf_counter()
    scores = {(fp, fi): codesign_score(spec, kp=adm["kp"] * fp, ki=adm["ki"] * fi) for fp in kp_f for fi in ki_f}
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
