"""A design's gains on a fitted stage (``design.loop.fitted.check_fitted``, what ``gantry report --data`` says): the
fitted parameters against the spec's ranges, and the least margins over the payload range against python-control's
``stability_margins`` of the same stage (its rational model) at each payload."""

import dataclasses
import math
from pathlib import Path

import control
import numpy as np
import pytest

from design.loop.controller import PI
from design.loop.fitted import PAYLOAD_POINTS, check_fitted
from design.workflows import load_problem
from plant.diagnose.diagnosis import diagnose
from plant.estimate.lockin import estimate_response
from plant.experiment.simulate import simulate_stepped_sine

SPEC = Path(__file__).resolve().parents[3] / "specs" / "stage_x_synth.toml"
GAINS = PI(178.5, 19150.0)


@pytest.fixture(scope="module")
def fitted():
    """A stage of the synthesis spec's kind whose delay, 1.0 ms, lies outside the spec's 0.3-0.8 ms."""
    loop = load_problem(SPEC).loop
    truth = loop.plant.plant(38.0).with_values({"delay.seconds": 0.001})
    rec = simulate_stepped_sine(truth, f_hz=np.geomspace(2, 75, 12), current_amplitude_a=0.5, duration_s=2.0,
                                noise_fraction=0.02, seed=1)
    return loop, diagnose(loop.plant.plant(), estimate_response(rec)).final


def test_a_delay_outside_the_spec_is_flagged_and_the_mass_is_not(fitted):
    loop, fit = fitted
    status = {p.name: p.status for p in check_fitted(loop, GAINS, fit).parameters}
    assert status["delay.seconds"] == "outside" and status["mass_kg"] == "inside"


def test_the_least_margins_over_the_payloads_are_python_controls(fitted):
    loop, fit = fitted
    check = check_fitted(loop, GAINS, fit)
    C = control.tf([GAINS.kp, GAINS.ki], [1.0, 0.0])
    pms, gms = [], []
    rng = loop.plant.payload_kg
    for m in np.r_[np.linspace(rng.min, rng.max, PAYLOAD_POINTS), fit.values["mass_kg"]]:
        gm, pm, *_ = control.stability_margins(control.tf(fit.plant.with_payload(m).to_control(pade_order=10)) * C)
        pms.append(pm)
        gms.append(20 * math.log10(gm))
    assert check.phase_margin_deg == pytest.approx(min(pms), abs=0.05)
    assert check.gain_margin_db == pytest.approx(min(gms), abs=0.05)
    assert not check.meets and check.stable


def test_an_unidentified_parameter_is_named_and_held_at_the_spec_nominal(fitted):
    """A current loop fitted at 9.75e9 Hz with no finite error: 'not identified', and the loop judged with the
    spec's 700 Hz (the same margins as a fit that found 700 Hz), not without a current loop's lag."""
    loop, fit = fitted
    name = "current_loop.bandwidth_hz"
    nominal = loop.plant.plant().parameters()[name].value

    def with_bandwidth(hz, stderr):
        return dataclasses.replace(fit, plant=fit.plant.with_values({name: hz}), values={**fit.values, name: hz},
                                   stderr={**fit.stderr, name: stderr})

    unidentified = check_fitted(loop, GAINS, with_bandwidth(9.75e9, math.inf))
    at_nominal = check_fitted(loop, GAINS, with_bandwidth(nominal, 1.0))
    assert [p.name for p in unidentified.unidentified] == [name]
    assert unidentified.phase_margin_deg == pytest.approx(at_nominal.phase_margin_deg, abs=1e-9)
    assert unidentified.gain_margin_db == pytest.approx(at_nominal.gain_margin_db, abs=1e-9)
