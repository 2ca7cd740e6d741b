"""The search between the dense check's points: its coordinates and its slack (what it finds is confirmed on
Newton's model in test_admittance.py)."""

from pathlib import Path

import numpy as np
import pytest

from design.admittance.between import one_motor_space, slack_of
from design.spec.schema import load_spec

SPEC = Path(__file__).resolve().parents[3] / "specs" / "stage_x_admittance.toml"


@pytest.mark.parametrize("grounded", [False, True])
def test_the_box_maps_the_declared_ranges_onto_the_unit_cube_and_back(grounded):
    problem = load_spec(SPEC).problem()
    box = one_motor_space(problem)(grounded)
    assert box.names[0] == "payload_kg" and box.names[1:box.n_scenario] == tuple(sorted(problem.plant.uncertainty))
    assert box.lo[0] == 5.0 and box.hi[0] == 40.0
    legs = [box.names.index("leg_stiffness_n_per_m"), box.names.index("leg_damping_n_s_per_m")]
    if grounded:
        # 300 N/m to 1e4 N/m: searched in log, as the Monte Carlo draws it; its midpoint is the geometric mean
        assert box.log[legs[0]] and box.value(np.full((1, box.lo.size), 0.5))[0, legs[0]] == pytest.approx(
            np.sqrt(300.0 * 1.0e4))
    else:
        assert np.all(box.hi[legs] == 0) and not box.log.any()      # a floating mouse keeps its feet up
    rng = np.random.default_rng(3)
    u = rng.uniform(size=(20, box.lo.size))
    u[:, box.hi == box.lo] = 0.0
    x = box.value(u)
    assert np.all((x >= box.lo - 1e-12) & (x <= box.hi * (1 + 1e-12)))
    assert np.allclose(box.unit(x), u, atol=1e-12)
    scenarios, mice = box.point(x[:2])
    assert scenarios.payload_kg[1] == x[1, 0] and mice[1].body_mass_kg == x[1, box.names.index("body_mass_kg")]


def test_slack_is_the_least_relative_margin_and_minus_one_when_unstable():
    s = slack_of([50.0, 45.0, 90.0, 30.0], [12.0, 3.0, np.inf, 20.0], [True, True, True, False], 45.0, 6.0)
    assert s == pytest.approx([5.0 / 45.0, -0.5, 1.0, -1.0])


def test_the_starts_are_the_tightest_curves_of_their_kind_of_mouse():
    from types import SimpleNamespace

    from design.admittance.between import _starts
    from design.admittance.mouse import MouseModel

    floating, braced = MouseModel(0.002, 0.02, 20.0, 0.2, 0.0, 0.0), MouseModel(0.002, 0.02, 20.0, 0.2, 300.0, 0.5)
    check = SimpleNamespace(mice=(braced, floating, braced, floating))
    slack = np.array([[-0.5, 0.1, 0.2], [np.inf, 0.3, 0.05], [0.0, -0.1, np.inf], [np.inf, np.inf, np.inf]])
    assert _starts(check, slack, False, 2) == [(1, 2), (1, 1)]
    assert _starts(check, slack, True, 3) == [(0, 0), (2, 1), (2, 0)]
    assert all(check.mice[k].grounded is False for k, _ in _starts(check, slack, False, 6))
