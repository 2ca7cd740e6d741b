"""Matplotlib figures (compute, plot and command line are separate layers).

Every function takes computed results, draws on ``ax``/``axes`` when given (else makes a
new figure) and returns the figure; nothing is shown or saved here. The backend is the caller's
(the command line selects Agg; a notebook keeps its own).
"""

from __future__ import annotations

from collections.abc import Sequence

import matplotlib.pyplot as plt


def fixed_margins(fig, *, left_in: float = 0.75, right_in: float = 0.15, bottom_in: float = 0.55,
                  top_in: float = 0.35, wspace: float = 0.22, hspace: float = 0.25):
    """Margins in inches instead of a tight layout, which draws every tick label twice (about a
    third of a report's drawing time); the defaults fit this tool's labels at fontsize 10."""
    w, h = fig.get_size_inches()
    fig.subplots_adjust(left=left_in / w, right=1 - right_in / w, bottom=bottom_in / h, top=1 - top_in / h,
                        wspace=wspace, hspace=hspace)
    return fig


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
