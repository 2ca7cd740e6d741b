"""Stage Y's two rails read jointly in time recordings (``plant.diagnose.two_rails``), on recordings of the
independent two-rail simulator (tests/reference/independent_two_rails.py: Lagrange's equations of the beam on its
rails, sampled exactly; it imports nothing of the tool), under a sweep of three sines, a chirp and a stepped sine
of current in one run, or a PI velocity loop on the encoders' mean following a chirp of velocity (the command
logged as computed, the reference recorded), with the rails' positions or velocities recorded.

Run:  python benchmarks/bench_two_rails.py [--n 40] [--seed 45]

Each draw: the thesis's Stage Y as the tool has it (35 kg, 440 N*s/m per rail, K_t = 20 N/A over both motors, the
yaw spring 1e5 to 4e5 N*m/rad), a form, positions (1-5 um of noise) or velocities (0.05-0.2 mm/s), and a class:

  none            nothing hidden
  rail_scale      encoder Y2 reads 1-5 % long or short
  motor_imbalance the motors' force constants 5-15 % either side of their mean
  offset_load     the load 0.1-0.25 m off the beam's centre
  damping_apart   the rails' dampings 10-30 % either side of their mean
  scale_imbalance a scale and unequal motors together

Scoring per recording (the full diagnosis, every force candidate, as ``gantry diagnose`` runs it)
  hit    the scale claimed exactly when there is one, within 3 standard errors or 0.05 % of the truth; the yaw
         claimed exactly when the motors or the load turn the beam, and its named causes exactly the truth's; the
         mass within 1 % and the damping within 2 %.
  false  a scale or a yaw claimed that is not there, causes named without the truth's among them, or a force effect
         named other than ``yaw_coupling`` under an off-centre load (whose inertia_kg must then lie within
         15 % of the load's m e, the carriage's mass times its offset over the rails' separation). Both
         causes named ("unequal motors or an off-centre load": the record cannot tell them apart) is a miss,
         not a false claim.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import as_commands  # noqa: F401  (BLAS on one thread, as the commands run it)
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "reference"))

import independent_dual_drive as dd  # noqa: E402
import independent_two_rails as tr  # noqa: E402

from plant import stage_y  # noqa: E402
from plant.data.recordings import TimeRecording  # noqa: E402
from plant.diagnose.time_diagnosis import diagnose_time  # noqa: E402
from plant.identify.inverse_model import Preprocessing  # noqa: E402

CLASSES = ("none", "rail_scale", "motor_imbalance", "offset_load", "scale_imbalance", "damping_apart")
def closed(rig, *, seed: int, **noise):
    """The rig under ``independent_two_rails.closed_loop`` following a chirp of velocity, 0.05 m/s from 0.3 to 12 Hz
    over 20 s."""
    ratio, span = 12.0 / 0.3, 20.0
    return tr.closed_loop(rig, lambda s: 0.05 * np.sin(2 * np.pi * 0.3 * span * (ratio ** (s / span) - 1)
                                                       / np.log(ratio)), span, seed=seed, **noise)


FORMS = {"sweep": tr.sweep, "chirp": tr.chirp, "stepped": tr.stepped, "closed": closed}
RIG = dd.Rig(beam_mass_kg=0.0, beam_inertia_kg_m2=0.5, carriage_mass_kg=35.0, k1=10.0, k2=10.0)


def draw(rng, k: int):
    kind = CLASSES[k % len(CLASSES)]
    form = list(FORMS)[(k // len(CLASSES)) % len(FORMS)]
    velocity = bool(rng.integers(2))
    rig = dataclasses.replace(RIG, yaw_stiffness=float(rng.uniform(1e5, 4e5)))
    scale = 1.0
    if kind in ("rail_scale", "scale_imbalance"):
        scale = 1 + float(rng.choice([-1, 1]) * rng.uniform(0.01, 0.05))
    if kind in ("motor_imbalance", "scale_imbalance"):
        d = float(rng.choice([-1, 1]) * rng.uniform(0.05, 0.15))
        rig = dataclasses.replace(rig, k1=10.0 * (1 - d), k2=10.0 * (1 + d))
    if kind == "damping_apart":
        d = float(rng.choice([-1, 1]) * rng.uniform(0.1, 0.3))
        rig = dataclasses.replace(rig, b1=440.0 * (1 - d), b2=440.0 * (1 + d))
    if kind == "offset_load":
        rig = dataclasses.replace(rig, carriage_position_m=0.4 + float(rng.choice([-1, 1]) * rng.uniform(0.1, 0.25)))
    noise = ({"velocity_noise_m_per_s": float(rng.uniform(5e-5, 2e-4))} if velocity else
             {"position_noise_m": float(rng.uniform(1e-6, 5e-6))})
    t, i, y1, y2, *reference = FORMS[form](rig, y2_scale=scale, seed=int(rng.integers(1 << 30)), **noise)
    out = "velocity" if velocity else "position"
    inertia = rig.carriage_mass_kg * (rig.carriage_position_m / rig.rail_separation_m - 0.5)
    return kind, form, out, scale, inertia, TimeRecording(t, i, np.vstack([y1, y2]), out, (f"{out}_y1", f"{out}_y2"),
                                                          reference=reference[0] if reference else None)


def score(kind: str, scale: float, inertia: float, diag) -> tuple[bool, bool]:
    rails, values = diag.rails, diag.final.values
    has_scale = kind in ("rail_scale", "scale_imbalance")
    cause = {"motor_imbalance": "motor_imbalance", "scale_imbalance": "motor_imbalance",
             "offset_load": "offset_m", "damping_apart": "dampings differ"}.get(kind)
    scale_ok = (rails.scale_claimed == has_scale and
                (not has_scale or abs(rails.y2_scale - scale) <= max(3 * rails.y2_scale_stderr, 5e-4)))
    named = [p for p in rails.yaw_patterns]
    yaw_ok = rails.yaw_claimed == (cause is not None) and (cause is None or (len(named) == 1 and cause in named[0]))
    stage_ok = abs(values["mass_kg"] / 35.0 - 1) < 0.01 and abs(values["damping_n_s_per_m"] / 440.0 - 1) < 0.02
    false = ((rails.scale_claimed and not has_scale) or (rails.yaw_claimed and cause is None)
             or (cause is not None and bool(named) and not any(cause in p for p in named)))
    allowed = {"yaw_coupling"} if kind in ("offset_load", "damping_apart") else set()
    wrong_force = bool(set(diag.selected) - allowed)
    coupling_ok = ("yaw_coupling" not in diag.selected or kind != "offset_load"
                   or abs(values["yaw_coupling.inertia_kg"] / inertia - 1) < 0.15)
    return scale_ok and yaw_ok and stage_ok and coupling_ok and not wrong_force, false or wrong_force


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=40, help="recordings (default 40)")
    ap.add_argument("--seed", type=int, default=45)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    hits, false, seconds = 0, 0, []
    for k in range(args.n):
        kind, form, out, scale, inertia, rec = draw(rng, k)
        t0 = time.perf_counter()
        diag = diagnose_time(stage_y(), rec, prep=Preprocessing(input_hold=True))
        seconds.append(time.perf_counter() - t0)
        hit, wrong = score(kind, scale, inertia, diag)
        hits += hit
        false += wrong
        mark = "hit " if hit else ("FALSE" if wrong else "miss")
        force = "".join(f"[{n}.{e.main_parameter} {diag.final.values[f'{n}.{e.main_parameter}']:.3g}] "
                        for n, e in ((n, diag.final.plant.effect(n)) for n in diag.selected))
        print(f"#{k:<3} {mark} {kind:16s} {form:8s} {out:8s} {force}{diag.rails.clause()[:150]}", flush=True)
    print(f"\n{hits}/{args.n} hits, {false} false; diagnosis {np.mean(seconds):.2f} s mean, {max(seconds):.2f} s max "
          f"per recording")


if __name__ == "__main__":
    main()
