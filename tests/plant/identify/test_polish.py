"""The polish's stopping rules (``plant.identify.fitting.POLISH_FIRST``, ``CRAWL``, ``REPOLISH_FIRST``) against
the whole evaluation budget spent at once, on a Stage Y stepped sine of the independent simulator
(``tests/reference/independent_sim.py``; ``benchmarks/bench_identification.py``'s recording 29: the load 0.17 m off
centre, the motors 5 % apart, the yaw mode at 39 Hz). Models the data reject (two resonances standing in for the yaw
mode, reduced chi^2 ~1e5) crawl along flat valleys; the polish leaves them once a stretch gains less than ``CRAWL``
of the cost, and a re-polish off a bound that has not overtaken the polish by its first stretch. What the rest of
the budget would have gained is far below anything a ranking reads, and the diagnosis is the same."""

import dataclasses

import independent_sim as sim
import numpy as np
import pytest

import plant.identify.fitting as fitting
from plant import stage_y
from plant.data.read_stepped_sine import read_recording
from plant.diagnose.diagnosis import diagnose
from plant.estimate.lockin import estimate_response

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    load, imbalance, inertia, tilt_hz = 0.5694, 0.0504, 1.136, 39.41
    net = sim.stage_y_beam(32.92, inertia, load, inertia * (2 * np.pi * tilt_hz) ** 2, damping_n_s_per_m=264.5)
    T = np.array([[1.0, -load], [1.0, sim.BEAM_LENGTH_M - load]])
    kt = sim.KT_N_PER_A
    net = dataclasses.replace(net, input_n_per_a=T.T @ np.array([kt * (1 + imbalance) / 2, kt * (1 - imbalance) / 2]))
    protocol = sim.Protocol(f_hz=tuple(np.geomspace(1.0, 75.0, 24)), block_s=3.0, sample_rate_hz=1000.0,
                            amplitude_a=1.812)
    rec = sim.simulate(net, sim.Drive(), protocol, noise=0.0244, seed=1048611106)
    path = sim.write_csv(rec, tmp_path_factory.mktemp("polish") / "tilt.csv")
    return estimate_response(read_recording(path)), load


def test_the_polish_leaves_a_crawl_where_no_ranking_can_see_the_rest(recording, monkeypatch):
    data, load = recording
    tool = diagnose(stage_y(load_position_m=load), data)
    monkeypatch.setattr(fitting, "POLISH_FIRST", fitting.POLISH_MAX)
    monkeypatch.setattr(fitting, "REPOLISH_FIRST", fitting.POLISH_MAX)
    whole = diagnose(stage_y(load_position_m=load), data)
    assert (tool.verdict, tool.added) == (whole.verdict, whole.added) == ("explained",
                                                                          ("tilt_coupling", "motor_imbalance"))
    for name, value in whole.final.values.items():
        assert tool.final.values[name] == pytest.approx(value, rel=1e-6, abs=1e-9), name
    spent = [sum(m.n_evaluations for m in d.models.values()) for d in (tool, whole)]
    assert spent[0] < 0.85 * spent[1]
    for k, m in whole.models.items():                    # every model as well fitted, to BIC's precision
        assert tool.models[k].chi2 < m.chi2 + max(1e-3 * m.chi2, 0.05), k
    crawled = [k for k, m in whole.models.items() if m.reduced_chi2 > 1e3 and
               tool.models[k].n_evaluations < 0.7 * m.n_evaluations]
    assert crawled                                       # the budget went on crawls, and they gained next to nothing:
    for k in crawled:                                    # under 1e-3 of chi^2, a thousandth of QBIC's unit per datum
        assert abs(tool.models[k].chi2 - whole.models[k].chi2) < 1e-3 * whole.models[k].chi2, k
