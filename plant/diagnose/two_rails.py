"""Stage Y's two rails read jointly in a time recording: what the mean of the rails hides.

A rigid beam moves both rails alike, so the rails' difference d = y2 - y1 is either how they are read or the
beam turning. Both show in the difference as functions of the common motion c = (y1 + y2) / 2:

* ``rail_scale``: encoder Y2 reads s times its rail (y2_scale). With the beam rigid, y1 = y, y2 = s y, so
  d = k c exactly with k = 2 (s - 1) / (s + 1). It changes no motion, but the mean of the rails reads
  (1 + s) / 2 times the motion, so a force fit on the mean puts (s - 1) / 2 on the mass and the damping (-1.5 %
  for s = 1.03). The fits then read Y2 / s.
* The beam turning (yaw) against the joints' stiffness k_y, below its mode: Lagrange's equations of the beam on
  its rails (``tests/reference/independent_two_rails.py``) give J_y d'' + c_y d' + k_y d = T for a torque T that
  follows the motion, T = p a + q v with a, v the common acceleration and velocity. Below the mode,
  d = (1 - tau s + psi s^2) T / k_y to second order (tau = c_y / k_y, psi = tau^2 - J_y / k_y), so
  d = alpha a + beta v + gamma a' + delta a'' with alpha = (p - tau q) / k_y, beta = q / k_y,
  gamma = (psi q - tau p) / k_y, delta = psi p / k_y. Unequal motors (``motor_imbalance``) turn the beam in
  proportion to the motor force, K i = m a + b v, so q / p = r = b / m (the fitted stage's); an off-centre load
  (``tilt_coupling.offset_m``) turns it by its inertia, q = 0. A cause is named when the yaw motion the free fit
  finds follows its pattern, with the yaw's lag tau anywhere from 0 to that of a mode at the band's edge, to within
  ``STRUCTURE_SHARE`` of its rms (``_yaw_patterns``); rails whose dampings differ turn it by their damping,
  p = 0, d = q (v - tau a + psi a') / k_y (``yaw_coupling.damping_n_s_per_m``).

The regression is of the difference on (c, a, v, a', a'', 1) (the 1: the encoders' zeros), each through the inverse
model's filter and decimation (``plant.identify.inverse_model.derivatives_chain``: the derivatives by central
differences at the full rate), on positions where they are recorded and on velocities otherwise (then d' = k v +
alpha a' + beta a + gamma a'' + delta a''', the same coefficients). Standard errors are Newey-West
(``plant.identify.time_fit``). A term is claimed when it lies ``CLAIM_Z`` standard errors from zero and carries
``STRUCTURE_SHARE`` or more of what the difference would leave without it; what remains is compared with the
encoders' noise through the same chain (``NOISE_RATIO_LIMIT``): beyond it the rails disagree in a way these terms
do not describe (a yaw mode within the band: a stepped sine of both rails fits ``tilt_coupling``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from plant.data.recordings import TimeRecording
from plant.errors import EffectError
from plant.identify.inverse_model import (
    NOISE_SEED,
    Preprocessing,
    decimation_factor,
    derivatives_chain,
    difference_noise_std,
    inverse_model_data,
)
from plant.identify.time_fit import NOISE_RATIO_LIMIT, STRUCTURE_SHARE, effective_factors, fit_inverse_model, newey_west
from plant.physics.mechanics import TiltCoupling
from plant.story import Section, Table

#: standard errors from zero at which a term of the difference is claimed
CLAIM_Z = 5.0
#: a yaw stiffness (N*m/rad) at which the motors' imbalance per stiffness is shown as a fraction: the default of
#: ``tilt_coupling.stiffness_n_m_per_rad``
REFERENCE_YAW_STIFFNESS = TiltCoupling.stiffness_n_m_per_rad
#: the terms that can be claimed (the others are the yaw's lag and inertia, and the encoders' zeros)
CLAIMABLE = ("scale", "acceleration", "velocity")


@dataclass(frozen=True)
class RailTerm:
    """One column of the difference's regression: its coefficient, Newey-West standard error and its share of what
    the difference would leave without it (module doc)."""

    name: str
    value: float
    stderr: float
    share: float

    @property
    def z(self) -> float:
        return abs(self.value) / self.stderr if self.stderr > 0 else 0.0

    @property
    def claimed(self) -> bool:
        """A term of ``CLAIMABLE``, ``CLAIM_Z`` standard errors from zero, carrying ``STRUCTURE_SHARE`` or more."""
        return self.name in CLAIMABLE and self.z > CLAIM_Z and self.share >= STRUCTURE_SHARE


@dataclass(frozen=True)
class RailReading:
    """What the two rails of a time recording say beside their mean (module doc)."""

    #: the regression's terms by name: scale k (1), acceleration alpha (m per m/s^2), velocity beta
    #: (m per m/s), zero (m, or m/s for velocity recordings)
    terms: dict[str, RailTerm]
    #: rms (m or m/s) of the difference, of its residual, and of the encoders' noise through the chain
    difference_rms: float
    residual_rms: float
    noise_rms: float
    #: "position" or "velocity": what was regressed
    kind: str
    #: the yaw patterns (``motor_imbalance``, ``tilt_coupling.offset_m``, damping) the claimed yaw terms are
    #: consistent with, each with its reason
    yaw_patterns: tuple[str, ...]
    #: the stage's motor force per velocity b (N*s/m, K i = m a + b v: both rails' damping) and the rails'
    #: separation L (m), which turn the velocity term into the motors' imbalance per yaw stiffness
    force_per_velocity_n_s_per_m: float = math.nan
    rail_separation_m: float = math.nan

    @property
    def y2_scale(self) -> float:
        """s from k = 2 (s - 1) / (s + 1)."""
        k = self.terms["scale"].value
        return (2 + k) / (2 - k)

    @property
    def y2_scale_stderr(self) -> float:
        k = self.terms["scale"]
        return 4 / (2 - k.value) ** 2 * k.stderr

    @property
    def scale_claimed(self) -> bool:
        return self.terms["scale"].claimed

    @property
    def yaw_claimed(self) -> bool:
        return self.terms["acceleration"].claimed or self.terms["velocity"].claimed

    @property
    def imbalance_per_stiffness(self) -> tuple[float, float]:
        """(value, standard error) of motor_imbalance.fraction / K_a (rad / (N*m)), K_a the joints' yaw stiffness:
        the motors K (1 + f) / 2 on Y1 and K (1 - f) / 2 on Y2 turn the beam by (F2 - F1) L / 2 = -f K i L / 2, and the
        rails part by that over K_a times L, so beta = -f b L^2 / (2 K_a): ``damping_difference_per_stiffness`` over
        b. Below the yaw mode the record gives f / K_a only; the fraction needs K_a
        (``tilt_coupling.stiffness_n_m_per_rad``, from a stepped sine through the mode)."""
        value, stderr = self.damping_difference_per_stiffness
        b = self.force_per_velocity_n_s_per_m
        return value / b, stderr / b

    @property
    def damping_difference_per_stiffness(self) -> tuple[float, float]:
        """(value, standard error) of (b2 - b1) / K_a (N*s/m per N*m/rad): rails whose dampings differ turn the beam
        by (b2 - b1) v L / 2 against K_a, so beta = -(b2 - b1) L^2 / (2 K_a) below the yaw mode."""
        b = self.terms["velocity"]
        per = -2.0 / self.rail_separation_m**2
        return per * b.value, abs(per) * b.stderr

    @property
    def couples_the_mean(self) -> bool:
        """The yaw may reach the force on the rails' mean (``yaw_coupling``): the beam turns, and not by unequal
        motors alone, whose torque leaves the mean's force balance as it is (module doc)."""
        motors_only = len(self.yaw_patterns) == 1 and "motor_imbalance" in self.yaw_patterns[0]
        return self.yaw_claimed and not motors_only

    @property
    def agree(self) -> bool:
        """Nothing claimed and the difference is the encoders' noise."""
        return not (self.scale_claimed or self.yaw_claimed) and self.explained

    @property
    def unit(self) -> str:
        """The unit of the difference regressed: m (positions) or m/s (velocities)."""
        return "m" if self.kind == "position" else "m/s"

    @property
    def noise_ratio(self) -> float:
        return self.residual_rms / self.noise_rms if self.noise_rms > 0 else math.inf

    @property
    def explained(self) -> bool:
        """The difference's residual is the encoders' noise."""
        return self.noise_ratio <= NOISE_RATIO_LIMIT

    def corrected(self, rec: TimeRecording) -> TimeRecording:
        """``rec`` with Y2 read to Y1's scale (Y2 / s) where the scale is claimed, else as it is."""
        if not self.scale_claimed:
            return rec
        return dataclasses.replace(rec, output=np.vstack([rec.output[0], rec.output[1] / self.y2_scale]))

    def clause(self) -> str:
        """The rails' part of a verdict: each claimed term with its size, and what is left beyond the noise."""
        unit = self.unit
        parts = []
        if self.scale_claimed:
            parts.append(f"encoder Y2 reads {100 * (self.y2_scale - 1):+.2f} ± {100 * self.y2_scale_stderr:.2g} % "
                         f"against Y1 (rail_scale.y2_scale = {self.y2_scale:.4f}; the fits read Y2 at Y1's scale)")
        if self.yaw_claimed:
            a, b = self.terms["acceleration"], self.terms["velocity"]
            parts.append(f"the rails part as the beam turns with the motion ({1e6 * a.value:+.3g} ± "
                         f"{1e6 * a.stderr:.2g} µm per m/s² of acceleration, {1e6 * b.value:+.3g} ± "
                         f"{1e6 * b.stderr:.2g} µm per m/s of velocity): {self._patterns_text()}")
        if not self.explained:
            parts.append(f"the rails disagree beyond {'these terms' if parts else 'their zeros'} by "
                         f"{self._size(self.residual_rms, unit)} rms, {self.noise_ratio:.3g} x the encoders' noise "
                         "(a yaw mode within the band: fit a stepped sine of both rails with tilt_coupling)")
        if not parts:
            return (f"the rails agree (their difference, {self._size(self.difference_rms, unit)} rms, is the "
                    "encoders' noise)")
        return "; ".join(parts)

    def _patterns_text(self) -> str:
        if not self.yaw_patterns:
            return ("the pattern of no single cause (unequal motors, an off-centre load or unequal dampings, "
                    "together)")
        return " or ".join(self._with_size(p) for p in self.yaw_patterns)

    def _with_size(self, pattern: str) -> str:
        """A cause's words, with the size per yaw stiffness K_a of unequal motors (``imbalance_per_stiffness``) or
        dampings (``damping_difference_per_stiffness``), and its value at ``REFERENCE_YAW_STIFFNESS``."""
        if "motor_imbalance" in pattern:
            (per, se), what, unit = self.imbalance_per_stiffness, "fraction", "rad/(N·m)"
        elif "dampings differ" in pattern:
            (per, se), what, unit = self.damping_difference_per_stiffness, "b2 - b1", "N·s/m per N·m/rad"
        else:
            return pattern
        if not math.isfinite(per):
            return pattern
        return (f"{pattern[:-1]}; {what} = {per:.3g} ± {se:.2g} {unit} × K_a, the joints' yaw stiffness, which a "
                f"record below the yaw mode cannot give: {per * REFERENCE_YAW_STIFFNESS:+.3g} at "
                f"{REFERENCE_YAW_STIFFNESS:.0e} N·m/rad)")

    @staticmethod
    def _size(x: float, unit: str) -> str:
        return f"{1e6 * x:.3g} µm" if unit == "m" else f"{1e6 * x:.3g} µm/s"

    def section(self) -> Section:
        unit = {"scale": "1", "acceleration": "m per m/s²", "velocity": "m per m/s", "jerk": "m per m/s³",
                "snap": "m per m/s⁴", "zero": self.unit}
        rows = tuple((t.name, f"{t.value:.4g}", f"{t.stderr:.2g}", f"{t.share:.2f}", unit[t.name],
                      "yes" if t.claimed else "no") for t in self.terms.values())
        unit_of = self.unit
        return Section("Both rails", (self.clause(),),
                       table=Table(("term", "value", "stderr", "share", "unit", "claimed"), rows),
                       aside=f"(the rails' difference on the common {self.kind}: rms "
                             f"{self._size(self.difference_rms, unit_of)}, residual "
                             f"{self._size(self.residual_rms, unit_of)}, encoders' noise "
                             f"{self._size(self.noise_rms, unit_of)})")


def rails_reading(plant, rec: TimeRecording, data, prep: Preprocessing) -> RailReading | None:
    """``read_rails`` of ``rec`` for the base ``plant`` (no effects), the motor force's pattern b / m from the base
    model fitted on the rails' mean (``data``: a scale on one rail moves both alike, not their ratio); None for one
    output."""
    if rec.output.shape[0] != 2:
        return None
    if plant.effects:
        raise EffectError("the rails' reading starts from the base model; give a plant without effects")
    base = fit_inverse_model(plant, data)
    m_per, b_per = effective_factors(base.plant)
    b = b_per * base.values["damping_n_s_per_m"]
    return read_rails(rec, damping_per_mass_per_s=b / (m_per * base.values["mass_kg"]), prep=prep,
                      force_per_velocity_n_s_per_m=b, rail_separation_m=float(plant.motor_length_m))


def at_one_scale(plant, rec: TimeRecording, data, prep: Preprocessing):
    """(the rails' reading or None, the recording and its inverse-model data) with Y2 read at Y1's scale where the
    reading claims a scale (``rails_reading``, ``RailReading.corrected``); ``data`` as ``rec`` gave it otherwise."""
    rails = rails_reading(plant, rec, data, prep)
    if rails is None or not rails.scale_claimed:
        return rails, rec, data
    rec = rails.corrected(rec)
    return rails, rec, inverse_model_data(rec, float(plant.force_constant_n_per_a), prep)


def read_rails(rec: TimeRecording, *, damping_per_mass_per_s: float, prep: Preprocessing = Preprocessing(),
               force_per_velocity_n_s_per_m: float = math.nan, rail_separation_m: float = math.nan
               ) -> RailReading | None:
    """The joint reading of a recording's two rails (module doc); None for one output. ``damping_per_mass_per_s``:
    the stage's effective damping over its effective mass (the fit on the mean), r = b / m of the motor force's
    pattern; ``force_per_velocity_n_s_per_m`` that b and ``rail_separation_m`` the rails' separation L (the
    motors' imbalance per yaw stiffness, ``RailReading.imbalance_per_stiffness``)."""
    if rec.output.shape[0] != 2:
        return None
    fs = rec.sample_rate_hz
    r = decimation_factor(fs, prep.decimate_band_hz)
    y1, y2 = rec.output
    common = derivatives_chain(fs, (y1 + y2) / 2, prep.filter_hz, r, 4)
    y = derivatives_chain(fs, y2 - y1, prep.filter_hz, r, 0)[0]
    sigma = math.hypot(difference_noise_std(y1), difference_noise_std(y2))
    e_noise = derivatives_chain(fs, sigma * np.random.default_rng(NOISE_SEED).standard_normal(y1.size),
                                prep.filter_hz, r, 0)[0]
    # derivative k of the common output: the rails' difference on (c, a, v, a', a'') for positions, the same
    # coefficients on (v, a', a, a'', a(3)) for velocities (module doc)
    columns = {"scale": common[0], "acceleration": common[2], "velocity": common[1], "jerk": common[3],
               "snap": common[4], "zero": np.ones(common.shape[1])}
    X = np.column_stack(list(columns.values()))
    coef = np.linalg.lstsq(X, y, rcond=None)[0]
    e = y - X @ coef
    cov = newey_west(X, e)[0]
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    terms = {}
    for j, name in enumerate(columns):
        part = X[:, j] * coef[j]
        terms[name] = RailTerm(name, float(coef[j]), float(se[j]), _rms(part) / max(_rms(e + part), 1e-300))
    yaw = [1, 2, 3, 4]                           # acceleration, velocity, jerk, snap: alpha, beta, gamma, delta
    patterns = _yaw_patterns(terms, X[:, yaw], coef[yaw], damping_per_mass_per_s,
                             1.0 / (math.pi * prep.decimate_band_hz))
    return RailReading(terms, _rms(y), _rms(e), _rms(e_noise), rec.output_kind, patterns,
                       force_per_velocity_n_s_per_m, rail_separation_m)


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean((x - x.mean()) ** 2)))


#: the causes of a yaw the rails' reading tells apart: the torque's direction (p_a, p_v) in T = p (p_a a + p_v v)
#: (``None``: the motor force's, (1, b / m)) and the words that name it
CAUSES = ((None, "the motor force's pattern (motors of unequal force constants: motor_imbalance)"),
          ((1.0, 0.0), "the acceleration's alone (a load off the beam's centre: tilt_coupling.offset_m)"),
          ((0.0, 1.0), "the velocity's alone (rails whose dampings differ: yaw_coupling.damping_n_s_per_m)"))


def _yaw_patterns(terms: dict[str, RailTerm], X: np.ndarray, theta: np.ndarray, r: float,
                  lag_max_s: float) -> tuple[str, ...]:
    """The causes (``CAUSES``) whose pattern (module doc) the free fit's yaw motion X theta (X: the columns a, v, a',
    a'') follows to within ``STRUCTURE_SHARE`` of its rms: a torque T = p (p_a a + p_v v) through the yaw below its
    mode, d = p (T - tau T' + psi T'') with T' = p_a a' + p_v a, T'' = p_a a'' + p_v a' and the yaw's lag
    tau = c_y / k_y = 2 zeta / w_y within [0, ``lag_max_s``] (a mode above the band: zeta <= 1, w_y >= the band's
    edge), and whose alpha the lag allows (``_lag_allows``: the lag is positive, so a damping's pattern, v - tau a,
    is not the motor force's, v + a / r)."""
    if not (terms["acceleration"].claimed or terms["velocity"].claimed):
        return ()
    import scipy.optimize

    a, v, jerk, snap = X.T
    free = X @ theta
    out = []
    for direction, words in CAUSES:
        pa, pv = (1.0, r) if direction is None else direction

        def left(tau: float) -> float:
            U = np.column_stack([(pa * a + pv * v) - tau * (pa * jerk + pv * a), pa * snap + pv * jerk])
            return _rms(free - U @ np.linalg.lstsq(U, free, rcond=None)[0])

        best = scipy.optimize.minimize_scalar(left, bounds=(0.0, lag_max_s), method="bounded",
                                              options={"xatol": 1e-3 * lag_max_s})
        if min(best.fun, left(0.0), left(lag_max_s)) <= STRUCTURE_SHARE * _rms(free) and _lag_allows(
                terms, pa, pv, lag_max_s):
            out.append(words)
    return tuple(out)


def _lag_allows(terms: dict[str, RailTerm], pa: float, pv: float, lag_max_s: float) -> bool:
    """Whether alpha lies where the cause puts it: alpha / beta = p_a / p_v - tau with the lag tau in [0,
    ``lag_max_s``] (the motor force's 1 / r - tau, a damping's -tau: opposite signs), within ``CLAIM_Z`` standard
    errors or ``STRUCTURE_SHARE`` of its size (the expansion's own error); no bound for p_v = 0 (beta = 0 then)."""
    if pv == 0:
        return True
    a, b = terms["acceleration"], terms["velocity"]
    lo, hi = sorted((b.value * (pa / pv - lag_max_s), b.value * pa / pv))
    tol = max(CLAIM_Z * a.stderr, STRUCTURE_SHARE * max(abs(lo), abs(hi)))
    return lo - tol <= a.value <= hi + tol
