"""Read any measurement: ``read_measurement`` tells a stepped sine (``plant.data.read_stepped_sine``)
from a time-domain recording (``plant.data.read_time_domain``) by the file and the column map;
``parse_column_map`` and ``parse_scale`` read the command line's ``--columns`` and ``--scale``."""

from __future__ import annotations

from pathlib import Path

from plant.arguments import check_path
from plant.data.read_stepped_sine import read_recording
from plant.data.read_time_domain import read_time_recording
from plant.data.recordings import Recording, TimeRecording
from plant.data.table import csv_header
from plant.errors import DataError
from plant.host.text_io import data_suffix

#: what a column map may name
ROLES = ("frequency", "time", "current", "velocity", "position", "reference")


def read_measurement(path: str | Path, *, columns: dict[str, list[str]] | None = None,
                     sample_rate_hz: float | None = None) -> Recording | TimeRecording:
    """A stepped-sine ``Recording`` or a ``TimeRecording``, by what the file and the column map say.

    ``.mat`` files are time-domain; a CSV is a stepped sine when it has (or the map names) a
    frequency column; spreadsheets and TDMS files are stepped sines (``plant.data.read_stepped_sine``)."""
    path = check_path("path", path)
    if not path.is_file():
        raise DataError(f"{path}: no such file")
    suffix = data_suffix(path)
    if suffix == ".mat":
        return read_time_recording(path, columns=columns)
    if suffix == ".csv":
        stepped = "frequency" in columns if columns else "frequency_hz" in csv_header(path)
        if not stepped:
            return read_time_recording(path, columns=columns)
    return read_recording(path, columns=columns, sample_rate_hz=sample_rate_hz)


def parse_column_map(text: str) -> dict[str, list[str]]:
    """``"frequency=2,current=3,velocity=6,velocity=7"`` -> ``{"frequency": ["2"], ..., "velocity": ["6", "7"]}``.

    Values are 1-based column numbers (spreadsheets), header names (CSV), channel names (TDMS) or
    variable names (MATLAB). A map needs a current and velocity or position outputs; a stepped sine
    also names its frequency column, a time-domain recording its time (and may name a reference)."""
    out: dict[str, list[str]] = {}
    for item in (p.strip() for p in text.split(",") if p.strip()):
        role, eq, col = item.partition("=")
        role = role.strip()
        if not eq or not col.strip():
            raise DataError(f"column map item {item!r}: expected ROLE=COLUMN, e.g. current=3")
        if role not in ROLES:
            raise DataError(f"column map item {item!r}: unknown role {role!r}; roles are {', '.join(ROLES)}")
        out.setdefault(role, []).append(col.strip())
    if "current" not in out:
        raise DataError(f"column map {text!r} names no current column")
    if "velocity" not in out and "position" not in out:
        raise DataError(f"column map {text!r} names no output: give velocity=... or position=...")
    if "velocity" in out and "position" in out:
        raise DataError(f"column map {text!r} names both velocity and position outputs; give one kind")
    for role in ("frequency", "time", "current", "reference"):
        if len(out.get(role, [])) > 1:
            raise DataError(f"column map {text!r} names {len(out[role])} {role} columns; give one")
    named = [c for cols in out.values() for c in cols]
    twice = sorted({c for c in named if named.count(c) > 1})
    if twice:
        raise DataError(f"column map {text!r} names column {twice[0]!r} twice")
    return out


def parse_scale(text: str) -> dict[str, float]:
    """``"velocity=1e-3,velocity:7=0.01"`` -> ``{"velocity": 0.001, "velocity:7": 0.01}``: unit factors
    into SI per role, or per column (``ROLE:COLUMN``, the column as the column map names it);
    both apply where they overlap."""
    out: dict[str, float] = {}
    for item in (p.strip() for p in text.split(",") if p.strip()):
        name, eq, value = item.rpartition("=")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise DataError(f"scale item {item!r}: expected ROLE=FACTOR or ROLE:COLUMN=FACTOR, e.g. velocity=1e-3") \
                from None
        if not eq or not name.strip():
            raise DataError(f"scale item {item!r}: expected ROLE=FACTOR or ROLE:COLUMN=FACTOR, e.g. velocity=1e-3")
    return out
