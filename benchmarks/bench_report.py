"""Wall time of ``gantry report specs/stage_x_synth.toml`` (target: 4 s on the 2-core machine) and
where it goes: imports, synthesis, figures and HTML, each measured in one process.

Run:  python benchmarks/bench_report.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "specs" / "stage_x_synth.toml"
TARGET_S = 4.0

BREAKDOWN = """
import time
t0 = time.perf_counter()
import matplotlib
matplotlib.use("Agg")
from design.views.report import design_report
from design.workflows import design, load_problem, report_content
t1 = time.perf_counter()
problem = load_problem({spec!r})
outcome = design(problem)
t2 = time.perf_counter()
content = report_content(problem, outcome=outcome, command="bench")
t3 = time.perf_counter()
design_report(content).write({out!r})
t4 = time.perf_counter()
print(t1 - t0, t2 - t1, t3 - t2, t4 - t3)
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "report.html"
        walls, parts = [], []
        for _ in range(args.repeats):
            t = time.perf_counter()
            subprocess.run([sys.executable, "-m", "design", "report", str(SPEC), "--out", str(out)], check=True,
                           capture_output=True, cwd=ROOT)
            walls.append(time.perf_counter() - t)
            res = subprocess.run([sys.executable, "-c", BREAKDOWN.format(spec=str(SPEC), out=str(out))], check=True,
                                 capture_output=True, text=True, cwd=ROOT)
            parts.append([float(x) for x in res.stdout.split()])
    median = statistics.median(walls)
    imp, syn, num, fig = (statistics.median(p[k] for p in parts) for k in range(4))
    print(f"gantry report {SPEC.name}: median {median:.2f} s over {args.repeats} runs "
          f"(min {min(walls):.2f}, max {max(walls):.2f}); target {TARGET_S:g} s: "
          f"{'met' if median <= TARGET_S else 'NOT met'}")
    print(f"in one process: imports {imp:.2f} s, synthesis (ccp + exact + verification) {syn:.2f} s, "
          f"report numbers (dense check, curves, Monte Carlo) {num:.2f} s, figures and HTML {fig:.2f} s; "
          f"the command line adds {median - imp - syn - num - fig:.2f} s (interpreter start, typer and rich)")


if __name__ == "__main__":
    main()
