"""What every effect of the library declares about itself.

An effect is a small frozen dataclass. Besides its parameters (floats, or arrays that
broadcast against the frequency axis) it owns what the rest of the tool needs to know:

* ``place``: ``"drive"`` (between the current command and the motor force: delay, current
  loop, sampling), ``"sensor"`` (between the moving mass and the recorded velocity: sensor
  filter, encoder differencing) or ``"mechanics"`` (a part of the lumped mass-spring-damper
  network, evaluated by the plant, never a series factor);
* ``limits_bandwidth``: whether it puts phase lag in a velocity loop (synthesis needs one);
* ``signature``: the residual it leaves when it is missing, in words;
* ``main_parameter``: the parameter a user quotes first;
* ``neutral``: parameter values at which the effect (practically) vanishes, so a model that
  contains another can start from that model's optimum;
* ``guesses(w_rad_s, ratio)``: starting values from the data divided by a parent model
  (lmfit's ``Model.guess``);
* ``excludes`` / ``requires_any``: effects it cannot be combined with / needs; ``contains``: effects it
  becomes at a parameter's neutral value;
* ``search_fixed``: parameters held at their defaults by the model search;
* ``complexity``: how much physics it assumes, breaking ties between equivalent models;
* ``in_synthesis``: has a response formula of ``s`` that casadi can build (PI synthesis);
* ``force_regressors(signals)``: its force as a sum of parameters times known signals of the velocity,
  position and motor force (``ForceSignals``), for the time-domain inverse model (None where it has no
  such form); ``configured(samples, residual)`` sets the fields the search holds from the recording.
"""

from __future__ import annotations

import abc
import dataclasses
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from plant.errors import EffectError
from plant.physics.algebra import NUMPY
from plant.physics.parameters import Parameter, check_batch, check_positive
from plant.physics.state_space import StateSpace, column, series, tf_ss, unity

if TYPE_CHECKING:
    import control

#: default Pade order used when a delay is turned into a rational model
PADE_ORDER = 6


class Effect(abc.ABC):
    """Base of all effects: a name, bounded parameters, its place and what it knows of itself."""

    name: ClassVar[str]
    #: parameter name -> (lower, upper, unit): physically plausible bounds used by fits
    bounds: ClassVar[dict[str, tuple[float, float, str]]]
    place: ClassVar[str]
    limits_bandwidth: ClassVar[bool] = False
    linear: ClassVar[bool] = True
    signature: ClassVar[str] = ""
    main_parameter: ClassVar[str]
    neutral: ClassVar[dict[str, float]] = {}
    excludes: ClassVar[tuple[str, ...]] = ()
    #: effects it contains: effect -> its parameter that, at its ``neutral`` value, makes it that effect (a cable
    #: with no stiffness is an offset); a diagnosis claims it only where the data set that parameter apart
    contains: ClassVar[dict[str, str]] = {}
    requires_any: ClassVar[tuple[str, ...]] = ()
    stages: ClassVar[tuple[str, ...]] = ("x", "y")
    #: fewest recorded outputs for the effect to be identifiable (2: both Y rails)
    min_outputs: ClassVar[int] = 1
    #: tried by the frequency-domain model search; ``not_searched`` says why not
    searched: ClassVar[bool] = True
    not_searched: ClassVar[str] = ""
    #: has a response formula of s for casadi (the exact PI synthesis needs one)
    in_synthesis: ClassVar[bool] = True
    search_fixed: ClassVar[tuple[str, ...]] = ()
    #: frequencies (Hz) the data identify only where they lie in the excited band: a mode's (a lag's corner far
    #: above the band still sets a measurable phase lag, which its standard error judges)
    in_band: ClassVar[tuple[str, ...]] = ()
    #: how much physics the effect assumes, for ties between models the data cannot tell apart:
    #: 0 a pure delay, 1 one lag or hold, 2 a filter or a mode
    complexity: ClassVar[int] = 2

    def parameters(self) -> dict[str, Parameter]:
        """The effect's parameters, keyed ``effect.parameter``."""
        out = {}
        for field, (lo, hi, unit) in self.bounds.items():
            value = float(np.mean(getattr(self, field)))
            key = f"{self.name}.{field}"
            out[key] = Parameter(key, value, lo, hi, unit=unit)
        return out

    def with_values(self, *, checked: bool = True, **values: float) -> Effect:
        """Copy with parameters replaced; ``checked=False`` skips validation (values already inside the
        fit's bounds: the fitter's hot path)."""
        unknown = set(values) - set(self.bounds)
        if unknown:
            raise EffectError(f"effect {self.name} has no parameter {sorted(unknown)[0]!r}; "
                              f"known: {sorted(self.bounds)}")
        return dataclasses.replace(self, **values) if checked else replace_unchecked(self, values)

    def _check_positive(self) -> None:
        for field in self.bounds:
            check_positive(f"{self.name}.{field}", getattr(self, field))
            check_batch(f"{self.name}.{field}", getattr(self, field))

    def guesses(self, w_rad_s: np.ndarray, ratio: np.ndarray) -> list[dict[str, float]]:
        """Starting values (field -> value) from ``ratio`` = data / parent model, shape (n_out, n_freq)."""
        return []

    def equivalent_delay_s(self) -> float | None:
        """Pure delay with the same low-frequency phase, or None when the effect is not delay-like."""
        return None

    #: the effect has a time-domain force model (``force_regressors``)
    time_domain: ClassVar[bool] = False
    #: it needs the recorded position (a force that depends on where the carriage is)
    needs_position: ClassVar[bool] = False
    #: it needs both of Stage Y's rails recorded (a force that follows the rails' difference)
    needs_rails: ClassVar[bool] = False
    #: fields a time-domain fit sets by profile least squares, each within a fraction of its configured value
    #: (a ripple's pitch within 5 %)
    profiled: ClassVar[dict[str, float]] = {}
    #: the stepped-sine simulation (``plant.experiment.simulate``) models it
    simulated: ClassVar[bool] = True
    #: ``Plant.frd`` models it (a force that averages out of a response, an offset or a ripple, counts as
    #: modelled; a Stribeck rise, whose first harmonic depends on the whole motion, does not)
    frequency_response: ClassVar[bool] = True
    #: the time-domain residual test that must show the effect's pattern before the diagnosis adds it (the
    #: ``variable`` of a ``plant.identify.time_fit.Structure``), None: BIC decides alone
    residual_signature: ClassVar[str | None] = None

    #: it adds a force on the rails that the continuous time-domain simulation applies (``rail_force_n``)
    rail_force: ClassVar[bool] = False
    #: it adds a friction on the rails that varies along the travel (``rail_friction_n``)
    rail_friction: ClassVar[bool] = False
    #: what of it a time-domain simulation's linear model holds (one of ``REALISED_AS``; every effect declares it)
    realised_as: ClassVar[str]

    def rail_force_n(self, position_m: float, velocity_m_per_s: float, motor_force_n: float) -> float:
        """The force (N, in the direction of motion's positive axis) the effect adds on the rails at the rails'
        position (m), velocity (m/s) and the motor's force (N), as the time-domain simulations (the continuous
        one and the mouse run) apply it (effects with ``rail_force``; chain factors, modes and friction act
        through the model instead)."""
        return 0.0

    def rail_friction_n(self, position_m: float) -> float:
        """The part (N) of the rails' Coulomb friction magnitude the effect adds at the rails' position (m), a
        friction that varies along the travel (effects with ``rail_friction``: a cable carrier's drag); the time
        simulations apply it with the Coulomb friction's law (sticking included). 0 for most effects."""
        return 0.0

    def rail_stiffness(self):
        """The stiffness (N/m) the effect puts between the rails and the ground, which the mechanics carries in
        both domains (``plant.physics.mechanics.BodyChain``: k / s beside the rail damping, a position state in
        the realisation, relaxed at x = 0); its ``rail_force_n`` is the rest of its force. 0 for most effects."""
        return 0.0

    def force_regressors(self, signals: ForceSignals) -> dict[str, np.ndarray] | None:
        """The effect's force (N) needed on top of the rigid body as sum(p * signal): field -> signal
        (the time-domain inverse model is linear in these parameters; the effect's other fields, held in
        the search, shape the signals); None when the effect has no such form (a delay, a mode or a filter
        act on the dynamics, not on the force balance)."""
        return None

    def configured(self, samples: FitSamples, residual_n: np.ndarray) -> Effect:
        """The effect with the fields the search holds set from the recording's ``samples`` and a parent model's
        force residual ``residual_n`` at them (a ripple's pitch from the residual's spectrum over position);
        itself when it has none."""
        return self


@dataclasses.dataclass(frozen=True)
class FitSamples:
    """The samples a time-domain fit uses (decimated, moving): velocity (m/s), acceleration (m/s^2), motor
    force K_f u (N) and position (m, None when the recording has velocity only)."""

    velocity_m_per_s: np.ndarray
    acceleration_m_per_s2: np.ndarray
    force_n: np.ndarray
    position_m: np.ndarray | None = None
    #: the samples' times (s), None when not known
    time_s: np.ndarray | None = None


@dataclasses.dataclass(frozen=True)
class ForceSignals:
    """Signals at the full rate (filtered, edges cut) that time-domain force models are formed from."""

    velocity_m_per_s: np.ndarray
    #: the motor force K_f u as the model computes it (N)
    force_n: np.ndarray
    #: None when the recording has velocity only
    position_m: np.ndarray | None = None
    #: the samples' times (s), None when not known
    time_s: np.ndarray | None = None
    #: Stage Y with both rails recorded: the rails' difference y2 - y1 differentiated, its velocity (m/s) and
    #: acceleration (m/s^2); None for one output
    rail_difference_velocity_m_per_s: np.ndarray | None = None
    rail_difference_acceleration_m_per_s2: np.ndarray | None = None


#: ``Effect.realised_as``: "state_space", held exactly by the plant's realisation (``plant.physics.realisation``:
#: a rational chain factor, a body or a spring); "applied", a delay of the command that a simulator applies
#: exactly (the realisation holds it only as a Pade approximant when asked); "force", nothing of it in the state
#: space, a force at the rails that each simulator applies its own way (``rail_force_n``, a friction law);
#: "beam", the Xie-Wang beam, one rail contact per motor, realised for one plant at a time; "drive_limit", the
#: drive clips its command; "approximate", only a Pade approximant of it is a state space (a difference quotient)
REALISED_AS = ("state_space", "applied", "force", "beam", "drive_limit", "approximate")


class ChainEffect(Effect):
    """A dimensionless factor of the drive or sensor chain (unity gain at DC)."""

    realised_as: ClassVar[str] = "state_space"

    @abc.abstractmethod
    def response(self, s, ops=NUMPY):
        """Factor at the Laplace variable ``s`` (complex array with ``NUMPY``, ``Pair`` with ``CASADI``)."""

    def frd(self, w_rad_s) -> np.ndarray:
        """Complex frequency response of the factor at ``w_rad_s`` (rad/s)."""
        return self.response(1j * np.asarray(w_rad_s))

    @abc.abstractmethod
    def to_tf(self, *, pade_order: int = PADE_ORDER) -> control.TransferFunction:
        """A rational python-control realisation (Pade for pure delays)."""

    def state_space(self, n: int, *, pade_order: int = PADE_ORDER) -> StateSpace:
        """The factor of a batch of ``n`` plants as a batched state-space model, (n, ...): ``to_tf`` of each
        plant's values realised by ``plant.physics.state_space.tf_ss`` (a delay by its Pade approximant)."""
        parts = []
        for j in range(n):
            one = replace_unchecked(self, {f.name: float(column(getattr(self, f.name), n)[j])
                                           for f in dataclasses.fields(self)})
            tf = one.to_tf(pade_order=pade_order)
            parts.append(tf_ss(np.asarray(tf.num[0][0], float), np.asarray(tf.den[0][0], float)))
        return StateSpace(*(np.stack([getattr(p, k) for p in parts]) for k in "ABCD"))


def effects_state_space(effects, place: str, n: int, *, pade_order: int = PADE_ORDER) -> StateSpace:
    """The product of the chain effects of ``effects`` at ``place`` ("drive" or "sensor") of a batch of ``n``
    plants as one batched state-space model (each effect's ``state_space``; a unit gain when there are none)."""
    out = unity(n)
    for e in effects:
        if isinstance(e, ChainEffect) and e.place == place:
            out = series(out, e.state_space(n, pade_order=pade_order))
    return out


class MechanicalEffect(Effect):
    """A part of the mechanics; the plant evaluates it within the network."""

    place: ClassVar[str] = "mechanics"


def replace_unchecked(obj, changes: dict):
    """Copy of a frozen dataclass with fields replaced, without running its validation."""
    new = object.__new__(type(obj))
    # the fields only: anything else in the instance's dict is a cache of the old values
    new.__dict__.update({f.name: obj.__dict__[f.name] for f in dataclasses.fields(obj)})
    new.__dict__.update(changes)
    return new


def series_tf(*tfs):
    """The product of SISO python-control transfer functions, its polynomials multiplied by ``np.convolve``:
    the same numbers as ``*`` (which adds each product to a zero fraction, five times slower)."""
    import control

    num, den = np.ones(1), np.ones(1)
    for tf in tfs:
        num, den = np.convolve(num, tf.num[0][0]), np.convolve(den, tf.den[0][0])
    return control.tf(num, den)


def balanced(sys) -> control.StateSpace:
    """A state-space realisation of ``sys`` (transfer function or state space) under the diagonal similarity
    that balances its state matrix (``scipy.linalg.matrix_balance``, powers of 2, so exact): the companion form
    of a high-order loop (Pade delay, resonances, filters) can have entries up to 1e24 and a condition number of
    1e67, which a matrix exponential (``c2d``, a step response) cannot take."""
    import control
    from scipy.linalg import matrix_balance

    s = sys if isinstance(sys, control.StateSpace) else control.ss(sys)
    if s.nstates == 0:
        return s
    A, B, C, D = (np.asarray(x, float) for x in (s.A, s.B, s.C, s.D))
    _, (scale, _) = matrix_balance(A, permute=False, separate=True)
    return control.ss(A / scale[:, None] * scale[None, :], B / scale[:, None], C * scale[None, :], D, s.dt,
                      inputs=s.input_labels, outputs=s.output_labels, name=s.name)


def scalar(effect: Effect, field: str) -> float:
    """The single value of ``effect.field`` (a rational model or a simulation needs one plant)."""
    value = np.asarray(getattr(effect, field), dtype=float)
    if value.size != 1:
        raise EffectError(f"{effect.name}.{field} is a batch of {value.size} values; a rational model needs one value")
    return float(value.reshape(()))


def phase_delay_s(w_rad_s: np.ndarray, ratio: np.ndarray) -> float:
    """Delay (>= 0, s) from the least-squares slope through the origin of the unwrapped phase of
    ``ratio`` (n_out, n_freq), averaged over outputs."""
    phase = np.unwrap(np.angle(np.mean(np.atleast_2d(ratio), axis=0)))
    return max(-float(np.sum(w_rad_s * phase) / np.sum(w_rad_s**2)), 0.0)
