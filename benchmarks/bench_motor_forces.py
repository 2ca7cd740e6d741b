"""Linear-motor forces benchmark: the time-domain diagnosis on recordings of two independent simulators that
share no code with the tool, with a force ripple, a force-constant profile, both, neither, or an amplifier
current limit (outside the time-domain library).

Run:  python benchmarks/bench_motor_forces.py [--n 60] [--seed 23]

Forms (drawn per recording):

* open loop, ``tests/reference/independent_linear_motor.py``: a slow sweep over ~0.17 m (0.25 Hz, 3 A, plus 3.1
  and 7.3 Hz), RK4 integration; truths: ripple 1.5-5 N at a 12-40 mm pitch and any phase, a force constant
  falling 15-40 % towards the ends of a 0.3 m track, both, neither, or a current limit at 55-80 % of the peak
  command; current noise 2-10 mA, position noise 0.5-5 um;
* closed position loop with Coulomb friction and an offset, ``tests/reference/independent_friction_sim.py`` (the
  EMPS-like axis, encoder-quantised, PD at 1 kHz); truths: friction and offset, with or without a ripple of
  2-6 N at 15-30 mm.

A hit: for a truth in the library, exactly its effects (friction and offset included in the closed loop),
"explained", the ripple's pitch within 1 % and its first-harmonic amplitude within 10 % (5 % of the drive
force absolute), the profile's slope and curvature within 15 % (0.02 absolute, or 3 Newey-West standard
errors where the recording's noise allows no better); for the current limit,
"not explained" with no effect claimed. False "explained": a truth outside the library called explained;
false "found": an effect claimed that is not there.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "reference"))

import independent_friction_sim as friction_sim  # noqa: E402
import independent_linear_motor as lm  # noqa: E402

from plant import Plant, stage_x  # noqa: E402
from plant.data.recordings import TimeRecording  # noqa: E402
from plant.diagnose.time_diagnosis import diagnose_time  # noqa: E402
from plant.identify.inverse_model import Preprocessing  # noqa: E402

TRAVEL_M = 0.3
OPEN = ("none", "ripple", "profile", "both", "current_limit")


def _draw(rng: np.random.Generator):
    """(form, truth label, axis, expected effects)."""
    if rng.uniform() < 0.25:
        ripple = rng.uniform() < 0.6
        axis = friction_sim.Axis(coulomb_n=rng.uniform(5, 30), offset_n=rng.uniform(-5, 5),
                                 ripple_n=rng.uniform(2, 6) if ripple else 0.0,
                                 ripple_period_m=rng.uniform(0.015, 0.03))
        expected = {"coulomb_friction", "offset"} | ({"force_ripple"} if ripple else set())
        return "closed", "friction+ripple" if ripple else "friction", axis, expected
    kind = OPEN[int(rng.integers(len(OPEN)))]
    kw = {}
    if kind in ("ripple", "both"):
        kw.update(ripple_n=(rng.uniform(1.5, 5.0),), ripple_phase_rad=(rng.uniform(0, 2 * np.pi),),
                  ripple_pitch_m=rng.uniform(0.012, 0.04))
    if kind in ("profile", "both"):
        kw.update(kt_droop=rng.uniform(0.15, 0.4), travel_m=TRAVEL_M)
    if kind == "current_limit":
        kw.update(current_limit_a=rng.uniform(0.55, 0.8) * 4.3)
    expected = {"ripple": {"force_ripple"}, "profile": {"force_constant_profile"},
                "both": {"force_ripple", "force_constant_profile"}}.get(kind, set())
    return "open", kind, lm.LinearMotorAxis(**kw), expected


def _record(form: str, axis, rng: np.random.Generator, seed: int) -> tuple[TimeRecording, Plant, Preprocessing]:
    if form == "closed":
        log = friction_sim.simulate(axis, seed=seed)
        rec = TimeRecording(log.time_s, log.command_v, log.position_m[None], "position", ("position_m",),
                            reference=log.reference_m)
        return rec, Plant("x", force_constant_n_per_a=axis.gain_n_per_v), Preprocessing(input_hold=True)
    t, current, position = lm.slow_sweep(axis, seed=seed, current_noise_a=rng.uniform(0.002, 0.01),
                                         position_noise_m=rng.uniform(0.5e-6, 5e-6))
    return TimeRecording(t, current, position[None], "position", ("x",)), stage_x(), Preprocessing()


def _parameters_ok(form: str, axis, diag) -> tuple[bool, str]:
    """The fitted shapes against the truth (module doc), and the errors in words."""
    words, ok = [], True
    ripple = diag.final.plant.effect("force_ripple")
    if ripple is not None:
        pitch, amp = ((axis.ripple_period_m, axis.ripple_n) if form == "closed" else
                      (axis.ripple_pitch_m, axis.ripple_n[0]))
        # the closed loop's force is in N of the drive: same scale; the open loop's relative to K at mid-travel
        scale = 1.0
        profile = diag.final.plant.effect("force_constant_profile")
        if form == "open" and axis.kt_droop:
            a = 4 * axis.kt_droop / axis.travel_m**2
            scale = 1 / (1 - a * profile.centre_m**2) if profile is not None else 1.0
        e_pitch = ripple.pitch_m / pitch - 1
        e_amp = ripple.amplitude_n() - amp * scale
        ok &= abs(e_pitch) < 0.01 and abs(e_amp) < max(0.1 * amp * scale, 0.05 * 10.0)
        words.append(f"pitch {100 * e_pitch:+.2f} %, amplitude {e_amp:+.2f} N")
    profile = diag.final.plant.effect("force_constant_profile")
    if profile is not None and form == "open" and axis.kt_droop:
        a = 4 * axis.kt_droop / axis.travel_m**2
        k_centre = 1 - a * profile.centre_m**2
        slope = -2 * a * profile.centre_m * profile.half_span_m / k_centre
        curvature = -a * profile.half_span_m**2 / k_centre
        e1, e2 = profile.slope - slope, profile.curvature - curvature
        se = diag.final.stderr
        ok &= (abs(e1) < max(0.15 * abs(slope), 0.02, 3 * se["force_constant_profile.slope"])
               and abs(e2) < max(0.15 * abs(curvature), 0.02, 3 * se["force_constant_profile.curvature"]))
        words.append(f"slope {e1:+.3f}, curvature {e2:+.3f}")
    return ok, "; ".join(words)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=60)
    parser.add_argument("--seed", type=int, default=23)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    hits = false_explained = false_found = 0
    seconds, sim_seconds = [], []
    by_truth: dict[str, list[int]] = {}
    print(f"{'#':>3} {'form':6} {'truth':16} {'found':44} {'verdict':14} {'ok':>3} {'s':>5}  parameters")
    for i in range(args.n):
        form, truth, axis, expected = _draw(rng)
        t0 = time.perf_counter()
        rec, plant, prep = _record(form, axis, rng, seed=i)
        sim_seconds.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        diag = diagnose_time(plant, rec, prep=prep)
        seconds.append(time.perf_counter() - t0)
        found = set(diag.selected)
        params_ok, words = _parameters_ok(form, axis, diag)
        if truth == "current_limit":
            hit = diag.verdict == "not_explained" and not found
            false_explained += diag.verdict == "explained"
        else:
            hit = found == expected and diag.verdict == "explained" and params_ok
        false_found += bool(found - expected)
        hits += hit
        by_truth.setdefault(f"{form} {truth}", [0, 0])
        by_truth[f"{form} {truth}"][0] += hit
        by_truth[f"{form} {truth}"][1] += 1
        print(f"{i:3d} {form:6} {truth:16} {', '.join(sorted(found)) or '-':44} {diag.verdict:14} "
              f"{'yes' if hit else 'NO':>3} {seconds[-1]:5.1f}  {words}", flush=True)
    n = args.n
    print(f"\nhits {hits}/{n} ({100 * hits / n:.0f} %); false \"explained\" {false_explained}; false \"found\" "
          f"{false_found}; diagnosis {np.mean(seconds):.1f} s mean, {np.max(seconds):.1f} s max per recording "
          f"(simulation {np.mean(sim_seconds):.1f} s)")
    for name, (h, m) in sorted(by_truth.items()):
        print(f"  {name:24s} {h}/{m}")


if __name__ == "__main__":
    main()
