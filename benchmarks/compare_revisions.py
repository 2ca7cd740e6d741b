"""Every bundled spec's design against another revision's: the designs, figures and verdicts of ``gantry synth
SPEC --json`` (and ``gantry reproduce --json``) from this checkout and from REV side by side, and where they differ
(``tests/golden/commands.differences``: relative 1e-6, wall times left out). What a refactor must leave unchanged.

Run:  python benchmarks/compare_revisions.py [REV] [SPEC ...]

REV (default ``HEAD``) is checked out in a temporary git worktree (removed at the end, whatever happens) and run
with its own code on the ``PYTHONPATH``; SPEC names files under ``specs/`` (default: every one that ``synth``
designs). Each command's exit status, wall and CPU seconds and peak memory are printed beside the verdict, so
the comparison is also a timing of both revisions on one machine in one run.
"""

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "golden"))
from commands import differences  # noqa: E402

#: bundled specs that are not synthesis specs (the thesis's own gains, the examples of refusals are designs too)
NOT_SYNTH = {"thesis_stage_x.toml", "thesis_stage_y.toml"}


def run(code: Path, args: list[str]) -> tuple[int, dict | str, float, float, float]:
    """(exit status, JSON or else the last line of standard error, wall s, CPU s, peak MB) of ``gantry ARGS`` with
    the library of the checkout at ``code``, run there (its own specs and examples)."""
    with tempfile.NamedTemporaryFile(suffix=".time") as f:
        env = {**os.environ, "PYTHONPATH": str(code), "PYTHONDONTWRITEBYTECODE": "1"}
        t0 = time.perf_counter()
        out = subprocess.run(["/usr/bin/time", "-f", "%U %S %M", "-o", f.name, sys.executable, "-m", "design",
                              *args], capture_output=True, text=True, cwd=code, env=env, timeout=1800)
        wall = time.perf_counter() - t0
        user, system, rss = Path(f.name).read_text().split()[-3:]
    try:
        result = json.loads(out.stdout)
    except json.JSONDecodeError:
        lines = out.stderr.strip().splitlines()
        result = lines[-1] if lines else ""
    return out.returncode, result, wall, float(user) + float(system), int(rss) / 1024


def main(argv: list[str]) -> int:
    rev = argv[0] if argv and not argv[0].endswith(".toml") else "HEAD"
    names = [a for a in argv if a.endswith(".toml")] or sorted(
        p.name for p in (ROOT / "specs").glob("*.toml") if p.name not in NOT_SYNTH)
    cases = [("reproduce", ["reproduce", "--json"])] + [(n, ["synth", f"specs/{n}", "--json"]) for n in names]
    work = Path(tempfile.mkdtemp(prefix="gantry-rev-"))
    tree = work / "tree"
    changed = 0
    try:
        subprocess.run(["git", "worktree", "add", "--detach", "-q", str(tree), rev], cwd=ROOT, check=True)
        print(f"{'case':34s} {'exit':>9s} {'wall s':>13s} {'CPU s':>13s} {'peak MB':>11s}  verdict ({rev} -> this)")
        for name, args in cases:
            old, new = run(tree, args), run(ROOT, args)
            diff = differences(new[1], old[1])
            if old[0] != new[0]:
                diff.insert(0, f"exit status {new[0]}, was {old[0]}")
            changed += bool(diff)
            print(f"{name:34s} {old[0]:>4d} {new[0]:>4d} {old[2]:6.1f} {new[2]:6.1f} {old[3]:6.1f} {new[3]:6.1f} "
                  f"{old[4]:5.0f} {new[4]:5.0f}  " + ("same" if not diff else f"{len(diff)} differences"), flush=True)
            for d in diff[:12]:
                print(f"    {d}")
    finally:
        subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT, capture_output=True)
        shutil.rmtree(work, ignore_errors=True)
    print(f"{changed} of {len(cases)} cases differ")
    return 1 if changed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
