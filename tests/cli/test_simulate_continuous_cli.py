"""`gantry simulate --form continuous|chirp`: one run with the position, which `gantry diagnose` reads as a
time-domain recording; the forces that depend on the position are found in it."""

import json

import numpy as np
import pytest
from in_process import gantry

RIPPLE = ("--stage", "x", "--effects", "force_ripple.sin1_n=3,force_ripple.cos1_n=1", "--amplitude-a", "3",
          "--sample-rate-hz", "500")




def test_a_simulated_ripple_is_found_by_the_diagnosis(tmp_path):
    """The README's round trip."""
    rec = tmp_path / "ripple.csv"
    out = gantry("simulate", *RIPPLE, "--form", "continuous", "--f-hz", "0.25,0.5,1,2,4,8", "--duration-s", "4",
                 "--out", rec)
    assert out.returncode == 0, out.stderr
    assert "6 sines 0.25-8 Hz x 4 s in one run" in out.stdout and "note:" not in out.stdout
    header = rec.read_text().splitlines()[0]
    assert header == "time_s,current_a,position_m"
    side = json.loads(rec.with_suffix(".json").read_text())
    assert side["settings"]["parameters"]["force_ripple.sin1_n"] == 3.0
    out = gantry("diagnose", rec, "--stage", "x", "--json")
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout)
    assert result["verdict"] == "explained" and result["final_effects"] == ["force_ripple"]
    values = {name: p["value"] for name, p in result["parameters"].items()}
    assert values["force_ripple.sin1_n"] == pytest.approx(3.0, rel=0.01)
    assert values["force_ripple.cos1_n"] == pytest.approx(1.0, rel=0.03)
    assert values["force_ripple.pitch_m"] == pytest.approx(0.03, rel=0.001)
    assert result["final_noise_ratio"] < 1.0


def test_chirp_json_and_a_travel_too_short_for_the_ripple(tmp_path):
    rec = tmp_path / "chirp.csv"
    out = gantry("simulate", *RIPPLE, "--form", "chirp", "--f-hz", "20:40:2", "--duration-s", "1", "--out", rec,
                 "--json")
    assert out.returncode == 0, out.stderr
    summary = json.loads(out.stdout)
    assert summary["excitation"] == {"form": "logarithmic chirp", "f0_hz": 20.0, "f1_hz": 40.0, "amplitude_a": 3.0}
    assert summary["duration_s"] == 2.0
    data = np.loadtxt(rec, delimiter=",", skiprows=1)
    assert data.shape == (1000, 3)
    assert summary["travel_m"] == pytest.approx(np.ptp(data[:, 2]), abs=1e-5)
    assert summary["travel_m"] < 0.06 and summary["notes"][0].startswith("force_ripple: the carriage covered")


@pytest.mark.parametrize("args, message", [
    (("--velocity-noise-m-per-s", "0.001"), "--velocity-noise-m-per-s: --form continuous records positions"),
    (("--noise-fraction", "0.01", "--current-noise-a", "0.1"), "either --noise-fraction or --current-noise-a"),
    (("--f-hz", "1,300"), "fewer than 4 samples per period"),
    (("--form", "steps"), "--form must be one of blocks, continuous, chirp"),
    (("--stage", "y", "--effects", "tilt_coupling"), "tilt_coupling"),
])
def test_bad_continuous_settings_are_refused_in_one_line(tmp_path, args, message):
    base = ["--stage", "x", "--form", "continuous", "--f-hz", "1,2", "--duration-s", "1", "--sample-rate-hz", "500"]
    if "--stage" in args:
        base = base[2:]
    out = gantry("simulate", *base, *args, "--out", tmp_path / "rec.csv")
    assert out.returncode == 2
    assert message in out.stderr and out.stderr.count("\n") == 1
    assert not (tmp_path / "rec.csv").exists()
