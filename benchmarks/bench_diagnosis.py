"""Diagnosis benchmark on recordings from the independent simulator (tests/reference/independent_sim.py).

Run:  python benchmarks/bench_diagnosis.py [--n 72] [--seed 2024] [--only CLASS] [--keep DIR] [--jobs 1]

Every recording is drawn from one class (classes cycle, so the set covers them evenly), written
as a stepped-sine CSV and diagnosed with ``python -m design diagnose REC.csv --stage x|y --json``
(Stage Y recordings also pass the load position, which the experimenter knows). The simulator
shares no code with the tool, so the truth does not depend on the code under test.

Scoring per recording
  hit   truth inside the library: verdict "explained", the named effect set equals the truth,
        main chain parameters within 15 % (delay.seconds, current_loop.bandwidth_hz,
        sensor_filter.frequency_hz), every truth mode matched by a reported mode within 15 %,
        mass_kg within 15 % for "mass only off", and final reduced chi2 < 2.
        Truth outside the library: verdict "not_explained".
  false found   verdict "explained" with a wrong effect set, or with a truth outside the library.
  strict        truth set not the best, but among the reported alternatives.
If the tool's JSON has no "verdict", it is taken as "explained" when the final reduced chi2 is
below 2 (marked with * in the table).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path

import as_commands  # noqa: F401  (BLAS on one thread, as the commands run it)
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "reference"))

import independent_sim as sim  # noqa: E402

TOLERANCE = 0.15
CHI2_LIMIT = 2.0
CHAIN_PARAMETERS = {"delay": "delay.seconds", "current_loop": "current_loop.bandwidth_hz",
                    "sensor_filter": "sensor_filter.frequency_hz"}
CLASSES = ("rigid_delay", "rigid_current_loop", "resonance", "payload_resonance", "delay_resonance",
           "current_loop_resonance", "delay_payload_resonance", "three_mass", "sensor_filter",
           "stage_y_tilt", "mass_only", "outside_four_mass")


@dataclass
class Case:
    """One benchmark recording: its class, file, truth and the diagnose command's outcome."""

    index: int
    cls: str
    path: Path
    truth: sim.Truth
    load_position_m: float | None = None
    result: dict | None = None
    error: str | None = None
    seconds: float = 0.0


def _named(res: dict) -> set[str]:
    """Effects the diagnosis added to the base model (a sensor it set from the recording, such as an
    encoder-differenced velocity, is part of the base model, not a finding)."""
    return set(res.get("added_effects", res.get("final_effects")) or [])


def _drive_draws(rng, cls: str):
    """Chain effects of the class: (Drive keyword arguments, effect names, main parameters)."""
    kwargs, effects, params = {}, [], {}
    if "delay" in cls:
        kwargs["delay_s"] = params["delay.seconds"] = float(rng.uniform(0.3e-3, 2.5e-3))
        effects.append("delay")
    if "current_loop" in cls:
        kwargs["current_loop_hz"] = params["current_loop.bandwidth_hz"] = float(rng.uniform(100, 400))
        effects.append("current_loop")
    if cls == "sensor_filter":
        kwargs["sensor_filter_hz"] = params["sensor_filter.frequency_hz"] = float(rng.uniform(80, 300))
        effects.append("sensor_filter")
    return kwargs, effects, params


def _two_mass(rng, sensed: str):
    """Motor + payload with a mode at 30-70 Hz and coupling damping ratio 0.02-0.1."""
    total_kg = rng.uniform(20, 45)
    payload_kg = total_kg * rng.uniform(0.3, 0.6)
    motor_kg = total_kg - payload_kg
    w_rad_s = 2 * np.pi * rng.uniform(30, 70)
    reduced_kg = motor_kg * payload_kg / total_kg
    zeta = rng.uniform(0.02, 0.1)
    return sim.two_mass(motor_kg, payload_kg, reduced_kg * w_rad_s ** 2, 2 * zeta * reduced_kg * w_rad_s,
                        rng.uniform(330, 550), sensed=sensed)


def _split(rng, total_kg: float, n: int) -> np.ndarray:
    shares = rng.uniform(0.6, 1.4, n)
    return total_kg * shares / shares.sum()


@dataclass
class Draw:
    """A drawn experiment: network, drive, protocol, relative noise, truth, Stage Y load position (m)."""

    net: sim.Network
    drive: sim.Drive
    protocol: sim.Protocol
    noise: float
    truth: sim.Truth
    load_position_m: float | None


def draw(cls: str, seed: int) -> Draw:
    """Draw an experiment of class ``cls`` from ``seed``."""
    rng = np.random.default_rng(seed)
    drive_kwargs, effects, params = _drive_draws(rng, cls)
    stage, outside, load_position_m = "x", False, None
    if cls in ("rigid_delay", "rigid_current_loop", "sensor_filter"):
        net = sim.rigid_stage(rng.uniform(20, 45), rng.uniform(330, 550))
    elif cls == "mass_only":
        mass_kg = rng.choice([rng.uniform(20, 28), rng.uniform(42, 45)])
        net = sim.rigid_stage(mass_kg, rng.uniform(330, 550))
    elif cls in ("resonance", "delay_resonance", "current_loop_resonance"):
        net = _two_mass(rng, "motor")
        effects.append("resonance")
    elif cls in ("payload_resonance", "delay_payload_resonance"):
        net = _two_mass(rng, "payload")
        effects.append("payload_resonance")
    elif cls == "three_mass":
        net = sim.tuned_chain(_split(rng, rng.uniform(20, 45), 3), [rng.uniform(25, 40), rng.uniform(50, 70)],
                              rng.uniform(0.02, 0.05), rng.uniform(330, 550))
        effects += ["resonance", "second_resonance"]
    elif cls == "outside_four_mass":
        net = sim.tuned_chain(_split(rng, rng.uniform(20, 45), 4),
                              [rng.uniform(20, 30), rng.uniform(38, 50), rng.uniform(58, 72)],
                              rng.uniform(0.02, 0.04), rng.uniform(330, 550))
        outside = True
    elif cls == "stage_y_tilt":
        stage = "y"
        offset_m = rng.uniform(0.05, 0.2) * rng.choice([-1.0, 1.0])
        load_position_m = sim.BEAM_LENGTH_M / 2 + offset_m
        inertia_kg_m2 = rng.uniform(1.0, 3.0)
        w_rad_s = 2 * np.pi * rng.uniform(28, 40)
        net = sim.stage_y_beam(rng.uniform(25, 45), inertia_kg_m2, load_position_m, inertia_kg_m2 * w_rad_s ** 2,
                               damping_n_s_per_m=rng.uniform(330, 550) / 2)
        effects.append("tilt_coupling")
    else:
        raise ValueError(f"unknown class {cls!r}")
    encoder = cls != "sensor_filter" and rng.random() < 0.25
    if encoder:
        drive_kwargs["encoder_quantum_m"] = float(rng.uniform(0.1e-6, 0.3e-6))
    first_periods = float(rng.uniform(2.0, 2.5)) if rng.random() < 0.15 else None
    protocol = sim.Protocol(block_s=float(rng.uniform(3, 5)), sample_rate_hz=float(rng.choice([500, 1000, 2000])),
                            amplitude_a=float(rng.uniform(0.5, 2.0)), first_block_periods=first_periods)
    noise = float(np.exp(rng.uniform(np.log(0.01), np.log(0.15))))
    truth = sim.Truth(
        effects=tuple(sorted(effects)), parameters=params, modes_hz=net.mode_frequencies_hz(),
        mass_kg=float(net.mass[0, 0] if stage == "y" else np.trace(net.mass)), stage=stage,
        outside_library=outside, seed=seed, description=cls,
        conditions={"sample_rate_hz": protocol.sample_rate_hz, "noise": noise, "encoder": encoder,
                    "short_first_block": first_periods is not None})
    return Draw(net, sim.Drive(**drive_kwargs), protocol, noise, truth, load_position_m)


def draw_case(index: int, cls: str, seed: int, directory: Path) -> Case:
    """Draw the recording of class ``cls`` from ``seed`` and write it (and its truth JSON) to ``directory``."""
    d = draw(cls, seed)
    rec = sim.simulate(d.net, d.drive, d.protocol, noise=d.noise, seed=seed, truth=d.truth)
    path = sim.write_csv(rec, directory / f"rec{index:03d}_{cls}.csv")
    path.with_suffix(".truth.json").write_text(json.dumps(asdict(d.truth), indent=1))
    return Case(index, cls, path, d.truth, d.load_position_m)


def run_case(case: Case) -> Case:
    """Run ``python -m design diagnose`` on the case's recording; fill result (or error) and wall seconds."""
    cmd = [sys.executable, "-m", "design", "diagnose", str(case.path), "--stage", case.truth.stage, "--json"]
    if case.load_position_m is not None:
        cmd += ["--load-position-m", f"{case.load_position_m:.6g}"]
    start = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    case.seconds = time.perf_counter() - start
    if proc.returncode != 0:
        case.error = (proc.stderr.strip().splitlines() or ["exit %d" % proc.returncode])[-1]
        return case
    try:
        case.result = json.loads(proc.stdout)
    except json.JSONDecodeError as exc:
        case.error = f"bad JSON: {exc}"
    return case


def _final_chi2(res: dict) -> float | None:
    if res.get("final_reduced_chi2") is not None:
        return float(res["final_reduced_chi2"])
    steps = res.get("steps") or []
    return float(steps[-1]["reduced_chi2"]) if steps and steps[-1].get("reduced_chi2") is not None else None


def _verdict(res: dict) -> tuple[str, bool]:
    """The tool's verdict and whether it had to be inferred from the final reduced chi2."""
    if res.get("verdict") in ("explained", "not_explained"):
        return res["verdict"], False
    chi2 = _final_chi2(res)
    return ("explained" if chi2 is not None and chi2 < CHI2_LIMIT else "not_explained"), True


def _within(value, truth: float) -> bool:
    return value is not None and abs(float(value) - truth) <= TOLERANCE * abs(truth)


def _parameter(res: dict, name: str):
    entry = (res.get("parameters") or {}).get(name)
    return entry.get("value") if isinstance(entry, dict) else entry


def score(case: Case) -> dict:
    """Hit, false-found and strict flags plus the columns of the table."""
    truth = case.truth
    row = {"hit": False, "false_found": False, "strict": False, "named": "", "verdict": "error",
           "chi2": None, "why": case.error or ""}
    if case.result is None:
        return row
    res = case.result
    named = _named(res)
    verdict, inferred = _verdict(res)
    chi2 = _final_chi2(res)
    row.update(named="+".join(sorted(named)) or "none", verdict=verdict + ("*" if inferred else ""), chi2=chi2)
    if truth.outside_library:
        row["hit"] = verdict == "not_explained"
        row["false_found"] = verdict == "explained"
        row["why"] = "" if row["hit"] else "claimed explained"
        return row
    right_set = named == set(truth.effects)
    row["false_found"] = verdict == "explained" and not right_set
    if not right_set:
        alternatives = res.get("alternatives") or []
        row["strict"] = any(set(a.get("effects") or []) == set(truth.effects) for a in alternatives)
    why = []
    if verdict != "explained":
        why.append("not explained")
    if not right_set:
        why.append("effect set")
    for name, value in truth.parameters.items():
        if not _within(_parameter(res, name), value):
            why.append(name)
    modes = res.get("modes_hz") or []
    for mode in truth.modes_hz:
        if not any(_within(m, mode) for m in modes):
            why.append(f"mode {mode:.1f} Hz")
    if not truth.effects and not _within(_parameter(res, "mass_kg"), truth.mass_kg):
        why.append("mass_kg")
    if chi2 is None or chi2 >= CHI2_LIMIT:
        why.append("chi2")
    row["hit"] = not why
    row["why"] = ", ".join(why)
    return row


def _truth_label(truth: sim.Truth) -> str:
    if truth.outside_library:
        return f"outside ({len(truth.modes_hz)} modes)"
    return "+".join(truth.effects) or "none"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=72, help="number of recordings (classes cycle)")
    parser.add_argument("--seed", type=int, default=2024, help="master seed")
    parser.add_argument("--only", choices=CLASSES, help="only this class")
    parser.add_argument("--keep", type=Path, help="keep the CSVs (and truth JSON) in this directory")
    parser.add_argument("--jobs", type=int, default=1, help="recordings diagnosed in parallel")
    args = parser.parse_args()

    classes = (args.only,) if args.only else CLASSES
    seeds = np.random.SeedSequence(args.seed).generate_state(args.n)
    with tempfile.TemporaryDirectory() as tmp:
        directory = args.keep or Path(tmp)
        directory.mkdir(parents=True, exist_ok=True)

        def one(k: int) -> Case:
            return run_case(draw_case(k, classes[k % len(classes)], int(seeds[k]), directory))

        with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            cases = list(pool.map(one, range(args.n)))

    rows = [score(c) for c in cases]
    print(f"{'#':>3} {'class':24} {'truth':32} {'named':32} {'verdict':14} {'chi2':>8} {'s':>6} "
          f"{'fs':>5} {'noise':>5} {'enc':>3} hit  why")
    for c, r in zip(cases, rows):
        cond = c.truth.conditions
        chi2 = f"{r['chi2']:.3g}" if r["chi2"] is not None else "-"
        print(f"{c.index:3d} {c.cls:24} {_truth_label(c.truth):32} {r['named']:32} {r['verdict']:14} {chi2:>8} "
              f"{c.seconds:6.2f} {cond['sample_rate_hz']:5.0f} {cond['noise']:5.3f} "
              f"{'yes' if cond['encoder'] else 'no':>3} {'HIT' if r['hit'] else '-':4} {r['why']}")
    n = len(rows)
    hits = sum(r["hit"] for r in rows)
    false_found = sum(r["false_found"] for r in rows)
    seconds = np.array([c.seconds for c in cases])
    wrong_set = [r for c, r in zip(cases, rows) if c.result is not None and not c.truth.outside_library
                 and _named(c.result) != set(c.truth.effects)]
    print(f"\nhit rate            {hits}/{n} = {hits / n:.0%}")
    print(f"false 'found'       {false_found}/{n} = {false_found / n:.0%}")
    print(f"seconds/recording   mean {seconds.mean():.2f}, max {seconds.max():.2f}")
    print(f"strict mode         truth among alternatives in {sum(r['strict'] for r in wrong_set)}"
          f"/{len(wrong_set)} diagnosed in-library recordings whose best effect set is wrong")
    errors = sum(c.error is not None for c in cases)
    if errors:
        print(f"errors              {errors}/{n} recordings failed to diagnose")
    print("\nhit rate per class")
    for cls in classes:
        got = [r["hit"] for c, r in zip(cases, rows) if c.cls == cls]
        if got:
            print(f"  {cls:24} {sum(got)}/{len(got)}")


if __name__ == "__main__":
    main()
