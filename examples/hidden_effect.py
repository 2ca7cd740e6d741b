"""Find an effect you were not told about: simulate a gantry with a hidden effect, diagnose it.

Run:  python examples/hidden_effect.py [SEED] [--kind KIND] [--report diagnosis.html]

A seeded draw picks the hidden truth (delay, current-loop lag, resonance, Coulomb friction,
none, two effects at once, a four-mass stage outside the library, a force constant drifting as
the coil warms over a 240 s record, or on Stage Y's two rails an encoder reading one rail to
another scale or two motors whose force constants differ; ``--kind`` chooses) with
realistic parameters and a payload of 25-50 kg; the simulated stepped-sine
recording (thesis section 4.1: 1-75 Hz, 5 s per frequency, 0.5 A) goes through the same path
as a real one: frequency-response estimation, then the diagnosis, which must name the
hidden effects and their values without being told, or say "not explained" when no model of
its library reproduces the data. The four-mass stage, the drifting force constant and the two
rails are recorded by the independent simulator of the tests (tests/reference/independent_sim.py),
which shares no code with the tool; the drift (K_t falling 2-5 % over the record, far slower than
the stage) scales each sample's velocity by K_t(t) / K_t(0), the rail's scale its Y2 column, and the
motors' force constants enter its beam's input matrix.
"""

import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
from rich.console import Console

from design.views.console import print_story
from plant import CoulombFriction, CurrentLoop, Delay, Resonance, stage_x, stage_y
from plant.data.read_stepped_sine import read_recording
from plant.diagnose.diagnosis import diagnose
from plant.estimate.lockin import estimate_response
from plant.experiment.simulate import simulate_stepped_sine

KINDS = ["delay", "current_loop", "resonance", "coulomb_friction", "none", "delay+resonance", "outside_library"]
DRIFT = "force_constant_drift"
RAILS = ["rail_scale", "motor_imbalance"]
argv = sys.argv[1:]
options = {argv[i]: argv[i + 1] for i in range(len(argv) - 1) if argv[i].startswith("--")}
args = [a for i, a in enumerate(argv) if not a.startswith("--") and (i == 0 or not argv[i - 1].startswith("--"))]
seed = int(args[0]) if args else 7
rng = np.random.default_rng(seed)
amplitude_a = 0.5
mass_kg = rng.uniform(25, 50)
kind = options.get("--kind") or str(rng.choice(KINDS))
if kind not in KINDS + [DRIFT] + RAILS:
    sys.exit(f"--kind must be one of {', '.join(KINDS + [DRIFT] + RAILS)}")
f_hz = np.geomspace(1, 75, 30)
if kind == "delay+resonance":
    f_r = rng.uniform(40, 70)
    hidden = (Delay(rng.uniform(0.5e-3, 2e-3)), Resonance(f_r, f_r * rng.uniform(0.5, 0.8), rng.uniform(0.02, 0.1)))
elif kind in ("outside_library", DRIFT, *RAILS):
    hidden = None
elif kind == "delay":
    hidden = Delay(rng.uniform(0.3e-3, 3e-3))
elif kind == "current_loop":
    hidden = CurrentLoop(rng.uniform(30, 150))
elif kind == "resonance":
    f_r = rng.uniform(30, 70)
    hidden = Resonance(f_r, f_r * rng.uniform(0.5, 0.85), rng.uniform(0.02, 0.1))
elif kind == "coulomb_friction":
    hidden = CoulombFriction(rng.uniform(0.1, 0.4) * 20.0 * amplitude_a)
else:
    hidden = None
noise = rng.uniform(0.01, 0.05)
declared = stage_x()
if kind in ("outside_library", DRIFT, *RAILS):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "reference"))
    import independent_sim as sim

    y2_scale = 1.0
    if kind in RAILS:
        load = 0.4 if kind == "rail_scale" else 0.28          # m from rail Y1 on the 0.8 m beam (known)
        d = rng.uniform(0.03, 0.08) if kind == "motor_imbalance" else 0.0
        y2_scale = 1 + rng.uniform(0.02, 0.05) if kind == "rail_scale" else 1.0
        inertia, tilt_hz, kt = 1.5, rng.uniform(25, 45), sim.KT_N_PER_A
        net = sim.stage_y_beam(mass_kg, inertia, rail1_m=load,
                               tilt_stiffness_n_m_per_rad=inertia * (2 * np.pi * tilt_hz) ** 2)
        T = np.array([[1.0, -load], [1.0, sim.BEAM_LENGTH_M - load]])
        net = replace(net, input_n_per_a=T.T @ np.array([kt * (1 + d) / 2, kt * (1 - d) / 2]))
        protocol, change = sim.Protocol(f_hz=tuple(f_hz), block_s=3.0, sample_rate_hz=1000.0, amplitude_a=1.75), 0.0
        hidden_words = (f"rail Y2 read {100 * (y2_scale - 1):+.1f} % long" if kind == "rail_scale" else
                        f"force constants {100 * d:+.1f} % / {-100 * d:+.1f} % on Y1 / Y2") + \
            f", tilt mode {tilt_hz:.1f} Hz, load {load:g} m from Y1"
        declared = stage_y(load_position_m=load)
    elif kind == DRIFT:
        net, change = sim.rigid_stage(mass_kg), -rng.uniform(0.02, 0.05)
        protocol = sim.Protocol(f_hz=tuple(np.geomspace(1, 75, 24)), block_s=10.0, sample_rate_hz=1000.0)
        hidden_words = f"force constant {100 * change:+.1f} % over the 240 s record"
    else:
        net, change = sim.tuned_chain(np.full(4, mass_kg / 4), modes_hz=np.sort(rng.uniform(20, 70, 3)),
                                      damping_ratio=0.03), 0.0
        protocol = sim.Protocol(f_hz=tuple(f_hz), block_s=5.0, sample_rate_hz=2000.0)
        hidden_words = f"four-mass chain, modes {', '.join(f'{m:.1f}' for m in net.mode_frequencies_hz())} Hz"
    rec = sim.simulate(net, protocol=protocol, noise=noise, seed=seed)
    durations = [t[-1] + (t[1] - t[0]) for t in rec.time_s]
    for start, t, v in zip(np.cumsum([0.0] + durations[:-1]), rec.time_s, rec.velocity_m_per_s):
        v *= (1.0 + change * (start + t) / sum(durations))[:, None]
        v[:, -1] *= y2_scale
    with tempfile.TemporaryDirectory() as tmp:
        measured = estimate_response(read_recording(sim.write_csv(rec, Path(tmp) / "rec.csv")))
else:
    truth = stage_x(mass_kg=mass_kg, excitation_current_a=amplitude_a)
    for effect in (hidden if isinstance(hidden, tuple) else (hidden,) if hidden is not None else ()):
        truth = truth * effect
    hidden_words = kind if hidden is None else f"{kind} {hidden!r}"
    measured = estimate_response(simulate_stepped_sine(truth, f_hz=f_hz, current_amplitude_a=amplitude_a,
                                                       noise_fraction=noise, seed=seed))
diag = diagnose(declared, measured)

print(f"(hidden from the diagnosis: seed {seed}, {hidden_words}, mass {mass_kg:.1f} kg, noise {100 * noise:.1f} %)\n")
print_story(Console(), diag.story())
print(f"\nverdict: {diag.verdict}; named: {', '.join(diag.added) or 'none'}"
      + (f", a drift of {100 * diag.drift.change:+.2f} %" if diag.drift is not None else "") + f"; truth: {kind}")
for effect in (hidden if isinstance(hidden, tuple) else (hidden,) if hidden is not None else ()):
    key = f"{effect.name}.{effect.main_parameter}"
    if key in diag.final.values:
        true = getattr(effect, effect.main_parameter)
        print(f"{key}: {diag.final.values[key]:.4g} +/- {diag.final.stderr[key]:.2g} (true {true:.4g}, "
              f"{100 * (diag.final.values[key] / true - 1):+.1f} %)")
if kind in RAILS:
    key, true = ("rail_scale.y2_scale", y2_scale) if kind == "rail_scale" else ("motor_imbalance.fraction", d)
    if key in diag.final.values:
        print(f"{key}: {diag.final.values[key]:.4g} +/- {diag.final.stderr[key]:.2g} (true {true:.4g})")
print(f"mass_kg: {diag.final.values['mass_kg']:.2f} +/- {diag.final.stderr['mass_kg']:.2g} (true {mass_kg:.2f})")
if "--report" in sys.argv:
    from design.views.diagnosis import diagnosis_report

    path = sys.argv[sys.argv.index("--report") + 1]
    diagnosis_report(diag, measured, title=f"Hidden effect, seed {seed}", provenance=f"examples/hidden_effect.py "
                     f"{seed}").write(path)
    print(f"report written to {path}")
