"""Where X and Y meet: the coupling between the axes read from a stepped sine of the X motor with every encoder
recorded, against the planar model (``plant.physics.planar``), and the geometric error that explains it.

Data: a stepped-sine recording of the X motor whose outputs are the rails' and the carriage's velocities
(``velocity_y1_m_per_s``, ``velocity_y2_m_per_s``, ``velocity_x_m_per_s``; ``plant.data``), estimated by lock-in
(``plant.estimate.lockin``). The coupling is read as each rail's velocity per the carriage's own, R_i = G_yi / G_x:
the drive's chain, the force constant and the current's noise cancel from it, and the planar model gives it from the
mechanics alone, R_i = H_yi,x / H_x,x (velocities per the X motor's force). Its variance follows the lock-in's
(delta method, the two outputs' noise independent): var R = (var G_y + |R|^2 var G_x) / |G_x|^2.

Models: "none" (the planar model as given: with the beam square and the carriage's centre of mass on the X motor's
line, R = 0 at rest), "beam_skew" (epsilon, ``beam_skew_rad``: both rails alike), "carriage_offset" (e,
``carriage_offset_m``: the rails apart, a yaw) and both; each fitted by weighted least squares, ranked by BIC (chi^2 +
k ln n, n real data). A coupling is named when it lowers BIC by ``ACCEPT_DELTA_BIC`` against the smaller model it
extends and each of its values lies inside the search's bounds and at least ``IDENTIFIED_SIGMA`` standard errors from
0 (the covariance scaled by the reduced chi^2 where that exceeds 1, as lmfit's ``scale_covar``); the coupling is "not
explained" when the model chosen leaves a reduced chi^2 above ``EXPLAINED_CHI2`` (the mechanics themselves differ
from the machine: masses, damping, yaw stiffness).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from plant.data.frequency_response import MeasuredResponse
from plant.diagnose.evidence import ACCEPT_DELTA_BIC
from plant.errors import DataError
from plant.physics.planar import MAX_SKEW_RAD, PlanarGantry, mobility
from plant.story import Section, Story, Table

#: the outputs a coupling recording needs, in order: rail Y1, rail Y2, the carriage along the beam (m/s)
OUTPUTS = ("velocity_y1_m_per_s", "velocity_y2_m_per_s", "velocity_x_m_per_s")
#: each model's parameters (``PlanarGantry`` fields), smallest first
MODELS = {"none": (), "beam_skew": ("beam_skew_rad",), "carriage_offset": ("carriage_offset_m",),
          "beam_skew+carriage_offset": ("beam_skew_rad", "carriage_offset_m")}
#: a named coupling's values lie at least this many standard errors from 0
IDENTIFIED_SIGMA = 3.0
#: the model chosen explains the coupling when its reduced chi^2 is at most this
EXPLAINED_CHI2 = 2.0


@dataclass(frozen=True)
class CouplingFit:
    """One model fitted to the measured coupling: its parameters' values and standard errors, chi^2 over ``dof``
    degrees of freedom, and BIC."""

    model: str
    parameters: tuple[str, ...]
    values: tuple[float, ...]
    stderr: tuple[float, ...]
    chi2: float
    dof: int
    bic: float
    #: a value stopped at the bound of the search (the skew's small-angle limit, the offset's half beam)
    at_bound: bool = False

    @property
    def reduced_chi2(self) -> float:
        return self.chi2 / max(self.dof, 1)

    @property
    def identified(self) -> bool:
        return not self.at_bound and all(abs(v) >= IDENTIFIED_SIGMA * s for v, s in zip(self.values, self.stderr))


@dataclass(frozen=True)
class CouplingDiagnosis:
    """The measured coupling (each rail's velocity per the carriage's, (2, n_freq), and its variance), every model's
    fit, the one chosen and the verdict in words."""

    f_hz: np.ndarray
    ratio: np.ndarray
    variance: np.ndarray
    carriage_position_m: float
    fits: tuple[CouplingFit, ...]
    chosen: CouplingFit
    explained: bool
    verdict: str

    def story(self) -> Story:
        """The verdict first, then every model's fit (its values with their errors, reduced χ², BIC)."""
        shown = {"beam_skew_rad": ("skew", 1e3, "mrad"), "carriage_offset_m": ("offset", 1e3, "mm")}
        rows = []
        for f in self.fits:
            values = ", ".join(f"{shown[n][0]} {v * shown[n][1]:.4g} ± {s * shown[n][1]:.2g} {shown[n][2]}"
                               for n, v, s in zip(f.parameters, f.values, f.stderr)) or "-"
            rows.append((f"{f.model} (chosen)" if f is self.chosen else f.model, values, f"{f.reduced_chi2:.3g}",
                         f"{f.bic:.1f}"))
        return Story((("Verdict", self.verdict),),
                     (Section(f"Where X and Y meet (carriage at {self.carriage_position_m:g} m from Y1)",
                              table=Table(("model", "values", "reduced χ²", "BIC"), tuple(rows), frozenset({0, 1}))),))


def coupling_ratio(measured: MeasuredResponse) -> tuple[np.ndarray, np.ndarray]:
    """(R, var R): each rail's velocity per the carriage's, (2, n_freq), from a recording of the X motor with the
    outputs ``OUTPUTS``; ``DataError`` naming the missing output otherwise."""
    names = tuple(measured.output_names)
    missing = [n for n in OUTPUTS if n not in names]
    if missing:
        raise DataError(f"{measured.source}: a coupling recording needs the outputs {', '.join(OUTPUTS)} (the X motor "
                        f"excited, every encoder recorded); {missing[0]} is missing (outputs: {', '.join(names)})")
    g = np.array([measured.response[names.index(n)] for n in OUTPUTS])
    v = np.array([measured.variance[names.index(n)] for n in OUTPUTS])
    with np.errstate(divide="ignore", invalid="ignore"):          # a carriage that never moved: inf, left out later
        ratio = g[:2] / g[2]
        return ratio, (v[:2] + np.abs(ratio) ** 2 * v[2]) / np.abs(g[2]) ** 2


def model_ratio(machine: PlanarGantry, carriage_position_m: float, w_rad_s) -> np.ndarray:
    """The planar model's rails' velocity per the carriage's under the X motor's force, (2, n_freq)."""
    M, D, K = machine.matrices(carriage_position_m)
    H = mobility(1j * np.asarray(w_rad_s, float), M, D, K)
    return H[:2, 2] / H[2, 2]


def _fit(model: str, machine: PlanarGantry, p: float, w: np.ndarray, ratio: np.ndarray,
         sigma: np.ndarray) -> CouplingFit:
    names = MODELS[model]
    n = 2 * ratio.size

    def residual(x):
        r = (model_ratio(machine.with_values(**dict(zip(names, x))), p, w) - ratio) / sigma
        return np.concatenate([r.real.ravel(), r.imag.ravel()])

    if names:
        # the model is nearly linear in small errors: scale each by its bound, start from 0
        scale = np.array([MAX_SKEW_RAD if k == "beam_skew_rad" else machine.rail_separation_m / 2 for k in names])
        sol = least_squares(lambda u: residual(u * scale), np.zeros(len(names)), x_scale=1.0, xtol=1e-12,
                            ftol=1e-12, gtol=1e-12, bounds=(-np.ones(len(names)), np.ones(len(names))))
        x, J, res = sol.x * scale, sol.jac / scale, sol.fun
        at_bound = bool(np.any(np.abs(sol.x) > 1 - 1e-6))
        # the covariance scaled by the reduced chi^2 when the misfit exceeds the noise (as lmfit's scale_covar)
        inflate = max(1.0, float(res @ res) / max(n - len(names), 1))
        try:
            cov = np.linalg.inv(J.T @ J) * inflate
            stderr = tuple(float(s) for s in np.sqrt(np.maximum(np.diag(cov), 0.0)))
        except np.linalg.LinAlgError:
            stderr = (math.inf,) * len(names)
    else:
        x, res, stderr, at_bound = np.zeros(0), residual(np.zeros(0)), (), False
    chi2 = float(res @ res)
    return CouplingFit(model, names, tuple(float(v) for v in x), stderr, chi2, n - len(names),
                       chi2 + len(names) * math.log(n), at_bound)


def diagnose_coupling(measured: MeasuredResponse, machine: PlanarGantry,
                      carriage_position_m: float) -> CouplingDiagnosis:
    """The coupling of the X motor's recording ``measured`` against ``machine`` with the carriage at
    ``carriage_position_m`` (module doc)."""
    ratio, variance = coupling_ratio(measured)
    f_hz = np.asarray(measured.f_hz, float)
    usable = np.all(np.isfinite(ratio) & np.isfinite(variance) & (variance > 0), axis=0)
    if usable.sum() < 2:
        raise DataError(f"{measured.source}: the carriage's velocity (velocity_x_m_per_s) answers the X motor at "
                        f"{int(usable.sum())} of {f_hz.size} frequencies: at least 2 are needed to read the coupling")
    ratio, variance, f_hz = ratio[:, usable], variance[:, usable], f_hz[usable]
    w = 2 * np.pi * f_hz
    sigma = np.sqrt(np.maximum(variance / 2, 1e-300))          # each of the real and imaginary parts
    fits = {m: _fit(m, machine, carriage_position_m, w, ratio, sigma) for m in MODELS}
    none = fits["none"]
    chosen = min([none] + [f for f in (fits["beam_skew"], fits["carriage_offset"])
                           if f.identified and none.bic - f.bic >= ACCEPT_DELTA_BIC], key=lambda f: f.bic)
    both = fits["beam_skew+carriage_offset"]
    if both.identified and chosen.bic - both.bic >= ACCEPT_DELTA_BIC:
        chosen = both
    explained = chosen.reduced_chi2 <= EXPLAINED_CHI2
    return CouplingDiagnosis(f_hz, ratio, variance, float(carriage_position_m),
                             tuple(fits.values()), chosen, explained, _verdict(chosen, fits["none"], explained))


def _verdict(chosen: CouplingFit, none: CouplingFit, explained: bool) -> str:
    units = {"beam_skew_rad": ("the beam's skew", 1e3, "mrad"), "carriage_offset_m": ("the carriage's offset", 1e3,
                                                                                      "mm")}
    parts = [f"{units[n][0]} {v * units[n][1]:.3g} ± {s * units[n][1]:.2g} {units[n][2]}"
             for n, v, s in zip(chosen.parameters, chosen.values, chosen.stderr)]
    if chosen.model == "none":
        head = ("X and Y meet as the planar model says (no coupling at rest)" if explained else
                "the rails' response to the X motor is not explained by the planar model")
    elif explained:
        head = f"X moves the rails: {' and '.join(parts)} (ΔBIC {none.bic - chosen.bic:.1f} against none)"
    else:
        head = (f"the rails' response to the X motor is not explained: the best model ({' and '.join(parts)}) still "
                "misses, so the planar model's mechanics differ from the machine's (masses, damping, yaw stiffness) "
                "and these values are not a measurement")
    return f"{head}: reduced χ² {chosen.reduced_chi2:.3g} over {chosen.dof} degrees of freedom."
