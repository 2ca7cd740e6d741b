"""Linear-motor forces benchmark: the time-domain diagnosis on recordings of two independent simulators that
share no code with the tool, with a force ripple, a force-constant profile, an amplifier current limit, a
Stribeck rise of the friction, alone and together, with nothing missing, or with a cable chain's spring.

Run:  python benchmarks/bench_motor_forces.py [--n 72] [--seed 23]

Forms (drawn per recording):

* open loop, ``tests/reference/independent_linear_motor.py`` (RK4 integration), with the current command as
  a slow multi-sine sweep (0.25 Hz, 3 A, plus 3.1 and 7.3 Hz, 16 s), a logarithmic chirp (0.2-8 Hz, 3 A,
  24 s) or a stepped sine in one run (0.25-8 Hz, 3 A, 4 s per frequency); the carriage covers ~0.15-0.2 m.
  Truths: ripple 1.5-5 N at a 12-40 mm pitch and any phase, a force constant falling 15-40 % towards the
  ends of a 0.3 m track, both, a current limit at 55-80 % of the peak command (with or without a ripple),
  neither, or a cable of 60-200 N/m with its rest mid-travel (the mean position of the same run without
  it); current noise 2-10 mA, position noise 0.5-5 um;
* closed position loop, ``tests/reference/independent_friction_sim.py`` (the EMPS-like axis, encoder-quantised,
  PD at 1 kHz) with Coulomb friction and an offset; truths: these alone, with a ripple of 2-6 N at 15-30 mm,
  or with a Stribeck rise of 5-15 N at 15-50 mm/s.

Drifts (``--drifts``, drawn after the others from their own generator, so the first ``--n`` recordings stay as
they were): the linear motor's force constant falling 3-8 % over the record (a coil warming) or its guides'
damping rising 6-15 % (a lubricant warming), under any open-loop form; the closed-loop axis's drive gain
drifting by 3-6 % either way, beside its Coulomb friction and offset.

A hit: for a truth in the library, exactly its effects, "explained", and the parameters: the ripple's pitch
within 1 % and its first-harmonic amplitude within 10 % (5 % of the drive force absolute); the profile's
slope and curvature within 15 % (0.02 absolute, or 3 Newey-West standard errors where the recording's noise
allows no better); the current limit within 5 % and its fraction lost within 0.1 of 1; the Stribeck excess
within 15 % and velocity within 20 %; the cable's stiffness within 5 % and its rest position within 2 mm; a
drift's rate (its change per second relative to the force constant, or in N s/m per second) within 10 % (or 3
Newey-West standard errors where the recording's noise allows no better).
False "found": an effect claimed that is not there.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import as_commands  # noqa: F401  (BLAS on one thread, as the commands run it)
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
OPEN = ("none", "ripple", "profile", "both", "current_limit", "limit+ripple", "cable")
#: the open-loop forms: the simulator's recording function and its peak current command (A)
FORMS = {"sweep": (lm.slow_sweep, 4.3), "chirp": (lm.chirp, 3.0), "stepped": (lm.stepped, 3.0)}


def _draw(rng: np.random.Generator):
    """(form, truth label, axis, expected effects)."""
    if rng.uniform() < 0.25:
        kind = ("friction", "friction+ripple", "friction+stribeck")[int(rng.integers(3))]
        axis = friction_sim.Axis(coulomb_n=rng.uniform(5, 30), offset_n=rng.uniform(-5, 5),
                                 ripple_n=rng.uniform(2, 6) if "ripple" in kind else 0.0,
                                 ripple_period_m=rng.uniform(0.015, 0.03),
                                 stribeck_n=rng.uniform(5, 15) if "stribeck" in kind else 0.0,
                                 stribeck_velocity_m_per_s=rng.uniform(0.015, 0.05))
        expected = ({"coulomb_friction", "offset"} | ({"force_ripple"} if "ripple" in kind else set())
                    | ({"stribeck_friction"} if "stribeck" in kind else set()))
        return "closed", kind, axis, expected
    form = tuple(FORMS)[int(rng.integers(len(FORMS)))]
    kind = OPEN[int(rng.integers(len(OPEN)))]
    kw = {}
    if "ripple" in kind or kind == "both":
        kw.update(ripple_n=(rng.uniform(1.5, 5.0),), ripple_phase_rad=(rng.uniform(0, 2 * np.pi),),
                  ripple_pitch_m=rng.uniform(0.012, 0.04))
    if kind in ("profile", "both"):
        kw.update(kt_droop=rng.uniform(0.15, 0.4), travel_m=TRAVEL_M)
    if "limit" in kind:
        kw.update(current_limit_a=rng.uniform(0.55, 0.8) * FORMS[form][1])
    if kind == "cable":
        kw.update(cable_n_per_m=rng.uniform(60, 200))
    expected = ({"force_ripple"} if "ripple" in kind or kind == "both" else set()) | \
        ({"force_constant_profile"} if kind in ("profile", "both") else set()) | \
        ({"current_limit"} if "limit" in kind else set()) | ({"cable_force"} if kind == "cable" else set())
    return form, kind, lm.LinearMotorAxis(**kw), expected


#: the drifts' truths: open-loop force constant or damping, closed-loop drive gain
DRIFTS = ("kt_drift", "damping_drift")


def _draw_drift(rng: np.random.Generator):
    """(form, truth label, axis, expected effects) of a drifting recording (module doc)."""
    if rng.uniform() < 0.25:
        span_s = 20.0                                       # ``friction_sim.simulate``'s default duration
        change = rng.uniform(0.03, 0.06) * rng.choice((-1.0, 1.0))
        axis = friction_sim.Axis(coulomb_n=rng.uniform(5, 30), offset_n=rng.uniform(-5, 5),
                                 gain_rate_per_s=change / span_s)
        return "closed", "friction+kt_drift", axis, {"coulomb_friction", "offset", "force_constant_drift"}
    form = tuple(FORMS)[int(rng.integers(len(FORMS)))]
    kind = DRIFTS[int(rng.integers(len(DRIFTS)))]
    span_s = {"sweep": 16.0, "chirp": 24.0, "stepped": 24.0}[form]
    if kind == "kt_drift":
        axis = lm.LinearMotorAxis(kt_rate_per_s=-rng.uniform(0.03, 0.08) / span_s)
        return form, kind, axis, {"force_constant_drift"}
    axis = lm.LinearMotorAxis(damping_rate_per_s=rng.uniform(0.06, 0.15) / span_s)
    return form, kind, axis, {"damping_drift"}


def _record(form: str, axis, rng: np.random.Generator, seed: int) -> tuple[TimeRecording, Plant, Preprocessing, object]:
    """The recording, the plant to diagnose it with, its preprocessing and the axis as simulated (a cable's rest
    position set)."""
    if form == "closed":
        log = friction_sim.simulate(axis, seed=seed)
        rec = TimeRecording(log.time_s, log.command_v, log.position_m[None], "position", ("position_m",),
                            reference=log.reference_m)
        return rec, Plant("x", force_constant_n_per_a=axis.gain_n_per_v), Preprocessing(input_hold=True), axis
    run = FORMS[form][0]
    noise = {"current_noise_a": rng.uniform(0.002, 0.01), "position_noise_m": rng.uniform(0.5e-6, 5e-6)}
    if axis.cable_n_per_m:
        _, _, free = run(replace(axis, cable_n_per_m=0.0), seed=seed, **noise)
        axis = replace(axis, cable_rest_m=float(np.mean(free)))
    t, current, position = run(axis, seed=seed, **noise)
    return TimeRecording(t, current, position[None], "position", ("x",)), stage_x(), Preprocessing(), axis


def _parameters_ok(form: str, axis, diag) -> tuple[bool, str]:
    """The fitted shapes against the truth (module doc), and the errors in words."""
    words, ok = [], True
    ripple = diag.final.plant.effect("force_ripple")
    profile = diag.final.plant.effect("force_constant_profile")
    open_loop = form != "closed"
    # the open loop's forces are relative to K at the profile's centre, the closed loop's in N of the drive
    scale = 1.0
    if open_loop and axis.kt_droop and profile is not None:
        scale = 1 / (1 - 4 * axis.kt_droop / axis.travel_m**2 * profile.centre_m**2)
    if ripple is not None:
        pitch, amp = ((axis.ripple_period_m, axis.ripple_n) if not open_loop else
                      (axis.ripple_pitch_m, axis.ripple_n[0]))
        e_pitch = ripple.pitch_m / pitch - 1
        e_amp = ripple.amplitude_n() - amp * scale
        ok &= abs(e_pitch) < 0.01 and abs(e_amp) < max(0.1 * amp * scale, 0.05 * 10.0)
        words.append(f"pitch {100 * e_pitch:+.2f} %, amplitude {e_amp:+.2f} N")
    if profile is not None and open_loop and axis.kt_droop:
        a = 4 * axis.kt_droop / axis.travel_m**2
        k_centre = 1 - a * profile.centre_m**2
        slope = -2 * a * profile.centre_m * profile.half_span_m / k_centre
        curvature = -a * profile.half_span_m**2 / k_centre
        e1, e2 = profile.slope - slope, profile.curvature - curvature
        se = diag.final.stderr
        ok &= (abs(e1) < max(0.15 * abs(slope), 0.02, 3 * se["force_constant_profile.slope"])
               and abs(e2) < max(0.15 * abs(curvature), 0.02, 3 * se["force_constant_profile.curvature"]))
        words.append(f"slope {e1:+.3f}, curvature {e2:+.3f}")
    limit = diag.final.plant.effect("current_limit")
    if limit is not None and open_loop and axis.current_limit_a:
        e_limit = limit.limit_n / (axis.kt_n_per_a * axis.current_limit_a) - 1
        ok &= abs(e_limit) < 0.05 and abs(limit.fraction_lost - 1) < 0.1
        words.append(f"limit {100 * e_limit:+.2f} %, fraction lost {limit.fraction_lost:.3f}")
    stribeck = diag.final.plant.effect("stribeck_friction")
    if stribeck is not None and not open_loop and axis.stribeck_n:
        e_excess = stribeck.excess_n / axis.stribeck_n - 1
        e_velocity = stribeck.velocity_m_per_s / axis.stribeck_velocity_m_per_s - 1
        ok &= abs(e_excess) < 0.15 and abs(e_velocity) < 0.2
        words.append(f"Stribeck excess {100 * e_excess:+.1f} %, velocity {100 * e_velocity:+.1f} %")
    cable = diag.final.plant.effect("cable_force")
    if cable is not None and open_loop and axis.cable_n_per_m:
        e_k = cable.stiffness_n_per_m / axis.cable_n_per_m - 1
        e_rest = cable.rest_m - axis.cable_rest_m
        ok &= abs(e_k) < 0.05 and abs(e_rest) < 2e-3
        words.append(f"cable stiffness {100 * e_k:+.2f} %, rest {1e3 * e_rest:+.2f} mm")
    words_drift, ok_drift = _drift_ok(form, axis, diag)
    return ok and ok_drift, "; ".join(words + words_drift)


def _drift_ok(form: str, axis, diag) -> tuple[list[str], bool]:
    """A fitted drift's rate against the truth's: the force constant's relative change per second at mid-record
    (the closed loop's drive gain, or the linear motor's force constant), the damping's change in N s/m per s."""
    words, ok = [], True
    kt_drift = diag.final.plant.effect("force_constant_drift")
    rate = getattr(axis, "gain_rate_per_s" if form == "closed" else "kt_rate_per_s", 0.0)
    if kt_drift is not None and rate:
        truth = rate / (1 + rate * kt_drift.mid_s)           # relative to K at mid-record, as the fit has it
        e = kt_drift.change / kt_drift.half_s / truth - 1
        se = diag.final.stderr["force_constant_drift.change"] / kt_drift.half_s / abs(truth)
        ok &= abs(e) < max(0.1, 3 * se)
        words.append(f"force-constant drift {100 * e:+.1f} % (se {100 * se:.1f} %)")
    damping = diag.final.plant.effect("damping_drift")
    if damping is not None and form != "closed" and axis.damping_rate_per_s:
        truth = axis.damping_n_s_per_m * axis.damping_rate_per_s
        e = damping.change_n_s_per_m / damping.half_s / truth - 1
        se = diag.final.stderr["damping_drift.change_n_s_per_m"] / damping.half_s / truth
        ok &= abs(e) < max(0.1, 3 * se)
        words.append(f"damping drift {100 * e:+.1f} % (se {100 * se:.1f} %)")
    return words, ok


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=72)
    parser.add_argument("--seed", type=int, default=23)
    parser.add_argument("--drifts", type=int, default=24, help="drifting recordings after the others (module doc)")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    drift_rng = np.random.default_rng([args.seed, 1])
    hits = false_found = 0
    seconds, sim_seconds = [], []
    by_truth: dict[str, list[int]] = {}
    print(f"{'#':>3} {'form':7} {'truth':17} {'found':56} {'verdict':14} {'ok':>3} {'s':>5}  parameters")
    for i in range(args.n + args.drifts):
        form, truth, axis, expected = _draw(rng) if i < args.n else _draw_drift(drift_rng)
        t0 = time.perf_counter()
        rec, plant, prep, axis = _record(form, axis, rng, seed=i)
        sim_seconds.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        diag = diagnose_time(plant, rec, prep=prep)
        seconds.append(time.perf_counter() - t0)
        found = set(diag.selected)
        params_ok, words = _parameters_ok(form, axis, diag)
        hit = found == expected and diag.verdict == "explained" and params_ok
        false_found += bool(found - expected)
        hits += hit
        by_truth.setdefault(f"{form} {truth}", [0, 0])
        by_truth[f"{form} {truth}"][0] += hit
        by_truth[f"{form} {truth}"][1] += 1
        print(f"{i:3d} {form:7} {truth:17} {', '.join(sorted(found)) or '-':56} {diag.verdict:14} "
              f"{'yes' if hit else 'NO':>3} {seconds[-1]:5.1f}  {words}", flush=True)
    n = args.n + args.drifts
    print(f"\nhits {hits}/{n} ({100 * hits / n:.0f} %); false \"found\" "
          f"{false_found}; diagnosis {np.mean(seconds):.1f} s mean, {np.max(seconds):.1f} s max per recording "
          f"(simulation {np.mean(sim_seconds):.1f} s)")
    for name, (h, m) in sorted(by_truth.items()):
        print(f"  {name:24s} {h}/{m}")


if __name__ == "__main__":
    main()
