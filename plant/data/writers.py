"""Write recordings: the long stepped-sine CSV of ``docs/formats.md``
(``frequency_hz,time_s,current_a,velocity...``) and a simulation with its JSON sidecar, atomically."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from plant.data.recordings import Recording
from plant.host.files import atomic_write_text, atomic_write_texts


def recording_csv_text(recording: Recording) -> str:
    """The long CSV format of ``docs/formats.md``."""
    import io

    n_out = len(recording.output_names)
    buf = io.StringIO()
    buf.write(",".join(["frequency_hz", "time_s", "current_a", *recording.output_names]) + "\n")
    for b in recording.blocks:
        cols = np.column_stack([np.full(b.time_s.shape, b.f_hz), b.time_s, b.current_a, *b.velocity_m_per_s])
        np.savetxt(buf, cols, fmt=["%.10g", "%.9f", "%.9g"] + ["%.9g"] * n_out, delimiter=",")
    return buf.getvalue()


def write_recording_csv(recording: Recording, path: str | Path) -> None:
    """Write the long CSV format of ``docs/formats.md`` atomically."""
    atomic_write_text(path, recording_csv_text(recording))


def write_simulation(recording: Recording, path: str | Path, *, spec: str | Path | None = None) -> Path:
    """Write a simulated recording (CSV) and its sidecar ``FILE.json`` (tool version, spec, settings, true
    parameters, seed) as a set; returns the sidecar's path."""
    import json

    from plant import __version__

    path = Path(path)
    sidecar = path.with_suffix(".json")
    side = {"recording": path.name, "gantry_version": __version__, "spec": None if spec is None else str(spec),
            "settings": recording.metadata}
    atomic_write_texts({path: recording_csv_text(recording),
                        sidecar: json.dumps(side, indent=2, allow_nan=False) + "\n"})
    return sidecar


