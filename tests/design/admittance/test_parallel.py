"""Array work spread over threads gives the answer of the calling thread alone, in order."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from design.admittance.model import PiLoops, admittance_problem
from design.admittance.monte_carlo import admittance_monte_carlo
from design.admittance.rig import RigTiming
from design.loop.controller import PI
from design.parallel import thread_map, workers
from design.spec.schema import load_spec

SPEC = Path(__file__).resolve().parents[3] / "specs" / "stage_x_admittance.toml"


def test_thread_map_keeps_order_and_raises(monkeypatch):
    monkeypatch.setenv("GANTRY_THREADS", "3")
    assert workers() == 3
    assert thread_map(lambda x: x * x, range(20)) == [x * x for x in range(20)]

    def boom(x):
        if x == 5:
            raise ValueError("five")
        return x

    with pytest.raises(ValueError, match="five"):
        thread_map(boom, range(10))


def test_a_pool_inside_a_worker_runs_in_that_worker(monkeypatch):
    import threading

    monkeypatch.setenv("GANTRY_THREADS", "2")

    def outer(x):
        inner = thread_map(lambda y: (y + 1, threading.get_ident()), range(x, x + 4))
        return [v for v, _ in inner], {t for _, t in inner}, threading.get_ident()

    results = thread_map(outer, [0, 10])
    assert [r[0] for r in results] == [[1, 2, 3, 4], [11, 12, 13, 14]]
    assert all(inner == {here} for _, inner, here in results)      # no third thread below a worker
    assert {r[2] for r in results} != {threading.get_ident()}       # the outer calls did run on the pool


def test_monte_carlo_on_two_threads_equals_one(monkeypatch):
    spec = load_spec(SPEC).problem()
    timing = RigTiming.of(admittance_problem(spec).rig)
    kw = dict(loops=PiLoops.of(spec, PI(210.0, 14.0)), m_v=0.33, b_v=7.6, timing=timing, samples=1200, seed=3)
    runs = []
    for n in ("1", "2"):
        monkeypatch.setenv("GANTRY_THREADS", n)
        runs.append(dataclasses.astuple(admittance_monte_carlo(spec, **kw)))
    assert all(np.array_equal(a, b) if isinstance(a, np.ndarray) else a == b for a, b in zip(*runs))
