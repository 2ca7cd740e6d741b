"""Where a model fails: normalised residuals, per-band chi-square and their description in words.

Residuals compare a measured response G (with variance E|G_hat - G|^2) to a model M on the
same frequencies. Normalised residuals are (G - M) / sqrt(var/2) for the real and the
imaginary part, each ~N(0, 1) when the model is right. The log-ratio log(G/M) splits the
misfit into a magnitude error (dB) and a phase error (deg).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: a band is "failing" when its reduced chi-square exceeds this (and is improbable under noise)
FAILING_REDUCED_CHI2 = 3.0


@dataclass(frozen=True)
class Band:
    """Misfit in one frequency band (all outputs together)."""

    f_low_hz: float
    f_high_hz: float
    n_points: int
    reduced_chi2: float
    #: mean magnitude error 20 log10 |G/M| and its 2-sigma noise level, dB
    magnitude_error_db: float
    magnitude_noise_db: float
    #: mean phase error angle(G/M) and its 2-sigma noise level, deg (negative: data lags the model)
    phase_error_deg: float
    phase_noise_deg: float


@dataclass(frozen=True)
class ResidualSummary:
    """Per-frequency errors and per-band chi-square of measured vs model."""

    f_hz: np.ndarray
    #: normalised complex residual (real and imaginary parts each ~N(0,1) under noise), (n_out, n_freq)
    normalised: np.ndarray
    magnitude_error_db: np.ndarray   # (n_out, n_freq)
    phase_error_deg: np.ndarray      # (n_out, n_freq)
    bands: tuple[Band, ...]
    failing: tuple[Band, ...]
    description: str

    @property
    def failing_merged(self) -> list[tuple[float, float, float]]:
        """The failing bands, adjacent ones merged (``merge_failing``): (f_low_hz, f_high_hz, reduced_chi2)."""
        return merge_failing(self.bands)


def residual_summary(f_hz, measured, variance, model, *, n_bands: int = 6) -> ResidualSummary:
    """Compare ``measured`` (n_out, n_freq) with ``model`` of the same shape; bands are log-spaced."""
    f = np.asarray(f_hz, float)
    G = np.atleast_2d(measured)
    M = np.atleast_2d(model)
    var = np.atleast_2d(variance)
    sigma = np.sqrt(var / 2)
    norm = (G - M) / sigma
    # where the model holds the stage still (friction it cannot overcome) there is no ratio: NaN, left out
    # of the band means below
    ratio = np.divide(G, M, out=np.full(np.broadcast_shapes(G.shape, M.shape), np.nan + 0j), where=M != 0)
    mag_db = 20 * np.log10(np.abs(ratio))
    ph_deg = np.where(np.isnan(ratio), np.nan, np.degrees(np.angle(ratio)))
    # 1-sigma of log-magnitude (dB) and phase (deg) from the complex noise: sigma/|G| rad
    rel = sigma / np.abs(G)
    mag_noise = 20 / np.log(10) * rel
    ph_noise = np.degrees(rel)

    n_bands = max(1, min(n_bands, f.size // 3 or 1))
    edges = np.geomspace(f.min(), f.max() * (1 + 1e-9), n_bands + 1)
    idx = np.clip(np.searchsorted(edges, f, side="right") - 1, 0, n_bands - 1)
    bands = []
    for k in range(n_bands):
        sel = idx == k
        if not np.any(sel):
            continue
        r = norm[:, sel]
        chi2 = float(np.sum(r.real**2 + r.imag**2))
        dof = 2 * r.size
        defined = np.isfinite(mag_db[:, sel])
        w_m = np.where(defined, 1 / mag_noise[:, sel] ** 2, 0.0)
        w_p = np.where(defined, 1 / ph_noise[:, sel] ** 2, 0.0)
        if not defined.any():
            w_m = w_p = np.full(defined.shape, np.nan)
        bands.append(Band(
            float(f[sel].min()), float(f[sel].max()), int(sel.sum()), chi2 / dof,
            float(np.sum(w_m * np.nan_to_num(mag_db[:, sel])) / np.sum(w_m)), float(2 / np.sqrt(np.sum(w_m))),
            float(np.sum(w_p * np.nan_to_num(ph_deg[:, sel])) / np.sum(w_p)), float(2 / np.sqrt(np.sum(w_p))),
        ))
    failing = tuple(b for b in bands if b.reduced_chi2 > FAILING_REDUCED_CHI2)
    words, rails = describe(tuple(bands), failing), _rails(mag_db, mag_noise)
    return ResidualSummary(f, norm, mag_db, ph_deg, tuple(bands), failing,
                           f"{words.rstrip('.')}; {rails}." if rails else words)


#: the rails' disagreement is told when its weighted mean lies this many standard errors from zero
RAILS_Z = 3.0


def _rails(mag_db: np.ndarray, mag_noise: np.ndarray) -> str:
    """With two outputs (Stage Y's rails): how much more the rails disagree in magnitude than the model has them,
    as the weighted mean over the band of (Y2's magnitude error - Y1's), when significant ("" otherwise): a mean of
    the rails hides a constant disagreement (a rail read to another scale)."""
    if mag_db.shape[0] != 2:
        return ""
    d = mag_db[1] - mag_db[0]
    w = np.where(np.isfinite(d), 1.0 / (mag_noise[0] ** 2 + mag_noise[1] ** 2), 0.0)
    if not np.any(w > 0):
        return ""
    mean, se = float(np.sum(w * np.nan_to_num(d)) / np.sum(w)), float(1.0 / np.sqrt(np.sum(w)))
    if abs(mean) <= RAILS_Z * se:
        return ""
    return f"the rails disagree by {mean:+.2f} ± {se:.2g} dB (Y2 over Y1) beyond the model, on average over the band"


def merge_failing(bands: tuple[Band, ...]) -> list[tuple[float, float, float]]:
    """Adjacent failing bands merged: (f_low_hz, f_high_hz, reduced_chi2 of the merged band)."""
    out: list[list[float]] = []
    prev_high = None
    for b in bands:
        if b.reduced_chi2 <= FAILING_REDUCED_CHI2:
            prev_high = None
            continue
        if out and prev_high is not None:
            lo, _, chi, n = out[-1]
            out[-1] = [lo, b.f_high_hz, (chi * n + b.reduced_chi2 * b.n_points) / (n + b.n_points), n + b.n_points]
        else:
            out.append([b.f_low_hz, b.f_high_hz, b.reduced_chi2, b.n_points])
        prev_high = b.f_high_hz
    return [(lo, hi, chi) for lo, hi, chi, _ in out]


def _significant(value: float, noise: float) -> bool:
    return abs(value) > max(noise, 1e-12)


def describe(bands: tuple[Band, ...], failing: tuple[Band, ...]) -> str:
    """Words for where and how the model fails, e.g. "phase lags the model increasingly above 20 Hz,
    magnitude agrees"."""
    if not failing:
        return "the model agrees with the data within the measurement noise at every frequency"
    start = failing[0].f_low_hz
    words = []
    ph = [b.phase_error_deg for b in failing]
    mag = [b.magnitude_error_db for b in failing]
    ph_sig = [_significant(b.phase_error_deg, b.phase_noise_deg) for b in failing]
    mag_sig = [_significant(b.magnitude_error_db, b.magnitude_noise_db) for b in failing]
    if any(ph_sig):
        growing = len(ph) > 1 and abs(ph[-1]) > abs(ph[0]) * 1.2
        if min(ph) < 0 < max(ph):
            words.append(f"phase departs from the model above {start:.3g} Hz, both ways "
                         f"({min(ph):+.1f} to {max(ph):+.1f} deg)")
        else:
            direction = "lags" if ph[0] < 0 else "leads"
            words.append(f"phase {direction} the model{' increasingly' if growing else ''} above {start:.3g} Hz "
                         f"(up to {max(ph, key=abs):+.1f} deg)")
    if any(mag_sig):
        shape = ""
        signs = np.sign([m for m, s in zip(mag, mag_sig) if s])
        if np.any(signs > 0) and np.any(signs < 0):
            shape = "a local peak/notch pattern"
        elif signs[0] < 0:
            shape = "magnitude falls below the model"
        else:
            shape = "magnitude rises above the model"
        words.append(f"{shape} (up to {max(mag, key=abs):+.2f} dB)")
    else:
        words.append("magnitude agrees")
    ranges = ", ".join(f"{lo:.3g}-{hi:.3g} Hz (reduced chi2 {chi:.1f})" for lo, hi, chi in merge_failing(bands))
    return f"{'; '.join(words)}. Inconsistent with the noise in {ranges}."
