"""Chunks of array work side by side on threads.

NumPy lets go of the interpreter lock inside its array loops, so chunks of large complex-array work (a
batch of scenarios on a frequency grid) run on both cores of a small machine; Python-heavy work gains
nothing from this and stays serial. ``GANTRY_THREADS`` (an environment variable) sets the number of
threads; 1 runs everything in the calling thread.

The tool's matrices are small (a state space of tens of states, batches of them): BLAS's own threads
(OpenBLAS) only spin on them, so a command runs BLAS on the calling thread (``one_blas_thread``, unless
the environment sets the BLAS's threads itself). Measured on
``gantry synth specs/stage_x_admittance.toml`` (2 cores): 21.2 s wall, 32.0 s CPU with OpenBLAS's threads,
17.9 s wall, 22.3 s CPU without.

May import: nothing of the tool.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

T = TypeVar("T")
R = TypeVar("R")


def workers() -> int:
    """Threads for array chunks: ``GANTRY_THREADS``, else the cores this process may use, at most 4."""
    env = os.environ.get("GANTRY_THREADS", "").strip()
    if env.isdigit() and int(env) >= 1:
        return int(env)
    return max(1, min(4, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1))


_inside = threading.local()


def _in_worker(fn: Callable[[T], R]) -> Callable[[T], R]:
    def call(x: T) -> R:
        _inside.worker = True
        return fn(x)
    return call


def thread_map(fn: Callable[[T], R], items: Iterable[T]) -> list[R]:
    """``[fn(x) for x in items]``, the calls spread over ``workers()`` threads (results in order; the first
    exception is raised). Called from inside a worker it runs in that worker: pools nested in pools would put
    more threads than cores on the interpreter lock."""
    items = list(items)
    n = min(workers(), len(items))
    if n <= 1 or getattr(_inside, "worker", False):
        return [fn(x) for x in items]
    with ThreadPoolExecutor(n) as pool:
        return list(pool.map(_in_worker(fn), items))


#: the variables the BLAS builds numpy and scipy ship with read for their threads
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS")


def one_blas_thread() -> None:
    """BLAS on the calling thread for this process: read when numpy and scipy load their BLAS, so called
    before they are imported (a variable the environment already sets is kept)."""
    for name in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(name, "1")
