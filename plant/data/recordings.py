"""The recording types: a stepped sine (``Recording``: one ``Block`` per excitation frequency,
thesis section 4.1) and a time-domain record of any excitation (``TimeRecording``: multisine, chirp,
PRBS, operating data, closed loop).

A ``TimeRecording`` is one continuous, uniformly sampled record: the drive's input (current in
A, or a command in V or counts whose force per unit is the plant's ``force_constant_n_per_a``),
one or more outputs (velocity in m/s or encoder position in m), and optionally the reference of
a loop that was closed (``reference``, in the outputs' unit). Readers (``plant.data.read``) return
either; the simulator produces stepped sines; ``plant.data.writers`` writes them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from plant.errors import DataError


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


OUTPUT_KINDS = ("velocity", "position")
#: largest relative deviation of a sample interval from the median one (uniform sampling)
SAMPLING_TOLERANCE = 0.01


#: magnitudes no gantry measurement reaches (a corrupt value far out of range would overflow the filters
#: and least squares): 10 kA of motor current, 1 km of travel, 1 km/s
MAX_CURRENT_A = 1e4
MAX_OUTPUT = {"position": 1e3, "velocity": 1e3}
UNITS = {"position": "m", "velocity": "m/s"}


@dataclass(frozen=True)
class TimeRecording:
    """One uniformly sampled record. Arrays: ``time_s`` (n,), ``current_a`` (n,), ``output`` (n_outputs, n)."""

    time_s: np.ndarray
    #: drive input; force = force_constant_n_per_a * current_a (a command in V with its gain in N/V works alike)
    current_a: np.ndarray
    #: velocity (m/s) or position (m) per output, shape (n_outputs, n)
    output: np.ndarray
    #: "velocity" or "position"
    output_kind: str
    #: names of the outputs as the file gives them
    output_names: tuple[str, ...]
    #: reference of a closed loop (same unit as ``output``), or None for open-loop data
    reference: np.ndarray | None = None
    #: further columns of the file, kept by name (SI as in the file)
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    source: str = "<memory>"
    #: scalars the file stated (a .mat file's gains) and provenance
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        t = np.asarray(self.time_s, dtype=float)
        i = np.asarray(self.current_a, dtype=float)
        y = np.atleast_2d(np.asarray(self.output, dtype=float))
        if self.output_kind not in OUTPUT_KINDS:
            raise DataError(f"{self.source}: output kind must be velocity or position, got {self.output_kind!r}")
        if t.ndim != 1 or i.shape != t.shape or y.shape[1:] != t.shape:
            raise DataError(f"{self.source}: time, input and outputs must have the same number of samples "
                            f"(time {t.shape}, input {i.shape}, outputs {y.shape})")
        if len(self.output_names) != y.shape[0]:
            raise DataError(f"{self.source}: {y.shape[0]} outputs but {len(self.output_names)} output names")
        for what, values, limit, unit in (("current", i, MAX_CURRENT_A, "A"),
                                          (self.output_kind, y, MAX_OUTPUT[self.output_kind], UNITS[self.output_kind])):
            far = ~(np.abs(values) <= limit)
            if np.any(far):
                k = int(np.argmax(far.reshape(-1, t.size).any(axis=0)))
                raise DataError(f"{self.source}: sample {k + 1} (t = {t[k]:g} s): a {what} beyond {limit:g} {unit} "
                                "is no measurement of a gantry (a corrupt value)")
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "current_a", i)
        object.__setattr__(self, "output", y)
        if self.reference is not None:
            r = np.asarray(self.reference, dtype=float)
            if r.shape != t.shape:
                raise DataError(f"{self.source}: the reference has {r.size} samples, time {t.size}")
            object.__setattr__(self, "reference", r)

    @property
    def n_samples(self) -> int:
        return int(self.time_s.size)

    @property
    def sample_rate_hz(self) -> float:
        return float(1.0 / np.median(np.diff(self.time_s)))

    @property
    def duration_s(self) -> float:
        return float(self.n_samples / self.sample_rate_hz)
