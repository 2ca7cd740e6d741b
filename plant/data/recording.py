"""Stepped-sine recordings: one block per excitation frequency (thesis section 4.1).

A ``Recording`` holds the raw samples of every block; readers for CSV, the thesis's
``.xlsx`` spreadsheets and LabVIEW ``.tdms`` files return one, the simulator produces
one, and ``write_recording_csv`` writes the CSV format of ``docs/formats.md``
(long format: ``frequency_hz,time_s,current_a,velocity...``) atomically.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from plant.host.files import atomic_write_text, atomic_write_texts


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


#: fewest distinct levels for values to be taken as lying on a lattice
MIN_LATTICE_LEVELS = 20
#: share of the values that must lie on the lattice
LATTICE_SHARE = 0.999
#: values screened before a large input is checked whole
LATTICE_SCREEN = 4096


def lattice_step(values: np.ndarray) -> float | None:
    """The step s when (almost) every value is an integer multiple n s of it, else None.

    An encoder position (quantum q, m) differenced at the logging rate fs gives velocities on
    the lattice n q fs. The step is first the smallest difference between sorted distinct values
    (differences below 1e-6 of the largest value are rounding of one level and skipped), then
    refined by least squares over all values, sum(n v) / sum(n^2), so that values written with
    9 or 10 significant digits still fit. Accepted when more than ``LATTICE_SHARE`` of the
    values are within 1e-6 + 1e-8 |n| of n s (the relative term: the printing precision of
    large counts) and at least ``MIN_LATTICE_LEVELS`` distinct levels occur (a few levels are
    also what a coarse but continuous signal shows). Continuous data has a smallest difference
    near 1e-6 of its range, so its values lie at random between lattice points: rejected.
    Large inputs are screened on every m-th value first (``LATTICE_SCREEN`` of them), so that
    continuous data is rejected without sorting all of it.
    """
    v = np.asarray(values, dtype=float).ravel()
    if v.size > 4 * LATTICE_SCREEN and _lattice_step(v[:: v.size // LATTICE_SCREEN]) is None:
        return None
    return _lattice_step(v)


def _lattice_step(v: np.ndarray) -> float | None:
    """``lattice_step`` of the 1-d array ``v``, without screening."""
    scale = float(np.max(np.abs(v), initial=0.0))
    if not scale > 0:
        return None
    levels = np.unique(v)
    steps = np.diff(levels)
    steps = steps[steps > 1e-6 * scale]
    if levels.size < MIN_LATTICE_LEVELS or steps.size == 0:
        return None
    n = np.round(v / steps.min())
    step = float(np.dot(n, v) / np.dot(n, n))
    n = np.round(v / step)
    on = np.abs(v / step - n) <= 1e-6 + 1e-8 * np.abs(n)
    if np.mean(on) <= LATTICE_SHARE or np.unique(n).size < MIN_LATTICE_LEVELS:
        return None
    return step


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


