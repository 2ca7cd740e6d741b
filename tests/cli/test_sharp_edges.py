"""The command line's edges: outputs only to regular files or standard output, temporary files a killed
writer left, a PDF that fails, gain bounds and nesting held at spec load, a closed pipe, and a P-only loop
that is not credited for the reference it never reaches."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from design.loop.analysis import analyse_loop
from design.loop.controller import PI
from design.loop.fast import fast_analyse_loop
from design.spec.schema import parse_spec
from design.synth.evaluation import evaluate
from plant import stage_x
from plant.host.files import atomic_write_text
from tests.reference.in_process import gantry as run

ROOT = Path(__file__).resolve().parents[2]
THESIS_X = ROOT / "specs" / "thesis_stage_x.toml"
SPEC_X = ROOT / "specs" / "stage_x_synth.toml"


def gantry(*args, env=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "design", *map(str, args)], capture_output=True, text=True,
                          timeout=600, env=env)


def one_line(out: subprocess.CompletedProcess, *words: str) -> None:
    assert out.returncode == 2, out.stderr
    assert out.stderr.count("\n") == 1 and out.stderr.startswith("gantry: error: "), out.stderr
    for w in words:
        assert w in out.stderr, out.stderr


def test_an_output_that_is_a_pipe_is_refused_and_left_as_it_is(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    out = gantry("sweep", THESIS_X, "--samples", "20", "--payload", "5:40:3", "--csv", fifo)
    one_line(out, str(fifo), "not a regular file")
    assert fifo.is_fifo()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pipe"]


def test_dash_writes_the_output_to_standard_output_and_only_one_output_goes_there(tmp_path):
    out = gantry("sweep", THESIS_X, "--samples", "20", "--payload", "5:40:3", "--csv", "-")
    assert out.returncode == 0, out.stderr
    header = out.stdout.splitlines()[0]
    assert header.startswith("payload_kg,")
    assert len(out.stdout.splitlines()) == 4 and "Monte Carlo sweep" in out.stderr     # the table on stderr
    one_line(gantry("sweep", THESIS_X, "--samples", "20", "--csv", "-", "--json"), "--csv and --json")
    one_line(gantry("report", THESIS_X, "--no-synth", "--out", "-", "--pdf"), "--pdf")


def test_a_temporary_file_a_killed_writer_left_is_removed_by_the_next_write(tmp_path):
    target = tmp_path / "out.csv"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".out.csv.{dead.pid}.abc123.tmp"
    alive = tmp_path / f".out.csv.{os.getppid()}.def456.tmp"        # a writer still running: kept
    other = tmp_path / f".other.csv.{dead.pid}.abc123.tmp"           # another file's: kept
    for p in (stale, alive, other):
        p.write_text("partial")
    atomic_write_text(target, "a,b\n")
    assert target.read_text() == "a,b\n"
    assert not stale.exists() and alive.exists() and other.exists()


def test_a_pdf_that_fails_leaves_no_html_behind(tmp_path):
    env = {**os.environ, "PATH": str(Path(sys.executable).parent)}     # no chromium on the path
    html = tmp_path / "r.html"
    out = gantry("report", THESIS_X, "--no-synth", "--out", html, "--pdf", env=env)
    one_line(out, "Chromium")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(("value", "bound"), [("1e308", "<= 1e+09"), ("1e-300", ">= 1e-09")])
def test_gain_bounds_out_of_range_are_refused_at_spec_load(tmp_path, value, bound):
    spec = tmp_path / "s.toml"
    spec.write_text(SPEC_X.read_text().replace("kp = { value = 236.0, min = 0.0, max = 10000.0 }",
                                               f"kp = {{ min = 0.0, max = {value} }}"))
    one_line(gantry("synth", spec, "--json"), "controller.kp.max", bound)


def test_nesting_thousands_deep_is_one_line(tmp_path):
    tables = tmp_path / "tables.toml"
    tables.write_text("[" + ".".join(["a"] * 10000) + "]\nx = 1\n")
    inline = tmp_path / "inline.toml"
    inline.write_text("x = " + "{a = " * 10000 + "1" + "}" * 10000 + "\n")
    arrays = tmp_path / "arrays.toml"
    arrays.write_text("x = " + "[" * 10000 + "]" * 10000 + "\n")
    one_line(gantry("synth", tables), "nested more than 16 levels")
    one_line(gantry("synth", inline), "nested thousands deep")
    one_line(gantry("synth", arrays), "nested thousands deep")


def test_an_empty_spec_and_a_missing_key_are_named(tmp_path):
    empty = tmp_path / "empty.toml"
    empty.write_text("")
    one_line(gantry("synth", empty), "empty.toml: the spec is empty", "[plant]")
    bare = tmp_path / "bare.toml"
    bare.write_text("[plant]\nforce_constant_n_per_a = 20.0\n")
    one_line(gantry("synth", bare), "plant.stage: required")


def test_a_closed_pipe_ends_quietly_as_sigpipe_would():
    p = subprocess.Popen([sys.executable, "-m", "design", "reproduce"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE)
    p.stdout.read(10)
    p.stdout.close()
    _, err = p.communicate(timeout=120)
    assert p.returncode == 141 and err == b"", err


def thesis_problem(**controller):
    data = tomllib.loads(THESIS_X.read_text())
    data["controller"].update(controller)
    return parse_spec(data).problem()


def test_a_p_only_loop_is_measured_against_the_reference_it_does_not_reach():
    # first-order plant Kt/(m s + b) under P control: T = k/(m s + b + k), k = Kp Kt; |T(jw)|^2 = 1/2 at
    # w = sqrt(2 k^2 - (b + k)^2) / m, and never when T(0) = k/(b + k) < 1/sqrt 2 (closed forms)
    plant = stage_x(mass_kg=10.0)
    kt, b, m = plant.force_constant_n_per_a, plant.damping_n_s_per_m, plant.mass_kg
    for kp in (20.0, 236.0, 1500.0):       # T(0) = 0.48, 0.91, 0.99
        k = kp * kt
        w = math.sqrt(2 * k * k - (b + k) ** 2) / m if 2 * k * k > (b + k) ** 2 else math.nan
        assert math.isnan(w) == (kp == 20.0)
        for bw in (analyse_loop(plant, PI(kp, 0.0)).closed_loop_bandwidth_hz,
                   fast_analyse_loop(plant, PI(kp, 0.0)).closed_loop_bandwidth_hz):
            if math.isnan(w):
                assert np.isnan(bw)
            else:
                assert float(bw) == pytest.approx(w / (2 * np.pi), rel=1e-4)


def test_a_pi_design_requires_integral_action_unless_the_spec_admits_p_only():
    required = thesis_problem()
    ev = evaluate(required, PI(1500.0, 0.0))
    assert not ev.meets and ev.binding.constraint == "integral_action"
    optional = thesis_problem(integral="optional")
    assert evaluate(optional, PI(1500.0, 0.0)).binding.constraint != "integral_action"
    assert evaluate(required, PI(1500.0, 47.0)).binding.constraint != "integral_action"


def test_a_stepped_sine_without_its_frequency_column_or_with_one_block_is_named_with_the_file(tmp_path):
    rec = tmp_path / "rec.csv"
    out = gantry("simulate", "--stage", "x", "--f-hz", "2:50:3", "--duration-s", "1", "--out", rec)
    assert out.returncode == 0, out.stderr
    lines = rec.read_text().splitlines()
    no_frequency = tmp_path / "no_frequency.csv"
    no_frequency.write_text("\n".join(line.split(",", 1)[1] for line in lines) + "\n")
    one_line(gantry("diagnose", no_frequency, "--stage", "x"), "no_frequency.csv", "time must increase",
             "frequency_hz column")
    one_block = tmp_path / "one_block.csv"
    first = lines[1].split(",", 1)[0]
    one_block.write_text("\n".join([lines[0]] + [line for line in lines[1:] if line.split(",", 1)[0] == first]) + "\n")
    one_line(gantry("fit", one_block, "--stage", "x"), "one_block.csv", "1 frequency", "record more frequencies")


def test_the_bundled_specs_travel_with_the_package_and_reproduce_runs_anywhere(tmp_path):
    package_specs = Path(__import__("design").__file__).parent / "specs"
    names = sorted(p.name for p in (ROOT / "specs").glob("*.toml"))
    assert sorted(p.name for p in package_specs.glob("*.toml")) == names
    out = subprocess.run([sys.executable, "-m", "design", "reproduce", "--json"], capture_output=True, text=True,
                         timeout=600, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert '"table_3_1"' in out.stdout


def test_friction_at_its_default_is_simulated_with_the_default_drive_and_diagnosed(tmp_path):
    """An effect at its defaults works with the command's defaults: the default Coulomb friction (3 N) is below
    the default drive force (0.5 A x 20 N/A = 10 N), so the stage slides, and the diagnosis names it."""
    out = run("simulate", "--stage", "x", "--effects", "coulomb_friction", "--out", str(tmp_path / "rec.csv"))
    assert out.returncode == 0, out.stderr
    diag = run("diagnose", str(tmp_path / "rec.csv"), "--stage", "x", "--json")
    assert diag.returncode == 0, diag.stderr
    found = json.loads(diag.stdout)
    assert found["verdict"] == "explained" and found["added_effects"] == ["coulomb_friction"]
    assert abs(found["parameters"]["coulomb_friction.force_n"]["value"] - 3.0) < 0.3


@pytest.mark.parametrize("command,name", [("synth", "stage_x_synth.toml"), ("planar-synth", "planar.toml")])
def test_a_bundled_specs_name_outside_the_checkout_is_answered_with_where_it_is(tmp_path, command, name):
    out = run(command, name, cwd=tmp_path)
    assert out.returncode == 2 and out.stdout == ""
    line = out.stderr.strip()
    assert "\n" not in line and line.startswith(f"gantry: error: {name}: cannot read spec file")
    where = Path(line.rsplit("bundled with the tool: ", 1)[1])
    assert where.name == name and where.is_file()
    assert run(command, "no_such_spec.toml", cwd=tmp_path).stderr.count("bundled") == 0
