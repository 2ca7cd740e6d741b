"""Identification round four on recordings of the independent simulator (tests/reference/independent_sim.py, which
imports nothing of the tool): a force constant drifting over the record, Stage Y rails read to different scales or
driven by motors whose force constants differ, those with a delay or a mode beside them, controls with nothing
missing, and a truth outside the library; stepped sines only (a drift in a time recording, under a sweep of three
sines, a chirp, a stepped sine in one run or a closed loop, is ``bench_motor_forces.py --drifts``; Stage Y's rails
in the open-loop time forms are ``bench_two_rails.py``).

Run:  python benchmarks/bench_identification.py [--n 64] [--seed 45] [--jobs 2]

The simulator records a plant whose force constant is constant; the drift scales each sample's velocity by
K_t(t) / K_t(0) (exact to first order in a rate far slower than the stage), the rail scale multiplies the Y2
column, the motors' force constants enter the beam's input matrix. Each recording is diagnosed in this process
(``plant.diagnose.diagnosis.diagnose``) so that every model it reports can be checked.

Scoring per recording
  hit     the verdict "explained", the named effect set equal to the truth's, a drift named exactly when there is
          one, main parameters within 15 % (the drift's change, the rail's scale - 1 and the motors' fraction
          within 15 % of their size), mass within 15 %; a truth outside the library: "not_explained".
  false   an effect named that is not in the truth (in an "explained" verdict), a drift named where there is
          none, or "explained" on a truth outside the library.
  unidentified   a reported model (selected, best or alternative) with an added effect whose parameter sits at a
          bound, has no finite error, whose main parameter's error exceeds its value, or a mode outside an octave
          of the band: checked here from the fit's own numbers, not by the tool's rule.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import as_commands  # noqa: F401  (BLAS on one thread, as the commands run it)
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "reference"))

import independent_sim as sim  # noqa: E402

CLASSES = ("drift", "drift_delay", "drift_control", "rail_scale", "rail_scale_tilt", "motor_imbalance",
           "rails_control", "outside_four_mass")
TOLERANCE = 0.15
MODES = ("resonance", "payload_resonance", "second_resonance", "tilt_coupling")
F_HZ = tuple(np.geomspace(1.0, 75.0, 24))


@dataclass
class Draw:
    net: sim.Network
    drive: sim.Drive
    protocol: sim.Protocol
    noise: float
    effects: tuple[str, ...]
    parameters: dict
    stage: str
    mass_kg: float
    load_position_m: float | None = None
    drift_change: float = 0.0
    y2_scale: float = 1.0
    outside: bool = False


@dataclass
class Outcome:
    index: int
    cls: str
    verdict: str = ""
    named: tuple[str, ...] = ()
    drift: float | None = None
    hit: bool = False
    false: bool = False
    unidentified: list[str] = field(default_factory=list)
    misses: list[str] = field(default_factory=list)
    seconds: float = 0.0


def _beam(rng, load_m: float, imbalance: float = 0.0):
    inertia = rng.uniform(1.0, 3.0)
    tilt_hz = rng.uniform(25, 45)
    net = sim.stage_y_beam(rng.uniform(25, 45), inertia, load_m, inertia * (2 * np.pi * tilt_hz) ** 2,
                           damping_n_s_per_m=rng.uniform(330, 550) / 2)
    T = np.array([[1.0, -load_m], [1.0, sim.BEAM_LENGTH_M - load_m]])
    kt = sim.KT_N_PER_A
    return dataclasses.replace(net, input_n_per_a=T.T @ np.array([kt * (1 + imbalance) / 2, kt * (1 - imbalance) / 2]))


def draw(cls: str, seed: int) -> Draw:
    rng = np.random.default_rng(seed)
    noise = float(np.exp(rng.uniform(np.log(0.01), np.log(0.05))))
    stepped = sim.Protocol(f_hz=F_HZ, block_s=3.0, sample_rate_hz=1000.0, amplitude_a=float(rng.uniform(0.5, 2.0)))
    if cls.startswith("drift"):
        mass = rng.uniform(20, 45)
        net = sim.rigid_stage(mass, rng.uniform(330, 550))
        protocol = dataclasses.replace(stepped, block_s=10.0)
        change = 0.0 if cls == "drift_control" else -rng.uniform(0.02, 0.05)
        drive, effects, params = sim.Drive(), (), {}
        if cls == "drift_delay":
            delay = float(rng.uniform(0.5e-3, 2e-3))
            drive, effects, params = sim.Drive(delay_s=delay), ("delay",), {"delay.seconds": delay}
        return Draw(net, drive, protocol, noise, effects, params, "x", mass, drift_change=change)
    if cls == "outside_four_mass":
        masses = rng.uniform(0.6, 1.4, 4)
        masses *= rng.uniform(20, 45) / masses.sum()
        net = sim.tuned_chain(masses, [rng.uniform(20, 30), rng.uniform(38, 50), rng.uniform(58, 72)],
                              rng.uniform(0.02, 0.04), rng.uniform(330, 550))
        return Draw(net, sim.Drive(), stepped, noise, (), {}, "x", float(masses.sum()), outside=True)
    # Stage Y
    off_centre = cls in ("rail_scale_tilt", "motor_imbalance", "rails_control")
    load = sim.BEAM_LENGTH_M / 2 + (rng.uniform(0.08, 0.2) * rng.choice([-1.0, 1.0]) if off_centre else 0.0)
    imbalance = float(rng.uniform(0.03, 0.08) * rng.choice([-1.0, 1.0])) if cls == "motor_imbalance" else 0.0
    scale = float(1 + rng.uniform(0.02, 0.05) * rng.choice([-1.0, 1.0])) if cls.startswith("rail_scale") else 1.0
    net = _beam(rng, load, imbalance)
    effects = (("tilt_coupling",) if off_centre else ()) + (("rail_scale",) if scale != 1.0 else ()) + \
        (("motor_imbalance",) if imbalance else ())
    params = {**({"rail_scale.y2_scale": scale} if scale != 1.0 else {}),
              **({"motor_imbalance.fraction": imbalance} if imbalance else {})}
    return Draw(net, sim.Drive(), dataclasses.replace(stepped, amplitude_a=float(rng.uniform(1.0, 2.0))), noise,
                effects, params, "y", float(net.mass[0, 0]), load_position_m=load, y2_scale=scale)


def record(d: Draw, seed: int, directory: Path) -> Path:
    rec = sim.simulate(d.net, d.drive, d.protocol, noise=d.noise, seed=seed)
    durations = [t[-1] + (t[1] - t[0]) for t in rec.time_s]
    total = float(sum(durations))
    for start, t, v in zip(np.cumsum([0.0] + durations[:-1]), rec.time_s, rec.velocity_m_per_s):
        v *= (1.0 + d.drift_change * (start + t) / total)[:, None]
        if d.stage == "y":
            v[:, 1] *= d.y2_scale
    return sim.write_csv(rec, directory / f"rec_{seed}.csv")


def unidentified(fit, band: tuple[float, float]) -> list[str]:
    """The added effects of ``fit`` that its own numbers do not identify (module doc)."""
    from plant.physics.effects import EFFECTS

    params = fit.plant.parameters()
    out = []
    for name in fit.free:
        effect, _, fld = name.partition(".")
        if not fld or effect == "encoder_velocity":
            continue
        p, v, e = params[name], fit.values[name], fit.stderr[name]
        bad = (any(math.isclose(v, b, rel_tol=1e-4, abs_tol=1e-12) for b in (p.lower, p.upper)) or not math.isfinite(e)
               or (fld == EFFECTS[effect].main_parameter and e > abs(v))
               or (effect in MODES and fld == "frequency_hz" and not band[0] / 2 <= v <= 2 * band[1]))
        if bad:
            out.append(f"{name} = {v:.4g} ± {e:.2g}")
    return out


def run(args: tuple[int, str, int]) -> Outcome:
    index, cls, seed = args
    from plant import stage_x, stage_y
    from plant.data.read_stepped_sine import read_recording
    from plant.diagnose.diagnosis import diagnose
    from plant.estimate.lockin import estimate_response

    d = draw(cls, seed)
    out = Outcome(index, cls)
    with tempfile.TemporaryDirectory() as tmp:
        data = estimate_response(read_recording(record(d, seed, Path(tmp))))
    t0 = time.perf_counter()
    declared = stage_x() if d.stage == "x" else stage_y(load_position_m=d.load_position_m)
    diag = diagnose(declared, data)
    out.seconds = time.perf_counter() - t0
    out.verdict, out.named = diag.verdict, tuple(sorted(diag.added))
    out.drift = None if diag.drift is None else diag.drift.change
    band = (float(min(data.f_hz)), float(max(data.f_hz)))
    for fit in [diag.final] + [diag.models[a.effects] for a in diag.alternatives]:
        out.unidentified += unidentified(fit, band)
    if d.outside:
        out.hit = diag.verdict == "not_explained"
        out.false = not out.hit
        return out
    truth = set(d.effects)
    extra = set(out.named) - truth
    drift_wrong = (diag.drift is not None) != (d.drift_change != 0.0)
    out.false = diag.verdict == "explained" and (bool(extra) or drift_wrong)
    if diag.verdict != "explained":
        out.misses.append("not explained")
    if set(out.named) != truth:
        out.misses.append(f"effects {sorted(out.named)}")
    if drift_wrong:
        out.misses.append("drift" if diag.drift is not None else "no drift")
    elif diag.drift is not None:
        span = diag.drift.span_s
        total = span * 24 / 23
        true = d.drift_change * span / total
        if abs(diag.drift.change - true) > TOLERANCE * abs(true):
            out.misses.append(f"drift {diag.drift.change:+.3%} for {true:+.3%}")
    for name, true in d.parameters.items():
        got = diag.final.values.get(name)
        size = abs(true - 1) if name.endswith("y2_scale") else abs(true)
        if got is None or abs(got - true) > TOLERANCE * size:
            out.misses.append(f"{name} {got} for {true:.4g}")
    mass = diag.final.values["mass_kg"] * (1 + (d.drift_change / 2 if diag.drift is not None else 0.0))
    if abs(mass - d.mass_kg) > TOLERANCE * d.mass_kg:
        out.misses.append(f"mass {mass:.3g} for {d.mass_kg:.3g}")
    out.hit = not out.misses
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=64)
    parser.add_argument("--seed", type=int, default=45)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    seeds = np.random.SeedSequence(args.seed).generate_state(args.n)
    todo = [(k, CLASSES[k % len(CLASSES)], int(seeds[k])) for k in range(args.n)]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        results = []
        for r in pool.map(run, todo):
            results.append(r)
            print(f"{r.index:3d} {r.cls:18s} {r.verdict:14s} {','.join(r.named) or 'none':38s} "
                  f"{'' if r.drift is None else f'drift {r.drift:+.2%}':14s} {r.seconds:6.2f} s "
                  f"{'HIT' if r.hit else '-':4s} {'FALSE ' if r.false else ''}{'; '.join(r.misses)}"
                  f"{' UNIDENTIFIED ' + '; '.join(r.unidentified) if r.unidentified else ''}", flush=True)
    n = len(results)
    hits = sum(r.hit for r in results)
    print(f"\nhit rate        {hits}/{n} = {100 * hits / n:.0f} %")
    print(f"false claims    {sum(r.false for r in results)}")
    print(f"unidentified    {sum(bool(r.unidentified) for r in results)} recordings with an unidentified effect "
          "in a reported model")
    secs = [r.seconds for r in results]
    print(f"seconds/diagnosis  mean {np.mean(secs):.2f}, max {np.max(secs):.2f}; wall {time.perf_counter() - t0:.0f} s")
    for cls in CLASSES:
        rs = [r for r in results if r.cls == cls]
        print(f"  {cls:18s} {sum(r.hit for r in rs)}/{len(rs)}")


if __name__ == "__main__":
    main()
