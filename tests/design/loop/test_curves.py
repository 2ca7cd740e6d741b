"""The report's closed-loop curves (``design.loop.curves.loop_curves``) against python-control: the bandwidth each row
marks is ``control.bandwidth`` of the feedback loop built by python-control from the same plant and PI (-3.01 dB,
the half-power definition), and the peaks of |S| and |T| are those of python-control's frequency responses of
feedback(1, L) and feedback(L, 1) on a dense grid."""

from pathlib import Path

import control
import numpy as np
import pytest

from design.loop.controller import PI
from design.loop.curves import loop_curves
from design.workflows import load_problem

SPEC = Path(__file__).resolve().parents[3] / "specs" / "thesis_stage_x.toml"


@pytest.fixture(scope="module")
def curves():
    problem = load_problem(SPEC).loop
    controller = PI(float(problem.controller.kp.value), float(problem.controller.ki.value))
    return problem, controller, loop_curves(problem, controller)


def test_each_rows_bandwidth_is_python_controls(curves):
    problem, controller, c = curves
    C = control.tf([controller.kp, controller.ki], [1.0, 0.0])
    for m, bw in zip(c.payload_kg, c.bandwidth_hz):
        plant = problem.plant.plant().with_values({"mass_kg": m})
        loop = control.tf(plant.to_control()) * C
        ref_hz = control.bandwidth(control.feedback(loop, 1), dbdrop=10 * np.log10(0.5)) / (2 * np.pi)
        assert bw == pytest.approx(ref_hz, rel=2e-3)


def test_the_peaks_of_s_and_t_are_python_controls(curves):
    problem, controller, c = curves
    C = control.tf([controller.kp, controller.ki], [1.0, 0.0])
    w = np.geomspace(c.bode_w_rad_s[0], c.bode_w_rad_s[-1], 20_000)
    for k, m in enumerate(c.payload_kg):
        loop = control.tf(problem.plant.plant().with_values({"mass_kg": m}).to_control()) * C
        S = np.abs(control.feedback(1, loop).frequency_response(w).complex).ravel()
        T = np.abs(control.feedback(loop, 1).frequency_response(w).complex).ravel()
        # the curves' 430-point grid may miss a peak by its spacing; within 0.5 % here
        assert c.peak_sensitivity[k] == pytest.approx(S.max(), rel=5e-3)
        assert c.peak_complementary[k] == pytest.approx(T.max(), rel=5e-3)
        assert c.peak_sensitivity[k] <= S.max() * (1 + 1e-6)
