"""A force constant drifting over a stepped sine (a coil warming) is named as a drift with its size, not as an effect
"near 1 Hz"; a recording without drift gets none.

Recordings from the independent simulator (tests/reference/independent_sim.py); the drift is put on them here: with
the motor's force K_t(t) i and K_t changing by 3.3 % over minutes, far slower than the stage's m/b = 80 ms, the
velocity is the constant-K_t velocity times K_t(t) / K_t(0) at every sample (to first order in the drift rate).
"""

import math
from dataclasses import replace

import independent_sim as sim
import numpy as np
import pytest

from plant import stage_x
from plant.data.read_stepped_sine import read_recording
from plant.diagnose.diagnosis import diagnose
from plant.estimate.lockin import estimate_response

PROTOCOL = sim.Protocol(f_hz=tuple(np.geomspace(1.0, 75.0, 24)), block_s=10.0, sample_rate_hz=1000.0)
CHANGE = -0.033      # of the force constant over the whole record


def recording(tmp_path, change: float, seed: int = 5):
    rec = sim.simulate(sim.rigid_stage(30.0, 440.0), sim.Drive(), PROTOCOL, noise=0.01, seed=seed)
    durations = [t[-1] + (t[1] - t[0]) for t in rec.time_s]
    total = float(np.sum(durations))
    start = 0.0
    for t, v, d in zip(rec.time_s, rec.velocity_m_per_s, durations):
        v *= (1.0 + change * (start + t) / total)[:, None]
        start += d
    path = sim.write_csv(rec, tmp_path / "rec.csv")
    return estimate_response(read_recording(path)), total


def test_a_force_constant_falling_as_the_coil_warms_is_named_a_drift(tmp_path):
    data, total = recording(tmp_path, CHANGE)
    diag = diagnose(stage_x(), data)
    assert diag.drift is not None and diag.verdict == "explained"
    span = diag.drift.span_s
    truth = CHANGE * span / total                 # between the first and the last block's middles
    assert diag.drift.change == pytest.approx(truth, abs=3 * diag.drift.stderr_per_s * span + 0.002)
    assert abs(diag.drift.change - truth) < 0.1 * abs(truth)
    # the stage at the record's middle (force constant 20 N/A x (1 - 3.3 % / 2)): mass and damping scale with 1/K_t
    mid = 1 + CHANGE / 2
    assert diag.final.values["mass_kg"] == pytest.approx(30.0 / mid, rel=0.02)
    assert diag.final.values["damping_n_s_per_m"] == pytest.approx(440.0 / mid, rel=0.02)
    assert "drifting" in diag.explanation and "falls" in diag.explanation and "near 1 Hz" not in diag.explanation
    assert diag.final_effects == ()
    assert "Drift over the record" in diag.story().text()


def test_a_recording_without_drift_claims_none(tmp_path):
    data, _ = recording(tmp_path, 0.0)
    diag = diagnose(stage_x(), data)
    assert diag.verdict == "explained" and diag.drift is None and diag.final_effects == ()
    assert math.isclose(diag.final.values["mass_kg"], 30.0, rel_tol=0.02)


def test_the_profiles_newton_steps_land_where_a_bounded_search_of_the_profile_does(tmp_path):
    # the shortcut (a few Newton steps on the near-parabola -2 ln L(r)) against scipy's bounded search of the same
    # profile to 1e-7 of the rate range: the same rate, the same curvature-based error
    from scipy import optimize

    from plant.diagnose.drift import MAX_CHANGE, block_times, fit_drift
    from plant.identify.fitting import fit_plant

    data, _ = recording(tmp_path, CHANGE)
    base = fit_plant(stage_x(), data, free=("mass_kg", "damping_n_s_per_m"))
    drift = fit_drift(base, data)
    t = block_times(data)
    tau, span = t - 0.5 * (t.min() + t.max()), float(np.ptp(t))

    def m2ll(r):
        scale = 1.0 + r * tau
        scaled = replace(data, response=data.response / scale, variance=data.variance / scale**2)
        fit = fit_plant(base.plant, scaled, free=base.free, start={n: base.values[n] for n in base.free})
        return fit.bic - fit.n_params * math.log(fit.n_data)

    limit = MAX_CHANGE / span
    best = optimize.minimize_scalar(m2ll, bounds=(-limit, limit), method="bounded", options={"xatol": 1e-7 * limit}).x
    # within a tenth of the rate's standard error: -2 ln L differs by under 0.01 there, the size of the polishes'
    # own tolerance (each side refits from its own starts)
    assert drift.rate_per_s == pytest.approx(best, abs=0.1 * drift.stderr_per_s)
    h = 2 * drift.stderr_per_s        # -2 ln L rises by 4 there: far above the polishes' own 0.01
    curvature = (m2ll(best + h) - 2 * m2ll(best) + m2ll(best - h)) / h**2
    # the error from the profile's curvature: the tool's refits start from their neighbours' optima, these from the
    # fit without drift; the two profiles' curvatures agree to 12 % (σ 7.9e-7 against 7.5e-7 here)
    assert drift.stderr_per_s == pytest.approx(math.sqrt(2 / curvature * drift.overdispersion), rel=0.1)
