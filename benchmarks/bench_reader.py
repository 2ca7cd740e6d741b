"""Time-domain CSV reader: peak memory and time of reading a large recording, the streamed reader against the
careful one (the whole text in memory, each line a string), side by side in one run.

Run:  python benchmarks/bench_reader.py [--rows 4000000]

Each reader runs in its own process on the same file (time_s,current_a,position_m,reference_m, 9-10
significant digits per cell as ``gantry simulate`` writes them); the figure is the process's peak resident
memory above that of a process that imported the reader and read nothing, over the file's size.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import as_commands  # noqa: F401  (BLAS on one thread, as the commands run it)
import numpy as np

ROOT = Path(__file__).resolve().parents[1]

CHILD = """
import json, resource, sys, time
sys.path.insert(0, {root!r})
from plant.data import read_time_domain
from plant.data.table import streamed_numbers
mode, path = sys.argv[1], sys.argv[2]
if mode == "careful":
    read_time_domain.streamed_numbers = lambda path: None
t0 = time.perf_counter()
rec = read_time_domain.read_time_recording(path) if mode != "baseline" else None
wall = time.perf_counter() - t0
print(json.dumps({{"peak_kb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, "wall_s": wall,
                   "n": 0 if rec is None else int(rec.time_s.size)}}))
"""


def _write(path: Path, rows: int, block: int = 200_000) -> None:
    """The recording, written a block at a time (the readers' processes inherit this one's memory at fork)."""
    rng = np.random.default_rng(0)
    with path.open("w") as fh:
        fh.write("time_s,current_a,position_m,reference_m\n")
        for k in range(0, rows, block):
            t = np.arange(k, min(k + block, rows)) / 1000.0
            current = 0.5 * np.sin(2 * np.pi * 0.7 * t) + 0.01 * rng.standard_normal(t.size)
            position = 0.05 * np.sin(2 * np.pi * 0.7 * t - 1.0) + 1e-6 * rng.standard_normal(t.size)
            np.savetxt(fh, np.column_stack([t, current, position, position]), delimiter=",",
                       fmt=["%.9f", "%.9g", "%.10g", "%.10g"])


def _run(mode: str, path: Path) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD.format(root=str(ROOT)), mode, str(path)], capture_output=True,
                         text=True, check=True)
    return json.loads(out.stdout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=4_000_000)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "recording.csv"
        t0 = time.perf_counter()
        _write(path, args.rows)
        size_mb = path.stat().st_size / 1e6
        print(f"file: {args.rows} rows, {size_mb:.0f} MB (written in {time.perf_counter() - t0:.1f} s)")
        base = _run("baseline", path)["peak_kb"]
        print(f"a process that imported the reader: {base / 1e3:.0f} MB peak")
        print(f"{'reader':10} {'wall s':>7} {'peak MB':>8} {'above import MB':>16} {'x file':>7}")
        for mode in ("streamed", "careful"):
            r = _run(mode, path)
            assert r["n"] == args.rows
            above = (r["peak_kb"] - base) / 1e3
            print(f"{mode:10} {r['wall_s']:7.2f} {r['peak_kb'] / 1e3:8.0f} {above:16.0f} {above / size_mb:7.2f}")


if __name__ == "__main__":
    main()
