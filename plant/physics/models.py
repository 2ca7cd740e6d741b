"""The thesis plants (Stage X Eq. 3.15, Stage Y Eq. 3.16) with composable effects.

A ``Plant`` is a frozen dataclass: base mechanics plus a tuple of effects. Compose with
``*`` (``stage_x() * Delay(0.001)``). Every parameter may be a float or an array that
broadcasts against the frequency axis, so ``plant.with_payload(np.linspace(5, 40, 200))``
evaluates 200 plants in one call: ``frd`` returns shape ``(..., n_freq)``.

Input is the motor current in A, output the recorded velocity in m/s:

    P(s) = K_t * D(s) * H(s) * S(s)

with D the product of the drive effects, S of the sensor effects and H the mechanics, the
velocity per force of the lumped network (``plant.physics.mechanics``): a chain of bodies, or the
Xie-Wang tilting beam with ``tilt_coupling``. For Stage Y the input is the total current
i = i1 + i2 of the two coupled motors, split equally, for which thesis Eq. 3.16 (a column of
Figure A.1) is exact: v_y = K_t L / (2 M l s + 2 b L) * i.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np

from plant.arguments import check_count
from plant.errors import ArgumentError, EffectError, ParameterError
from plant.grid import check_grid
from plant.physics.algebra import NUMPY
from plant.physics.coulomb_response import rigid_body_first_harmonic
from plant.physics.effect_base import PADE_ORDER, ChainEffect, Effect, balanced, replace_unchecked, series_tf
from plant.physics.effects import make_effect
from plant.physics.gantry_models import xie_wang_frd
from plant.physics.mechanics import (
    BodyChain,
    CoulombFriction,
    ModeEffect,
    TiltCoupling,
    body_chain,
)
from plant.physics.parameters import THESIS, Parameter, check_batch, check_positive

if TYPE_CHECKING:
    import control

BASE_PARAMETERS = ("mass_kg", "damping_n_s_per_m", "force_constant_n_per_a")
#: physically plausible bounds of the base parameters used by fits (lower, upper, unit)
BASE_BOUNDS = {
    "mass_kg": (0.5, 500.0, "kg"),
    "damping_n_s_per_m": (1.0, 1.0e4, "N*s/m"),
    "force_constant_n_per_a": (0.1, 1000.0, "N/A"),
}
#: the load stays this fraction of the beam length away from either rail
_RAIL_CLEARANCE = 0.02


@dataclass(frozen=True)
class Plant:
    """Stage X or Y of the gantry with effects; velocity (m/s) per current (A)."""

    stage: Literal["x", "y"]
    mass_kg: float | np.ndarray = THESIS["mass_kg"].value
    damping_n_s_per_m: float | np.ndarray = THESIS["damping_n_s_per_m"].value
    force_constant_n_per_a: float | np.ndarray = THESIS["force_constant_n_per_a"].value
    motor_length_m: float = THESIS["motor_length_m"].value
    load_position_m: float = THESIS["load_position_m"].value
    effects: tuple[Effect, ...] = field(default=())
    #: current amplitude (A) of a sinusoidal excitation: needed only by the describing
    #: function of a nonlinear effect (``coulomb_friction``)
    excitation_current_a: float | None = None

    def __post_init__(self) -> None:
        if self.stage not in ("x", "y"):
            raise ParameterError(f"stage must be 'x' or 'y', got {self.stage!r}")
        for name in BASE_PARAMETERS:
            check_positive(name, getattr(self, name))
            check_batch(name, getattr(self, name))
        check_positive("motor_length_m", self.motor_length_m)
        check_positive("load_position_m", self.load_position_m)
        if self.load_position_m < _RAIL_CLEARANCE * self.motor_length_m:
            raise ParameterError(
                f"load_position_m ({self.load_position_m:g}) must be at least {_RAIL_CLEARANCE:g} x motor_length_m "
                f"({_RAIL_CLEARANCE * self.motor_length_m:g} m) from rail Y1: the moving mass the motors see, "
                "2 M l / L (thesis Eq. 3.16), vanishes there")
        if self.load_position_m >= self.motor_length_m:
            raise ParameterError(
                f"load_position_m ({self.load_position_m:g}) must lie inside the beam (motor_length_m "
                f"{self.motor_length_m:g})")
        if not isinstance(self.effects, tuple | list):
            raise ArgumentError(f"effects must be a tuple of Effect objects, e.g. (Delay(0.001),), got "
                                f"{type(self.effects).__name__} {self.effects!r}")
        for e in self.effects:
            if not isinstance(e, Effect):
                raise EffectError(f"effects must be Effect objects, got {e!r}")
        names = [e.name for e in self.effects]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise EffectError(f"effect {sorted(dup)[0]} added twice: its parameter names would clash")
        for e in self.effects:
            if self.stage not in e.stages:
                raise EffectError(f"{e.name} applies to Stage {'/'.join(s.upper() for s in e.stages)} only")
            clash = [n for n in e.excludes if n in names]
            if clash:
                raise EffectError(f"{e.name} and {clash[0]} cannot be combined: they describe the same "
                                  "mechanics differently")
            if e.requires_any and not any(n in names for n in e.requires_any):
                raise EffectError(f"{e.name} needs one of {', '.join(e.requires_any)} in the plant")
            if not e.linear:
                if self.excitation_current_a is None:
                    raise EffectError(f"{e.name} needs excitation_current_a (its describing function "
                                      "depends on the excitation amplitude)")
                check_positive("excitation_current_a", self.excitation_current_a)

    # --- composition -------------------------------------------------------------
    def __mul__(self, effect: Effect) -> Plant:
        if not isinstance(effect, Effect):
            return NotImplemented
        return dataclasses.replace(self, effects=self.effects + (effect,))

    def with_effects(self, *effects: Effect) -> Plant:
        return dataclasses.replace(self, effects=tuple(effects))

    def effect(self, name: str) -> Effect | None:
        return next((e for e in self.effects if e.name == name), None)

    @property
    def effect_names(self) -> tuple[str, ...]:
        return tuple(e.name for e in self.effects)

    @property
    def linear(self) -> bool:
        return all(e.linear for e in self.effects)

    @property
    def affine_in_mass_damping(self) -> bool:
        """1/P is linear in (mass_kg, damping_n_s_per_m): a linear chain of bodies (no tilt, no ground spring)."""
        return self.linear and self._tilt() is None and not self.mechanics().grounded

    def with_payload(self, payload_kg) -> Plant:
        """Same plant with ``mass_kg`` replaced; an array of payloads gives a batch on axis -2."""
        check_positive("payload_kg", payload_kg)
        m = np.asarray(payload_kg, dtype=float)
        return dataclasses.replace(self, mass_kg=m.reshape(-1, 1) if m.ndim else float(m))

    # --- parameters --------------------------------------------------------------
    def parameters(self) -> dict[str, Parameter]:
        """All parameters keyed by name (``mass_kg``, ``delay.seconds``, ...)."""
        out = {}
        for name in BASE_PARAMETERS:
            lo, hi, unit = BASE_BOUNDS[name]
            out[name] = Parameter(name, float(np.mean(getattr(self, name))), lo, hi, unit=unit)
        for e in self.effects:
            out.update(e.parameters())
        return out

    def with_values(self, values: dict[str, float], *, checked: bool = True) -> Plant:
        """New plant with the named parameters replaced (``{"mass_kg": 40, "delay.seconds": 1e-3}``);
        ``checked=False`` skips validation (values already inside the fit's bounds)."""
        base = {}
        per_effect: dict[str, dict[str, float]] = {}
        for key, value in values.items():
            if key in BASE_PARAMETERS:
                base[key] = value
            elif "." in key:
                effect_name, param = key.split(".", 1)
                per_effect.setdefault(effect_name, {})[param] = value
            else:
                raise ParameterError(f"unknown parameter {key!r}; base parameters are {', '.join(BASE_PARAMETERS)} "
                                     "and effect parameters are written effect.parameter")
        missing = set(per_effect) - set(self.effect_names)
        if missing:
            raise EffectError(f"parameter {sorted(missing)[0]}.* given but the plant has no such effect "
                              f"(effects: {', '.join(self.effect_names) or 'none'})")
        effects = tuple(e.with_values(checked=checked, **per_effect[e.name]) if e.name in per_effect else e
                        for e in self.effects)
        if checked:
            return dataclasses.replace(self, effects=effects, **base)
        return replace_unchecked(self, {"effects": effects, **base})

    # --- the network -------------------------------------------------------------
    @property
    def output_names(self) -> tuple[str, ...]:
        return ("velocity",) if self.stage == "x" else ("velocity_y1", "velocity_y2")

    def _effective_mass_damping(self):
        """Rigid-body mass and rail damping with K_t / (m_e s + b_e) = Eq. 3.15 (X) or Eq. 3.16 (Y)."""
        m = np.asarray(self.mass_kg, float)
        b = np.asarray(self.damping_n_s_per_m, float)
        if self.stage == "x":
            return m, b
        return 2 * m * self.load_position_m / self.motor_length_m, 2 * b

    def _tilt(self) -> TiltCoupling | None:
        return next((e for e in self.effects if isinstance(e, TiltCoupling)), None)

    def mechanics(self, *, extra_damping_n_s_per_m=0.0) -> BodyChain:
        """The chain of bodies (no tilt): the rigid body of Eq. 3.15 / 3.16 split by the mode effects."""
        m_e, b_e = self._effective_mass_damping()
        modes = tuple(e for e in self.effects if isinstance(e, ModeEffect))
        chain = body_chain(m_e, b_e + extra_damping_n_s_per_m, modes)
        springs = [k for k in (e.rail_stiffness() for e in self.effects) if np.any(np.asarray(k) != 0)]
        return dataclasses.replace(chain, rail_stiffness_n_per_m=sum(springs)) if springs else chain

    def modes_hz(self) -> np.ndarray:
        """Undamped natural frequencies of the mechanics (Hz): the chain's modes or the tilt mode."""
        tilt = self._tilt()
        if tilt is not None:
            return np.atleast_1d(np.asarray(tilt.frequency_hz, float))
        return self.mechanics().modes_hz()

    def antiresonances_hz(self) -> np.ndarray:
        """Undamped antiresonances of the recorded velocity (Hz); none with the tilt model."""
        return np.zeros(0) if self._tilt() is not None else self.mechanics().antiresonances_hz()

    def _loads_l1_l2(self, tilt: TiltCoupling):
        L = self.motor_length_m
        l1 = np.clip(self.load_position_m + np.asarray(tilt.offset_m, float), _RAIL_CLEARANCE * L,
                     (1 - _RAIL_CLEARANCE) * L)
        return l1, L - l1

    # --- frequency response --------------------------------------------------------
    def chain_response(self, s, place: str, ops=NUMPY):
        """Product of the chain effects at ``place`` ("drive" or "sensor"); 1 when there are none."""
        out = 1.0
        for e in self.effects:
            if isinstance(e, ChainEffect) and e.place == place:
                out = e.response(s, ops) * out
        return out

    def response(self, s, ops=NUMPY):
        """Velocity per current at the Laplace variable ``s`` for a chain of bodies (no tilt, linear):
        one formula for NumPy (complex ``s``) and casadi (``Pair`` ``s``, ``ops=CASADI``)."""
        if self._tilt() is not None or not self.linear:
            raise EffectError("response(s) covers linear chains of bodies; use frd() for tilt_coupling and "
                              "coulomb_friction")
        kt = np.asarray(self.force_constant_n_per_a, float) if ops is NUMPY else \
            float(np.asarray(self.force_constant_n_per_a).reshape(()))
        mech = self.mechanics()
        if ops is not NUMPY:
            mech = dataclasses.replace(mech, **{k: _floats(getattr(mech, k)) for k in
                                                ("masses_kg", "stiffness_n_per_m", "damping_n_s_per_m")},
                                       rail_damping_n_s_per_m=float(np.asarray(mech.rail_damping_n_s_per_m).reshape(())),
                                       rail_stiffness_n_per_m=float(np.asarray(mech.rail_stiffness_n_per_m).reshape(())))
        return kt * self.chain_response(s, "drive", ops) * mech.velocity_per_force(s) * \
            self.chain_response(s, "sensor", ops)

    def _friction_damping(self, w):
        """Describing-function damping of the friction at the excitation amplitude (N*s/m): the model of
        friction in a chain of bodies or the tilting beam. Harmonic balance at the rail, whose velocity
        amplitude V solves |Z V + 4 F_c / pi| = F with Z the rail's driving-point impedance (the chain's, or
        the rigid body's m_e s + b_e under the tilting beam) and F the motor force amplitude."""
        friction = self.effect(CoulombFriction.name)
        if friction is None:
            return 0.0
        if self._tilt() is None:
            z = 1.0 / dataclasses.replace(self.mechanics(), sensed=0).velocity_per_force(1j * w)
        else:
            m_e, b_e = self._effective_mass_damping()
            z = b_e + 1j * w * m_e
        c = 4 * np.asarray(friction.force_n, float) / np.pi
        force_amp = self._force_amplitude_n(w)
        # |Z V + c| = F  ->  |Z|^2 V^2 + 2 Re(Z) c V + c^2 - F^2 = 0, its positive root
        a2 = np.abs(z) ** 2
        disc = (z.real * c) ** 2 - a2 * (c**2 - force_amp**2)
        v_amp = (-z.real * c + np.sqrt(np.maximum(disc, 0.0))) / a2
        return friction.describing_damping(v_amp)

    def _force_amplitude_n(self, w):
        """Amplitude (N) of the motor force's first harmonic at the excitation current and frequency."""
        kt = np.asarray(self.force_constant_n_per_a, float)
        return kt * self.excitation_current_a * self._limit_gain() * np.abs(self.chain_response(1j * w, "drive"))

    def _limit_gain(self):
        """The current limit's describing gain at the excitation current (1 without a limit): the clip acts on
        the command, before the current loop."""
        limit = self.effect("current_limit")
        if limit is None:
            return 1.0
        return limit.describing_gain(np.asarray(self.force_constant_n_per_a, float) * self.excitation_current_a)

    def _chain_frd(self, w) -> np.ndarray:
        """Chain of bodies times the chain effects; with Coulomb friction, the exact first harmonic of the
        rigid body (``plant.physics.coulomb_response``) or, for a chain of several bodies, the describing function."""
        s = 1j * w
        kt = np.asarray(self.force_constant_n_per_a, float)
        series = kt * self._limit_gain() * self.chain_response(s, "drive") * self.chain_response(s, "sensor")
        friction = self.effect(CoulombFriction.name)
        if friction is None:
            return series * self.mechanics().velocity_per_force(s)
        if not any(isinstance(e, ModeEffect) for e in self.effects) and not self.mechanics().grounded:
            m_e, b_e = self._effective_mass_damping()
            return series * rigid_body_first_harmonic(m_e, b_e, friction.force_n, self._force_amplitude_n(w), w)
        n_fric = self._friction_damping(w)
        stuck = np.isinf(n_fric)
        with np.errstate(invalid="ignore"):
            mech = self.mechanics(extra_damping_n_s_per_m=np.where(stuck, 0.0, n_fric)).velocity_per_force(s)
        return np.where(stuck, 0.0, mech) * series

    def _check_frequency_model(self) -> None:
        for e in self.effects:
            if not e.frequency_response:
                raise EffectError(f"{e.name} has no frequency-response model (it is fitted from time-domain data); "
                                  "leave it out of a plant whose response is computed")

    def frd_outputs(self, w_rad_s, *, checked: bool = True) -> np.ndarray:
        """Velocity per current at each output, shape (..., n_outputs, n_freq) (m/s per A). ``checked=False``
        skips validating the grid, for a caller evaluating many plants on one grid it has checked."""
        self._check_frequency_model()
        w = check_grid(w_rad_s) if checked else w_rad_s
        tilt = self._tilt()
        if tilt is None:
            resp = self._chain_frd(w)[..., None, :]
            return np.repeat(resp, len(self.output_names), axis=-2) * self.output_scales()
        kt = np.asarray(self.force_constant_n_per_a, float)
        n_fric = self._friction_damping(w)
        stuck = np.isinf(n_fric)
        b = np.asarray(self.damping_n_s_per_m, float) + np.where(stuck, 0, n_fric) / 2
        l1, l2 = self._loads_l1_l2(tilt)
        h = xie_wang_frd(w, mass_kg=self.mass_kg, inertia_kg_m2=tilt.inertia_kg_m2, damping1_n_s_per_m=b,
                         damping2_n_s_per_m=b, l1_m=l1, l2_m=l2,
                         joint_stiffness_n_m_per_rad=tilt.stiffness_n_m_per_rad)
        # the motors' shares of K_t i (half each, unless their force constants differ)
        s1, s2 = (_over_outputs(x) for x in self.motor_shares())
        v = (h[..., :, 0, :] * s1 + h[..., :, 1, :] * s2) * (kt[..., None] if kt.ndim else kt)
        s = 1j * w
        series = self._limit_gain() * self.chain_response(s, "drive") * self.chain_response(s, "sensor")
        v = v * (series[..., None, :] if np.ndim(series) else series) * self.output_scales()
        # friction that sticks at this excitation holds both rails
        return np.where(stuck[..., None, :], 0.0, v) if np.ndim(stuck) else (0.0 * v if stuck else v)

    def output_scales(self) -> np.ndarray:
        """Factor on each recorded output, shape (..., n_outputs, 1) (broadcast over frequency): 1, or a rail read
        to another scale (``rail_scale``)."""
        scale = self.effect("rail_scale")
        n = len(self.output_names)
        return np.ones((n, 1)) if scale is None else scale.output_scales(n)

    def motor_shares(self) -> tuple:
        """Each rail motor's part of the force K_t i (Y1, Y2): half each, unless their force constants differ
        (``motor_imbalance``)."""
        imbalance = self.effect("motor_imbalance")
        return (0.5, 0.5) if imbalance is None else imbalance.shares()

    def frd(self, w_rad_s) -> np.ndarray:
        """Velocity per current (m/s per A), shape (..., n_freq); Stage Y: mean of the rails Y1, Y2."""
        if self._tilt() is None and self.effect("rail_scale") is None:  # the outputs coincide: skip the copies
            self._check_frequency_model()
            w = check_grid(w_rad_s)
            return self._chain_frd(w)
        return self.frd_outputs(w_rad_s).mean(axis=-2)

    # --- python-control interoperability ---------------------------------------
    def to_control(self, *, pade_order: int = PADE_ORDER) -> control.TransferFunction:
        """Rational model as a transfer function (Pade for delays). A nonlinear effect has none and raises
        ``EffectError``. Its polynomial coefficients span many decades (to 1e29 with a delay and a current loop):
        to compute with it, take ``to_state_space()``."""
        import control

        check_count("pade_order", pade_order, minimum=1)
        self._check_rational("to_control")
        kt = float(np.asarray(self.force_constant_n_per_a).reshape(()))
        tilt = self._tilt()
        if tilt is None:
            A, B, C = chain_state_space(self.mechanics())
            tf = control.minreal(control.ss2tf(control.ss(A, B[:, :1] * kt, C, 0.0)), verbose=False)
            # unit constant term in the denominator (as 1 + s/w...): products with Pade factors stay in range
            num, den = (np.asarray(p[0][0], float) for p in (tf.num, tf.den))
            sys = control.tf(num / den[-1], den / den[-1])
        else:
            ss = self._beam_ss(tilt)
            # mean rail velocity for f1 = f2 = K_t i / 2
            mean = control.ss([], [], [], [[0.5, 0.5]]) * ss * control.ss([], [], [], [[kt / 2], [kt / 2]])
            sys = control.minreal(control.ss2tf(mean), verbose=False)
        return series_tf(sys, *(e.to_tf(pade_order=pade_order) for e in self.effects if isinstance(e, ChainEffect)))

    def to_state_space(self, *, pade_order: int = PADE_ORDER) -> control.StateSpace:
        """A well-scaled rational model: the drive chain's effects, the mechanics (the chain of bodies, or the
        tilting beam) and the sensor chain's effects as state-space blocks in series, each block and the whole
        balanced by a diagonal similarity (``balanced``); delays as Pade approximants of ``pade_order``. Input
        ``current`` (A), output ``velocity`` (m/s; Stage Y: the mean of the rails, as ``frd``, with the rails'
        scales and motor shares). The product of transfer functions (``to_control``) has polynomial coefficients
        over 30 decades; this realisation's state matrix has entries within a few decades. python-control takes
        it as it is (``ct.bode_plot``, ``ct.margin``, ``ct.feedback``). A nonlinear effect, a batch of parameters or
        an effect with no frequency-response model raises ``EffectError``/``ParameterError``."""
        import control

        check_count("pade_order", pade_order, minimum=1)
        self._check_rational("to_state_space")
        self._check_frequency_model()
        kt = float(np.asarray(self.force_constant_n_per_a).reshape(()))
        scales = np.asarray(self.output_scales(), float).reshape(-1)
        tilt = self._tilt()
        if tilt is None:
            A, B, C = chain_state_space(self.mechanics())
            # every recorded output reads the same rail: the mean of their scales (``frd``)
            mech = control.ss(A, B * kt, C * float(np.mean(scales)), 0.0)
        else:
            beam = self._beam_ss(tilt)
            # the beam's position y_c (state 0) moves nothing and no velocity reads it: left out, the rest is minimal
            beam = control.ss(beam.A[1:, 1:], beam.B[1:], beam.C[:, 1:], beam.D)
            shares = np.array([[float(np.asarray(x).reshape(()))] for x in self.motor_shares()])
            mech = (control.ss([], [], [], [scales / len(scales)]) * beam *
                    control.ss([], [], [], shares * kt))
        out = balanced(mech)
        for place in ("drive", "sensor"):
            for e in self.effects:
                if isinstance(e, ChainEffect) and e.place == place:
                    block = balanced(control.ss(e.to_tf(pade_order=pade_order)))
                    out = out * block if place == "drive" else block * out
        out = balanced(out)
        return control.ss(out.A, out.B, out.C, out.D, name=f"stage_{self.stage}", inputs="current",
                          outputs="velocity")

    def _beam_ss(self, tilt) -> control.StateSpace:
        """The tilting beam (Xie & Wang) of one plant: forces on the rails in, the rails' velocities out."""
        from plant.physics.gantry_models import xie_wang_ss

        l1, l2 = (float(v) for v in self._loads_l1_l2(tilt))
        damping = float(np.asarray(self.damping_n_s_per_m).reshape(()))
        return xie_wang_ss(mass_kg=float(np.asarray(self.mass_kg).reshape(())),
                           inertia_kg_m2=float(np.asarray(tilt.inertia_kg_m2).reshape(())),
                           damping1_n_s_per_m=damping, damping2_n_s_per_m=damping, l1_m=l1, l2_m=l2,
                           joint_stiffness_n_m_per_rad=float(np.asarray(tilt.stiffness_n_m_per_rad).reshape(())))

    def _check_rational(self, what: str) -> None:
        for name in BASE_PARAMETERS:
            if np.size(getattr(self, name)) != 1:
                raise ParameterError(f"{name} is a batch; {what} needs one plant (index the batch first)")
        for e in self.effects:
            if not e.linear:
                raise EffectError(f"{e.name} is nonlinear and has no transfer function; "
                                  "use frd() (describing function) or the time-domain simulator")

    def to_frd_data(self, w_rad_s) -> control.FrequencyResponseData:
        """python-control ``FrequencyResponseData`` of ``frd`` on the grid."""
        import control

        w = check_grid(w_rad_s)
        resp = self.frd(w)
        if resp.ndim != 1:
            raise ParameterError("to_frd_data needs one plant, not a batch")
        return control.frd(resp, w)


def _floats(values: tuple) -> tuple[float, ...]:
    return tuple(float(np.asarray(v).reshape(())) for v in values)


def chain_state_space(chain: BodyChain) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, C) of a chain of bodies: states (v_0 .. v_(n-1), spring extensions q_i - q_(i+1), and with a
    ground spring body 0's position q_0, relaxed at 0), inputs (motor force on body 0, N), output the recorded
    velocity (m/s)."""
    M, D, K = chain.matrices()
    n = M.shape[0]
    T = np.zeros((n, n - 1))
    for i in range(n - 1):
        T[i, i], T[i + 1, i] = 1.0, -1.0
    k = np.array([K[i, i + 1] for i in range(n - 1)]) * -1.0
    Minv = np.linalg.inv(M)
    A = np.block([[-Minv @ D, -Minv @ T * k], [T.T, np.zeros((n - 1, n - 1))]])
    if chain.grounded:
        ground = np.zeros((2 * n, 2 * n))
        ground[:-1, :-1] = A
        ground[:n, -1] = -Minv[:, 0] * float(np.asarray(chain.rail_stiffness_n_per_m).reshape(()))
        ground[-1, 0] = 1.0
        A = ground
    B = np.zeros((A.shape[0], 1))
    B[:n, 0] = Minv[:, 0]
    C = np.zeros((1, A.shape[0]))
    C[0, chain.sensed] = 1.0
    return A, B, C


def stage_x(**params) -> Plant:
    """Thesis Stage X (Eq. 3.15) with the thesis values unless overridden."""
    return Plant("x", **params)


def stage_y(**params) -> Plant:
    """Thesis Stage Y (Eq. 3.16) with the thesis values unless overridden."""
    return Plant("y", **params)


def build_plant(stage: str, *, effects: dict[str, dict[str, float]] | None = None, **params) -> Plant:
    """Plant from a stage name, base parameters and ``{effect_name: {param: value}}``."""
    fx = tuple(make_effect(name, **(p or {})) for name, p in (effects or {}).items())
    return Plant(stage, effects=fx, **params)


def corner_frequency_hz(plant: Plant) -> np.ndarray:
    """Corner frequency b_e / (2 pi m_e) of the base plant (X: b/M; Y: b L / (M l)), Hz."""
    m_e, b_e = plant._effective_mass_damping()
    return b_e / (2 * math.pi * m_e)


def _over_outputs(value) -> np.ndarray:
    """A parameter value (scalar or (..., 1), broadcast over frequency) as (..., 1, 1): over outputs and frequency."""
    x = np.asarray(value, float)
    return (x if x.ndim else x[None])[..., None, :]
