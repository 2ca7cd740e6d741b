"""Robustness sweeps: loop margins and bandwidth against payload, with Monte Carlo over uncertainty.

For every payload the same parameter samples are used (common random numbers), so sample
``j`` is one physical machine carried through the whole payload range and the percentile
bands against payload are smooth. Each uncertain parameter is drawn independently and
uniformly between its ``min`` and ``max`` (``plant.uncertainty`` of the spec file). The
nominal sweep uses the default analysis grid (it equals ``design.loop.analysis.payload_sweep``);
the samples use the fast path of ``design.loop.fast`` in chunks, so memory stays bounded.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from design.loop.analysis import PayloadSweep, payload_sweep
from design.loop.controller import PI
from design.loop.fast import fast_analyse_batch
from design.loop.margins import BANDWIDTH_LEVELS2
from design.problem import LoopProblem, Uncertainty
from plant.errors import ParameterError, SpecError
from plant.physics.models import Plant

DEFAULT_PERCENTILES = (5.0, 50.0, 95.0)
#: plants evaluated per chunk of the fast path (x 281 grid points: ~18 MB per complex array)
CHUNK_PLANTS = 4096
SAMPLING = "uniform, independent per parameter, the same samples at every payload"
#: the swept quantities: name -> unit; for all of them lower is worse
QUANTITIES = {"closed_loop_bandwidth_hz": "Hz", "phase_margin_deg": "deg", "gain_margin_db": "dB"}
#: a margin may fall short of its requirement by this much (deg, dB) and pass (rounding; as the verification)
MARGIN_TOLERANCE = 0.05


def percentiles_inf(x: np.ndarray, q, *, axis: int = -1) -> np.ndarray:
    """Linear-interpolation percentiles along ``axis`` that keep ``+inf`` (an infinite gain margin)
    instead of turning it into nan; nan (undefined) sorts above every value. Shape ``(len(q), ...)``."""
    xs = np.sort(np.moveaxis(np.asarray(x, float), axis, -1), axis=-1)
    n = xs.shape[-1]
    pos = np.asarray(q, float) / 100.0 * (n - 1)
    i = np.floor(pos).astype(int)
    j = np.minimum(i + 1, n - 1)
    t = (pos - i).reshape(-1, *[1] * (xs.ndim - 1))
    lo, hi = np.moveaxis(xs[..., i], -1, 0), np.moveaxis(xs[..., j], -1, 0)
    with np.errstate(invalid="ignore"):
        return np.where((t == 0) | (lo == hi), lo, lo + t * (hi - lo))


@dataclass(frozen=True)
class Distribution:
    """One quantity across payloads and samples (lower is worse for all of them)."""

    name: str
    unit: str
    #: raw values, shape (n_payloads, n_samples)
    samples: np.ndarray
    #: percentile levels (%) of ``percentiles``
    levels: tuple[float, ...]
    #: percentiles per payload, shape (len(levels), n_payloads)
    percentiles: np.ndarray
    #: minimum over the samples per payload (nan samples ignored), shape (n_payloads,)
    worst: np.ndarray

    def percentile(self, level: float) -> np.ndarray:
        """Percentile ``level`` (%) per payload."""
        return percentiles_inf(self.samples, [level])[0]


@dataclass(frozen=True)
class WorstCase:
    """The overall worst sample of one quantity: its value, payload and parameters."""

    name: str
    value: float
    payload_kg: float
    sample_index: int
    parameters: dict[str, float]


@dataclass(frozen=True)
class SweepCheck:
    """A sweep against the spec's requirements: the violations, one per payload and requirement (worst sample)."""

    phase_margin_deg: float
    gain_margin_db: float
    min_bandwidth_hz: float | None
    violations: tuple[str, ...]

    @property
    def meets(self) -> bool:
        return not self.violations


@dataclass(frozen=True)
class SweepResult:
    """Margins and bandwidth against payload: nominal curve and Monte Carlo statistics.

    With ``samples == 0`` the nominal plant is the only sample, so the percentile bands and
    the worst case collapse onto the nominal curve.
    """

    stage: str
    controller: PI
    payload_kg: np.ndarray
    seed: int
    samples: int
    sampling: str
    #: parameter name -> (min, max) of the uniform distribution
    uncertainty: dict[str, tuple[float, float]]
    #: parameter name -> drawn values, shape (n_samples,) (the nominal value when samples == 0)
    parameter_samples: dict[str, np.ndarray]
    #: nominal plant on the default analysis grid (equals ``design.loop.analysis.payload_sweep``)
    nominal: PayloadSweep
    closed_loop_bandwidth_hz: Distribution
    phase_margin_deg: Distribution
    gain_margin_db: Distribution
    #: samples per payload whose closed loop is unstable (their margins are no guarantee), (n_payloads,)
    unstable_samples: np.ndarray
    #: "half_power" (|T(0)|/sqrt 2) or "minus_3_db"
    bandwidth_definition: str = "half_power"

    def check(self, requirements) -> SweepCheck:
        """The swept loops against ``requirements`` (phase and gain margin, minimum bandwidth): every sample
        at every payload, the worst case of each payload named."""
        found = []
        for i, m in enumerate(self.payload_kg):
            if self.unstable_samples[i]:
                found.append(f"{int(self.unstable_samples[i])} unstable closed loop(s) at {m:g} kg")
            pm, gm = float(self.phase_margin_deg.worst[i]), float(self.gain_margin_db.worst[i])
            bw = float(self.closed_loop_bandwidth_hz.worst[i])
            if pm < requirements.phase_margin_deg - MARGIN_TOLERANCE:
                found.append(f"phase margin {pm:.1f} deg < {requirements.phase_margin_deg:g} at {m:g} kg")
            if gm < requirements.gain_margin_db - MARGIN_TOLERANCE:
                found.append(f"gain margin {gm:.1f} dB < {requirements.gain_margin_db:g} at {m:g} kg")
            if requirements.min_bandwidth_hz is not None and not bw >= requirements.min_bandwidth_hz:
                found.append(f"bandwidth {bw:.2f} Hz < {requirements.min_bandwidth_hz:g} at {m:g} kg")
        return SweepCheck(requirements.phase_margin_deg, requirements.gain_margin_db, requirements.min_bandwidth_hz,
                          tuple(found))

    @property
    def distributions(self) -> tuple[Distribution, ...]:
        return (self.closed_loop_bandwidth_hz, self.phase_margin_deg, self.gain_margin_db)

    @property
    def levels(self) -> tuple[float, ...]:
        return self.closed_loop_bandwidth_hz.levels

    def worst_case(self) -> dict[str, WorstCase]:
        """The overall worst sample of each quantity over all payloads."""
        out = {}
        for d in self.distributions:
            x = np.where(np.isnan(d.samples), np.inf, d.samples)
            ip, js = np.unravel_index(int(np.argmin(x)), x.shape)
            params = {k: float(v[js]) for k, v in self.parameter_samples.items()}
            out[d.name] = WorstCase(d.name, float(d.samples[ip, js]), float(self.payload_kg[ip]), int(js), params)
        return out



def checked_ranges(uncertainty: Mapping, plant: Plant) -> dict[str, tuple[float, float]]:
    """Validate ``uncertainty`` (name -> Uncertainty or (min, max)) against the plant's parameters."""
    known = plant.parameters()
    out = {}
    for name, rng in uncertainty.items():
        key = f"plant.uncertainty.{name}"
        lo, hi = (rng.min, rng.max) if isinstance(rng, Uncertainty) else rng
        lo, hi = float(lo), float(hi)
        if name == "mass_kg":
            raise SpecError(f"{key}: the payload is swept (payload range / --payload), it cannot also be uncertain")
        if name not in known:
            others = ", ".join(k for k in known if k != "mass_kg")
            raise SpecError(f"{key}: the plant has no parameter {name!r}; its parameters are {others} "
                            "(effect parameters need the effect under plant.effects)")
        p = known[name]
        if not (np.isfinite(lo) and np.isfinite(hi)) or hi < lo:
            raise SpecError(f"{key}: need finite min <= max, got [{lo:g}, {hi:g}]")
        if lo < p.lower or hi > p.upper:
            raise SpecError(f"{key}: range [{lo:g}, {hi:g}] leaves the physical bounds [{p.lower:g}, {p.upper:g}] "
                            f"{p.unit}")
        out[name] = (lo, hi)
    return out


def draw_samples(uncertainty: Mapping[str, tuple[float, float]], samples: int, *, seed: int) -> dict[str, np.ndarray]:
    """Independent uniform draws per parameter (``numpy.random.default_rng(seed)``), in name order."""
    rng = np.random.default_rng(seed)
    return {name: rng.uniform(lo, hi, samples) for name, (lo, hi) in sorted(uncertainty.items())}


def batch_plant(plant: Plant, payload_kg, parameters: Mapping[str, np.ndarray], *, rows=None) -> Plant:
    """One plant per (payload, sample) pair as an ``(n, 1)`` parameter batch, payload-major: flat row
    ``r`` is payload ``r // n_samples`` with sample ``r % n_samples``; ``rows`` selects some (default all)."""
    m = np.asarray(payload_kg, float).ravel()
    n_s = len(next(iter(parameters.values()))) if parameters else 1
    r = np.arange(m.size * n_s) if rows is None else np.asarray(rows, int)
    values = {"mass_kg": m[r // n_s][:, None]}
    values.update({k: np.asarray(v, float)[r % n_s][:, None] for k, v in parameters.items()})
    return plant.with_values(values)


def monte_carlo_sweep(source: LoopProblem | Plant, *, payload_kg=None, samples: int = 0, seed: int = 0,
                      controller: PI | None = None, uncertainty: Mapping | None = None, percentiles=DEFAULT_PERCENTILES,
                      progress: Callable[[int, int], None] | None = None) -> SweepResult:
    """Sweep the velocity loop P (Kp + Ki/s) over ``payload_kg`` with ``samples`` Monte Carlo draws.

    ``source`` is a ``LoopProblem`` (plant, uncertainty, gains and payload range default to it) or a
    ``Plant`` (then ``payload_kg`` and ``controller`` are required). ``uncertainty`` maps parameter
    names (``damping_n_s_per_m``, ``delay.seconds``) to ``(min, max)``; ``progress(done, total)``
    is called after each chunk of plants. ``controller``: the PI (default the spec's ``controller`` values).
    """
    definition = "half_power"
    if isinstance(source, LoopProblem):
        definition = source.requirements.bandwidth_definition
        plant = source.plant.plant()
        uncertainty = source.plant.uncertainty if uncertainty is None else uncertainty
        payload_kg = source.plant.payload_kg.grid() if payload_kg is None else payload_kg
        if controller is None:
            for key in ("kp", "ki"):
                if getattr(source.controller, key).value is None:
                    raise SpecError(f"controller.{key}.value is needed for a sweep (or pass a controller)")
            controller = PI(source.controller.kp.value, source.controller.ki.value)
    elif isinstance(source, Plant):
        plant = source
        if payload_kg is None or controller is None:
            raise ParameterError("a sweep of a Plant needs payload_kg and a controller")
    else:
        raise ParameterError(f"source must be a LoopProblem or a Plant, got {type(source).__name__}")
    m = np.asarray(payload_kg, float).ravel()
    if m.size == 0 or not np.all(np.isfinite(m)) or np.any(m <= 0):
        raise ParameterError("payload_kg must be one or more finite positive masses (kg)")
    if int(samples) != samples or samples < 0:
        raise ParameterError(f"samples must be a non-negative integer, got {samples!r}")
    levels = tuple(float(q) for q in percentiles)
    if not levels or any(not 0 <= q <= 100 for q in levels):
        raise ParameterError(f"percentiles must lie in [0, 100], got {percentiles!r}")
    ranges = checked_ranges(uncertainty or {}, plant)
    if samples and not ranges:
        raise SpecError("plant.uncertainty: no parameter ranges to sample; add some or drop --samples")

    level2 = BANDWIDTH_LEVELS2[definition]
    nominal = payload_sweep(plant, controller, m, level2=level2)
    if samples:
        params = draw_samples(ranges, int(samples), seed=seed)
        raw = _fast_samples(plant, m, params, controller, progress, level2)
        unstable = np.sum(~raw.pop("stable"), axis=1)
    else:
        params = {name: np.array([plant.parameters()[name].value]) for name in sorted(ranges)}
        raw = {q: getattr(nominal, q)[:, None] for q in QUANTITIES}
        unstable = (~nominal.closed_loop_stable).astype(int)
        if progress is not None:
            progress(m.size, m.size)
    dists = {q: Distribution(q, unit, raw[q], levels, percentiles_inf(raw[q], levels), np.fmin.reduce(raw[q], axis=1))
             for q, unit in QUANTITIES.items()}
    return SweepResult(plant.stage, controller, m, int(seed), int(samples), SAMPLING, ranges, params,
                       nominal, **dists, unstable_samples=unstable, bandwidth_definition=definition)


def _fast_samples(plant, m, params, controller: PI, progress, level2: float) -> dict[str, np.ndarray]:
    n_s = len(next(iter(params.values())))
    numbers = fast_analyse_batch(lambda rows: batch_plant(plant, m, params, rows=rows), m.size * n_s, controller,
                                 level2=level2, chunk=CHUNK_PLANTS, progress=progress)
    return {q: getattr(numbers, q).reshape(m.size, n_s) for q in (*QUANTITIES, "stable")}
