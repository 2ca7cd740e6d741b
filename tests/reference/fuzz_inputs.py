"""The fuzz suite's machinery: valid inputs to start from, hypothesis strategies that break them, and
``run_case``, which calls the command line in-process in a fresh directory and checks its contract.

The contract: exit status 0 (success) or 2 (bad input: exactly one line on stderr, ``gantry: error: ...``),
130 for Ctrl-C and 143 for SIGTERM; never a traceback; an output exists only after a success, all of
its files, with no temporary file left, and every file that was there before is unchanged otherwise.

``GANTRY_FUZZ_SEED`` changes the seed (default ``SEED``). ``GANTRY_FUZZ_LOG=FILE`` turns a run into a
survey: every case is appended to FILE as a JSON line (test, seed, arguments, status, seconds, problems),
and a failing case is logged, its input files kept in FILE.cases/N/, instead of stopping its test.
"""

from __future__ import annotations

import bz2
import contextlib
import gzip
import io
import json
import lzma
import os
import resource
import shutil
import signal
import sys
import tempfile
import threading
import time
import tomllib
import traceback
import warnings
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, Phase, given, seed, settings
from hypothesis import strategies as st

from plant.host.interrupts import Terminated

ROOT = Path(__file__).resolve().parents[2]
SEED = int(os.environ.get("GANTRY_FUZZ_SEED", "1414"))
LOG = os.environ.get("GANTRY_FUZZ_LOG")
#: address space a command may use (bytes): a runaway allocation fails with MemoryError instead of the machine
MEMORY_LIMIT = 8 * 1024**3


def explore(part: str, examples: tuple[int, int], strategy, body, *, shrink: bool = True) -> None:
    """Run ``body`` on examples of ``strategy``: ``examples[0]`` of them in the fast part, ``examples[1]`` in the
    slow part, each part with its own recorded seed."""
    bases()     # made before hypothesis draws: strategies must not run the tool
    slow = part == "slow"
    s = SEED + slow
    print(f"hypothesis seed {s}, {examples[slow]} examples")
    phases = (Phase.explicit, Phase.generate, *((Phase.shrink,) if shrink and not LOG else ()))
    config = settings(max_examples=examples[slow], database=None, deadline=None, derandomize=False, phases=phases,
                      print_blob=True, suppress_health_check=list(HealthCheck))
    seed(s)(config(given(strategy)(body)))()


# ---------------------------------------------------------------- running the command line


class Hang(BaseException):
    """The command ran past its time limit."""


@dataclass
class Result:
    status: int | str          # the exit status, or "escaped" when an exception left main()
    out: str
    err: str
    seconds: float
    hung: bool = False
    interrupted: bool = False  # the injected interrupt was raised
    where: str = ""            # ... in these (innermost) frames
    lost: bool = False         # ... but in a finaliser, which swallowed it (the signal handler saw it all the same)


@dataclass
class Interrupt:
    """Ctrl-C (or SIGTERM) at the ``at``-th Python or C call of the run, or at the ``at``-th call of ``target``
    (``module:attribute``)."""

    at: int
    target: str | None = None
    signal: str = "SIGINT"

    def deliver(self) -> None:
        """Send the signal to this process, as the terminal or a supervisor would: the command line's
        handler raises (and records) it. In another thread (whose signal the main thread would handle
        later, perhaps after the command) the exception is raised there instead."""
        if threading.current_thread() is not threading.main_thread():
            raise KeyboardInterrupt if self.signal == "SIGINT" else Terminated
        signal.raise_signal(signal.SIGINT if self.signal == "SIGINT" else signal.SIGTERM)

    @property
    def status(self) -> int:
        return 130 if self.signal == "SIGINT" else 143


def _raise_hang(signum, frame):
    raise Hang


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """Print a warning to stderr as Python does (pytest would otherwise collect it)."""
    sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))


@contextlib.contextmanager
def _injected(interrupt: Interrupt | None, result: Result):
    """Deliver ``interrupt``'s signal once, where it says."""
    if interrupt is None:
        yield
        return
    count = 0

    def fire():
        result.interrupted = True
        frames = traceback.extract_stack(sys._getframe(2), limit=4)
        result.where = " < ".join(f"{Path(f.filename).name}:{f.lineno} {f.name}" for f in reversed(frames))
        interrupt.deliver()

    if interrupt.target is None:
        def profile(frame, event, arg):
            nonlocal count
            if event in ("call", "c_call"):
                count += 1
                if count == interrupt.at + 1:      # the first call is main's own, before any of its code runs
                    sys.setprofile(None)
                    fire()
        sys.setprofile(profile)
        try:
            yield
        finally:
            sys.setprofile(None)
        return
    module, _, attr = interrupt.target.partition(":")
    owner = __import__(module, fromlist=["_"])
    *path, name = attr.split(".")
    for p in path:
        owner = getattr(owner, p)
    original = getattr(owner, name)

    def patched(*args, **kwargs):
        nonlocal count
        count += 1
        if count == interrupt.at:
            fire()
        return original(*args, **kwargs)

    setattr(owner, name, patched)
    try:
        yield
    finally:
        setattr(owner, name, original)


def call(args: list[str], *, cwd: Path, timeout: float = 60.0, interrupt: Interrupt | None = None) -> Result:
    """``gantry ARGS`` in this process (``design.cli.main``), from ``cwd``, with Python's default warning filters
    (as the console script has them), ``MEMORY_LIMIT`` and a ``timeout`` in seconds."""
    from design.cli import _command, main
    from design.cli.common import app

    result = Result(0, "", "", 0.0)
    # stdout has a byte buffer, as a process's has (a CSV written to "-" goes there)
    stdout, stderr = io.TextIOWrapper(io.BytesIO(), encoding="utf-8", write_through=True), io.StringIO()
    saved = (sys.argv, os.getcwd(), signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGALRM),
             resource.getrlimit(resource.RLIMIT_AS), sys.unraisablehook, signal.getsignal(signal.SIGINT))
    lost = []
    sys.unraisablehook = lambda u: lost.append(u.exc_value)     # an interrupt raised in a finaliser is lost
    sys.argv = ["gantry", *map(str, args)]
    if interrupt is not None:       # a start-up as a fresh process has it: the commands registered and built anew
        app.registered_commands.clear()
        _command.cache_clear()
    os.chdir(cwd)
    signal.signal(signal.SIGALRM, _raise_hang)
    signal.signal(signal.SIGINT, signal.default_int_handler)     # as a fresh process has it
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, saved[4][1]))
    t0 = time.perf_counter()
    try:
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr), warnings.catch_warnings():
            warnings.resetwarnings()
            warnings.showwarning = _show_warning
            warnings.simplefilter("default")
            for category in (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning):
                warnings.simplefilter("ignore", category)
            signal.setitimer(signal.ITIMER_REAL, timeout)
            try:
                with _injected(interrupt, result):
                    main()
            except SystemExit as exc:
                result.status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            except Hang:
                raise
            except BaseException:     # the console script would print this traceback
                traceback.print_exc()
                result.status = "escaped"
            finally:
                signal.setitimer(signal.ITIMER_REAL, 0)
    except Hang:
        result.hung = True
    finally:
        result.seconds = time.perf_counter() - t0
        sys.argv = saved[0]
        os.chdir(saved[1])
        signal.signal(signal.SIGTERM, saved[2])
        signal.signal(signal.SIGALRM, saved[3])
        resource.setrlimit(resource.RLIMIT_AS, saved[4])
        sys.unraisablehook = saved[5]
        signal.signal(signal.SIGINT, saved[6])
        import matplotlib.pyplot as plt

        plt.close("all")
    if interrupt is not None and any(isinstance(e, (KeyboardInterrupt, Terminated)) for e in lost):
        result.interrupted, result.lost = False, True
    stdout.flush()
    result.out, result.err = stdout.buffer.getvalue().decode("utf-8", errors="replace"), stderr.getvalue()
    return result


def count_calls(args: list[str], *, cwd: Path) -> int:
    """Python and C calls of one run of ``gantry ARGS`` (where an ``Interrupt`` may land)."""
    total = 0

    def profile(frame, event, arg):
        nonlocal total
        total += event in ("call", "c_call")

    sys.setprofile(profile)
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            call(args, cwd=cwd)
    finally:
        sys.setprofile(None)
    return total


# ---------------------------------------------------------------- cases and their contract


@dataclass
class Case:
    """One run: ``files`` (and ``dirs``, ``links``) made in a fresh directory, ``args`` run from it."""

    args: list[str]
    files: dict[str, bytes] = field(default_factory=dict)
    #: files a success writes, all of them (relative to the case directory)
    outputs: tuple[str, ...] = ()
    #: other files a success may replace (the target of a symlink given as the output)
    may_change: tuple[str, ...] = ()
    dirs: tuple[str, ...] = ()
    links: dict[str, str] = field(default_factory=dict)
    read_only: tuple[str, ...] = ()
    interrupt: Interrupt | None = None
    timeout: float = 60.0
    #: synth: exit status 1 means "no verified design" (infeasible, unbounded), not a bug
    no_design_is_1: bool = False
    json_out: bool = False

    def __repr__(self) -> str:
        files = {k: v if len(v) <= 120 else f"<{len(v)} bytes>" for k, v in self.files.items()}
        return f"Case(args={self.args!r}, files={files!r}, interrupt={self.interrupt!r})"

    def _repr_pretty_(self, printer, cycle) -> None:
        printer.text(repr(self))


def _snapshot(root: Path) -> dict[str, object]:
    found = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            rel = str(p.relative_to(root))
            if p.is_symlink():
                found[rel] = ("link", os.readlink(p))
            elif p.is_dir():
                found[rel] = ("dir",)
            else:
                found[rel] = p.read_bytes()
    return found


def run_case(case: Case) -> None:
    """Run ``case`` and check the contract; a failure raises ``AssertionError`` (or is logged, see the module
    doc)."""
    root = Path(tempfile.mkdtemp(prefix="gantry-fuzz-"))
    try:
        for d in case.dirs:
            (root / d).mkdir(parents=True, exist_ok=True)
        for name, raw in case.files.items():
            (root / name).parent.mkdir(parents=True, exist_ok=True)
            (root / name).write_bytes(raw)
        for name, target in case.links.items():
            (root / name).symlink_to(target)
        for d in case.read_only:
            (root / d).chmod(0o555)
        before = _snapshot(root)
        result = call(case.args, cwd=root, timeout=case.timeout, interrupt=case.interrupt)
        problems = contract(case, result, before, _snapshot(root))
    finally:
        for d in case.read_only:
            (root / d).chmod(0o755)
        shutil.rmtree(root, ignore_errors=True)
    report(case, result, problems)


def _strict_json(text: str) -> bool:
    def refuse(constant):
        raise ValueError(constant)
    try:
        json.loads(text, parse_constant=refuse)
    except ValueError:
        return False
    return True


def contract(case: Case, r: Result, before: dict, after: dict) -> list[tuple[str, str]]:
    """(class, detail) of every way the run broke the contract; the classes are traceback, wrong exit, message
    (not one line), partial output and hang."""
    problems = []
    if r.hung:
        return [("hang", f"still running after {case.timeout:g} s")]
    if "Traceback" in r.err or "Traceback" in r.out or r.status == "escaped":
        problems.append(("traceback", r.err.strip().splitlines()[-1] if r.err.strip() else "(empty stderr)"))
    allowed = {0, 2}
    # exit 3: a complete result the mouse cannot drive (synth) or keep up with (mouse-run, planar-run); its outputs
    # are written
    verdict_3 = bool(case.args) and case.args[0] in ("synth", "mouse-run", "planar-run")
    if case.interrupt is not None and r.interrupted:
        allowed = {case.interrupt.status}
    else:
        if case.interrupt is not None and r.lost:      # the command may still honour the stop it recorded
            allowed.add(case.interrupt.status)
        if case.no_design_is_1 and "this is a bug" not in r.err:
            allowed.add(1)
        if verdict_3:
            allowed.add(3)
    if r.status not in allowed:
        why = " (the injected interrupt was raised)" if r.interrupted else ""
        problems.append(("wrong exit", f"exit status {r.status}, expected {sorted(allowed)}{why}"))
    if r.status in (2, 130, 143):
        lines = r.err.split("\n")
        if not (len(lines) == 2 and lines[1] == "" and lines[0].startswith("gantry: error: ")
                and lines[0][len("gantry: error: "):].strip()):
            problems.append(("message", f"stderr is not one 'gantry: error: ...' line: {r.err[-300:]!r}"))
    if r.status in (0, 3) and case.json_out and not _strict_json(r.out):
        problems.append(("partial output", f"--json printed no strict JSON: {r.out[-200:]!r}"))
    success = r.status == 0 or (verdict_3 and r.status == 3)
    # an output given as a symbolic link is written through to its target; the link stays
    links = {name: str(Path(name).parent / before[name][1]) for name in case.outputs
             if isinstance(before.get(name), tuple) and before[name][0] == "link"}
    outputs = {links.get(name, name) for name in case.outputs}
    changeable = outputs | set(case.may_change) if success else set()
    for name in sorted(set(before) | set(after)):
        if name in changeable:
            continue
        when = "after a success" if success else f"exit {r.status}"
        if name not in before:
            problems.append(("partial output", f"{name!r} was created ({when})"))
        elif name not in after:
            problems.append(("partial output", f"{name!r} was removed ({when})"))
        elif before[name] != after[name]:
            problems.append(("partial output", f"{name!r} was changed ({when})"))
    if success:
        for name in outputs:
            if not isinstance(after.get(name), bytes):
                problems.append(("partial output", f"exit {r.status} but output {name!r} is "
                                                   f"{after.get(name, 'missing')!r}"))
    return problems


def report(case: Case, r: Result, problems: list[tuple[str, str]]) -> None:
    """Log the case (survey mode) or fail on its problems."""
    test = os.environ.get("PYTEST_CURRENT_TEST", "?").split(" ")[0]
    if LOG:
        entry = {"test": test, "seed": SEED, "args": case.args, "status": r.status, "seconds": round(r.seconds, 3),
                 "interrupt": None if case.interrupt is None else vars(case.interrupt) | {"raised": r.interrupted,
                                                                                          "where": r.where},
                 "files": {k: len(v) for k, v in case.files.items()}, "problems": problems,
                 "stderr": r.err[-2000:]}
        if problems:
            kept = Path(f"{LOG}.cases")
            keep = kept / str(len(list(kept.iterdir())) if kept.is_dir() else 0)
            for name, raw in case.files.items():
                (keep / name).parent.mkdir(parents=True, exist_ok=True)
                (keep / name).write_bytes(raw)
            entry["kept"] = str(keep)
        with open(LOG, "a") as fh:
            fh.write(json.dumps(entry, default=str) + "\n")
        return
    assert not problems, (f"gantry {' '.join(map(repr, case.args))}\n"
                          f"files: { {k: (v if len(v) < 200 else f'{len(v)} bytes') for k, v in case.files.items()} }\n"
                          f"interrupt: {case.interrupt} raised: {r.interrupted} in {r.where}\n"
                          f"exit status {r.status}\nproblems: {problems}\nstderr:\n{r.err[-3000:]}")


# ---------------------------------------------------------------- valid inputs to start from


class Blob(bytes):
    """Bytes with a short repr (hypothesis prints strategies with their arguments)."""

    def __repr__(self) -> str:
        return f"<{len(self)} bytes>"


class Text(str):
    """Text with a short repr."""

    def __repr__(self) -> str:
        return f"<{len(self)} characters>"


class Rows(tuple):
    """Rows with a short repr."""

    def __repr__(self) -> str:
        return f"<{len(self)} rows>"


@dataclass(frozen=True)
class Bases:
    recording: bytes        # stepped sine CSV: 5 blocks, 4-60 Hz, 0.4 s at 500 Hz
    time_domain: bytes      # 3 s of the EMPS measurement as CSV (time_s, current_a, position_m, reference_m)
    mat: bytes              # the EMPS .mat file
    tdms: bytes             # the first three blocks of the recording as a TDMS file (channels frequency, time, ...)
    fit_json: bytes         # gantry fit --json of the recording
    specs: dict[str, bytes]
    rows: tuple             # the recording's rows (frequency, time, current, velocity) for spreadsheets


@cache
def bases() -> Bases:
    import scipy.io
    from nptdms import ChannelObject, TdmsWriter

    from plant import Delay, stage_x
    from plant.data.writers import recording_csv_text
    from plant.experiment.simulate import simulate_stepped_sine

    rec = simulate_stepped_sine(stage_x(mass_kg=30.0) * Delay(0.001), f_hz=np.geomspace(4, 60, 5),
                                current_amplitude_a=0.5, duration_s=0.4, sample_rate_hz=500.0,
                                noise_fraction=0.01, seed=1)
    text = recording_csv_text(rec)
    mat_path = ROOT / "examples" / "data" / "emps" / "DATA_EMPS.mat"
    emps = scipy.io.loadmat(mat_path)
    n = 3000
    td = np.column_stack([emps[k].ravel()[:n] for k in ("t", "vir", "qm", "qg")])
    buf = io.StringIO()
    buf.write("time_s,current_a,position_m,reference_m\n")
    np.savetxt(buf, td, fmt="%.9g", delimiter=",")
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "rec.csv").write_text(text)
        fit = call(["fit", "rec.csv", "--stage", "x", "--effects", "delay", "--json"], cwd=Path(tmp))
    assert fit.status == 0, fit.err
    rows = Rows((b.f_hz, t, i, v) for b in rec.blocks[:3] for t, i, v in
                zip(b.time_s, b.current_a, b.velocity_m_per_s[0]))
    specs = {p.name: Blob(p.read_bytes()) for p in sorted((ROOT / "specs").glob("*.toml"))}
    tdms = io.BytesIO()
    with TdmsWriter(tdms) as writer:
        writer.write_segment([ChannelObject("recording", name, np.array(column))
                              for name, column in zip(("frequency", "time", "current", "velocity"), zip(*rows))])
    return Bases(Blob(text.encode()), Blob(buf.getvalue().encode()), Blob(mat_path.read_bytes()),
                 Blob(tdms.getvalue()), Blob(fit.out.encode()), specs, rows)


# ---------------------------------------------------------------- byte-level mutation


@st.composite
def mutated_bytes(draw, raw: bytes, max_ops: int = 4) -> bytes:
    """``raw`` with 1..``max_ops`` bytes flipped, set, inserted, deleted or duplicated, or cut short. The draws do
    not depend on the bytes (a spreadsheet's bytes carry the time it was written)."""
    data = bytearray(raw)
    for _ in range(draw(st.integers(1, max_ops))):
        op = draw(st.sampled_from(["flip", "set", "insert", "delete", "duplicate", "truncate"]))
        at = draw(st.integers(0, 2**20)) * (len(data) + 1) >> 20
        n, blob = draw(st.integers(1, 64)), draw(st.binary(min_size=1, max_size=16))
        if op == "flip" and at < len(data):
            data[at] ^= 1 << n % 8
        elif op == "set" and at < len(data):
            data[at] = blob[0]
        elif op == "insert":
            data[at:at] = blob
        elif op == "delete":
            del data[at:at + n]
        elif op == "duplicate":
            data[at:at] = data[at:at + 4 * n]
        elif op == "truncate":
            del data[at:]
    return bytes(data)


# ---------------------------------------------------------------- option values

WEIRD_NUMBERS = ["0", "-1", "nan", "inf", "-inf", "1e999", "1e-300", "1e308", "", "abc", "0x10", "1_0", " 1", "٣",
                 "5e-324", "-0"]


@st.composite
def number(draw, lo: float, hi: float, integer: bool = False) -> str:
    """Option text: a number between ``lo`` and ``hi``, one time in eight a weird one."""
    if draw(st.integers(0, 7)) == 0:
        return draw(st.sampled_from(WEIRD_NUMBERS))
    if integer:
        return str(draw(st.integers(int(lo), int(hi))))
    return f"{draw(st.floats(lo, hi)):.4g}"


# ---------------------------------------------------------------- recordings (CSV)

CELLS = ["", " ", "nan", "NaN", "-nan", "inf", "-inf", "Infinity", "1e999", "-1e999", "1e308", "-1e308", "1e-320",
         "0", "-0", "-1", "1e5", "TRUE", "false", "abc", '"1.5"', "1,5", "0x10", "1_000", "١٢", "½", "∞", "µ",
         "2024-01-01", "--1", "1e", ".", "+", "9" * 400]
NAMES = ["", "frequency_hz", "time_s", "current_a", "velocity_m_per_s", "velocity_2_m_per_s", "position_m",
         "reference_m", "Frequency_Hz", " frequency_hz", "frequency", "velocity", "velocity_µm_per_s", "ＭＡＳＳ", "x"]
ENCODINGS = ["utf-8", "utf-8-sig", "utf-16", "utf-16-le", "utf-16-be", "latin-1", "cp1252"]
COMPRESSORS = {"none": lambda b: b, "gzip": gzip.compress, "bzip2": bz2.compress, "xz": lzma.compress}

cell = st.one_of(st.sampled_from(CELLS), st.floats().map(repr), st.integers().map(str), st.text(max_size=8))
TABLE_EDITS = ["drop_column", "rename_column", "swap_columns", "duplicate_column", "cells", "cells", "column",
               "scale_column", "keep_rows", "duplicate_rows", "swap_rows", "reverse_rows", "sort_by", "ragged",
               "insert_line"]


def edit_table(draw, header: list[str], rows: list[list[str]]) -> tuple[list[str], list[list[str]]]:
    """``header`` and ``rows`` after one edit drawn from ``TABLE_EDITS``."""
    name = draw(st.sampled_from(TABLE_EDITS))
    width, n = len(header), len(rows)
    col = draw(st.integers(0, width - 1)) if width else 0
    row = draw(st.integers(0, n - 1)) if n else 0
    if name == "drop_column" and width:
        return header[:col] + header[col + 1:], [r[:col] + r[col + 1:] for r in rows]
    if name == "rename_column" and width:
        header = header[:col] + [draw(st.one_of(st.sampled_from(NAMES), st.text(max_size=10)))] + header[col + 1:]
    elif name == "swap_columns" and width:
        other = draw(st.integers(0, width - 1))
        perm = list(range(width))
        perm[col], perm[other] = other, col
        return [header[p] for p in perm], [[r[p] for p in perm if p < len(r)] for r in rows]
    elif name == "duplicate_column" and width:
        return header + [header[col]], [r + r[col:col + 1] for r in rows]
    elif name == "cells" and n:
        rows = [list(r) for r in rows]
        for _ in range(draw(st.integers(1, 5))):
            r = rows[draw(st.integers(0, n - 1))]
            if r:
                r[draw(st.integers(0, len(r) - 1))] = draw(cell)
    elif name in ("column", "scale_column"):
        value = draw(cell) if name == "column" else draw(st.sampled_from([0.0, -1.0, 1e-300, 1e300, 1e-9, 1e9]))
        rows = [r[:col] + [value if name == "column" else _scaled(r[col], value)] + r[col + 1:] if col < len(r)
                else r for r in rows]
    elif name == "keep_rows":
        lo, hi = sorted((draw(st.integers(0, n)), draw(st.integers(0, n))))
        rows = rows[lo:hi]
    elif name == "duplicate_rows":
        rows = rows[:row] + rows[row:row + draw(st.integers(1, 50))] + rows[row:]
    elif name == "swap_rows" and n:
        rows, other = list(rows), draw(st.integers(0, n - 1))
        rows[row], rows[other] = rows[other], rows[row]
    elif name == "reverse_rows":
        rows = rows[::-1]
    elif name == "sort_by" and width:
        rows = sorted(rows, key=lambda r: r[col] if col < len(r) else "")
    elif name == "ragged" and n:
        delta = draw(st.integers(-3, 3))
        rows = rows[:row] + [rows[row] + ["1"] * delta if delta > 0 else rows[row][:len(rows[row]) + delta]] \
            + rows[row + 1:]
    elif name == "insert_line":
        line = draw(st.sampled_from(["", " ", "# comment", ",,,", "HEADER", "1,2"]))
        rows = rows[:row] + [header if line == "HEADER" else [line]] + rows[row:]
    return header, rows


def _scaled(text: str, factor: float) -> str:
    try:
        return repr(float(text) * factor)
    except ValueError:
        return text


@st.composite
def encoded(draw, text: str, name: str) -> tuple[str, bytes]:
    """(file name, bytes) of ``text`` in some encoding, line ending and compression."""
    newline = draw(st.sampled_from(["\n", "\n", "\r\n", "\r"]))
    text = text.replace("\n", newline)
    encoding = draw(st.sampled_from(ENCODINGS))
    raw = text.encode(encoding, errors="replace")
    how = draw(st.sampled_from(["none", "none", "none", "gzip", "bzip2", "xz"]))
    raw = COMPRESSORS[how](raw)
    stem, _, suffix = name.rpartition(".")
    suffix = draw(st.sampled_from([suffix, suffix, f"{suffix}.gz" if how == "gzip" else suffix, suffix.upper(),
                                   "txt", f"{suffix}.bz2"]))
    return f"{stem}.{suffix}", raw


@st.composite
def recording_files(draw, base: bytes, name: str = "rec.csv") -> tuple[str, bytes]:
    """A CSV recording with columns, cells, rows, delimiter, encoding and compression broken at random."""
    lines = base.decode().splitlines()
    header, rows = lines[0].split(","), [line.split(",") for line in lines[1:]]
    for _ in range(draw(st.integers(0, 3))):
        header, rows = edit_table(draw, header, rows)
    delimiter = draw(st.sampled_from([",", ",", ",", ",", ",", ";", "\t", ", "]))
    text = "\n".join(delimiter.join(r) for r in [header, *rows])
    text += draw(st.sampled_from(["\n", "", "\n\n"]))
    if draw(st.booleans()) and draw(st.booleans()):     # cut mid-line
        text = text[:draw(st.integers(0, len(text)))]
    return draw(encoded(Text(text), name))


# ---------------------------------------------------------------- spreadsheets

XLSX_CELLS = [None, "", "abc", "1,5", " 2.5 ", float("nan"), float("inf"), -float("inf"), 1e308, -1e308, 5e-324,
              True, False, "=1/0", "=B1*2", "#DIV/0!", 10**20, -0.0, "NaN", "µ"]
XLSX_MAPS = ["frequency=2,current=3,velocity=6,time=4", "frequency=2,current=3,velocity=6",
             "frequency=2,current=3,velocity=6,velocity=5", "frequency=2,current=3,velocity=99",
             "frequency=0,current=3,velocity=6", "frequency=B,current=3,velocity=6", "frequency=2,current=2,velocity=6",
             "current=3,velocity=6", "frequency=2,current=3,position=6", "frequency=2,current=3,velocity=6,time=1"]


@st.composite
def spreadsheets(draw, rows: tuple) -> tuple[bytes, str]:
    """(.xlsx bytes, column map) of the thesis layout (no header; frequency 2, current 3, time 4, velocity 6) with
    cells, rows and sheets broken at random."""
    import datetime

    import openpyxl

    table = [[k, f, i, t, 0, v] for k, (f, t, i, v) in enumerate(rows)]
    for _ in range(draw(st.integers(0, 6))):
        r, c = draw(st.integers(0, len(table) - 1)), draw(st.integers(0, 6))
        value = draw(st.one_of(st.sampled_from(XLSX_CELLS), st.just(datetime.datetime(2024, 1, 1)),
                               st.floats(), st.text(max_size=6)))
        if isinstance(value, str):
            from openpyxl.cell.cell import ILLEGAL_CHARACTERS_RE

            value = ILLEGAL_CHARACTERS_RE.sub("", value)
        table[r] = table[r][:c] + [value] + table[r][c + 1:] if c < 6 else table[r] + [value]
    how = draw(st.sampled_from(["keep", "keep", "truncate", "header", "blank_rows", "empty_first_sheet", "shuffle"]))
    if how == "truncate":
        table = table[:draw(st.integers(0, len(table)))]
    elif how == "header":
        table.insert(0, ["n", "frequency_hz", "current_a", "time_s", "", "velocity_m_per_s"])
    elif how == "blank_rows":
        table[draw(st.integers(0, len(table) - 1)):0] = [[None] * 6] * draw(st.integers(1, 5))
    elif how == "shuffle":
        table = draw(st.permutations(table))
    wb = openpyxl.Workbook()
    ws = wb.active
    if how == "empty_first_sheet":
        ws = wb.create_sheet("data")
    for row in table:
        ws.append(row)
    buf = io.BytesIO()
    wb.save(buf)
    return buf.getvalue(), draw(st.sampled_from(XLSX_MAPS))


# ---------------------------------------------------------------- specs


class Raw(str):
    """A TOML value written as is (``1e999``, a date)."""


SPEC_VALUES = [-1.0, 0, 0.0, -0.0, Raw("1e999"), Raw("-1e999"), Raw("nan"), Raw("inf"), 1e308, 1e300, 5e-324,
               1e-300, 10**30, 10**400, -(10**30), 2**63 - 1, "", "abc", "35 kg", "µ", "x", True, False, [],
               [1.0, 2.0], {}, {"min": 1.0}, {"min": 5.0, "max": 1.0}, {"value": -1.0}, Raw("1979-05-27"),
               Raw("07:32:00"), Raw("0x7fffffff"), 1, 3, 10000, 1e4, 0.5, 2.0, 1e-9, 1e9]
spec_value = st.one_of(st.sampled_from(SPEC_VALUES), st.floats(), st.integers(), st.text(max_size=10))
SPEC_EDITS = ["set", "set", "set", "scale", "scale", "effect", "effect", "delete", "misspell", "add", "drop_section",
              "measured"]
#: effects and their default parameters (``plant.physics.effects``)
EFFECT_DEFAULTS = {"delay": {"seconds": 0.001}, "current_loop": {"bandwidth_hz": 1000.0}, "sampling": {"rate_hz": 1e4},
                   "sensor_filter": {"frequency_hz": 200.0, "damping_ratio": 0.707},
                   "encoder_velocity": {"rate_hz": 2000.0},
                   "resonance": {"frequency_hz": 50.0, "antiresonance_hz": 35.0, "damping_ratio": 0.05},
                   "payload_resonance": {"frequency_hz": 50.0, "antiresonance_hz": 35.0, "damping_ratio": 0.05},
                   "second_resonance": {"frequency_hz": 120.0, "antiresonance_hz": 90.0, "damping_ratio": 0.05},
                   "coulomb_friction": {"force_n": 10.0}, "offset": {"force_n": 0.0},
                   "tilt_coupling": {"frequency_hz": 40.0, "stiffness_n_m_per_rad": 2e5, "offset_m": 0.0}}
FACTORS = [-1, 0, 1e-3, 0.1, 0.5, 1, 1, 2, 10, 1e3]


@st.composite
def effect_parameters(draw) -> tuple[str, dict[str, float]]:
    """An effect of the library with its default parameters scaled (some dropped)."""
    name = draw(st.sampled_from(sorted(EFFECT_DEFAULTS)))
    params = {k: v * draw(st.sampled_from(FACTORS)) if v else draw(st.sampled_from([0.0, 0.01, -5.0]))
              for k, v in EFFECT_DEFAULTS[name].items() if draw(st.integers(0, 4))}
    return name, params


def key_paths(data, prefix=()) -> list[tuple]:
    """Every key path of a parsed TOML document (tables, values, array elements)."""
    out = []
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list) else ()
    for k, v in items:
        out.append((*prefix, k))
        out.extend(key_paths(v, (*prefix, k)))
    return out


def edit_spec(draw, data: dict, edits=SPEC_EDITS) -> dict:
    """``data`` (changed in place) after one edit drawn from ``edits``."""
    name = draw(st.sampled_from(edits))
    paths = key_paths(data)
    if name == "drop_section":
        table = data
        *outer, last = draw(st.sampled_from(["plant", "controller", "requirements", "objective", "plant.effects",
                                             "plant.uncertainty", "admittance"])).split(".")
        for k in outer:
            table = table.get(k) if isinstance(table, dict) else None
        if isinstance(table, dict):
            table.pop(last, None)
    elif name == "effect":
        if isinstance(data.get("plant"), dict):
            effect, params = draw(effect_parameters())
            data["plant"].setdefault("effects", {})
            if isinstance(data["plant"]["effects"], dict):
                data["plant"]["effects"][effect] = params
    elif name == "measured":
        if isinstance(data.get("plant"), dict):
            data["plant"]["measured"] = [{"payload_kg": draw(st.one_of(spec_value, st.just(20.0))),
                                          "file": draw(st.sampled_from(["rec.csv", "missing.csv", ".", ""]))}]
    elif paths:
        path = draw(st.sampled_from(paths))
        parent = data
        for k in path[:-1]:
            parent = parent[k]
        key = path[-1]
        if name == "set":
            parent[key] = draw(spec_value)
        elif name == "scale" and isinstance(parent[key], (int, float)) and not isinstance(parent[key], bool):
            parent[key] *= draw(st.sampled_from([-1, 0.5, 2, 10, 0.1, 100, 1e-3, 1e3]))
        elif name == "delete":
            del parent[key]
        elif name == "misspell" and isinstance(key, str):
            new = draw(st.sampled_from([key + "s", key.replace("_", "-"), key.upper(), key[:-1], key + " ",
                                        key + "µ"]))
            parent[new] = parent.pop(key)
        elif name == "add" and isinstance(parent[key], dict):
            parent[key][draw(st.sampled_from(["points", "min", "max", "value", "extra", "delay", "seconds", "kind",
                                              "uncertainty"]))] = draw(spec_value)
    return data


def _key(k) -> str:
    return json.dumps(str(k), ensure_ascii=False)


def _value(v) -> str:
    if isinstance(v, Raw):
        return str(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + "}"
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(type(v))


def to_toml(data: dict) -> str:
    """TOML text of a parsed document (``Raw`` values written as they are)."""
    lines: list[str] = []

    def table(d: dict, path: list[str]) -> None:
        def nested(v):
            return isinstance(v, dict) or (isinstance(v, list) and v and all(isinstance(x, dict) for x in v))
        lines.extend(f"{_key(k)} = {_value(v)}" for k, v in d.items() if not nested(v))
        for k, v in d.items():
            header = ".".join(_key(p) for p in [*path, k])
            if isinstance(v, dict):
                lines.append(f"[{header}]")
                table(v, [*path, k])
            elif nested(v):
                for item in v:
                    lines.append(f"[[{header}]]")
                    table(item, [*path, k])

    table(data, [])
    return "\n".join(lines) + "\n"


@st.composite
def spec_files(draw, specs: dict[str, bytes], names=None) -> tuple[str, bytes]:
    """(name of the spec it started from, TOML bytes) with values replaced, keys deleted or misspelt, sections
    removed, or (one time in three) only numbers scaled and effects added; sometimes in another encoding or
    compressed."""
    base = draw(st.sampled_from(sorted(names or specs)))
    data = tomllib.loads(specs[base].decode())
    edits = ["scale", "effect"] if draw(st.integers(0, 2)) == 0 else SPEC_EDITS
    for _ in range(draw(st.integers(1, 3))):
        data = edit_spec(draw, data, edits)
    text = to_toml(data)
    if draw(st.integers(0, 4)) == 0:
        return base, draw(encoded(Text(text), "spec.toml"))[1]
    return base, text.encode()
