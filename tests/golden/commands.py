"""The commands whose ``--json`` output is the stable contract, and how their outputs are compared.

``python tests/golden/commands.py [NAME ...]`` (from the repository root) writes ``tests/golden/*.json``;
``tests/cli/test_json_contract.py`` checks that the commands still print the same JSON. The files were
written by the code before ``design/`` was split into sub-packages; the ``synth_*`` files again when
synthesis became robust to the specs' ``plant.uncertainty`` (a deliberate change of the designs), and
``synth_admittance`` when the bundled admittance spec took the walking mouse, the rig's 100 Hz law and the
co-design of the PI gains (a new spec and a new design); ``diagnose_*`` when the diagnosis contract became one
across kinds of data (``docs/formats.md``: the time-domain verdict ``not_explained`` and its dBIC of an added
effect positive, the key ``domain`` on frequency data), and again when the effect library gained the
position-dependent motor forces (their candidates in the rankings, one effective sample size from the
largest model of the larger search, the motor force among the residual tests); ``diagnose_x`` again when the
fit re-polished log coordinates stuck at their lower bound (two alternatives' fits leave a bad basin);
``synth_admittance`` again when the interaction loop was sampled exactly and the motor judged on the
locomotion profile (the design became optimal: no ``tradeoff``, which is given only when it is not), and when
the motor's force on the profile took the held reference's staircase (``motor_force_n`` 109-128 -> 139-154 N, the
design the same) and the mouse figures took the velocity shortfall, and when the bundled spec took the lab's
recorded force (``recorded_force`` and ``limits.motor_force_criterion`` added, the design the same); the
``synth_*`` files again when the one-motor designs stated their coverage (``coverage`` added, nothing else changed),
and ``sweep_x`` when the sweep's verdict did (``covered`` added); ``diagnose_*`` again when the library gained
``cable_force`` (its row among the frequency-domain candidates not searched; on EMPS its combinations among the
time-domain models, whose smallest residual sets the effective sample size, so the other models' dBIC moved; the
selection the same); ``synth_admittance`` again when the design was searched between the dense check's points (a
floating mouse of 24 g, between the range's 20 and 35 g, had PM 44.74 deg at the ray's design, confirmed on
Newton's model: (m_v, b_v) went up its ray by 1.26 %, ``between_grid`` added, the binding and coverage text
changed), and the ``synth_*`` files when the PI designs were searched between their dense check's points too
(``between_grid`` added: the bundled designs' least slack is on the check's corner, the designs the same; the
solver record's keys that a step leaves null, written since the record became typed, are in the files now);
``synth_admittance`` again when python-control's verification read its margins on 500 points, not 1,500 (its least
phase margin 45.43831 -> 45.43801 deg, the design the same); ``diagnose_x`` again when reported models named only
effects the data identify (its 14 alternatives within dBIC 10 each added a lag or mode the data do not determine:
``alternatives`` empty, ``criterion``, ``overdispersion``, ``left_out`` and ``implausible`` added, the selection the
same), and ``diagnose_emps`` for ``implausible``; ``diagnose_x`` for ``drift`` (null) and when the library gained
Stage Y's ``rail_scale`` and ``motor_imbalance`` (their rows among the candidates skipped on Stage X); ``fit_emps``
and ``diagnose_emps`` when the time-domain noise was read from fourth differences (EMPS's position noise 1.7e-7 ->
its true, smaller level: the noise ratio 14.9 -> 31.2, the fitted values and verdicts the same); both again when the
library gained ``force_constant_drift`` and ``damping_drift`` (rows skipped on the stepped sine; on EMPS their
models among the candidates, the selection and verdict the same); ``diagnose_emps`` when a time-domain diagnosis
stopped fitting models of three effects (the largest, no other's parent) that its admission rule would drop (an
effect whose pattern the model without it does not show): 39 models fitted, not 94, the effective sample size read
from the best of those (676 -> 513; the BICs scaled, dBIC of coulomb_friction +1245 -> +944; the selection, values
and verdict the same; one alternative within dBIC 10 instead of 13, which the rule did not admit; a note says how
many were not fitted); ``fit_emps``
and ``diagnose_emps`` when the inverse model's least squares took the acceleration's noise out of X^T X and the
residual's pattern tests likewise (bias-compensated: EMPS's position noise is small, its values move in the sixth
digit); ``diagnose_x`` and ``diagnose_emps`` when the library gained ``yaw_coupling`` and the time diagnosis read
Stage Y's two rails jointly (its row among the frequency-domain candidates not searched; ``rails`` null on EMPS's
one output), and ``fit_emps`` when the time fit read both rails too (``rails`` null on one output); EMPS's standard
errors in both files moved in the ninth digit on rewriting, which f1ceaa9's code gives alike today (arithmetic, not
a change); ``synth_admittance`` when the forces on the locomotion profile took a 2 ms grid that divides the law's
period and the reach its own 0.25 ms grid (the motor's force on the profile within 0.03 %, the force felt's RMS
1.0340 -> 1.0342 N, the velocity shortfall 8.45 -> 8.42 %, the reach 17.42 -> 17.79 m/s^2, which the 1 ms grid had
2 % low; the design the same); ``diagnose_emps`` when the time diagnosis gave plain least squares' residual beside
each model's (``ls_rms_residual_n`` added in ``steps``, ``ranking`` and ``alternatives``; the keys were added to the
file, whose other numbers stay as written), and when the models that the admission rule drops left the
alternatives for ``not_admitted`` with the reason (EMPS's coulomb_friction + cable_force, dBIC -30.5 below the
selected model, its cable's stiffness within 3 robust standard errors of 0: not an alternative; the steps'
``decision`` names the least-squares residual it compares).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
GOLDEN = Path(__file__).resolve().parent
EMPS = "examples/data/emps/DATA_EMPS.mat"
#: recording made by the ``simulate`` case, used by the fit and diagnose cases
RECORDING = "golden_recording.csv"
#: name -> arguments of ``gantry``; {tmp} is a scratch folder
COMMANDS = {
    "reproduce_x": ["reproduce", "--json"],
    "reproduce_y": ["reproduce", "--spec", "specs/thesis_stage_y.toml", "--json"],
    "synth_x": ["synth", "specs/stage_x_synth.toml", "--json"],
    "synth_y": ["synth", "specs/stage_y_synth.toml", "--json"],
    "synth_admittance": ["synth", "specs/stage_x_admittance.toml", "--json"],
    "synth_infeasible": ["synth", "specs/infeasible_example.toml", "--json"],
    "sweep_x": ["sweep", "specs/stage_x_synth.toml", "--payload", "5:40:8", "--samples", "50", "--seed", "3",
                "--json"],
    "simulate_x": ["simulate", "--stage", "x", "--effects", "delay.seconds=0.001", "--f-hz", "2:120:12",
                   "--duration-s", "1.5", "--seed", "4", "--out", "{tmp}/" + RECORDING, "--json"],
    "fit_x": ["fit", "{tmp}/" + RECORDING, "--stage", "x", "--effects", "delay", "--json"],
    "diagnose_x": ["diagnose", "{tmp}/" + RECORDING, "--stage", "x", "--json"],
    "fit_emps": ["fit", EMPS, "--stage", "x", "--columns", "time=t,current=vir,position=qm",
                 "--set", "force_constant_n_per_a=35.15", "--effects", "coulomb_friction,offset", "--json"],
    "diagnose_emps": ["diagnose", EMPS, "--stage", "x", "--columns", "time=t,current=vir,position=qm",
                      "--set", "force_constant_n_per_a=35.15", "--json"],
}
#: keys whose values depend on the machine (wall times, also "seconds" and any key ending in "_seconds") or on where
#: files are
VOLATILE = {"elapsed_s", "simulation_s", "out", "sidecar", "source"}


def _volatile(key: str) -> bool:
    return key in VOLATILE or key == "seconds" or key.endswith("_seconds")


def run(name: str, tmp: Path, gantry=None) -> dict:
    """Exit status and JSON of the command ``name``, run by ``gantry(*args, cwd=...)`` (returning a
    ``CompletedProcess``) or in a new process."""
    args = [a.replace("{tmp}", str(tmp)) for a in COMMANDS[name]]
    if gantry is not None:
        out = gantry(*args, cwd=ROOT)
    else:
        out = subprocess.run([sys.executable, "-m", "design", *args], capture_output=True, text=True, cwd=ROOT,
                             timeout=600)
    try:
        result = json.loads(out.stdout)
    except json.JSONDecodeError:
        raise RuntimeError(f"gantry {' '.join(args)}: exit {out.returncode}: {out.stderr}") from None
    return {"exit_status": out.returncode, "json": result}


def differences(new, old, path: str = "", rel: float = 1e-6, abs_tol: float = 1e-9) -> list[str]:
    """Where two JSON values differ beyond a relative tolerance (volatile keys skipped)."""
    if isinstance(old, dict) and isinstance(new, dict):
        out = [f"{path}.{k}: missing" for k in old if k not in new and not _volatile(k)]
        for k in old:
            if k in new and not _volatile(k):
                out += differences(new[k], old[k], f"{path}.{k}", rel, abs_tol)
        return out
    if isinstance(old, list) and isinstance(new, list):
        if len(old) != len(new):
            return [f"{path}: {len(new)} items, was {len(old)}"]
        return [d for i, (a, b) in enumerate(zip(new, old)) for d in differences(a, b, f"{path}[{i}]", rel, abs_tol)]
    if isinstance(old, float) or isinstance(new, float):
        if isinstance(old, (int, float)) and isinstance(new, (int, float)) and not isinstance(old, bool) \
                and math.isclose(new, old, rel_tol=rel, abs_tol=abs_tol):
            return []
        return [f"{path}: {new!r}, was {old!r}"]
    return [] if new == old else [f"{path}: {new!r}, was {old!r}"]


def main(names: list[str]) -> None:
    """Write the golden files of ``names`` (default: every command)."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        for name in names or COMMANDS:
            (GOLDEN / f"{name}.json").write_text(json.dumps(run(name, Path(tmp)), indent=1, sort_keys=True) + "\n")
            print("wrote", name)


if __name__ == "__main__":
    main(sys.argv[1:])
