"""The loop as python-control models (``design.loop.control_models``) and its MATLAB file: the thesis plant
against its closed form, a plant with a delay and a current loop against python-control's own margins of the
exact frequency response, S + T = 1, and the .mat file rebuilt into the same models."""

from __future__ import annotations

import control
import numpy as np
import pytest
from scipy.io import loadmat

from design.loop.control_models import loop_models
from design.loop.controller import PI
from plant import CurrentLoop, Delay, stage_x

W = np.geomspace(2 * np.pi * 0.05, 2 * np.pi * 300.0, 400)


def _resp(sys, w=W):
    return np.asarray(sys(1j * w)).reshape(-1)


def test_thesis_plant_and_pi_are_their_closed_forms():
    p = stage_x(mass_kg=20.0)
    m = loop_models(p, PI(236.0, 47.0))
    M, b, kt = 20.0, float(p.damping_n_s_per_m), float(p.force_constant_n_per_a)   # thesis Eq. 3.17: K_t/(M s + b)
    assert np.allclose(_resp(m.P), kt / (M * 1j * W + b), rtol=1e-10)
    assert np.allclose(_resp(m.C), 236.0 + 47.0 / (1j * W), rtol=1e-12)
    assert np.allclose(_resp(m.L), _resp(m.P) * _resp(m.C), rtol=1e-9)
    assert np.allclose(_resp(m.S) + _resp(m.T), 1.0, atol=1e-9)


def test_delayed_plant_margins_match_python_control_on_the_exact_response():
    plant = stage_x(mass_kg=35.0) * Delay(0.0008) * CurrentLoop(700.0)
    m = loop_models(plant, PI(178.5, 1.915e4))
    w = np.geomspace(2 * np.pi * 1e-3, 2 * np.pi * 5e3, 5000)    # 20,000: the same margins within 1e-9
    exact = control.frd(plant.frd(w) * (178.5 + 1.915e4 / (1j * w)), w)
    gm, pm, *_ = control.stability_margins(exact)
    margins = m.margins()
    gm_db, pm_deg = margins
    assert (margins.gain_margin_db, margins.phase_margin_deg) == (gm_db, pm_deg)
    assert pm_deg == pytest.approx(pm, abs=0.05)
    assert gm_db == pytest.approx(20 * np.log10(gm), abs=0.05)
    # the Pade factor follows the delay closely in the loop's band, and the realisation stays well scaled
    assert np.allclose(_resp(m.P), plant.frd(W), rtol=1e-6)
    assert np.max(np.abs(m.L.A)) < 1e8


def test_mat_file_rebuilds_the_same_models(tmp_path):
    from design.views.mat import write_design_mat
    from design.workflows import design, load_problem

    outcome = design(load_problem("specs/stage_x_synth.toml"))
    write_design_mat(outcome, tmp_path / "design.mat")
    d = loadmat(tmp_path / "design.mat")
    m = outcome.loop_models()
    assert d["kp_a_per_m_per_s"].item() == outcome.controller.kp and d["ki_a_per_m"].item() == outcome.controller.ki
    for name in ("P", "L", "T"):
        rebuilt = control.ss(*(d[f"{name}_{part}"] for part in "ABCD"))
        assert np.allclose(_resp(rebuilt), _resp(getattr(m, name)), rtol=1e-12)
    assert d["phase_margin_deg"].item() == pytest.approx(m.margins()[1])


def test_figures_leave_the_session_backend_alone(tmp_path):
    # a notebook's figures are pyplot's business: these are made without it, so no pyplot figure is opened and
    # the backend an interactive session chose stays (python-control itself imports pyplot, which is fine)
    import subprocess
    import sys

    code = ("import sys, matplotlib\n"
            "matplotlib.use('svg')\n"
            "from design.loop.control_models import loop_models\n"
            "from design.loop.controller import PI\n"
            "from plant import stage_x\n"
            "from plant.experiment.simulate import simulate_stepped_sine\n"
            "from plant.estimate.response import estimate\n"
            "p = stage_x(mass_kg=20.0)\n"
            "loop_models(p, PI(236.0, 47.0)).plot().savefig(sys.argv[1] + '/l.png')\n"
            "rec = simulate_stepped_sine(p, f_hz=[2.0, 10.0, 50.0], current_amplitude_a=0.5, duration_s=1.5,\n"
            "                            noise_fraction=0.01)\n"
            "fig = estimate(rec).plot(); fig.savefig(sys.argv[1] + '/r.png')\n"
            "assert len(fig.axes) == 2 and len(fig.axes[0].lines) == 1\n"
            "assert matplotlib.get_backend() == 'svg', matplotlib.get_backend()\n"
            "plt = sys.modules.get('matplotlib.pyplot')\n"
            "assert plt is None or plt.get_fignums() == [], plt.get_fignums()\n")
    out = subprocess.run([sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert (tmp_path / "l.png").stat().st_size > 0 and (tmp_path / "r.png").stat().st_size > 0


def test_a_measured_response_is_drawn_with_its_band_around_it():
    """The 2-sigma band of each magnitude point lies around that point (|G| -+ 2 sigma), not around 0 dB."""
    from plant import stage_x
    from plant.estimate.response import estimate
    from plant.experiment.simulate import simulate_stepped_sine

    rec = simulate_stepped_sine(stage_x(mass_kg=20.0), f_hz=[2.0, 10.0, 50.0], current_amplitude_a=0.5,
                                duration_s=1.5, noise_fraction=0.2, seed=1)
    measured = estimate(rec)
    mag = measured.plot().axes[0]
    line_db = mag.lines[0].get_ydata()
    band = mag.collections[0].get_paths()[0].vertices[:, 1]
    a = np.abs(measured.response[0])
    two_sigma = 2 * np.sqrt(measured.variance[0])
    assert band.min() == pytest.approx(np.min(20 * np.log10(np.maximum(a - two_sigma, a * 1e-3))), abs=1e-9)
    assert band.max() == pytest.approx(np.max(20 * np.log10(a + two_sigma)), abs=1e-9)
    assert band.min() < np.min(line_db) and band.max() > np.max(line_db)
