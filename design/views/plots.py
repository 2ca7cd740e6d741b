"""Matplotlib figures (compute, plot and command line are separate layers).

Every function takes computed results, draws on ``ax``/``axes`` when given (else makes a
new figure) and returns the figure; nothing is shown or saved here. The backend is the caller's
(the command line selects Agg; a notebook keeps its own).
"""

from __future__ import annotations

from collections.abc import Sequence

import matplotlib.pyplot as plt
import numpy as np

from design.loop.margins import unwrapped_phase_deg


def fixed_margins(fig, *, left_in: float = 0.75, right_in: float = 0.15, bottom_in: float = 0.55,
                  top_in: float = 0.35, wspace: float = 0.22, hspace: float = 0.25):
    """Margins in inches instead of a tight layout, which draws every tick label twice (about a
    third of a report's drawing time); the defaults fit this tool's labels at fontsize 10."""
    w, h = fig.get_size_inches()
    fig.subplots_adjust(left=left_in / w, right=1 - right_in / w, bottom=bottom_in / h, top=1 - top_in / h,
                        wspace=wspace, hspace=hspace)
    return fig


def bode(w_rad_s, responses: Sequence[np.ndarray], labels: Sequence[str], *, axes=None, title: str = "",
         bands: Sequence[np.ndarray | None] | None = None, styles: Sequence[str] | None = None,
         unit: str = "", legend: bool = True, wrap_phase: bool = False):
    """Magnitude (dB, of ``unit``) and phase (deg) against frequency (Hz); ``bands`` are optional 2-sigma
    magnitude half-widths (same units as the response) drawn as shaded regions. With ``wrap_phase`` the phase
    is drawn in (-180, 180] deg instead of unwrapped."""
    if axes is None:
        fig, axes = plt.subplots(2, 1, sharex=True, figsize=(7, 5.5), layout="tight")
    fig = axes[0].figure
    f = np.asarray(w_rad_s) / (2 * np.pi)
    for k, (resp, label) in enumerate(zip(responses, labels)):
        style = styles[k] if styles else "-"
        mag = np.abs(resp)
        # a response of zero (a model that holds the stage still by its friction) leaves a gap
        line, = axes[0].semilogx(f, 20 * np.log10(np.where(mag > 0, mag, np.nan)), style, label=label)
        if bands and bands[k] is not None:
            lo = np.maximum(mag - bands[k], mag * 1e-3)
            axes[0].fill_between(f, 20 * np.log10(lo), 20 * np.log10(mag + bands[k]), color=line.get_color(),
                                 alpha=0.2, lw=0)
        phase = wrapped_phase_deg(resp) if wrap_phase else unwrapped_phase_deg(resp)
        axes[1].semilogx(f, phase, linestyle=line.get_linestyle(), color=line.get_color(),
                         marker=line.get_marker(), markersize=line.get_markersize())
    axes[0].set_ylabel(f"magnitude (dB re 1 {unit})" if unit else "magnitude (dB)")
    axes[1].set_ylabel("phase (deg)")
    if wrap_phase:
        axes[1].set(ylim=(-185.0, 185.0), yticks=np.arange(-180.0, 181.0, 90.0))
    axes[1].set_xlabel("frequency (Hz)")
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    if legend:
        axes[0].legend(fontsize=8)
    if title:
        axes[0].set_title(title)
    return fig


def wrapped_phase_deg(resp) -> np.ndarray:
    """Phase (deg) in (-180, 180], NaN at each point where it wraps, so that no line joins -180 and 180."""
    p = np.angle(np.asarray(resp), deg=True)
    p[1:][np.abs(np.diff(p)) > 180.0] = np.nan
    return p


def payload_sweep_figure(sweeps, *, axes=None, labels: Sequence[str] | None = None):
    """Thesis Figure 4.31 extended: plant corner and closed-loop bandwidth (Hz) and phase margin
    against payload, one line per ``PayloadSweep``."""
    if axes is None:
        fig, axes = plt.subplots(1, 3, figsize=(12, 3.8), layout="tight")
    fig = axes[0].figure
    for k, s in enumerate(sweeps):
        label = labels[k] if labels else f"Stage {s.stage.upper()}"
        axes[0].plot(s.payload_kg, s.open_loop_corner_hz, "o-", label=label)
        axes[1].plot(s.payload_kg, s.closed_loop_bandwidth_hz, "o-", label=label)
        axes[2].plot(s.payload_kg, s.phase_margin_deg, "o-", label=label)
    titles = ("open-loop (plant corner) bandwidth", "closed-loop bandwidth", "phase margin")
    for ax, title, unit in zip(axes, titles, ("Hz", "Hz", "deg")):
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("payload (kg)")
        ax.set_ylabel(unit)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=8)
    return fig
