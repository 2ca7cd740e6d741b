"""``gantry export``: each drive's numbers convert back to the design's Kp, Ki (by the vendor's formula written out
here, not only by the tool's own inverse), a worked example per vendor, and bad input as one line, exit 2."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from in_process import gantry

from design.views import drive_parameters as dp

ROOT = Path(__file__).resolve().parents[2]
GOLDEN = ROOT / "tests" / "golden"
STAGE_X = ROOT / "specs" / "stage_x_synth.toml"
EXAMPLE = ROOT / "examples" / "data" / "stage_x_design.json"
#: the bundled specs' force constant (plant.force_constant_n_per_a of stage_x_synth.toml)
K_F = 20.0


def _golden(name: str) -> dict:
    return json.loads((GOLDEN / name).read_text(encoding="utf-8"))["json"]


def _written(tmp_path_factory, golden: str, name: str) -> tuple[Path, dict]:
    """The golden file's design JSON written to a file of its own, and the design."""
    d = _golden(golden)
    path = tmp_path_factory.mktemp("export") / name
    path.write_text(json.dumps(d), encoding="utf-8")
    return path, d


@pytest.fixture(scope="module")
def pi_design(tmp_path_factory) -> tuple[Path, dict]:
    return _written(tmp_path_factory, "synth_x.json", "x.json")


@pytest.fixture(scope="module")
def admittance_design(tmp_path_factory) -> tuple[Path, dict]:
    return _written(tmp_path_factory, "synth_admittance.json", "xa.json")


def _exported(*args) -> dict:
    out = gantry("export", *map(str, args), "--json")
    assert out.returncode == 0, out.stderr
    return {p["name"]: p for p in json.loads(out.stdout)["parameters"]}


def _value(params: dict, start: str) -> float:
    return next(p["value"] for name, p in params.items() if name.startswith(start))


def test_the_readme_example_is_the_golden_design():
    """The README's example design is what gantry synth prints on stage_x_synth.toml (the golden file)."""
    assert json.loads(EXAMPLE.read_text(encoding="utf-8")) == _golden("synth_x.json")


def test_beckhoff_converts_back_to_the_gains(pi_design):
    path, d = pi_design
    p = _exported(path, "--drive", "beckhoff", "--spec", STAGE_X)
    kp_n, tn_ms = _value(p, "S-0-0100"), _value(p, "S-0-0101")
    # AX5000: S-0-0100 in N/(m/s) (P-0-0010 bit 15), S-0-0101 Tn in ms of Kp (1 + 1/(Tn s))
    kp, ki = kp_n / K_F, (kp_n / K_F) / (tn_ms / 1000.0)
    assert kp == pytest.approx(d["gains"]["kp"], rel=1e-9) and ki == pytest.approx(d["gains"]["ki"], rel=1e-9)
    # AX8000: 3140:01 in N/(m/s), 3140:02 Tn in s
    kp8, tn8 = _value(p, "AX8000 3140:01"), _value(p, "AX8000 3140:02")
    assert kp8 / K_F == pytest.approx(d["gains"]["kp"], rel=1e-9)
    assert kp8 / K_F / tn8 == pytest.approx(d["gains"]["ki"], rel=1e-9)
    assert dp.beckhoff_gains(kp_n, tn_ms, K_F) == pytest.approx((kp, ki), rel=1e-12)


def test_beckhoff_worked_example():
    """Kp 178.5 A/(m/s), Ki 19150 A/m, K_f 20 N/A: S-0-0100 = 178.5 x 20 = 3570.000 N/(m/s); Tn = 178.5 / 19150 s
    = 9.3211 ms, typed 9.3 (one decimal)."""
    out = dp.beckhoff(178.5, 19150.0, 20.0)
    assert out.parameter("S-0-0100").entry == "3570.000"
    assert out.parameter("S-0-0101").value == pytest.approx(9.321148825065274, rel=1e-12)
    assert out.parameter("S-0-0101").entry == "9.3"
    assert out.parameter("AX8000 3140:02").value == pytest.approx(0.009321148825065274, rel=1e-12)


def test_beckhoff_flags_an_integral_time_the_drive_cannot_hold():
    """The admittance co-design's Ki 18.5 A/m gives Tn 10.8 s, above S-0-0101's 6000.0 ms and 3140:02's 5 s."""
    out = dp.beckhoff(199.9, 18.54, 20.0)
    assert "maximum 6000.0 ms" in out.parameter("S-0-0101").note
    assert "maximum 5 s" in out.parameter("AX8000 3140:02").note
    assert "integral part off" in dp.beckhoff(100.0, 0.0, 20.0).parameter("S-0-0101").note


def test_copley_converts_back_to_the_gains(pi_design):
    path, d = pi_design
    r = 5e-7
    p = _exported(path, "--drive", "copley", "--encoder-resolution-m", r)
    kp_drive, ki_drive = p["Kp in drive units"]["value"], p["Ki in drive units"]["value"]
    # 0.01 A per 0.1 counts/s: I = 0.01 kp_drive (v / r) / 0.1, so kp = 0.01 kp_drive / (0.1 r)
    assert 0.01 * kp_drive / (0.1 * r) == pytest.approx(d["gains"]["kp"], rel=1e-9)
    assert 0.01 * ki_drive / (0.1 * r) == pytest.approx(d["gains"]["ki"], rel=1e-9)
    assert p["encoder resolution"]["value"] == pytest.approx(2e6, rel=1e-12)
    assert p["Vp, Vi"]["value"] is None
    assert dp.copley_gains(kp_drive, ki_drive, r) == pytest.approx((d["gains"]["kp"], d["gains"]["ki"]), rel=1e-12)


def test_copley_worked_example():
    """Kp 200 A/(m/s) on a 1 um encoder: 200 A/(m/s) = 2e-4 A per count/s = 0.02 (0.01 A) per count/s = 0.002
    (0.01 A) per (0.1 counts/s); Ki 20000 A/m likewise 0.2."""
    out = dp.copley(200.0, 20000.0, 1e-6)
    assert out.parameter("Kp in drive units").value == pytest.approx(0.002, rel=1e-12)
    assert out.parameter("Ki in drive units").value == pytest.approx(0.2, rel=1e-12)


def test_generic_converts_back_and_carries_the_discrete_numbers(pi_design):
    path, d = pi_design
    p = _exported(path, "--drive", "generic")
    kp, tn = p["Kp"]["value"], p["Tn = Kp/Ki"]["value"]
    assert kp == pytest.approx(d["gains"]["kp"], rel=1e-9) and kp / tn == pytest.approx(d["gains"]["ki"], rel=1e-9)
    discrete = {"loop_rate_hz": 4000.0, "kp": 178.5, "ki_per_sample": 4.7875,
                "filters": [{"kind": "notch", "b0": 0.9, "b1": -1.7, "b2": 0.85, "a1": -1.7, "a2": 0.75}]}
    out = dp.generic(178.5, 19150.0, discrete=discrete)
    assert out.parameter("ki per sample").value == 4.7875 and out.parameter("loop rate").value == 4000.0
    assert out.parameter("filter 1 (notch) a2").value == 0.75
    assert dp.generic(5.0, 0.0).parameter("Tn").value is None


def test_labview_converts_back_to_the_virtual_dynamics(admittance_design):
    path, d = admittance_design
    p = _exported(path, "--drive", "labview")
    alpha, beta, T = p["alpha"]["value"], p["beta"]["value"], p["dt (loop period)"]["value"]
    # forward Euler (the lab's VI): alpha = 1 - b_v T / m_v, beta = T / m_v
    m_v = T / beta
    b_v = (1.0 - alpha) * m_v / T
    a = d["admittance"]
    assert m_v == pytest.approx(a["m_v"], rel=1e-9) and b_v == pytest.approx(a["b_v"], rel=1e-9)
    assert p["m (virtual mass)"]["value"] == a["m_v"] and p["c (virtual damping)"]["value"] == a["b_v"]
    assert T == pytest.approx(1.0 / a["rig"]["update_rate_hz"], rel=1e-12)


def test_labview_worked_example():
    """m_v 0.04 kg, b_v 4 N*s/m at 100 Hz by forward Euler: alpha = 1 - 4 x 0.01 / 0.04 = 0, beta = 0.01 / 0.04
    = 0.25 m/s per N."""
    adm = {"m_v": 0.04, "b_v": 4.0, "rig": {"update_rate_hz": 100.0, "computation_delay_samples": 0,
                                            "discrete": {"alpha": 0.0, "beta_m_per_s_per_n": 0.25,
                                                         "beta_prev_m_per_s_per_n": 0.0,
                                                         "rule": dp.RULES["forward_euler"]}}}
    out = dp.labview(adm, "example")
    assert out.parameter("alpha").value == 0.0 and out.parameter("beta").value == 0.25
    assert "applied 0 sample(s) after F[k] is read" in out.notes[0]


@pytest.mark.parametrize("rule", ["forward_euler", "backward_euler", "tustin", "zoh"])
def test_every_rule_inverts(rule):
    from design.admittance.rig import law_coefficients

    alpha, beta, beta_prev = (float(c) for c in law_coefficients(0.05, 3.0, 0.01, rule))
    assert dp.labview_virtual(alpha, beta, beta_prev, 0.01, rule) == pytest.approx((0.05, 3.0), rel=1e-9)


def test_labview_refuses_coefficients_that_are_not_its_law():
    adm = {"m_v": 0.04, "b_v": 4.0, "rig": {"update_rate_hz": 100.0, "discrete": {
        "alpha": 0.5, "beta_m_per_s_per_n": 0.25, "rule": dp.RULES["forward_euler"]}}}
    with pytest.raises(dp.DataError, match="is not the law"):
        dp.labview(adm, "example")


def test_the_table_names_the_parameters(pi_design):
    out = gantry("export", pi_design[0], "--drive", "beckhoff", "--spec", STAGE_X)
    assert out.returncode == 0, out.stderr
    assert "S-0-0100 velocity loop Kp" in out.stdout and "3570.309" in out.stdout


def _one_line(out) -> bool:
    return (out.returncode == 2 and out.stderr.count("\n") == 1 and out.stderr.startswith("gantry: error:")
            and "Traceback" not in out.stderr)


def test_bad_input_is_one_line(tmp_path, pi_design):
    not_design = tmp_path / "fit.json"
    not_design.write_text(json.dumps({"parameters": {}}), encoding="utf-8")
    cases = {
        "missing file": (tmp_path / "none.json", "--drive", "generic"),
        "not a design": (not_design, "--drive", "generic"),
        "not JSON": (STAGE_X, "--drive", "generic"),
        "unknown drive": (pi_design[0], "--drive", "siemens"),
        "no admittance": (pi_design[0], "--drive", "labview"),
        "no encoder resolution": (pi_design[0], "--drive", "copley"),
        "no spec": (pi_design[0], "--drive", "beckhoff"),
        "bad resolution": (pi_design[0], "--drive", "copley", "--encoder-resolution-m", "-1"),
    }
    for what, args in cases.items():
        out = gantry("export", *map(str, args))
        assert _one_line(out), (what, out.returncode, out.stderr)
    assert "no admittance design" in gantry("export", pi_design[0], "--drive", "labview").stderr
    assert "--encoder-resolution-m" in gantry("export", pi_design[0], "--drive", "copley").stderr
    assert "drives are beckhoff, copley, generic, labview" in gantry("export", pi_design[0], "--drive", "x").stderr


def test_a_continuous_law_has_no_labview_coefficients(tmp_path, admittance_design):
    d = json.loads(json.dumps(admittance_design[1]))
    d["admittance"]["rig"] = {"update_rate_hz": None, "discrete": None}
    path = tmp_path / "continuous.json"
    path.write_text(json.dumps(d), encoding="utf-8")
    out = gantry("export", path, "--drive", "labview")
    assert _one_line(out) and "continuous" in out.stderr
    assert math.isfinite(d["admittance"]["m_v"])
