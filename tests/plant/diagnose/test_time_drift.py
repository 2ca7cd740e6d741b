"""A force constant drifting over a time-domain recording shows in the residual against current x time, and only
there. The closed-loop friction axis of tests/reference/independent_friction_sim.py (it imports nothing of the tool)
applies gain x command; a logged command divided by 1 + d u (u running from -1 to 1 over the record) is what a
drive whose force constant is K (1 + d u) logs for the same motion, seen with a constant K."""

import numpy as np
from independent_friction_sim import Axis, simulate

from plant.data.recordings import TimeRecording
from plant.diagnose.time_diagnosis import diagnose_time
from plant.identify.inverse_model import Preprocessing
from plant.physics.models import Plant

AXIS = Axis(offset_n=-3.0)


def structure(drift: float):
    log = simulate(AXIS, seed=3)
    u = np.linspace(-1.0, 1.0, log.time_s.size)
    rec = TimeRecording(log.time_s, log.command_v / (1 + drift * u), log.position_m[None], "position",
                        ("position_m",), reference=log.reference_m)
    diag = diagnose_time(Plant("x", force_constant_n_per_a=AXIS.gain_n_per_v), rec,
                         prep=Preprocessing(input_hold=True))
    return diag, next(st for st in diag.final.structure if st.variable == "current x time")


def test_a_force_constant_drifting_4_percent_shows_against_current_x_time():
    diag, st = structure(0.02)                         # K(t) / K from 0.98 to 1.02 over the record
    assert st.significant and "drifting" in st.summary
    change = float(st.summary.split(": ")[-1].split(" %")[0])
    assert abs(change - 4.0) < 0.6, st.summary         # +4 % from the first sample to the last
    assert diag.verdict == "not_explained" and "current x time" in diag.explanation


def test_a_constant_force_constant_shows_no_drift():
    diag, st = structure(0.0)
    assert not st.significant and diag.verdict == "explained"
