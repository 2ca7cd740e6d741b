"""The dual-drive reference's batched closed loop (NumPy) against its python-control build, draw by draw."""

import ast
from pathlib import Path

import independent_dual_drive as ref
import numpy as np
import pytest

#: per structure, gains where some drawn rigs are stable and some not (found with python-control)
GAINS = {"per_motor": [(100.0, 5000.0), (300.0, 15000.0)],
         "common_differential": [(100.0, 5000.0, 100.0, 5000.0), (1000.0, 50000.0, 1000.0, 50000.0)],
         "master_slave": [(100.0, 5000.0), (300.0, 15000.0)]}


def _rigs(n: int, seed: int) -> list[ref.Rig]:
    rng = np.random.default_rng(seed)
    return [ref.Rig(carriage_mass_kg=35.0 + rng.uniform(5.0, 40.0), carriage_position_m=rng.uniform(0.1, 0.7),
                    b1=rng.uniform(300.0, 600.0), b2=rng.uniform(300.0, 600.0), delay_s=rng.uniform(3e-4, 8e-4),
                    current_loop_hz=rng.uniform(500.0, 2000.0)) for _ in range(n)]


def test_module_imports_neither_plant_nor_design():
    tree = ast.parse(Path(ref.__file__).read_text())
    names = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names} | \
        {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
    assert not {m for m in names if m.split(".")[0] in ("plant", "design")}


@pytest.mark.parametrize("structure", list(GAINS))
def test_batched_closed_loop_has_python_controls_poles_and_unstable_counts(structure):
    rigs = _rigs(40, seed=len(structure))
    counts = []
    for gains in GAINS[structure]:
        fast = ref.unstable_pole_counts(rigs, structure, gains)
        lam = np.linalg.eigvals(ref.closed_loop_matrices(rigs, structure, gains))
        for rig, mine, n_fast in zip(rigs, lam, fast):
            poles = ref.closed_loop(rig, structure, gains).poles()
            assert n_fast == ref.unstable_poles(rig, structure, gains)
            poles = np.delete(poles, np.argmin(np.abs(poles)))      # the common position, which nothing feeds back
            assert poles.size == mine.size
            gap = max(np.min(np.abs(mine - p)) / max(1.0, abs(p)) for p in poles)
            assert gap < 1e-7, (rig, gap)
        counts.append(int(np.count_nonzero(fast)))
    assert counts[0] < 40 and counts[1] > 0          # both stable and unstable rigs are compared
