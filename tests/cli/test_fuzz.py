"""Fuzzing the command line in-process: generated recordings, spreadsheets and specs, mutated bytes, output paths
and interrupts. Every case must end with exit status 0 or 2 (130/143 when interrupted), one line on stderr
for an error, no traceback, no hang, and outputs that are all there after a success and untouched otherwise
(``tests/reference/fuzz_inputs.py``). The fast part runs by default; ``-m slow`` runs the long one."""

from __future__ import annotations

import os
import tempfile
from functools import cache
from pathlib import Path

import pytest
from fuzz_inputs import (
    EFFECT_DEFAULTS,
    ROOT,
    Blob,
    Case,
    Interrupt,
    bases,
    call,
    count_calls,
    effect_parameters,
    explore,
    mutated_bytes,
    number,
    recording_files,
    run_case,
    spec_files,
    spreadsheets,
)
from hypothesis import strategies as st

PARTS = [pytest.param("fast", id="fast"), pytest.param("slow", marks=pytest.mark.slow, id="slow")]
OLD = b"an earlier output\n"

FIT = ["--stage", "x", "--effects", "delay", "--json"]
FIT_EXTRAS = [[], [], ["--rational", "1,0"], ["--frf", "auto"], ["--sample-rate-hz", "500"], ["--stage", "y"],
              ["--columns", "frequency=frequency_hz,current=current_a,velocity=velocity_m_per_s"]]
TIME_FIT = ["--stage", "x", "--set", "force_constant_n_per_a=35.15", "--effects", "coulomb_friction,offset", "--json"]
TIME_EXTRAS = [[], [], ["--frf", "auto"], ["--frf", "closed-loop"], ["--input-hold"], ["--frf", "lpm"],
               ["--columns", "time=time_s,current=current_a,position=position_m,reference=reference_m"]]
DIAGNOSE = ["--stage", "x", "--effects", "delay,current_loop", "--json"]
CHEAP_SPECS = sorted(p.name for p in (ROOT / "specs").glob("*.toml") if "admittance" not in p.name)


@st.composite
def recording_cases(draw) -> Case:
    """fit or diagnose a stepped sine or a time-domain CSV broken by ``recording_files``."""
    b = bases()
    stepped = draw(st.integers(0, 3)) > 0
    name, raw = draw(recording_files(b.recording if stepped else b.time_domain))
    files = {name: raw}
    if draw(st.integers(0, 3)) > 0:
        args = ["fit", name, *(FIT if stepped else TIME_FIT), *draw(st.sampled_from(FIT_EXTRAS if stepped
                                                                                   else TIME_EXTRAS))]
        return Case(args, files, json_out=True)
    args = ["diagnose", name, *(DIAGNOSE if stepped else TIME_FIT[:4] + ["--json"])]
    extra = draw(st.sampled_from(["", "report", "amplitude"]))
    if extra == "amplitude":
        return Case([*args, "--amplitude-files", name], files, json_out=True)
    if extra == "report":
        return Case([*args, "--report", "diagnosis.html"], files, outputs=("diagnosis.html",), json_out=True)
    return Case(args, files, json_out=True)


@pytest.mark.parametrize("part", PARTS)
def test_recordings(part):
    explore(part, (40, 150), recording_cases(), run_case)


@st.composite
def spreadsheet_cases(draw) -> Case:
    raw, columns = draw(spreadsheets(bases().rows))
    args = ["fit", "rec.xlsx", "--stage", "x", "--effects", "delay", "--columns", columns, "--json"]
    if "time=" not in columns:
        args += draw(st.sampled_from([["--sample-rate-hz", "500"], [], ["--sample-rate-hz", "0"]]))
    return Case(args, {"rec.xlsx": raw}, json_out=True)


@pytest.mark.parametrize("part", PARTS)
def test_spreadsheets(part):
    explore(part, (10, 40), spreadsheet_cases(), run_case)


@st.composite
def cheap_spec_cases(draw) -> Case:
    """A broken spec through sweep, reproduce and simulate."""
    _, raw = draw(spec_files(bases().specs, CHEAP_SPECS))
    files = {"spec.toml": raw, "rec.csv": bases().recording}
    command = draw(st.sampled_from(["sweep", "sweep", "sweep_mc", "reproduce", "simulate"]))
    if command == "sweep":
        return Case(["sweep", "spec.toml", "--payload", "5:40:3", "--csv", "sweep.csv", "--json"], files,
                    outputs=("sweep.csv",), json_out=True)
    if command == "sweep_mc":
        return Case(["sweep", "spec.toml", "--samples", "3", "--json"], files, json_out=True)
    if command == "reproduce":
        return Case(["reproduce", "--spec", "spec.toml", "--points", "2", "--json"], files, json_out=True)
    return Case(["simulate", "--spec", "spec.toml", "--f-hz", "5:50:3", "--duration-s", "0.2", "--sample-rate-hz",
                 "400", "--out", "sim.csv"], files, outputs=("sim.csv", "sim.json"))


@pytest.mark.parametrize("part", PARTS)
def test_specs(part):
    explore(part, (30, 100), cheap_spec_cases(), run_case)


@st.composite
def design_spec_cases(draw) -> Case:
    """A broken spec (or fit result) through synth and report."""
    b = bases()
    _, raw = draw(spec_files(b.specs))
    files = {"spec.toml": raw, "rec.csv": b.recording, "fit.json": b.fit_json}
    command = draw(st.sampled_from(["synth", "synth_from_fit", "report", "report_synth", "report_data"]))
    if command == "synth":
        return Case(["synth", "spec.toml", "--method", "ccp", "--report", "design.html"], files,
                    outputs=("design.html",), no_design_is_1=True, timeout=300)
    if command == "synth_from_fit":
        files["fit.json"] = draw(st.one_of(st.just(b.fit_json), mutated_bytes(b.fit_json)))
        return Case(["synth", "spec.toml", "--method", "ccp", "--plant-from", "fit.json", "--json"], files,
                    no_design_is_1=True, json_out=True, timeout=300)
    if command == "report_data":
        name, files[name] = draw(recording_files(b.recording))
        files["spec.toml"] = b.specs["thesis_stage_x.toml"]
        return Case(["report", "spec.toml", "--no-synth", "--samples", "0", "--data", name, "--out", "design.html"],
                    files, outputs=("design.html",), timeout=300)
    synth = ["--synth"] if command == "report_synth" else ["--no-synth"]
    return Case(["report", "spec.toml", *synth, "--samples", "0", "--out", "design.html"], files,
                outputs=("design.html",), timeout=300)


@pytest.mark.parametrize("part", PARTS)
def test_specs_through_synth_and_report(part):
    explore(part, (3, 30), design_spec_cases(), run_case, shrink=part == "fast")


#: the planar run's inputs besides the bundled specs: both axes' designs and a 0.1 s walk
PLANAR_X_DESIGN = b'{"gains": {"kp": 199.9, "ki": 18.5, "m_v": 0.0419, "b_v": 5.02}}'
PLANAR_Y_DESIGN = (b'{"admittance": {"structure": "common_differential", "m_v": 0.06, "b_v": 6.0, "gains": '
                   b'{"kp_common": 219.8, "ki_common": 18957.0, "kp_differential": 191.2, "ki_differential": 1.0}}}')
FORCE_RECORD = "examples/data/lab_mouse_track.csv"
PLANAR_WALK = b"time_s,x_m,y_m\n0,0,0\n0.05,0.002,0.001\n0.1,0.005,0.003\n"


@st.composite
def byte_cases(draw) -> Case:
    """Any input with bytes flipped, inserted, deleted or cut, or random bytes, through the command that reads it."""
    b = bases()
    kind = draw(st.sampled_from(["recording", "recording", "time_domain", "spec", "spec", "xlsx", "tdms", "mat",
                                 "fit_json", "planar", "random"]))
    if kind == "recording":
        return Case(["fit", "rec.csv", *FIT], {"rec.csv": draw(mutated_bytes(b.recording))}, json_out=True)
    if kind == "time_domain":
        return Case(["fit", "td.csv", *TIME_FIT], {"td.csv": draw(mutated_bytes(b.time_domain))}, json_out=True)
    if kind == "spec":
        raw = draw(mutated_bytes(b.specs[draw(st.sampled_from(CHEAP_SPECS))]))
        return Case(["sweep", "spec.toml", "--payload", "5:40:3", "--csv", "sweep.csv"], {"spec.toml": raw},
                    outputs=("sweep.csv",))
    if kind == "xlsx":
        raw, _ = draw(spreadsheets(b.rows))
        return Case(["fit", "rec.xlsx", "--stage", "x", "--columns", "frequency=2,current=3,time=4,velocity=6"],
                    {"rec.xlsx": draw(mutated_bytes(Blob(raw)))})
    if kind == "tdms":
        return Case(["fit", "rec.tdms", "--stage", "x", "--effects", "delay", "--columns",
                     "frequency=frequency,current=current,time=time,velocity=velocity", "--json"],
                    {"rec.tdms": draw(mutated_bytes(b.tdms))}, json_out=True)
    if kind == "mat":
        return Case(["fit", "emps.mat", "--stage", "x", "--columns", "time=t,current=vir,position=qm", "--set",
                     "force_constant_n_per_a=35.15", "--effects", "coulomb_friction,offset"],
                    {"emps.mat": draw(mutated_bytes(b.mat))})
    if kind == "fit_json":
        return Case(["report", "spec.toml", "--no-synth", "--samples", "0", "--plant-from", "fit.json", "--out",
                     "design.html"], {"spec.toml": b.specs["thesis_stage_x.toml"],
                                      "fit.json": draw(mutated_bytes(b.fit_json))}, outputs=("design.html",))
    if kind == "planar":
        # both axes' specs and designs and a short walk, one of them mutated, through the planar mouse run
        # (the specs in a folder beside examples/, where Stage X's spec finds its force record)
        files = {"s/x.toml": b.specs["stage_x_admittance.toml"], "s/y.toml": b.specs["stage_y_admittance.toml"],
                 "x.json": Blob(PLANAR_X_DESIGN), "y.json": Blob(PLANAR_Y_DESIGN), "walk.csv": Blob(PLANAR_WALK)}
        which = draw(st.sampled_from(sorted(files)))
        files[which] = Blob(draw(mutated_bytes(files[which])))
        files[FORCE_RECORD] = Blob((ROOT / FORCE_RECORD).read_bytes())
        return Case(["planar-run", "s/x.toml", "s/y.toml", "--x-design", "x.json", "--y-design", "y.json", "--path",
                     "walk.csv", "--json"], files, json_out=True)
    name = draw(st.sampled_from(["rec.csv", "rec.csv.gz", "rec.xlsx", "spec.toml"]))
    raw = draw(st.one_of(st.binary(max_size=4096), st.sampled_from([b"\x1f\x8b", b"BZh", b"\xfd7zXZ\x00", b"PK\x03\x04",
                                                                     b"\xff\xfe", b"\xef\xbb\xbf", b""])))
    if name == "spec.toml":
        return Case(["sweep", "spec.toml", "--payload", "5:40:3"], {name: raw})
    return Case(["fit", name, "--stage", "x", "--columns", "frequency=2,current=3,time=4,velocity=6"]
                if name.endswith("xlsx") else ["fit", name, *FIT], {name: raw})


@pytest.mark.parametrize("part", PARTS)
def test_mutated_bytes(part):
    explore(part, (20, 80), byte_cases(), run_case)


@st.composite
def option_cases(draw) -> Case:
    """Cheap commands with option values drawn around their useful ranges, now and then weird."""
    b = bases()
    files = {"rec.csv": b.recording, "td.csv": b.time_domain,
             "spec.toml": b.specs[draw(st.sampled_from(["thesis_stage_x.toml", "thesis_stage_y.toml",
                                                         "stage_x_synth.toml", "stage_y_synth.toml"]))]}

    def some(*options):
        return [x for option in options if draw(st.booleans()) for x in option]

    def effects(n=2):
        names = draw(st.lists(st.sampled_from(sorted(EFFECT_DEFAULTS) + ["bogus", ""]), max_size=n))
        return ",".join(names)

    command = draw(st.sampled_from(["simulate", "excite", "sweep", "fit", "fit", "fit_time", "diagnose"]))
    stage = draw(st.sampled_from(["x", "x", "x", "x", "y", "y", "z"]))
    if command == "simulate":
        name, params = draw(effect_parameters())
        effect = ",".join([name, *(f"{name}.{k}={v:g}" for k, v in params.items())])
        f_hz = draw(st.one_of(st.builds("{}:{}:{}".format, number(0.1, 20), number(20, 400), number(2, 12, True)),
                              st.lists(number(0.1, 400), min_size=1, max_size=6, unique=True).map(",".join)))
        return Case(["simulate", "--stage", stage, "--f-hz", f_hz, "--duration-s", draw(number(0.05, 1)),
                     "--sample-rate-hz", draw(number(20, 4000)), "--out", "sim.csv",
                     *some(["--effects", effect], ["--set", f"mass_kg={draw(number(0.01, 2000))}"],
                           ["--noise-fraction", draw(number(0, 1))], ["--amplitude-a", draw(number(1e-3, 100))],
                           ["--current-quantum-a", draw(number(1e-6, 0.1))], ["--f-spacing", "linear"],
                           ["--velocity-quantum-m-per-s", draw(number(1e-7, 1e-2))],
                           ["--seed", draw(number(0, 9, True))])],
                    files, outputs=("sim.csv", "sim.json"))
    if command == "excite":
        rate = draw(st.sampled_from(["100", "200", "500", "1000", "2000", "4000", "1e4"]))
        period = draw(st.one_of(st.sampled_from(["0.1", "0.5", "1", "2", "5"]), number(0.05, 5)))
        phases = draw(st.sampled_from(["schroeder", "random", "optimised", "bogus"]))
        form = draw(st.sampled_from(["auto", "stepped", "multisine", "bogus"]))
        return Case(["excite", "--out", "ms.csv", "--period-s", period, "--sample-rate-hz", rate, "--phases", phases,
                     "--form", form, "--frequencies", draw(number(0, 20, True)),
                     "--block-s", draw(st.one_of(st.sampled_from(["0.5", "1", "2"]), number(0.001, 2))),
                     *some(["--f-min-hz", draw(number(0.01, 50))], ["--f-max-hz", draw(number(1, 2000))],
                           ["--periods", draw(number(1, 4, True))], ["--duration-s", draw(number(0.1, 20))],
                           ["--lines-per-decade", draw(number(0.5, 1000))], ["--amplitude-a", draw(number(1e-3, 50))],
                           ["--noise-m-per-s", draw(number(1e-6, 1))]), "--json"],
                    files, outputs=("ms.csv",), json_out=True)
    if command == "sweep":
        payload = draw(st.one_of(st.builds("{}:{}:{}".format, number(0.01, 50), number(1, 1500), number(1, 6, True)),
                                 number(0.01, 1500)))
        return Case(["sweep", "spec.toml", "--payload", payload, "--samples", draw(number(0, 5, True)),
                     "--seed", draw(number(0, 99, True)), "--json"], files, json_out=True)
    if command == "fit":
        free = ",".join(draw(st.lists(st.sampled_from(["mass_kg", "damping_n_s_per_m", "force_constant_n_per_a",
                                                        "delay.seconds", "resonance.frequency_hz", "bogus"]),
                                      max_size=3)))
        rational = draw(st.sampled_from(["1,0", "2,1", "4,3", "0,0", "1", "-1,0", "a,b", "1,2"]))
        return Case(["fit", "rec.csv", "--stage", stage, "--effects", effects(),
                     *some(["--free", free], ["--rational", rational], ["--set", f"mass_kg={draw(number(0.01, 2000))}"],
                           ["--rational-weighting", draw(st.sampled_from(["thesis", "uniform", "bogus"]))],
                           ["--load-position-m", draw(number(0, 1))]), "--json"], files, json_out=True)
    if command == "fit_time":
        return Case(["fit", "td.csv", "--stage", "x", "--set", "force_constant_n_per_a=35.15", "--effects",
                     draw(st.sampled_from(["coulomb_friction,offset", "offset", "", "delay"])),
                     *some(["--frf", draw(st.sampled_from(["auto", "periodic", "lpm", "closed-loop", "bogus"]))],
                           ["--band-hz", f"{draw(number(0, 50))}:{draw(number(1, 600))}"],
                           ["--filter-hz", draw(number(1, 600))], ["--decimate-band-hz", draw(number(1, 600))],
                           ["--method", draw(st.sampled_from(["output-error", "inverse-model", "bogus"]))],
                           ["--input-hold"]), "--json"], files, json_out=True)
    return Case(["diagnose", "rec.csv", "--stage", stage, "--effects", effects() or "delay",
                 *some(["--fit-force-constant"], ["--load-position-m", draw(number(0, 1))],
                       ["--motor-length-m", draw(number(0.1, 2))]), "--json"], files, json_out=True)


@pytest.mark.parametrize("part", PARTS)
def test_options(part):
    explore(part, (20, 80), option_cases(), run_case)


# ---------------------------------------------------------------- output paths and interrupts

#: command -> (arguments, OUT standing for the output path; suffix of the output; the input an output may name)
WRITERS = {
    "sweep": (["sweep", "spec.toml", "--payload", "5:40:3", "--csv", "OUT"], ".csv", "spec.toml"),
    "simulate": (["simulate", "--spec", "spec.toml", "--f-hz", "5:50:3", "--duration-s", "0.2", "--sample-rate-hz",
                  "400", "--out", "OUT"], ".csv", "spec.toml"),
    "excite": (["excite", "--out", "OUT", "--duration-s", "2", "--period-s", "1", "--sample-rate-hz", "200",
                "--f-max-hz", "50", "--phases", "schroeder"], ".csv", None),
    "diagnose": (["diagnose", "rec.csv", "--stage", "x", "--effects", "delay", "--report", "OUT"], ".html", "rec.csv"),
    "report": (["report", "spec.toml", "--no-synth", "--samples", "0", "--out", "OUT"], ".html", "spec.toml"),
    "synth": (["synth", "spec.toml", "--method", "ccp", "--report", "OUT"], ".html", "spec.toml"),
}
CHEAP_WRITERS = ["sweep", "sweep", "simulate", "simulate", "excite", "excite", "diagnose", "report"]
PATH_KINDS = ["new", "dot_slash", "existing", "missing_dir", "nested_missing_dir", "existing_dir", "trailing_slash",
              "parent_is_file", "input", "input_respelt", "link_to_input", "link_to_file", "dangling_link",
              "link_to_dir", "link_to_missing_dir", "long_name", "unicode_name", "newline_name", "dash_name", "empty",
              "dot", *(["read_only_dir"] if os.geteuid() != 0 else [])]


def writer_case(command: str, out: str, **fields) -> Case:
    """``command`` of ``WRITERS`` writing to ``out``, with its inputs; a success writes ``out`` (and simulate its
    sidecar)."""
    args, _, _ = WRITERS[command]
    b = bases()
    files = {"spec.toml": b.specs["stage_x_synth.toml"], "rec.csv": b.recording, **fields.pop("files", {})}
    path = Path(out)
    outputs = (os.path.normpath(out),) if path.name else ()
    if command == "simulate" and path.suffix:
        outputs += (os.path.normpath(path.with_suffix(".json")),)
    return Case([out if a == "OUT" else a for a in args], files, outputs=outputs, timeout=300, no_design_is_1=True,
                **fields)


def placed(command: str, kind: str) -> Case:
    """``command`` writing to an output path of ``kind``."""
    _, suffix, source = WRITERS[command]
    source = source or "spec.toml"
    out, link = "out" + suffix, "link" + suffix
    simple = {"new": out, "dot_slash": "./" + out, "missing_dir": "nodir/" + out, "nested_missing_dir": "a/b/" + out,
              "long_name": "x" * 300 + suffix, "unicode_name": "résumé µ" + suffix, "newline_name": "out\n" + suffix,
              "dash_name": "-out" + suffix, "empty": "", "dot": ".", "input": source}
    if kind in simple:
        return writer_case(command, simple[kind])
    if kind == "existing":
        return writer_case(command, out, files={out: OLD, "out.json": OLD})
    if kind in ("existing_dir", "trailing_slash"):
        return writer_case(command, "dir" + suffix + "/" * (kind == "trailing_slash"), dirs=("dir" + suffix,),
                           files={f"dir{suffix}/keep": OLD})
    if kind == "parent_is_file":
        return writer_case(command, "file.txt/" + out, files={"file.txt": OLD})
    if kind == "input_respelt":
        return writer_case(command, "sub/../" + source, dirs=("sub",))
    if kind == "read_only_dir":
        return writer_case(command, "ro/" + out, dirs=("ro",), read_only=("ro",))
    targets = {"link_to_input": source, "link_to_file": "other" + suffix, "dangling_link": "gone" + suffix,
               "link_to_dir": "dir", "link_to_missing_dir": "nodir/x" + suffix}
    case = writer_case(command, link, links={link: targets[kind]}, dirs=("dir",),
                       files={"other" + suffix: OLD} if kind == "link_to_file" else {})
    case.may_change = (targets[kind],) if kind in ("link_to_file", "dangling_link") else ()
    return case


@st.composite
def path_cases(draw) -> Case:
    return placed(draw(st.sampled_from(CHEAP_WRITERS)), draw(st.sampled_from(PATH_KINDS)))


@pytest.mark.parametrize("part", PARTS)
def test_output_paths(part):
    explore(part, (15, 60), path_cases(), run_case)


@pytest.mark.skipif(os.geteuid() == 0, reason="permissions do not apply to root")
@pytest.mark.parametrize("command", ["sweep", "simulate", "excite"])
def test_a_read_only_directory(command):
    run_case(placed(command, "read_only_dir"))


#: functions on the way of each command where an interrupt may land (module:attribute)
TARGETS = {
    "sweep": ["design.loop.sweep:monte_carlo_sweep", "design.views.json:sweep_csv"],
    "simulate": ["plant.experiment.simulate:simulate_stepped_sine", "plant.data.writers:recording_csv_text"],
    "excite": ["plant.experiment.excitation:design_multisine", "plant.experiment.excitation:predicted_variance",
               "plant.experiment.excitation:design_stepped_sine"],
    "diagnose": ["design.workflows:diagnose_recording", "matplotlib.figure:Figure.savefig"],
    "report": ["design.workflows:report_content", "matplotlib.figure:Figure.savefig"],
    "synth": ["cvxpy:Problem.solve", "design.workflows:design", "matplotlib.figure:Figure.savefig"],
}
COMMON_TARGETS = ["os:replace", "tempfile:mkstemp", "os:fdopen", "plant.host.text_io:decode", "json:dumps"]


@cache
def calls_of(command: str) -> int:
    """Python and C calls of a run of ``command`` (the second run: imports and caches are warm)."""
    case = writer_case(command, "out" + WRITERS[command][1])
    with tempfile.TemporaryDirectory() as tmp:
        for name, raw in case.files.items():
            (Path(tmp) / name).write_bytes(raw)
        call(case.args, cwd=Path(tmp))
        return count_calls(case.args, cwd=Path(tmp))


@st.composite
def interrupt_cases(draw, commands) -> Case:
    """Ctrl-C (or SIGTERM) at a random call of a command that writes an output, or inside a function on its way."""
    command = draw(st.sampled_from(commands))
    suffix = WRITERS[command][1]
    signal = draw(st.sampled_from(["SIGINT", "SIGINT", "SIGINT", "SIGTERM"]))
    if draw(st.booleans()):
        at = 2 + calls_of(command) * draw(st.integers(0, 1050)) // 1000    # 1: the call of main() itself
        interrupt = Interrupt(at, None, signal)
    else:
        target = draw(st.sampled_from(TARGETS[command] + COMMON_TARGETS))
        interrupt = Interrupt(draw(st.integers(1, 3)), target, signal)
    existing = {"out" + suffix: OLD, "out.json": OLD} if draw(st.booleans()) else {}
    return writer_case(command, "out" + suffix, files=existing, interrupt=interrupt)


@pytest.mark.parametrize("part", PARTS)
def test_interrupts(part):
    for command in ["sweep", "simulate", "excite", "diagnose", "report"]:
        calls_of(command)
    explore(part, (15, 50), interrupt_cases(["sweep", "simulate", "excite", "diagnose", "report"]), run_case)


@pytest.mark.slow
def test_interrupting_synthesis():
    calls_of("synth")
    explore("slow", (0, 8), interrupt_cases(["synth"]), run_case, shrink=False)
