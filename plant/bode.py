"""The one Bode plot: magnitude (dB) and phase (deg) against frequency (Hz) of any responses, with optional 2-sigma
bands, drawn on given axes or on a new ``matplotlib.figure.Figure`` made without pyplot (an interactive session's
backend is left as it is; show it in a notebook by leaving it as the cell's value, or save it with ``savefig``).
Every ``.plot()`` of a response or a loop and every Bode figure of the reports draw through it.

May import: nothing of the tool.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def wrapped_phase_deg(resp) -> np.ndarray:
    """Phase (deg) in (-180, 180], NaN at each point where it wraps, so that no line joins -180 and 180."""
    p = np.angle(np.asarray(resp), deg=True)
    p[1:][np.abs(np.diff(p)) > 180.0] = np.nan
    return p


def bode(w_rad_s, responses: Sequence[np.ndarray], labels: Sequence[str], *, axes=None, title: str = "",
         bands: Sequence[np.ndarray | None] | None = None, styles: Sequence[str] | None = None,
         unit: str = "", legend: bool = True, wrap_phase: bool = False, phase_of: Sequence[bool] | None = None,
         marker_size: float | None = None, figsize=(7.0, 5.5)):
    """Magnitude (dB, of ``unit``) and phase (deg) against frequency (Hz) of ``responses`` on ``w_rad_s`` (rad/s).

    ``bands``: 2-sigma half-widths of each response's magnitude (its units; None: none), shaded on the magnitude
    and, as arcsin(band / |response|), on the phase. ``styles``: matplotlib format strings. ``phase_of``: which
    responses get a phase line (default all). ``wrap_phase``: the phase in (-180, 180] instead of unwrapped.
    ``axes``: a (magnitude, phase) pair to draw on; else a new figure. Returns the figure."""
    if axes is None:
        from matplotlib.figure import Figure

        fig = Figure(figsize=figsize, layout="tight")
        axes = fig.subplots(2, 1, sharex=True)
    fig = axes[0].figure
    f = np.asarray(w_rad_s, float) / (2 * np.pi)
    for k, (resp, label) in enumerate(zip(responses, labels)):
        style = styles[k] if styles else "-"
        mag = np.abs(resp)
        extra = {} if marker_size is None else {"ms": marker_size}
        # a response of zero (a model that holds the stage still by its friction) leaves a gap
        line, = axes[0].semilogx(f, 20 * np.log10(np.where(mag > 0, mag, np.nan)), style, label=label, **extra)
        band = bands[k] if bands else None
        if band is not None:
            lo = np.maximum(mag - band, mag * 1e-3)
            axes[0].fill_between(f, 20 * np.log10(lo), 20 * np.log10(mag + band), color=line.get_color(),
                                 alpha=0.2, lw=0)
        if phase_of is not None and not phase_of[k]:
            continue
        phase = wrapped_phase_deg(resp) if wrap_phase else np.degrees(np.unwrap(np.angle(resp), axis=-1))
        axes[1].semilogx(f, phase, linestyle=line.get_linestyle(), color=line.get_color(),
                         marker=line.get_marker(), markersize=line.get_markersize())
        if band is not None:
            spread = np.degrees(np.arcsin(np.minimum(band / np.maximum(mag, 1e-300), 1.0)))
            axes[1].fill_between(f, phase - spread, phase + spread, color=line.get_color(), alpha=0.2, lw=0)
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
