"""Time-domain recordings, the inverse-model and output-error fits and the time-domain diagnosis.

References: the EMPS benchmark's published IDIM-LS values (Janot, Gautier & Brunot 2019:
M = 95.1089 kg, Fv = 203.5034 N*s/m, Fc = 20.3935 N, offset = -3.1648 N) and the true parameters
of ``independent_friction_sim``, a closed-loop axis simulated without the tool's code.
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.io
from in_process import gantry as _gantry
from independent_friction_sim import Axis, simulate

from plant.data.read import parse_column_map, read_measurement
from plant.data.read_stepped_sine import read_recording
from plant.data.read_time_domain import read_time_recording
from plant.data.recordings import TimeRecording
from plant.diagnose.time_diagnosis import diagnose_time
from plant.errors import DataError, EffectError, ParameterError
from plant.identify.inverse_model import Preprocessing
from plant.identify.time_fit import fit_inverse_model, fit_output_error
from plant.physics.effects import make_effect
from plant.physics.models import Plant

TESTS = Path(__file__).resolve().parents[2]

EMPS = Path(__file__).resolve().parents[3] / "examples" / "data" / "emps" / "DATA_EMPS.mat"
EMPS_COLUMNS = "time=t,current=vir,position=qm,reference=qg"
PUBLISHED = {"mass_kg": 95.1089, "damping_n_s_per_m": 203.5034, "coulomb_friction.force_n": 20.3935,
             "offset.force_n": -3.1648}
#: the simulator's drive holds each command for one sample: the fits are told so
HOLD = Preprocessing(input_hold=True)




def _recording(axis: Axis, seed: int) -> TimeRecording:
    log = simulate(axis, seed=seed)
    return TimeRecording(log.time_s, log.command_v, log.position_m[None], "position", ("position_m",),
                         reference=log.reference_m)


def _plant(axis: Axis, *names: str) -> Plant:
    return Plant("x", force_constant_n_per_a=axis.gain_n_per_v, effects=tuple(make_effect(n) for n in names),
                 excitation_current_a=1.0)


def test_simulator_is_independent_of_the_tool():
    source = (TESTS / "reference" / "independent_friction_sim.py").read_text()
    imported = {a.name.split(".")[0] for node in ast.walk(ast.parse(source)) if isinstance(node, ast.Import)
                for a in node.names}
    imported |= {node.module.split(".")[0] for node in ast.walk(ast.parse(source))
                 if isinstance(node, ast.ImportFrom) and node.module}
    assert not imported & {"plant", "design"}


# --- EMPS: real measurements ---------------------------------------------------------------
def test_emps_fit_matches_the_published_idim_ls():
    out = _gantry("fit", str(EMPS), "--stage", "x", "--columns", "time=t,current=vir,position=qm",
                  "--set", "force_constant_n_per_a=35.15", "--effects", "coulomb_friction,offset", "--json")
    assert out.returncode == 0, out.stderr
    params = json.loads(out.stdout)["parameters"]
    for name, published in PUBLISHED.items():
        value = params[name]["value"]
        tol = 0.3 if name == "offset.force_n" else 0.02 * abs(published)
        assert abs(value - published) <= tol, (name, value, published)
        assert 0 < params[name]["stderr"] < 0.1 * abs(published)


def test_emps_diagnosis_adds_friction_and_offset_and_says_what_is_left():
    out = _gantry("diagnose", str(EMPS), "--stage", "x", "--columns", "time=t,current=vir,position=qm",
                  "--set", "force_constant_n_per_a=35.15", "--json")
    assert out.returncode == 0, out.stderr
    d = json.loads(out.stdout)
    assert set(d["final_effects"]) == {"coulomb_friction", "offset"}
    rms = [s["rms_residual_n"] for s in d["steps"]]
    assert rms == sorted(rms, reverse=True) and rms[-1] < 0.3 * rms[0]
    if d["verdict"] != "explained":
        assert d["explanation"].startswith("not explained") and "N rms" in d["explanation"]


def test_emps_output_error_agrees_with_the_inverse_model():
    rec = read_measurement(EMPS, columns=parse_column_map(EMPS_COLUMNS))
    plant = _plant(Axis(gain_n_per_v=35.15), "coulomb_friction", "offset")
    idim = fit_inverse_model(plant, rec)
    oe = fit_output_error(plant, rec, start=idim)
    assert oe.n_starts >= 3
    for name in ("mass_kg", "damping_n_s_per_m", "coulomb_friction.force_n"):
        assert oe.values[name] == pytest.approx(idim.values[name], rel=0.1)


# --- simulated axes with known truth -------------------------------------------------------
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_inverse_model_recovers_the_simulated_axis(seed):
    axis = Axis()
    fit = fit_inverse_model(_plant(axis, "coulomb_friction", "offset"), _recording(axis, seed), prep=HOLD)
    assert fit.values["mass_kg"] == pytest.approx(axis.mass_kg, rel=0.005)
    assert fit.values["damping_n_s_per_m"] == pytest.approx(axis.viscous_n_s_per_m, rel=0.01)
    assert fit.values["coulomb_friction.force_n"] == pytest.approx(axis.coulomb_n, rel=0.01)
    assert fit.values["offset.force_n"] == pytest.approx(axis.offset_n, abs=0.1)
    assert fit.explained


def test_ignoring_the_hold_biases_mass_by_about_half_a_sample_of_damping():
    """First order: F(t_k) held over [t_k, t_k+1) acts half a sample late, F = M a(t + h/2) + b v(t + h/2)
    = M a + b v + (b h / 2) a + ..., so the mass grows by b h / 2; the friction's sign change half a sample
    late and the jerk term add to it with the same sign, hence the factor-of-two band."""
    axis = Axis()
    rec = _recording(axis, 0)
    plant = _plant(axis, "coulomb_friction", "offset")
    shift = fit_inverse_model(plant, rec).values["mass_kg"] - fit_inverse_model(plant, rec, prep=HOLD).values["mass_kg"]
    first_order = axis.viscous_n_s_per_m * 0.5e-3
    assert first_order <= shift <= 2 * first_order


@pytest.mark.parametrize("shape", [(61,), (3001,), (4, 25000)])
@pytest.mark.parametrize("r", [1, 2, 7, 25])
def test_decimation_is_scipys_for_one_signal_or_several(shape, r):
    import scipy.signal

    from plant.identify.inverse_model import _decimate

    x = np.cumsum(np.random.default_rng(r).standard_normal(shape), axis=-1)
    ref = scipy.signal.decimate(x, r, ftype="iir", zero_phase=True) if r > 1 else x
    assert _decimate(x, r).shape == ref.shape
    assert np.allclose(_decimate(x, r), ref, rtol=0, atol=1e-12 * np.max(np.abs(x)))


def test_effect_columns_are_scipys_decimation_of_the_ripple_and_stay_within_their_budget(monkeypatch):
    # a ripple of pitch p: sin / cos of 2 pi x / p and of twice that at the full rate, decimated as
    # scipy.signal.decimate(ftype="iir", zero_phase=True) does (the reference script's MATLAB decimate)
    import scipy.signal

    from plant.identify import inverse_model
    from plant.identify.inverse_model import inverse_model_data

    data = inverse_model_data(_recording(Axis(), 0), Axis().gain_n_per_v, HOLD)
    ripple = make_effect("force_ripple")
    cols = data.effect_columns(ripple)
    phase = 2 * np.pi * data.full_rate_position_m / ripple.pitch_m
    for name, signal in {"sin1_n": np.sin(phase), "cos1_n": np.cos(phase), "sin2_n": np.sin(2 * phase),
                         "cos2_n": np.cos(2 * phase)}.items():
        ref = scipy.signal.decimate(signal, data.decimation, ftype="iir", zero_phase=True)
        assert np.allclose(cols[name], ref, rtol=0, atol=1e-12), name
        assert not cols[name].flags.writeable
        # no view that keeps the full-rate filtered rows alive: the memo's byte count is what it holds
        assert cols[name].base is None or cols[name].base.size <= 4 * ref.size
    assert data.effect_columns(ripple) is cols                      # kept
    one = sum(c.nbytes for c in cols.values())
    memo = inverse_model._ColumnMemo(2 * one)
    for k in range(3):
        memo.put(k, {n: c.copy() for n, c in cols.items()})
    assert memo.get(0) is None and memo.get(1) is not None and memo.get(2) is not None and memo.used == 2 * one


def test_output_error_recovers_the_simulated_axis():
    axis = Axis()
    rec = _recording(axis, 3)
    oe = fit_output_error(_plant(axis, "coulomb_friction", "offset"), rec, prep=HOLD)
    assert oe.values["mass_kg"] == pytest.approx(axis.mass_kg, rel=0.02)
    assert oe.values["damping_n_s_per_m"] == pytest.approx(axis.viscous_n_s_per_m, rel=0.03)
    assert oe.values["coulomb_friction.force_n"] == pytest.approx(axis.coulomb_n, rel=0.05)
    assert oe.values["offset.force_n"] == pytest.approx(axis.offset_n, abs=0.3)


@pytest.mark.parametrize(("axis", "expected"), [
    (Axis(coulomb_n=0.0, offset_n=0.0), ()),
    (Axis(coulomb_n=0.0), ("offset",)),
    (Axis(offset_n=0.0), ("coulomb_friction",)),
    (Axis(), ("coulomb_friction", "offset")),
])
@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.slow)])
def test_diagnosis_finds_exactly_the_simulated_force_effects(axis, expected, seed):
    diag = diagnose_time(Plant("x", force_constant_n_per_a=axis.gain_n_per_v), _recording(axis, seed), prep=HOLD)
    assert set(diag.selected) == set(expected)
    assert diag.verdict == "explained", diag.explanation
    assert [s.fit.rms_residual for s in diag.steps] == sorted((s.fit.rms_residual for s in diag.steps), reverse=True)


@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.slow)])
def test_diagnosis_finds_a_force_periodic_in_position_beside_friction_and_offset(seed):
    """The simulator's F_p(x) = 4 N sin(2 pi x / 20 mm) is the force the drive must supply: ``force_ripple``'s
    convention, so its sine coefficient is +4 N."""
    axis = Axis(ripple_n=4.0)
    diag = diagnose_time(Plant("x", force_constant_n_per_a=axis.gain_n_per_v), _recording(axis, seed), prep=HOLD)
    assert set(diag.selected) == {"coulomb_friction", "offset", "force_ripple"}
    assert diag.verdict == "explained", diag.explanation
    ripple = diag.final.plant.effect("force_ripple")
    assert ripple.pitch_m == pytest.approx(axis.ripple_period_m, rel=2e-3)
    assert ripple.sin1_n == pytest.approx(axis.ripple_n, abs=0.1)
    assert abs(ripple.cos1_n) < 0.1


def test_base_model_failure_is_described_by_direction_and_regime():
    axis = Axis(offset_n=0.0)
    diag = diagnose_time(Plant("x", force_constant_n_per_a=axis.gain_n_per_v), _recording(axis, 0), prep=HOLD)
    assert "coulomb_friction" in diag.direction.description
    assert diag.direction.forward_n * diag.direction.backward_n < 0
    assert diag.steps[0].fit.regimes and not diag.steps[0].fit.explained


def test_effects_without_a_force_model_are_refused_in_the_time_domain():
    axis = Axis()
    with pytest.raises(EffectError, match="delay has no time-domain force model"):
        fit_inverse_model(_plant(axis, "delay"), _recording(axis, 0))
    with pytest.raises(ParameterError, match="force_constant_n_per_a scales every force"):
        fit_inverse_model(_plant(axis), _recording(axis, 0), free=("mass_kg", "force_constant_n_per_a"))


def test_offset_leaves_frequency_responses_unchanged():
    w = np.array([5.0, 50.0, 500.0])
    with_offset = Plant("x", effects=(make_effect("offset", force_n=-3.0),)).frd_outputs(w)
    np.testing.assert_array_equal(with_offset, Plant("x").frd_outputs(w))


# --- readers --------------------------------------------------------------------------------
def _write_mat(path: Path, **variables) -> Path:
    scipy.io.savemat(path, {k: np.asarray(v, dtype=float).reshape(-1, 1) if np.ndim(v) else v
                            for k, v in variables.items()})
    return path


def test_csv_time_recording_round_trip_keeps_reference_and_extra_columns(tmp_path):
    t = np.arange(200) / 1000.0
    i = np.sin(2 * np.pi * 5 * t)
    q = 1e-3 * (1 - np.cos(2 * np.pi * 5 * t))
    path = tmp_path / "run.csv"
    rows = "\n".join(f"{a:.6f},{b:.6f},{c:.9f},{c:.9f},{b * 2:.6f}" for a, b, c in zip(t, i, q))
    path.write_text("time_s,current_a,position_m,reference_m,voltage_v\n" + rows + "\n")
    rec = read_measurement(path)
    assert isinstance(rec, TimeRecording)
    assert rec.output_kind == "position" and rec.output_names == ("position_m",)
    assert rec.reference is not None and "voltage_v" in rec.extra
    assert rec.sample_rate_hz == pytest.approx(1000.0)


def test_mat_reader_keeps_scalars_and_reads_the_bundled_emps():
    rec = read_measurement(EMPS, columns=parse_column_map(EMPS_COLUMNS))
    assert rec.n_samples == 24841 and rec.output_kind == "position"
    assert rec.metadata["mat_scalars"]["gtau"] == pytest.approx(35.15, abs=0.01)


@pytest.mark.parametrize(("variables", "columns", "message"), [
    ({"t": np.arange(100) / 1e3, "u": np.sin(np.arange(100)), "q": np.cos(np.arange(100))},
     "time=t,current=vir,position=q", r"no variable 'vir' \(current\); variables: q, t, u"),
    ({"t": np.r_[np.arange(50), np.arange(49, 99)] / 1e3, "u": np.sin(np.arange(100)), "q": np.cos(np.arange(100))},
     "time=t,current=u,position=q", r"sample 51 of variable 't': time must increase"),
    ({"t": np.arange(100) / 1e3, "u": np.ones(100), "q": np.cos(np.arange(100))},
     "time=t,current=u,position=q", r"the input 'u' never moves"),
    ({"t": np.arange(100) / 1e3, "u": np.sin(np.arange(100)), "q": np.ones(100)},
     "time=t,current=u,position=q", r"the output 'q' never moves"),
    ({"t": np.r_[np.arange(50), np.arange(51, 101)] / 1e3, "u": np.sin(np.arange(100)), "q": np.cos(np.arange(100))},
     "time=t,current=u,position=q", r"sampling is not uniform"),
    ({"t": np.arange(100) / 1e3, "u": np.sin(np.arange(100)), "q": np.cos(np.arange(99))},
     "time=t,current=u,position=q", r"'q' \(position\) has 99 samples"),
])
def test_mat_reader_names_what_is_wrong(tmp_path, variables, columns, message):
    path = _write_mat(tmp_path / "bad.mat", **variables)
    with pytest.raises(DataError, match=message):
        read_time_recording(path, columns=parse_column_map(columns))


def test_bad_files_get_one_line_and_exit_2(tmp_path):
    garbage = tmp_path / "garbage.mat"
    garbage.write_bytes(b"\x00\x01not a mat file" * 10)
    out = _gantry("fit", str(garbage), "--stage", "x", "--columns", "time=t,current=u,position=q")
    assert out.returncode == 2 and out.stderr.count("\n") == 1 and "not a readable MATLAB .mat file" in out.stderr
    out = _gantry("fit", str(EMPS), "--stage", "x", "--columns", "time=t,current=vir,position=nope")
    assert out.returncode == 2 and "no variable 'nope'" in out.stderr
    out = _gantry("fit", str(EMPS), "--stage", "x", "--columns", EMPS_COLUMNS, "--set", "force_constant=3")
    assert out.returncode == 2 and "unknown parameter 'force_constant'" in out.stderr


def test_stepped_sine_reader_refuses_a_map_without_frequency(tmp_path):
    path = tmp_path / "x.csv"
    path.write_text("f,t,i,v\n1,0,0,0\n")
    with pytest.raises(DataError, match="a stepped-sine column map names the frequency column"):
        read_recording(path, columns=parse_column_map("time=t,current=i,velocity=v"))


def test_emps_example_runs_from_the_checkout(tmp_path):
    example = Path(__file__).resolve().parents[3] / "examples" / "emps.py"
    out = subprocess.run([sys.executable, str(example), "--report", str(tmp_path / "emps.html")], capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "mass_kg" in out.stdout and "Verdict:" in out.stdout
    assert (tmp_path / "emps.html").read_text().count("<svg") == 3


@pytest.mark.parametrize(("excess_n", "velocity_m_per_s", "seed"), [
    (12.0, 0.02, 0), pytest.param(8.0, 0.04, 1, marks=pytest.mark.slow)])
def test_diagnosis_finds_a_stribeck_rise_of_the_friction(excess_n, velocity_m_per_s, seed):
    """The simulator's friction F_c + F_s exp(-(v / v_s)^2) (sticking below F_c + F_s): stribeck_friction is
    added on top of Coulomb friction and the offset, with its excess and velocity."""
    axis = Axis(stribeck_n=excess_n, stribeck_velocity_m_per_s=velocity_m_per_s)
    diag = diagnose_time(Plant("x", force_constant_n_per_a=axis.gain_n_per_v), _recording(axis, seed), prep=HOLD)
    assert set(diag.selected) == {"coulomb_friction", "stribeck_friction", "offset"}
    assert diag.verdict == "explained", diag.explanation
    stribeck = diag.final.plant.effect("stribeck_friction")
    assert stribeck.excess_n == pytest.approx(excess_n, rel=0.1)
    assert stribeck.velocity_m_per_s == pytest.approx(velocity_m_per_s, rel=0.1)
    assert diag.final.values["coulomb_friction.force_n"] == pytest.approx(axis.coulomb_n, rel=0.05)


def test_a_stribeck_rise_below_the_moving_samples_is_not_claimed():
    """At v_s = 2 mm/s the rise lies within the samples at rest that every fit leaves out: nothing to see, and
    nothing is claimed."""
    axis = Axis(stribeck_n=6.0, stribeck_velocity_m_per_s=0.002)
    diag = diagnose_time(Plant("x", force_constant_n_per_a=axis.gain_n_per_v), _recording(axis, 2), prep=HOLD)
    assert "stribeck_friction" not in diag.selected
