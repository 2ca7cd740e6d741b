"""Stepped-sine recordings: one block per excitation frequency (thesis section 4.1).

A ``Recording`` holds the raw samples of every block; readers for CSV, the thesis's
``.xlsx`` spreadsheets and LabVIEW ``.tdms`` files return one, the simulator produces
one, and ``write_recording_csv`` writes the CSV format of ``shared/ARCHITECTURE.md``
(long format: ``frequency_hz,time_s,current_a,velocity...``) atomically.
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class Block:
    """Samples of one excitation frequency; ``time_s`` restarts at 0 in every block."""

    f_hz: float
    time_s: np.ndarray
    current_a: np.ndarray
    #: shape (n_outputs, n_samples), m/s
    velocity_m_per_s: np.ndarray

    @property
    def sample_rate_hz(self) -> float:
        return float(1.0 / np.median(np.diff(self.time_s)))


@dataclass(frozen=True)
class Recording:
    """A stepped-sine recording: blocks in increasing frequency and the output column names."""

    blocks: tuple[Block, ...]
    #: CSV column names of the outputs, e.g. ("velocity_m_per_s",) or
    #: ("velocity_y1_m_per_s", "velocity_y2_m_per_s")
    output_names: tuple[str, ...]
    source: str = "<memory>"
    #: free-form provenance (simulator settings, seed, ...), written as CSV comment-free sidecar by callers
    metadata: dict = field(default_factory=dict)

    @property
    def f_hz(self) -> np.ndarray:
        return np.array([b.f_hz for b in self.blocks])


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and a rename (never half-written)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent if str(path.parent) else ".", prefix=f".{path.name}.", suffix=".tmp")
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file the usual permissions
        with os.fdopen(fd, "w", newline="") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_recording_csv(recording: Recording, path: str | Path) -> None:
    """Write the long CSV format of ``shared/ARCHITECTURE.md`` atomically."""
    import io

    n_out = len(recording.output_names)
    buf = io.StringIO()
    buf.write(",".join(["frequency_hz", "time_s", "current_a", *recording.output_names]) + "\n")
    for b in recording.blocks:
        cols = np.column_stack([np.full(b.time_s.shape, b.f_hz), b.time_s, b.current_a, *b.velocity_m_per_s])
        np.savetxt(buf, cols, fmt=["%.10g", "%.9f", "%.9g"] + ["%.9g"] * n_out, delimiter=",")
    atomic_write_text(path, buf.getvalue())
