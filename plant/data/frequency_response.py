"""Measured frequency responses (velocity per current) with their uncertainty.

``MeasuredResponse`` is the hand-over between estimation (``plant.estimate.lockin``) and fitting,
diagnosis and data-driven synthesis.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from plant.arguments import check_count
from plant.errors import DataError

if TYPE_CHECKING:
    import control


@dataclass(frozen=True)
class MeasuredResponse:
    """Estimated G = V/I per output and frequency.

    ``variance`` is E|G_hat - G|^2 of the complex estimate; its real and imaginary
    parts each carry half of it (circular noise), which is how fits weight them.
    ``method="rms"`` (thesis Appendix B): ``response`` is the real, positive magnitude
    estimate, ``variance`` its scatter, and ``snr_db`` / ``harmonic_distortion`` and the data
    checks are NaN (not estimated).

    ``harmonic_distortion`` may hold NaN also for the lock-in: a harmonic at or above 0.45 x the
    sample rate is aliased and not measurable (``nanmax`` / ``np.isfinite`` before ranking it).
    ``notes`` are the estimator's findings about the data: blocks left out and why, short
    blocks, outputs whose fundamental was not detected, the velocity sensor. The per-block
    data checks (``fundamental_fraction``, ``current_fundamental_fraction``,
    ``current_snr_db``) and ``current_amplitude_variance`` are NaN where not computed; given as None
    they are filled with NaN.
    """

    f_hz: np.ndarray                     # (n_freq,)
    response: np.ndarray                 # complex (n_outputs, n_freq), m/s per A
    variance: np.ndarray                 # (n_outputs, n_freq), (m/s per A)^2
    output_names: tuple[str, ...]
    #: current amplitude (A) of the excitation at each frequency
    current_amplitude_a: np.ndarray      # (n_freq,)
    #: signal-to-noise ratio of the output fundamental, dB
    snr_db: np.ndarray                   # (n_outputs, n_freq)
    #: 2nd and 3rd harmonic amplitude of the output relative to its fundamental
    harmonic_distortion: np.ndarray      # (n_outputs, n_freq, 2)
    source: str = "<memory>"
    method: str = "lock-in"
    metadata: dict = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    #: share of each output's power (about its offset) at the fundamental, (n_outputs, n_freq)
    fundamental_fraction: np.ndarray | None = None
    #: share of the current's power (about its offset) at the fundamental, (n_freq,)
    current_fundamental_fraction: np.ndarray | None = None
    #: fundamental power of the current over its fit residual's, dB, (n_freq,)
    current_snr_db: np.ndarray | None = None
    #: variance of ``current_amplitude_a`` (A^2), (n_freq,): the model of a nonlinear plant depends on it
    current_amplitude_variance: np.ndarray | None = None

    def __post_init__(self) -> None:
        shape = np.shape(self.response)
        for name, default in (("fundamental_fraction", shape), ("current_fundamental_fraction", shape[-1:]),
                              ("current_snr_db", shape[-1:]), ("current_amplitude_variance", shape[-1:])):
            if getattr(self, name) is None:
                object.__setattr__(self, name, np.full(default, np.nan))
        object.__setattr__(self, "notes", tuple(self.notes))

    @property
    def w_rad_s(self) -> np.ndarray:
        return 2 * np.pi * np.asarray(self.f_hz)

    def to_frd(self, output: int | str = 0) -> control.FrequencyResponseData:
        """python-control ``FrequencyResponseData`` of one output (index or name)."""
        import control

        names = self.output_names
        if isinstance(output, str):
            if output not in names:
                raise DataError(f"{self.source}: no output {output!r}; outputs: {', '.join(names)}")
            k = names.index(output)
        else:
            k = check_count("output", output)
            if not 0 <= k < len(names):
                raise DataError(f"{self.source}: output index {output} out of range 0..{len(names) - 1} "
                                f"({', '.join(names)})")
        return control.frd(self.response[k], self.w_rad_s)

    def plot(self):
        """Bode plot of every output with its 2-sigma band (from ``variance``), a ``matplotlib.figure.Figure``
        made without pyplot (an interactive session's backend is left as it is)."""
        from plant.bode import bode

        responses = list(np.atleast_2d(self.response))
        bands = [2 * np.sqrt(np.asarray(v, float)) for v in np.atleast_2d(self.variance)]      # 2 sigma
        return bode(self.w_rad_s, responses, list(self.output_names), bands=bands, styles=["o-"] * len(responses),
                    marker_size=3, unit="(m/s)/A", title=f"{Path(self.source).name}: {self.method}",
                    figsize=(7.0, 5.0))
