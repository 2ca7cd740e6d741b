"""Write recordings: the long stepped-sine CSV of ``docs/formats.md``
(``frequency_hz,time_s,current_a,velocity...``), the time-domain CSV (``time_s,current_a,position...``) and a
simulation with its JSON sidecar, atomically."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from plant.data.recordings import Recording, TimeRecording
from plant.host.files import atomic_write_text, atomic_write_texts

#: rows formatted per ``%`` operation: bounds the temporary tuple and format string (about 1 MB each)
CSV_CHUNK_ROWS = 16384


def csv_rows(columns: np.ndarray, formats: list[str]) -> str:
    """The rows of ``columns`` (n_rows, n_columns), comma-separated in the printf ``formats`` of each column, one
    line each: the text ``numpy.savetxt(..., fmt=formats, delimiter=",")`` writes, formatted a chunk of rows per
    ``%`` operation instead of one row per Python call (``benchmarks/bench_writer.py`` compares the two)."""
    columns = np.asarray(columns, dtype=float)
    if columns.ndim != 2 or columns.shape[1] != len(formats):
        raise ValueError(f"csv_rows: {columns.shape} columns for {len(formats)} formats")
    row = ",".join(formats) + "\n"
    return "".join((row * len(part)) % tuple(part.ravel().tolist())
                   for part in (columns[i:i + CSV_CHUNK_ROWS] for i in range(0, len(columns), CSV_CHUNK_ROWS)))


def recording_csv_text(recording: Recording) -> str:
    """The long CSV format of ``docs/formats.md``."""
    formats = ["%.10g", "%.9f", "%.9g"] + ["%.9g"] * len(recording.output_names)
    return ",".join(["frequency_hz", "time_s", "current_a", *recording.output_names]) + "\n" + "".join(
        csv_rows(np.column_stack([np.full(b.time_s.shape, b.f_hz), b.time_s, b.current_a, *b.velocity_m_per_s]),
                 formats) for b in recording.blocks)


def time_recording_csv_text(recording: TimeRecording) -> str:
    """The time-domain CSV format of ``docs/formats.md``: ``time_s,current_a`` and the outputs by name."""
    return ",".join(["time_s", "current_a", *recording.output_names]) + "\n" + csv_rows(
        np.column_stack([recording.time_s, recording.current_a, *recording.output]),
        ["%.9f", "%.9g"] + ["%.10g"] * len(recording.output_names))


def write_recording_csv(recording: Recording, path: str | Path) -> None:
    """Write the long CSV format of ``docs/formats.md`` atomically."""
    atomic_write_text(path, recording_csv_text(recording))


def write_simulation(recording: Recording | TimeRecording, path: str | Path, *,
                     spec: str | Path | None = None) -> Path:
    """Write a simulated recording (stepped-sine blocks or a time-domain run, CSV) and its sidecar ``FILE.json``
    (tool version, spec, settings, true parameters, seed) as a set; returns the sidecar's path."""
    import json

    from plant import __version__

    path = Path(path)
    sidecar = path.with_suffix(".json")
    side = {"recording": path.name, "gantry_version": __version__, "spec": None if spec is None else str(spec),
            "settings": recording.metadata}
    text = time_recording_csv_text(recording) if isinstance(recording, TimeRecording) else \
        recording_csv_text(recording)
    atomic_write_texts({path: text,
                        sidecar: json.dumps(side, indent=2, allow_nan=False) + "\n"})
    return sidecar


