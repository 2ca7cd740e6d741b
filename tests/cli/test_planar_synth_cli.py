"""``gantry planar-synth``: the bundled planar spec designed and verified end to end (slow), its worst point held
to the independent Newton-Euler model, and what it refuses in one line."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
from in_process import gantry

SPECS = Path(__file__).resolve().parents[2] / "specs"
PLANAR = SPECS / "planar.toml"


def _spec(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "planar.toml"
    path.write_text(text)
    return path


def _bundled(tmp_path: Path, **replace) -> str:
    text = PLANAR.read_text()
    for old, new in replace.items():
        text = text.replace(old, new)
    return text.replace('"stage_x_synth.toml"', f'"{SPECS / "stage_x_synth.toml"}"').replace(
        '"stage_y_dual.toml"', f'"{SPECS / "stage_y_dual.toml"}"')


@pytest.mark.parametrize("text, words", [
    ("name = 'no planar table'\n", "needs a [planar] table"),
    ("[planar]\nstage_x = 'stage_x_synth.toml'\nstage_y = 'stage_y_dual.toml'\n[rotation]\ninertia_kg_m2 = 0.05\n"
     "damping_n_m_s_per_rad = 0.05\ntorque_constant_n_m_per_a = 2.0\nspeed = 3\n", "rotation.speed"),
    ("[planar]\nstage_x = 'stage_x_synth.toml'\nstage_y = 'stage_y_dual.toml'\n[rotation]\ninertia_kg_m2 = -1\n"
     "damping_n_m_s_per_rad = 0.05\ntorque_constant_n_m_per_a = 2.0\n", "rotation.inertia_kg_m2"),
])
def test_bad_planar_specs_get_one_line_naming_the_key(tmp_path, text, words):
    r = gantry("planar-synth", _spec(tmp_path, text))
    assert r.returncode == 2 and words in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr


def test_a_stage_y_without_dual_drive_and_a_missing_file_are_refused(tmp_path):
    no_dual = _bundled(tmp_path).replace(str(SPECS / "stage_y_dual.toml"), str(SPECS / "stage_y_synth.toml"))
    r = gantry("planar-synth", _spec(tmp_path, no_dual))
    assert r.returncode == 2 and "[dual_drive]" in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    missing = _bundled(tmp_path).replace(str(SPECS / "stage_x_synth.toml"), str(tmp_path / "nowhere.toml"))
    r = gantry("planar-synth", _spec(tmp_path, missing))
    assert r.returncode == 2 and "nowhere.toml" in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr


@pytest.mark.slow
def test_the_bundled_planar_spec_is_designed_verified_and_its_worst_point_holds_on_newton_euler():
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "reference"))
    import numpy as np
    from independent_planar_loops import Gains, Machine, channel_loops, margins

    r = gantry("planar-synth", PLANAR, "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["status"] == "optimal" and d["verified"] and d["check"]["holds"]
    c = d["check"]
    assert c["design_plants"]["plants"] == 960 and c["between"]["plants"] > c["between"]["dense_plants"] > 3000
    assert c["monte_carlo"]["plants"] == 2000 and c["monte_carlo"]["failing"] == 0
    assert c["monte_carlo"]["rate_upper_bound"] == pytest.approx(1 - 0.05 ** (1 / 2000), rel=1e-9)
    assert c["design_plants"]["rate_upper_bound"] is None
    y = next(s for s in d["stage_y"]["structures"] if s["structure"] == d["stage_y"]["recommended"])
    rot = d["rotation"]
    # the rotation loop needs Stage Y's loops closed: the same gains with them open lose phase margin
    assert rot["with_stage_y_open"]["phase_margin_deg"] < c["design_plants"]["rotation"]["phase_margin_deg"]
    p = c["between"]["worst_point"]
    m = Machine(carriage_mass_kg=16.0 + p["payload_kg"], carriage_position_m=p["carriage_position_m"],
                damping1_n_s_per_m=p["damping1_n_s_per_m"], damping2_n_s_per_m=p["damping2_n_s_per_m"],
                y_delay_s=p["delay.seconds"], y_current_loop_hz=p["current_loop.bandwidth_hz"],
                rotation_inertia_kg_m2=p["rotation.inertia_kg_m2"], rotation_delay_s=p["rotation.delay.seconds"])
    g = Gains(**y["gains"], kp_rotation=rot["kp"], ki_rotation=rot["ki"])
    w = 2 * np.pi * np.logspace(-2, 3.5, 50000)
    (gm_c, pm_c), (gm_d, pm_d), (gm_r, pm_r) = (margins(loop) for loop in channel_loops(w, m, g))
    assert min(pm_c, pm_d) >= 45.0 - 0.01 and min(gm_c, gm_d) >= 6.0 - 0.01
    assert pm_r >= 45.0 - 0.01 and gm_r >= 6.0 - 0.01
