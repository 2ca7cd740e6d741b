"""Read time-domain recordings (CSV, MATLAB ``.mat``) into a validated ``TimeRecording``.

CSV (``docs/formats.md``): a header with ``time_s``, ``current_a`` and outputs whose
names start with ``velocity`` (m/s) or ``position`` (m); a column whose name starts with
``reference`` is a closed loop's reference; other columns are kept by name. A column map
(``parse_column_map``: ``time=t,current=vir,position=qm,reference=qg``) names them otherwise;
for ``.mat`` files it is required and names variables (vectors of equal length; 1 x 1 numbers
in the file, such as a loop's gains, are kept in ``metadata["mat_scalars"]``).

Every problem raises ``DataError`` naming the file, the column or variable and the row
(CSV: as a spreadsheet numbers it, header = row 1) or sample (1-based).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from plant.data.recordings import SAMPLING_TOLERANCE, TimeRecording
from plant.data.table import NumericCsv
from plant.errors import DataError
from plant.host.text_io import data_suffix

#: fewest samples of a time-domain recording
MIN_SAMPLES = 64


def read_time_recording(path: str | Path, *, columns: dict[str, list[str]] | None = None) -> TimeRecording:
    """Read a time-domain CSV or ``.mat`` recording (module doc) and validate it."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file")
    if columns and "frequency" in columns:
        raise DataError(f"{path}: a time-domain recording has no frequency column (remove frequency=... from the "
                        "column map)")
    suffix = data_suffix(path)
    if suffix == ".mat":
        if not columns:
            raise DataError(f"{path}: a .mat file needs a column map naming its variables, e.g. "
                            "--columns time=t,current=vir,position=qm")
        return _validated(path, *_read_mat(path, columns))
    if suffix == ".csv":
        return _validated(path, *_read_csv(path, columns))
    raise DataError(f"{path}: unknown file type {suffix!r} for a time-domain recording; expected .csv or .mat")


def _default_map(path: Path, header: list[str]) -> dict[str, list[str]]:
    """Roles by the header names of ``docs/formats.md``."""
    missing = [c for c in ("time_s", "current_a") if c not in header]
    if missing:
        raise DataError(f"{path}: missing column {missing[0]!r} (header: {', '.join(header)}); or give a column map, "
                        "e.g. --columns time=t,current=i,velocity=v")
    out = {"time": ["time_s"], "current": ["current_a"]}
    velocity = [h for h in header if h.startswith("velocity")]
    position = [h for h in header if h.startswith("position")]
    if velocity and position:
        raise DataError(f"{path}: both velocity and position columns ({velocity[0]!r}, {position[0]!r}); name the "
                        "outputs with a column map")
    if not velocity and not position:
        raise DataError(f"{path}: no output column: expected columns whose names start with 'velocity' (m/s) or "
                        f"'position' (m) (header: {', '.join(header)})")
    out["velocity" if velocity else "position"] = velocity or position
    reference = [h for h in header if h.startswith("reference")]
    if len(reference) > 1:
        raise DataError(f"{path}: {len(reference)} reference columns ({', '.join(reference)}); name one with a "
                        "column map")
    if reference:
        out["reference"] = reference
    return out


def _read_csv(path: Path, columns):
    csv_file = NumericCsv.read(path)
    header = csv_file.header
    columns = columns or _default_map(path, header)
    mapped = [c for cols in columns.values() for c in cols]
    values = csv_file.numbers(mapped, optional=header)                  # unmapped numeric columns ride along
    labels = {h: f"row {{row}}, column {h!r}" for h in header}
    return columns, values, csv_file.rows, labels, {}


def _read_mat(path: Path, columns):
    import scipy.io

    try:
        content = scipy.io.loadmat(path, squeeze_me=False)
    except NotImplementedError:
        raise DataError(f"{path}: a MATLAB v7.3 (HDF5) file; save it with save(..., '-v7') or export a CSV") from None
    except Exception as exc:  # scipy raises several types for a file that is not MAT
        raise DataError(f"{path}: not a readable MATLAB .mat file ({exc})") from None
    variables = {k: v for k, v in content.items() if not k.startswith("__")}
    values, scalars = {}, {}
    for name, v in variables.items():
        if isinstance(v, np.ndarray) and v.dtype.kind in "iuf" and v.size == 1:
            scalars[name] = float(v.item())
    for role, names in columns.items():
        for name in names:
            if name not in variables:
                raise DataError(f"{path}: no variable {name!r} ({role}); variables: {', '.join(sorted(variables))}")
            v = variables[name]
            if not isinstance(v, np.ndarray) or v.dtype.kind not in "iufb" or v.ndim > 2 or min(v.shape) != 1:
                shape = "x".join(map(str, getattr(v, "shape", ()))) or "?"
                raise DataError(f"{path}: variable {name!r} ({role}) is not a numeric vector (shape {shape})")
            values[name] = np.asarray(v, dtype=float).ravel()
    for name, v in variables.items():
        if name not in values and isinstance(v, np.ndarray) and v.dtype.kind in "iuf" and v.ndim == 2 \
                and min(v.shape) == 1 and v.size > 1:
            values[name] = np.asarray(v, dtype=float).ravel()
    labels = {name: f"sample {{row}} of variable {name!r}" for name in values}
    return columns, values, None, labels, {"mat_scalars": scalars}


def _validated(path: Path, columns, values, rows, labels, metadata) -> TimeRecording:
    """Check lengths, finiteness, increasing and uniform time, and that input and outputs move."""
    mapped = {role: names for role, names in columns.items()}
    n = values[mapped["current"][0]].size
    for role, names in mapped.items():
        for name in names:
            if values[name].size != n:
                raise DataError(f"{path}: {name!r} ({role}) has {values[name].size} samples, "
                                f"{mapped['current'][0]!r} has {n}")
    if n < MIN_SAMPLES:
        raise DataError(f"{path}: {n} samples; a time-domain recording needs at least {MIN_SAMPLES}")
    rows = np.arange(1, n + 1) if rows is None else rows
    for role, names in mapped.items():
        for name in names:
            bad = ~np.isfinite(values[name])
            if bad.any():
                raise DataError(f"{path}: {labels[name].format(row=rows[bad.argmax()])}: NaN or infinite value")
    if "time" not in mapped:
        raise DataError(f"{path}: no time column; name it in the column map (time=...)")
    t = values[mapped["time"][0]]
    d = np.diff(t)
    if np.any(d <= 0):
        i = int(np.argmax(d <= 0)) + 1
        restart = (f"; time starting again at {t[i]:g} s looks like the next block of a stepped sine, which "
                   "needs a frequency_hz column naming each block's frequency" if t[i] <= t[0] else "")
        raise DataError(f"{path}: {labels[mapped['time'][0]].format(row=rows[i])}: time must increase "
                        f"({t[i - 1]:g} s then {t[i]:g} s){restart}")
    step = float(np.median(d))
    off = np.abs(d - step) > SAMPLING_TOLERANCE * step
    if off.any():
        i = int(np.argmax(off)) + 1
        raise DataError(f"{path}: {labels[mapped['time'][0]].format(row=rows[i])}: the sampling is not uniform "
                        f"(interval {d[i - 1]:g} s, median {step:g} s); resample the recording first")
    current_name = mapped["current"][0]
    i_a = values[current_name]
    if np.ptp(i_a) == 0:
        raise DataError(f"{path}: the input {current_name!r} never moves (every sample is {i_a[0]:g}): nothing "
                        "excites the plant")
    kind = "velocity" if "velocity" in mapped else "position"
    outputs = mapped[kind]
    for name in outputs:
        if np.ptp(values[name]) == 0:
            raise DataError(f"{path}: the output {name!r} never moves (every sample is {values[name][0]:g})")
    reference = values[mapped["reference"][0]] if "reference" in mapped else None
    used = {c for cols in mapped.values() for c in cols}
    extra = {k: v for k, v in values.items() if k not in used and v.size == n}
    metadata = dict(metadata, columns={role: list(names) for role, names in mapped.items()})
    return TimeRecording(time_s=t - t[0], current_a=i_a, output=np.vstack([values[o] for o in outputs]),
                         output_kind=kind, output_names=tuple(outputs), reference=reference, extra=extra,
                         source=str(path), metadata=metadata)

