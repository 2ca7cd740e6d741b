"""Where a mouse means to go on the floor: two-dimensional paths for the planar mouse run
(``design.admittance.planar_run``), at the drive's ticks.

* ``diagonal_path``: the spec's trapezoid (``design.admittance.profile.trapezoid``: peak speed, peak
  acceleration, travel) along a heading (degrees from the beam's X axis toward +Y);
* ``turn_path``: the same speed profile along a straight run on X, a quarter circle of ``radius_m`` and a
  straight run on Y (the speed's trapezoid over the whole length; on the arc the mouse's acceleration has its
  centripetal part v^2 / R);
* ``planar_path_from_csv``: a recorded path (CSV columns ``time_s``, ``x_m``, ``y_m``), smoothed and
  differentiated as ``design.admittance.mouse_run.path_from_csv`` does for one axis.

Each starts at (0, 0), relative to where the clamp is, with rest before and after.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from design.admittance.profile import trapezoid
from plant.errors import DataError, ParameterError
from plant.host.text_io import read_text

#: rest before and after a path (s)
REST_S = 1.0
#: a mouse's turn on the floor: the quarter circle's radius (m; assumption, a body length and a half)
TURN_RADIUS_M = 0.05


@dataclass(frozen=True)
class PlanarPath:
    """Time (s, the drive's ticks) and the intended position (m), velocity (m/s) and acceleration (m/s^2),
    each (n, 2) as (x along the beam, y along the rails)."""

    time_s: np.ndarray
    position_m: np.ndarray
    velocity_m_per_s: np.ndarray
    acceleration_m_per_s2: np.ndarray
    source: str

    @property
    def speed_m_per_s(self) -> np.ndarray:
        return np.hypot(*self.velocity_m_per_s.T)


def _along(locomotion, rate_hz: float, rest_s: float):
    """Time, distance s (m), speed s' and its rate s'' of the spec's trapezoid at ``rate_hz``."""
    prof = trapezoid(locomotion, dt_s=1.0 / rate_hz, rest_s=rest_s)
    v = prof.velocity_m_per_s
    s = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]))]) / rate_hz
    return prof.time_s, s, v, prof.acceleration_m_per_s2


def _words(locomotion) -> str:
    return (f"{locomotion.travel_m:g} m at {locomotion.peak_speed_m_per_s:g} m/s, "
            f"{locomotion.peak_acceleration_m_per_s2:g} m/s^2")


def diagonal_path(locomotion, rate_hz: float, *, heading_deg: float = 45.0, rest_s: float = REST_S) -> PlanarPath:
    """The spec's trapezoid along ``heading_deg`` (0: along X, 90: along Y)."""
    if not math.isfinite(heading_deg):
        raise ParameterError(f"heading_deg must be a finite angle, got {heading_deg!r}")
    t, s, v, a = _along(locomotion, rate_hz, rest_s)
    u = np.array([math.cos(math.radians(heading_deg)), math.sin(math.radians(heading_deg))])
    return PlanarPath(t, np.outer(s, u), np.outer(v, u), np.outer(a, u),
                      f"a straight run at {heading_deg:g} deg, {_words(locomotion)}")


def turn_path(locomotion, rate_hz: float, *, radius_m: float = TURN_RADIUS_M, rest_s: float = REST_S) -> PlanarPath:
    """Along X, a left quarter turn of ``radius_m``, then along Y, the spec's speed trapezoid over the
    whole length (``locomotion.travel_m``, which must hold the arc)."""
    arc = math.pi * radius_m / 2
    if not (math.isfinite(radius_m) and radius_m > 0 and arc < locomotion.travel_m):
        raise ParameterError(f"radius_m: the quarter turn ({arc:.3g} m of arc) must fit in the travel "
                             f"({locomotion.travel_m:g} m) with a positive radius, got {radius_m!r}")
    leg = (locomotion.travel_m - arc) / 2
    t, s, v, a = _along(locomotion, rate_hz, rest_s)
    phase = np.clip((s - leg) / radius_m, 0.0, math.pi / 2)          # the heading along the path (rad)
    on_arc = (s > leg) & (s < leg + arc)
    x = np.where(s <= leg, s, leg + radius_m * np.sin(phase))
    y = np.where(s <= leg, 0.0, radius_m * (1 - np.cos(phase)) + np.maximum(s - leg - arc, 0.0))
    tangent = np.stack([np.cos(phase), np.sin(phase)], axis=1)
    normal = np.stack([-np.sin(phase), np.cos(phase)], axis=1)
    acc = a[:, None] * tangent + np.where(on_arc, v**2 / radius_m, 0.0)[:, None] * normal
    return PlanarPath(t, np.stack([x, y], axis=1), v[:, None] * tangent, acc,
                      f"a run with a quarter turn of {radius_m:g} m radius, {_words(locomotion)}")


def planar_path_from_csv(path, rate_hz: float, *, rest_s: float = REST_S) -> PlanarPath:
    """A recorded path (CSV with columns ``time_s``, ``x_m``, ``y_m``), resampled to ``rate_hz`` after a 5 ms
    moving average on each axis, ``rest_s`` of rest before and after; DataError naming the file and row."""
    p = Path(path)
    lines = [ln for ln in read_text(p, what="path file").splitlines() if ln.strip()]
    if not lines:
        raise DataError(f"{p}: empty; expected a header time_s,x_m,y_m and rows")
    header = [h.strip() for h in lines[0].split(",")]
    for col in ("time_s", "x_m", "y_m"):
        if col not in header:
            raise DataError(f"{p}: missing column {col!r} (header: {', '.join(header)})")
    cols = [header.index(c) for c in ("time_s", "x_m", "y_m")]
    rows = []
    for number, line in enumerate(lines[1:], start=2):
        cells = line.split(",")
        try:
            values = [float(cells[c]) for c in cols]
        except (IndexError, ValueError):
            raise DataError(f"{p}: row {number}: expected numbers in columns time_s, x_m and y_m, got "
                            f"{line[:60]!r}") from None
        if not all(math.isfinite(v) for v in values) or max(abs(values[1]), abs(values[2])) >= 1e3:
            raise DataError(f"{p}: row {number}: {line[:60]!r} is not a finite time and positions within 1 km")
        rows.append(values)
    data = np.asarray(rows)
    if len(data) < 3 or np.any(np.diff(data[:, 0]) <= 0):
        raise DataError(f"{p}: need at least 3 rows with strictly increasing time_s")
    t = data[:, 0] - data[0, 0]
    if t[-1] > 600:
        raise DataError(f"{p}: {t[-1]:.0f} s of path; at most 600 s can be simulated")
    grid = np.arange(0.0, t[-1] + 2 * rest_s, 1.0 / rate_hz)
    width = max(int(round(0.005 * rate_hz)), 1)
    kernel = np.ones(2 * width + 1) / (2 * width + 1)
    axes = []
    for j in (1, 2):
        xs = np.interp(grid - rest_s, t, data[:, j] - data[0, j])
        axes.append(np.convolve(np.pad(xs, width, mode="edge"), kernel, mode="same")[width:-width])
    x = np.stack(axes, axis=1)
    v = np.gradient(x, 1.0 / rate_hz, axis=0)
    return PlanarPath(grid, x, v, np.gradient(v, 1.0 / rate_hz, axis=0), f"recorded path {p.name}")
