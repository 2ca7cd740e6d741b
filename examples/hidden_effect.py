"""Find an effect you were not told about: simulate a gantry with a hidden effect, diagnose it.

Run:  python examples/hidden_effect.py [SEED] [--report diagnosis.html]

A seeded draw picks one hidden effect (delay, current-loop lag, resonance, Coulomb friction,
or none) with realistic parameters and a payload of 25-50 kg; the simulated stepped-sine
recording (thesis section 4.1: 1-75 Hz, 5 s per frequency, 0.5 A) goes through the same path
as a real one: frequency-response estimation, then the diagnosis, which must name the
hidden effect and its value without being told.
"""

import sys

import numpy as np

from plant import CoulombFriction, CurrentLoop, Delay, Resonance, stage_x
from plant.diagnosis import diagnose
from plant.effects import EFFECTS
from plant.lockin import estimate_response
from plant.simulate import simulate_stepped_sine

args = [a for a in sys.argv[1:] if not a.startswith("--")]
seed = int(args[0]) if args else 7
rng = np.random.default_rng(seed)
amplitude_a = 0.5
mass_kg = rng.uniform(25, 50)
kind = rng.choice(["delay", "current_loop", "resonance", "coulomb_friction", "none"])
if kind == "delay":
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
truth = stage_x(mass_kg=mass_kg, excitation_current_a=amplitude_a)
truth = truth * hidden if hidden is not None else truth
noise = rng.uniform(0.01, 0.05)

recording = simulate_stepped_sine(truth, f_hz=np.geomspace(1, 75, 30), current_amplitude_a=amplitude_a,
                                  noise_fraction=noise, seed=seed)
measured = estimate_response(recording)
diag = diagnose(stage_x(), measured)

print(f"(hidden from the diagnosis: seed {seed}, {kind}{'' if hidden is None else ' ' + repr(hidden)}, "
      f"mass {mass_kg:.1f} kg, noise {100 * noise:.1f} %)\n")
print(diag.story())
print(f"\nnamed: {', '.join(diag.added) or 'none'}; truth: {kind}")
if hidden is not None and kind in diag.added:
    key = f"{kind}.{EFFECTS[kind].main_parameter}"
    true = getattr(hidden, key.split(".")[1])
    print(f"{key}: {diag.final.values[key]:.4g} +/- {diag.final.stderr[key]:.2g} (true {true:.4g}, "
          f"{100 * (diag.final.values[key] / true - 1):+.1f} %)")
print(f"mass_kg: {diag.final.values['mass_kg']:.2f} +/- {diag.final.stderr['mass_kg']:.2g} (true {mass_kg:.2f})")
if "--report" in sys.argv:
    from design.diagnosis_view import diagnosis_report

    path = sys.argv[sys.argv.index("--report") + 1]
    diagnosis_report(diag, measured, title=f"Hidden effect, seed {seed}", provenance=f"examples/hidden_effect.py "
                     f"{seed}").write(path)
    print(f"report written to {path}")
