"""What a user waits for: wall time, CPU time and peak memory of the commands of a design iteration, each in
its own process, optionally side by side with another commit of the tool in one run.

Run:  python benchmarks/bench_speed.py [--against REF] [--repeat 1] [--only NAME]

Commands: ``gantry synth`` and ``gantry report`` on the bundled Stage X spec, ``gantry synth`` on the admittance
spec, and ``gantry diagnose`` on a ``gantry simulate`` default recording (50 blocks x 5 s, the thesis's size).
``--against REF`` checks REF out in a temporary git worktree and runs the same commands with its code (same
interpreter and packages); the ratio is REF / this checkout. CPU and peak memory come from the child's own
resource usage (``os.wait4``), as ``/usr/bin/time -f "%U %S %M"`` reports them.

Each tree's modules are compiled to bytecode first (``compileall``), as ``pip install`` does for an installed
tool: where ``PYTHONDONTWRITEBYTECODE`` is set (this sandbox sets it), a checkout would otherwise be compiled anew
by every run, which no user of the installed tool waits for.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _commands(tmp: Path) -> dict[str, list[str]]:
    return {
        "synth stage_x_synth --json": ["synth", "specs/stage_x_synth.toml", "--json"],
        "report stage_x_synth": ["report", "specs/stage_x_synth.toml", "--out", str(tmp / "design.html")],
        "synth stage_x_admittance --json": ["synth", "specs/stage_x_admittance.toml", "--json"],
        "diagnose (50 blocks x 5 s) --json": ["diagnose", str(tmp / "thesis.csv"), "--stage", "x", "--json"],
    }


def _measure(tree: Path, args: list[str]) -> tuple[float, float, float]:
    """(wall s, CPU s, peak MB) of ``python -m design ARGS`` run with the code of ``tree``."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    t0 = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-m", "design", *args], cwd=tree, env=env, stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE)
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    err = p.stderr.read().decode(errors="replace")
    p.stderr.close()
    if os.waitstatus_to_exitcode(status) not in (0, 3):
        raise SystemExit(f"{' '.join(args)} failed in {tree}:\n{err[-2000:]}")
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", help="a git commit to measure beside this checkout")
    parser.add_argument("--repeat", type=int, default=1, help="runs per command and tree, the trees in turn "
                                                                "(the median is shown)")
    parser.add_argument("--only", help="only the commands whose name contains this, e.g. 'report'")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        subprocess.run([sys.executable, "-m", "design", "simulate", "--stage", "x", "--out", str(tmp / "thesis.csv")],
                       cwd=ROOT, check=True, stdout=subprocess.DEVNULL, env={**os.environ, "PYTHONPATH": str(ROOT)})
        trees = {"this checkout": ROOT}
        if args.against:
            other = tmp / "against"
            subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(other), args.against],
                           check=True, capture_output=True)
            trees[args.against] = other
        for tree in trees.values():
            subprocess.run([sys.executable, "-m", "compileall", "-q", str(tree / "design"), str(tree / "plant")],
                           check=True, stdout=subprocess.DEVNULL)
        try:
            print(f"{'command':36} {'tree':14} {'wall s':>7} {'CPU s':>7} {'peak MB':>8}")
            for name, cmd in _commands(tmp).items():
                if args.only and args.only not in name:
                    continue
                runs: dict[str, list] = {label: [] for label in trees}
                for _ in range(args.repeat):      # the trees in turn, so a drift of the machine hits both alike
                    for label, tree in trees.items():
                        runs[label].append(_measure(tree, cmd))
                rows = {label: sorted(r)[len(r) // 2] for label, r in runs.items()}
                for label, (wall, cpu, peak) in rows.items():
                    print(f"{name:36} {label[:14]:14} {wall:7.2f} {cpu:7.2f} {peak:8.0f}", flush=True)
                if args.against:
                    (w0, c0, m0), (w1, c1, m1) = rows["this checkout"], rows[args.against]
                    print(f"{'':36} {'ratio':14} {w1 / w0:7.2f} {c1 / c0:7.2f} {m1 / m0:8.2f}")
        finally:
            if args.against:
                subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(trees[args.against])],
                               capture_output=True)


if __name__ == "__main__":
    main()
