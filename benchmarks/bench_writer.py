"""CSV writer: the rows of a recording formatted by ``plant.data.writers.csv_rows`` against numpy's ``savetxt`` (what
the writers used before), the same columns and formats side by side in one run, the texts checked equal.

Run:  python benchmarks/bench_writer.py [--rows 250000] [--repeat 3]

The columns are a stepped-sine block's as ``gantry simulate`` writes them (frequency_hz, time_s, current_a,
velocity_m_per_s: ``%.10g``, ``%.9f``, ``%.9g``, ``%.9g``); the thesis-size recording is 50 blocks of 5 s at 5 kHz,
1.25 million rows. Times are the best of ``--repeat`` runs, CPU time of this process.
"""

from __future__ import annotations

import argparse
import io
import sys
import time
from pathlib import Path

import as_commands  # noqa: F401  (BLAS on one thread, as the commands run it)
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from plant.data.writers import csv_rows  # noqa: E402

FORMATS = ["%.10g", "%.9f", "%.9g", "%.9g"]


def _savetxt(columns: np.ndarray) -> str:
    buf = io.StringIO()
    np.savetxt(buf, columns, fmt=FORMATS, delimiter=",")
    return buf.getvalue()


def _best(fn, columns: np.ndarray, repeat: int) -> tuple[float, str]:
    best, text = float("inf"), ""
    for _ in range(repeat):
        t0 = time.process_time()
        text = fn(columns)
        best = min(best, time.process_time() - t0)
    return best, text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=250_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    t = np.arange(args.rows) / 5000.0
    columns = np.column_stack([np.full(args.rows, 12.5), t, 0.5 * np.sin(2 * np.pi * 12.5 * t),
                               0.01 * np.sin(2 * np.pi * 12.5 * t - 1.2) + 1e-4 * rng.standard_normal(args.rows)])
    old, old_text = _best(_savetxt, columns, args.repeat)
    new, new_text = _best(lambda c: csv_rows(c, FORMATS), columns, args.repeat)
    assert new_text == old_text, "csv_rows wrote other text than numpy.savetxt"
    print(f"{args.rows} rows, {len(new_text) / 1e6:.1f} MB of text, identical")
    print(f"{'writer':16} {'CPU s':>7} {'rows/s':>11}")
    for name, s in (("numpy.savetxt", old), ("csv_rows", new)):
        print(f"{name:16} {s:7.3f} {args.rows / s:11.3g}")
    print(f"ratio savetxt / csv_rows: {old / new:.2f}")


if __name__ == "__main__":
    main()
