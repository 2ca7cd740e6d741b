"""`gantry simulate` -> `gantry fit` end to end."""

import json
import subprocess
import sys


def gantry(*args):
    return subprocess.run([sys.executable, "-m", "design", *map(str, args)], capture_output=True, text=True)


def test_delay_and_mass_come_back_within_their_uncertainty(tmp_path):
    rec = tmp_path / "rec.csv"
    out = gantry("simulate", "--stage", "x", "--set", "mass_kg=40", "--effects", "delay.seconds=0.001",
                 "--f-hz", "1:75:25", "--seed", "3", "--out", rec)
    assert out.returncode == 0, out.stderr
    out = gantry("fit", rec, "--stage", "x", "--effects", "delay", "--json")
    assert out.returncode == 0, out.stderr
    res = json.loads(out.stdout)
    truth = {"mass_kg": 40.0, "delay.seconds": 0.001}    # what the simulation was told
    for name, true in truth.items():
        p = res["parameters"][name]
        assert abs(p["value"] - true) <= 2 * p["stderr"], (name, p)
    assert 0.5 < res["reduced_chi2"] < 2.0
    assert set(res) >= {"parameters", "reduced_chi2", "aic", "bic", "flags"}


def test_fit_names_a_bad_parameter(tmp_path):
    rec = tmp_path / "rec.csv"
    assert gantry("simulate", "--stage", "x", "--f-hz", "2:40:6", "--duration-s", "2", "--out", rec).returncode == 0
    out = gantry("fit", rec, "--stage", "x", "--free", "mass_kg,delay.seconds")
    assert out.returncode == 2
    assert "delay.seconds" in out.stderr and out.stderr.count("\n") == 1
