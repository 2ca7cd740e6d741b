"""``gantry planar-run``: both axes' designs read from their JSON, a recorded x-y path, what it prints, writes and
refuses (the physics is held to Newton's planar equations in tests/design/admittance/test_planar_run.py)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from in_process import gantry

SPECS = Path(__file__).resolve().parents[2] / "specs"
X_SPEC, Y_SPEC = SPECS / "stage_x_admittance.toml", SPECS / "stage_y_admittance.toml"


def _designs(tmp_path: Path, *, y_m_v: float = 0.06) -> tuple[Path, Path]:
    x = tmp_path / "x.json"
    x.write_text(json.dumps({"gains": {"kp": 199.9, "ki": 18.5, "m_v": 0.0419, "b_v": 5.02}}))
    y = tmp_path / "y.json"
    y.write_text(json.dumps({"admittance": {"structure": "common_differential", "m_v": y_m_v, "b_v": 6.0,
                                            "gains": {"kp_common": 219.8, "ki_common": 1.896e4,
                                                      "kp_differential": 191.2, "ki_differential": 1.0}}}))
    return x, y


def _walk(tmp_path: Path, heading_deg: float) -> Path:
    t = np.linspace(0.0, 0.6, 61)
    s = 0.05 * (1 - np.cos(np.pi * t / 0.6)) / 2                  # 5 cm, a smooth start and stop
    u = np.array([np.cos(np.radians(heading_deg)), np.sin(np.radians(heading_deg))])
    path = tmp_path / "walk.csv"
    path.write_text("time_s,x_m,y_m\n" + "".join(f"{a},{b * u[0]},{b * u[1]}\n" for a, b in zip(t, s)))
    return path


def test_a_recorded_walk_along_x_pushes_nothing_sideways_and_a_diagonal_one_does(tmp_path):
    x, y = _designs(tmp_path)
    along = gantry("planar-run", X_SPEC, Y_SPEC, "--x-design", x, "--y-design", y, "--path", _walk(tmp_path, 0.0),
                   "--json", "--out", tmp_path / "run.csv")
    assert along.returncode in (0, 3), along.stderr
    d = json.loads(along.stdout)
    assert (along.returncode == 0) == d["mouse_keeps_up"]
    assert d["carriage_mass_kg"] == 40.0 and d["y"]["structure"] == "common_differential"
    assert d["peak_force_n"] > 0.1 and d["peak_lateral_force_n"] < 1e-6 and d["peak_yaw_urad"] < 1e-6
    rows = (tmp_path / "run.csv").read_text().splitlines()
    # a row per drive tick over the walk and its 1 s of rest before and after
    assert rows[0].startswith("time_s,intended_x_m,intended_y_m,x_m,y_m")
    assert len(rows) - 1 == round((0.6 + 2.0) * d["drive_rate_hz"])
    drawn = gantry("planar-run", X_SPEC, Y_SPEC, "--x-design", x, "--y-design", y, "--path", _walk(tmp_path, 45.0),
                   "--json", "--plot", tmp_path / "run.svg")
    diagonal = json.loads(drawn.stdout)
    figure = (tmp_path / "run.svg").read_text()
    assert figure.startswith("<svg") and "The path on the floor" in figure and "across the heading" in figure
    # Y's heavier law (and the beam it moves) lags X's: the felt force turns off the mouse's heading
    assert diagonal["peak_lateral_force_n"] > 0.02 and diagonal["peak_yaw_urad"] > 0.1


def test_bad_designs_and_paths_are_one_line_each(tmp_path):
    x, y = _designs(tmp_path)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"gains": {"kp": 1.0}}))
    heavy = tmp_path / "heavy.json"
    heavy.write_text(y.read_text().replace('"m_v": 0.06', '"m_v": 1e308'))
    cases = [
        (("--x-design", x, "--y-design", heavy), "Stage Y's design: m_v = 1e+308 kg lies outside the spec's "
                                                 "admittance.m_v bounds [0.005, 100]"),
        (("--x-design", x, "--y-design", bad), "bad.json: not the JSON of gantry synth --json on a two-motor Stage Y"),
        (("--x-design", bad, "--y-design", y), "bad.json: not the JSON of gantry synth --json with gains"),
        (("--x-design", x, "--y-design", y, "--carriage-m", "0.75"), "--path: the carriage would leave the beam"),
        (("--x-design", x, "--y-design", y, "--path", tmp_path / "none.csv"), "none.csv"),
    ]
    for args, words in cases:
        out = gantry("planar-run", X_SPEC, Y_SPEC, *args)
        assert out.returncode == 2 and out.stderr.count("\n") == 1 and words in out.stderr, out.stderr
    out = gantry("planar-run", X_SPEC, X_SPEC, "--x-design", x, "--y-design", y)
    assert out.returncode == 2 and "[dual_drive]" in out.stderr and out.stderr.count("\n") == 1, out.stderr
