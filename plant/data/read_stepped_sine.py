"""Read stepped-sine recordings: the CSV of ``docs/formats.md``, the thesis's ``.xlsx``
spreadsheets (thesis Appendix B: no header, frequency in column 2, current in column 3,
velocities in columns 6 and 7) and LabVIEW ``.tdms`` files, into a validated ``Recording``.

Every problem raises ``DataError`` naming the file, the column and the row (1-based, as a
spreadsheet shows it) or the frequency block. Whether a block can be estimated (its length,
its sampling, its current) is the estimator's question (``plant.estimate.lockin``): it leaves a bad
block out with a note instead of refusing the whole recording.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from plant.data.recordings import MAX_CURRENT_A, MAX_OUTPUT, Block, Recording
from plant.data.table import NumericCsv
from plant.errors import DataError
from plant.host.text_io import data_suffix

#: a time step longer than this many median steps within a block is refused (a corrupt time value;
#: missing samples leave shorter gaps, which the lock-in handles with the actual sample times)
MAX_GAP_STEPS = 1000

#: roles a stepped-sine recording may map
STEPPED_ROLES = ("frequency", "time", "current", "velocity")


class _Columns(NamedTuple):
    """What a reader found: values per table key (frequency_hz, time_s, current_a, outputs), the
    output keys, each sample's row number in the file, each key's column as messages name it
    and as a scale key names it, and a sample rate stated by the file (TDMS waveforms)."""

    table: dict[str, np.ndarray]
    outputs: tuple[str, ...]
    rows: np.ndarray
    labels: dict[str, str]
    ids: dict[str, str]
    sample_rate_hz: float | None = None


def read_recording(path: str | Path, *, columns: dict[str, list[str]] | None = None,
                   scale: dict[str, float] | None = None, sample_rate_hz: float | None = None) -> Recording:
    """Read a recording by its suffix (.csv, .xlsx, .tdms) and validate every block.

    ``columns`` is needed for .xlsx/.tdms (see ``parse_column_map``); for .csv it may map roles to
    header names. ``scale`` multiplies values into SI, per role (``{"velocity": 1e-3}`` for mm/s)
    or per column (``{"velocity:7": 0.01}``; see ``parse_scale``). ``sample_rate_hz`` is used
    when the file has no time column (a TDMS waveform's own increment otherwise). Rows that are
    empty in every mapped column (blank CSV lines, formatting below a sheet's data) are skipped;
    messages give the file's own row numbers.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file")
    if columns:
        if "frequency" not in columns:
            raise DataError(f"{path}: a stepped-sine column map names the frequency column, e.g. frequency=2 "
                            "(without one the file is a time-domain recording)")
        other = sorted(set(columns) - set(STEPPED_ROLES))
        if other:
            raise DataError(f"{path}: a stepped-sine recording has no {other[0]} column (roles: "
                            f"{', '.join(STEPPED_ROLES)})")
    suffix = data_suffix(path)
    if suffix == ".csv":
        found = _read_csv(path, columns)
    elif suffix in (".xlsx", ".xlsm"):
        found = _read_xlsx(path, _need_map(path, columns))
    elif suffix == ".tdms":
        found = _read_tdms(path, _need_map(path, columns))
    else:
        raise DataError(f"{path}: unknown file type {suffix!r}; expected .csv, .xlsx or .tdms")
    table = dict(found.table)
    keys = {"frequency": ["frequency_hz"], "time": ["time_s"], "current": ["current_a"],
            "velocity": list(found.outputs)}
    for name, factor in (scale or {}).items():
        role, _, column = name.partition(":")
        if role not in STEPPED_ROLES or isinstance(factor, bool) or not isinstance(factor, (int, float)) \
                or not math.isfinite(factor) or factor == 0:
            raise DataError(f"scale {name}={factor!r}: role must be one of {', '.join(STEPPED_ROLES)} "
                            "(or ROLE:COLUMN for "
                            "one column) and the factor a finite non-zero number")
        targets = [k for k in keys[role] if k in found.ids and (not column or found.ids[k] == column)]
        if column and not targets:
            raise DataError(f"{path}: scale {name}: no {role} column {column!r} (the {role} columns are "
                            f"{', '.join(repr(found.ids[k]) for k in keys[role] if k in found.ids) or 'none'})")
        for key in targets:
            table[key] = table[key] * factor
    rate = sample_rate_hz if sample_rate_hz is not None else found.sample_rate_hz
    return _blocks(path, table, found.outputs, found.rows, rate, found.labels)


def _need_map(path: Path, columns):
    if not columns:
        raise DataError(f"{path}: spreadsheets and TDMS files need a column map, e.g. "
                        "--columns frequency=2,current=3,velocity=6,velocity=7")
    return columns


def _read_csv(path: Path, columns):
    """Columns by header name: frequency_hz, time_s, current_a, velocity* (or a column map of names)."""
    csv_file = NumericCsv.read(path)
    header = csv_file.header
    if columns:
        wanted = {"frequency_hz": columns["frequency"][0], "current_a": columns["current"][0]}
        if "time" in columns:
            wanted["time_s"] = columns["time"][0]
        outs = columns["velocity"]
    else:
        wanted = {"frequency_hz": "frequency_hz", "time_s": "time_s", "current_a": "current_a"}
        outs = [h for h in header if h.startswith("velocity")]
        if not outs:
            raise DataError(f"{path}: no output column: expected one or more columns whose names start with "
                            f"'velocity' (header: {', '.join(header)})")
    keys = [*wanted.items(), *((o, o) for o in outs)]
    values = csv_file.numbers([col for _, col in keys])
    return _Columns({key: values[col] for key, col in keys}, tuple(outs), csv_file.rows,
                    {key: f"column {col!r}" for key, col in keys}, {key: col for key, col in keys})


def _read_xlsx(path: Path, columns):
    import openpyxl

    try:
        wb = openpyxl.load_workbook(path, read_only=True, data_only=True)
    except Exception as exc:  # openpyxl raises many types for a bad workbook
        raise DataError(f"{path}: cannot read the workbook ({exc})") from None
    ws = wb.worksheets[0]
    index = {}
    for role, cols in columns.items():
        for c in cols:
            if not c.isdigit() or int(c) < 1:
                raise DataError(f"{path}: spreadsheet column {role}={c!r} must be a 1-based column number")
            index.setdefault(role, []).append(int(c) - 1)
    mapped = [j for cols in index.values() for j in cols]
    rows, numbers = [], []
    for number, row in enumerate(ws.iter_rows(values_only=True), start=1):
        if any(row[j] is not None for j in mapped if j < len(row)):   # rows empty in every mapped column
            rows.append(row)                                         # (formatting below the data) are skipped
            numbers.append(number)
    wb.close()
    return _table_from_rows(path, rows, index, np.asarray(numbers, dtype=int))


def _table_from_rows(path, rows, index, numbers):
    """Columns of spreadsheet ``rows`` (1-based row ``numbers`` in the file) by 0-based ``index``."""
    table, outs, labels, ids = {}, [], {}, {}
    for role, cols in index.items():
        for k, j in enumerate(cols):
            key = {"frequency": "frequency_hz", "time": "time_s", "current": "current_a"}.get(role)
            if role == "velocity":
                key = f"velocity_{k + 1}_m_per_s" if len(cols) > 1 else "velocity_m_per_s"
                outs.append(key)
            values = np.empty(len(rows))
            for i, row in enumerate(rows):
                cell = row[j] if j < len(row) else None
                try:
                    values[i] = float(cell)
                except (TypeError, ValueError):
                    raise DataError(f"{path}: row {numbers[i]}, column {j + 1} ({role}): {cell!r} is not a "
                                    "number") from None
            table[key] = values
            labels[key] = f"column {j + 1} ({role})"
            ids[key] = str(j + 1)
    if not rows:
        raise DataError(f"{path}: the sheet is empty")
    return _Columns(table, tuple(outs), numbers, labels, ids)


def _read_tdms(path: Path, columns):
    """Channels by name, or ``group/channel`` where a name is in several groups. Without a time
    channel, a LabVIEW waveform's ``wf_increment`` (s) on the current channel gives the sample rate
    (an explicit ``sample_rate_hz`` wins)."""
    from nptdms import TdmsFile

    try:
        tdms = TdmsFile.read(path)
    except Exception as exc:  # npTDMS raises many types for a bad file
        raise DataError(f"{path}: cannot read the TDMS file ({exc})") from None
    channels: dict[str, list] = {}
    for group in tdms.groups():
        for ch in group.channels():
            channels.setdefault(ch.name, []).append(ch)
            channels[f"{group.name}/{ch.name}"] = [ch]
    table, outs, labels, ids = {}, [], {}, {}
    n, rate = None, None
    for role, names in columns.items():
        for k, name in enumerate(names):
            found = channels.get(name, [])
            if not found:
                listed = ", ".join(c.name if len(channels[c.name]) == 1 else f"{c.group_name}/{c.name}"
                                   for group in tdms.groups() for c in group.channels())
                raise DataError(f"{path}: no channel {name!r} ({role}); channels: {listed}")
            if len(found) > 1:
                raise DataError(f"{path}: channel {name!r} ({role}) is in several groups; name it as "
                                f"{' or '.join(repr(f'{c.group_name}/{c.name}') for c in found)}")
            values = np.asarray(found[0][:], dtype=float)
            if n is not None and values.size != n:
                raise DataError(f"{path}: channel {name!r} has {values.size} samples, others {n}")
            n = values.size
            key = {"frequency": "frequency_hz", "time": "time_s", "current": "current_a"}.get(role)
            if role == "velocity":
                key = f"velocity_{name}" if len(names) > 1 else "velocity_m_per_s"
                outs.append(key)
            table[key] = values
            labels[key] = f"channel {name!r} ({role})"
            ids[key] = name
            if role == "current" and "wf_increment" in found[0].properties:
                increment = float(found[0].properties["wf_increment"])
                if not (math.isfinite(increment) and increment > 0):
                    raise DataError(f"{path}: channel {name!r} ({role}): waveform increment {increment!r} s is not "
                                    "a positive sample interval")
                rate = 1.0 / increment
    return _Columns(table, tuple(outs), np.arange(1, (n or 0) + 1), labels, ids, rate)


def _blocks(path: Path, table, outs, rows, sample_rate_hz, labels) -> Recording:
    """Split rows into frequency blocks and validate them; ``labels`` names each table key's column
    as the file does (header name, spreadsheet column number or TDMS channel)."""
    where = str(path)
    if rows.size == 0:
        raise DataError(f"{where}: no data rows (the columns are empty)")
    if "time_s" not in table:
        if sample_rate_hz is None or not sample_rate_hz > 0:
            raise DataError(f"{where}: no time column; give the sample rate (--sample-rate-hz)")
    for key, values in table.items():
        bad = ~np.isfinite(values)
        if bad.any():
            raise DataError(f"{where}: row {rows[bad.argmax()]}, {labels[key]}: NaN or infinite sample")
    f = table["frequency_hz"]
    if np.any(f <= 0):
        i = int(np.argmax(f <= 0))
        raise DataError(f"{where}: row {rows[i]}, {labels['frequency_hz']}: frequency must be positive, "
                        f"got {f[i]:g}")
    starts = np.flatnonzero(np.r_[True, f[1:] != f[:-1]])
    ends = np.r_[starts[1:], f.size]
    seen: dict[float, int] = {}
    blocks = []
    for a, b in zip(starts, ends):
        fb = float(f[a])
        if fb in seen:
            raise DataError(f"{where}: duplicate block: {fb:g} Hz appears at rows {seen[fb]} and {rows[a]} "
                            "(one block per frequency)")
        seen[fb] = int(rows[a])
        label = f"{where}: block {fb:g} Hz (rows {rows[a]}-{rows[b - 1]})"
        t = table["time_s"][a:b] if "time_s" in table else np.arange(b - a) / sample_rate_hz
        d = np.diff(t)
        if np.any(d <= 0):
            i = int(np.argmax(d <= 0)) + 1
            raise DataError(f"{label}: row {rows[a + i]}, {labels['time_s']}: time must increase within a block "
                            f"({t[i - 1]:g} s then {t[i]:g} s)")
        if t.size < 2:
            raise DataError(f"{label}: a block needs at least two samples")
        step = float(np.median(d))
        if np.any(d > MAX_GAP_STEPS * step):
            k = int(np.argmax(d > MAX_GAP_STEPS * step)) + 1
            raise DataError(f"{label}: row {rows[a + k]}, {labels['time_s']}: {t[k - 1]:g} s then {t[k]:g} s, more "
                            f"than {MAX_GAP_STEPS} sample steps ({step:.3g} s) apart: a wrong time value")
        i = table["current_a"][a:b]
        vel = np.vstack([table[o][a:b] for o in outs])
        for name, values, limit in (("current_a", i[None], MAX_CURRENT_A), *((o, vel[k:k + 1], MAX_OUTPUT["velocity"])
                                                                        for k, o in enumerate(outs))):
            far = ~(np.abs(values[0]) <= limit)
            if np.any(far):
                k = int(np.argmax(far))
                raise DataError(f"{label}: row {rows[a + k]}, {labels.get(name, name)}: {values[0][k]:g} is beyond "
                                f"{limit:g}, no measurement of a gantry (a corrupt value)")
        blocks.append(Block(fb, t - t[0], i, vel))
    order = np.argsort([b.f_hz for b in blocks], kind="stable")
    return Recording(tuple(blocks[k] for k in order), tuple(outs), source=where)
