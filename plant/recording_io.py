"""Read stepped-sine recordings: the CSV of ``shared/ARCHITECTURE.md``, the thesis's ``.xlsx``
spreadsheets (thesis Appendix B: no header, frequency in column 2, current in column 3,
velocities in columns 6 and 7) and LabVIEW ``.tdms`` files, into a validated ``Recording``.

Every problem raises ``DataError`` naming the file, the column and the row (1-based, as a
spreadsheet shows it) or the frequency block.
"""

from __future__ import annotations

import csv
import math
import warnings
from pathlib import Path

import numpy as np

from plant.errors import DataError
from plant.recording import Block, Recording

ROLES = ("frequency", "time", "current", "velocity")
#: fewest samples per period of the excitation that the estimator accepts
MIN_SAMPLES_PER_PERIOD = 4
#: whole periods needed after settling
MIN_PERIODS = 2


def parse_column_map(text: str) -> dict[str, list[str]]:
    """``"frequency=2,current=3,velocity=6,velocity=7"`` -> ``{"frequency": ["2"], ..., "velocity": ["6", "7"]}``.

    Values are 1-based column numbers (spreadsheets) or channel names (TDMS)."""
    out: dict[str, list[str]] = {}
    for item in (p.strip() for p in text.split(",") if p.strip()):
        role, eq, col = item.partition("=")
        role = role.strip()
        if not eq or not col.strip():
            raise DataError(f"column map item {item!r}: expected ROLE=COLUMN, e.g. frequency=2")
        if role not in ROLES:
            raise DataError(f"column map item {item!r}: unknown role {role!r}; roles are {', '.join(ROLES)}")
        out.setdefault(role, []).append(col.strip())
    for role in ("frequency", "current", "velocity"):
        if role not in out:
            raise DataError(f"column map {text!r} names no {role} column")
    for role in ("frequency", "time", "current"):
        if len(out.get(role, [])) > 1:
            raise DataError(f"column map {text!r} names {len(out[role])} {role} columns; give one")
    return out


def read_recording(path: str | Path, *, columns: dict[str, list[str]] | None = None,
                   scale: dict[str, float] | None = None, sample_rate_hz: float | None = None) -> Recording:
    """Read a recording by its suffix (.csv, .xlsx, .tdms) and validate every block.

    ``columns`` is needed for .xlsx/.tdms (see ``parse_column_map``); ``scale`` multiplies a
    role's values into SI (e.g. ``{"velocity": 1e-3}`` for mm/s); ``sample_rate_hz`` is used
    when the file has no time column.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file")
    suffix = path.suffix.lower()
    if suffix == ".csv":
        table, names, rows, labels = _read_csv(path, columns)
    elif suffix in (".xlsx", ".xlsm"):
        table, names, rows, labels = _read_xlsx(path, _need_map(path, columns))
    elif suffix == ".tdms":
        table, names, rows, labels = _read_tdms(path, _need_map(path, columns))
    else:
        raise DataError(f"{path}: unknown file type {suffix!r}; expected .csv, .xlsx or .tdms")
    keys = {"frequency": ["frequency_hz"], "time": ["time_s"], "current": ["current_a"], "velocity": list(names)}
    for role, factor in (scale or {}).items():
        if role not in ROLES or isinstance(factor, bool) or not isinstance(factor, (int, float)) \
                or not math.isfinite(factor) or factor == 0:
            raise DataError(f"scale {role}={factor!r}: role must be one of {', '.join(ROLES)} and the factor "
                            "a finite non-zero number")
        for key in keys[role]:
            if key in table:
                table[key] = table[key] * factor
    return _blocks(path, table, names, rows, sample_rate_hz, labels)


def _need_map(path: Path, columns):
    if not columns:
        raise DataError(f"{path}: spreadsheets and TDMS files need a column map, e.g. "
                        "--columns frequency=2,current=3,velocity=6,velocity=7")
    return columns


def _read_csv(path: Path, columns):
    """Columns by header name: frequency_hz, time_s, current_a, velocity* (or a column map of names).
    A UTF-8 byte-order mark (spreadsheet exports) is ignored."""
    with path.open(newline="", encoding="utf-8-sig") as fh:
        reader = csv.reader(fh)
        try:
            header = [h.strip() for h in next(reader)]
        except StopIteration:
            raise DataError(f"{path}: the file is empty") from None
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
    for col in [*wanted.values(), *outs]:
        if col not in header:
            raise DataError(f"{path}: missing column {col!r} (header: {', '.join(header)})")
    keys = [*wanted.items(), *((o, o) for o in outs)]
    cols = [header.index(col) for _, col in keys]
    labels = {key: f"column {col!r}" for key, col in keys}
    try:  # fast path; on failure the slow path below names the bad cell
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "no data": reported below with the file name
            data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=cols, ndmin=2)
        if data.shape[0]:
            return ({key: data[:, k] for k, (key, _) in enumerate(keys)}, tuple(outs), np.arange(2, data.shape[0] + 2),
                    labels)
    except ValueError:
        pass
    with path.open(newline="", encoding="utf-8-sig") as fh:
        raw = list(csv.reader(fh))[1:]
    if not raw:
        raise DataError(f"{path}: no data rows below the header")
    table = {}
    for (key, col), j in zip(keys, cols):
        values = np.empty(len(raw))
        for i, row in enumerate(raw):
            try:
                values[i] = float(row[j])
            except (IndexError, ValueError):
                cell = row[j] if j < len(row) else "<missing>"
                raise DataError(f"{path}: row {i + 2}, column {col!r}: {cell!r} is not a number") from None
        table[key] = values
    return table, tuple(outs), np.arange(2, len(raw) + 2), labels


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
    rows = [r for r in ws.iter_rows(values_only=True)]
    wb.close()
    return _table_from_rows(path, rows, index, first_row=1)


def _table_from_rows(path, rows, index, *, first_row):
    table, outs, labels = {}, [], {}
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
                    raise DataError(f"{path}: row {i + first_row}, column {j + 1} ({role}): {cell!r} is not a "
                                    "number") from None
            table[key] = values
            labels[key] = f"column {j + 1} ({role})"
    if not rows:
        raise DataError(f"{path}: the sheet is empty")
    return table, tuple(outs), np.arange(first_row, len(rows) + first_row), labels


def _read_tdms(path: Path, columns):
    from nptdms import TdmsFile

    try:
        tdms = TdmsFile.read(path)
    except Exception as exc:  # npTDMS raises many types for a bad file
        raise DataError(f"{path}: cannot read the TDMS file ({exc})") from None
    channels = {ch.name: ch for group in tdms.groups() for ch in group.channels()}
    table, outs, labels = {}, [], {}
    n = None
    for role, names in columns.items():
        for k, name in enumerate(names):
            if name not in channels:
                raise DataError(f"{path}: no channel {name!r} ({role}); channels: {', '.join(channels)}")
            values = np.asarray(channels[name][:], dtype=float)
            if n is not None and values.size != n:
                raise DataError(f"{path}: channel {name!r} has {values.size} samples, others {n}")
            n = values.size
            key = {"frequency": "frequency_hz", "time": "time_s", "current": "current_a"}.get(role)
            if role == "velocity":
                key = f"velocity_{name}" if len(names) > 1 else "velocity_m_per_s"
                outs.append(key)
            table[key] = values
            labels[key] = f"channel {name!r} ({role})"
    return table, tuple(outs), np.arange(1, (n or 0) + 1), labels


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
        fs = 1.0 / float(np.median(d))
        if fs / fb < MIN_SAMPLES_PER_PERIOD * (1 - 1e-6):     # tolerance: times read from text are rounded
            raise DataError(f"{label}: {fs / fb:.2f} samples per period; at least {MIN_SAMPLES_PER_PERIOD} are "
                            f"needed (sample rate {fs:g} Hz is too low for {fb:g} Hz)")
        if (t[-1] - t[0]) * fb < (MIN_PERIODS + 1) * (1 - 1e-6):
            raise DataError(f"{label}: {(t[-1] - t[0]) * fb:.2f} periods recorded; at least {MIN_PERIODS} whole "
                            "periods are needed after settling (record longer)")
        i = table["current_a"][a:b]
        if np.ptp(i) <= 1e-12 * max(1.0, float(np.max(np.abs(i)))):
            raise DataError(f"{label}, {labels['current_a']}: the current is "
                            f"{'zero' if not np.any(i) else 'constant'}; "
                            "a stepped-sine block needs a sinusoidal current")
        vel = np.vstack([table[o][a:b] for o in outs])
        blocks.append(Block(fb, t - t[0], i, vel))
    order = np.argsort([b.f_hz for b in blocks], kind="stable")
    return Recording(tuple(blocks[k] for k in order), tuple(outs), source=where)
