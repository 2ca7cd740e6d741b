"""The plant's open-loop linear model in the time domain: the one realisation every simulation and every
sampled-data check is built from.

From the current command i_c to the recorded velocities (SI units), a batch of plants::

    i_c -> drive chain E -> i (motor current) -> F_m = K_t i on the rails
        -> mechanics: the chain of bodies (``chain_state_space``; thesis Eq. 3.15 / 3.16 split by the mode
           effects, on a ground spring where an effect has one) driven on body 0, or with ``tilt_coupling`` the
           Xie-Wang model (thesis Eq. 2.14-2.15) with both motors carrying K_t i / 2 on their rails
        -> the sensed bodies' velocities -> sensor chain H -> the recorded velocities

Each rail contact also takes a force F_j besides the motor's (friction, an effect's ``rail_force_n``, a load on
the clamp). The drive chain holds every drive factor of the plant but the delay and the drive's sampling, which
a simulator applies exactly to the command; with a ``pade_order`` they enter by their rational approximants
(``ChainEffect.state_space``), as a sampled-data check needs them. One sensor chain per distinct recorded
velocity: Stage Y's two rails read the same velocity unless the beam tilts (or a rail is read to another scale,
``rail_scale``, or the motors push unequally, ``motor_imbalance``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from plant.errors import ParameterError
from plant.physics.effect_base import effects_state_space
from plant.physics.gantry_models import xie_wang_ss
from plant.physics.models import Plant, chain_state_space
from plant.physics.state_space import column


@dataclass(frozen=True)
class Realisation:
    """x' = A x + B (i_c, F_1 .. F_k), batched (n, ...): i_c the current command (A) reaching the drive chain,
    F_j a force (N) on rail contact j besides the motor's. Rows over the states: ``outputs`` the recorded
    velocities (after the sensor chain, m/s), ``velocity`` the sensed bodies' velocities before it, ``contacts``
    the contacts' sliding velocities; ``current`` the motor current i (A) over (x, i_c); the motor force on
    contact j is ``share[j]`` K_t i; ``ground`` the rails' position where a ground spring holds them (an effect's
    ``rail_stiffness``; relaxed at 0, so a run that starts elsewhere sets it to its start), zero rows without one.
    ``drive``, ``mechanics``, ``sensor``: the states of each part."""

    A: np.ndarray
    B: np.ndarray
    outputs: np.ndarray
    velocity: np.ndarray
    contacts: np.ndarray
    current: np.ndarray
    force_constant_n_per_a: np.ndarray
    share: np.ndarray
    drive: slice
    mechanics: slice
    sensor: slice
    ground: np.ndarray

    @property
    def order(self) -> int:
        return self.A.shape[-1]

    @property
    def n_contacts(self) -> int:
        return self.contacts.shape[-2]

    def one(self, index: int = 0) -> Realisation:
        """Plant ``index`` of the batch, without the batch axis."""
        fields = ("A", "B", "outputs", "velocity", "contacts", "current", "force_constant_n_per_a", "ground")
        return replace(self, **{f: getattr(self, f)[index] for f in fields})

    @property
    def motor_force(self) -> np.ndarray:
        """The motor's force on contact 0 (N) as a row over (x, i_c)."""
        return self.force_constant_n_per_a[..., None] * self.share[0] * self.current


def _chain_mechanics(plants: Plant, n: int):
    """(A, B, C) of a batch of ``n`` plants' chains of bodies: inputs the force on body 0, output the sensed
    body's velocity (one body in closed form)."""
    chain = plants.mechanics()
    if len(chain.masses_kg) == 1 and not chain.grounded:
        m = column(chain.masses_kg[0], n)[:, None, None]
        b = column(chain.rail_damping_n_s_per_m, n)[:, None, None]
        return -b / m, 1.0 / m, np.ones((n, 1, 1))
    parts = []
    for j in range(n):
        pick = lambda x: float(column(x, n)[j])          # noqa: E731
        one = replace(chain, masses_kg=tuple(map(pick, chain.masses_kg)),
                      stiffness_n_per_m=tuple(map(pick, chain.stiffness_n_per_m)),
                      damping_n_s_per_m=tuple(map(pick, chain.damping_n_s_per_m)),
                      rail_damping_n_s_per_m=pick(chain.rail_damping_n_s_per_m),
                      rail_stiffness_n_per_m=pick(chain.rail_stiffness_n_per_m))
        parts.append(chain_state_space(one))
    return tuple(np.stack([p[i] for p in parts]) for i in range(3))


def _scalar(name: str, value) -> float:
    arr = np.asarray(value, dtype=float)
    if arr.size != 1:
        raise ParameterError(f"{name} is a batch of {arr.size} values; the tilt model needs one plant")
    return float(arr.reshape(()))


def _tilt_mechanics(plant: Plant, tilt):
    """(A, B per rail, C per rail) of the Xie-Wang beam of one plant, its position y_c dropped (nothing depends
    on it): states (alpha, v_c, omega)."""
    l1, l2 = (float(v) for v in plant._loads_l1_l2(tilt))
    b = _scalar("damping_n_s_per_m", plant.damping_n_s_per_m)
    ss = xie_wang_ss(mass_kg=_scalar("mass_kg", plant.mass_kg),
                     inertia_kg_m2=_scalar("tilt_coupling.inertia_kg_m2", tilt.inertia_kg_m2),
                     damping1_n_s_per_m=b, damping2_n_s_per_m=b, l1_m=l1, l2_m=l2,
                     joint_stiffness_n_m_per_rad=_scalar("tilt_coupling.stiffness_n_m_per_rad",
                                                         tilt.stiffness_n_m_per_rad))
    return ss.A[None, 1:, 1:], ss.B[None, 1:, :], ss.C[None, :, 1:]


def realise(plants: Plant, n: int = 1, *, pade_order: int | None = None) -> Realisation:
    """The ``Realisation`` of a batch of ``n`` plants (module docstring); ``pade_order``: the delay and the
    sampling by their Pade approximants of that order (None: left out, for a simulator to apply exactly)."""
    tilt = plants.effect("tilt_coupling")
    n_out = len(plants.output_names)
    if tilt is None:
        Am, Bm, Cm = _chain_mechanics(plants, n)
        contacts = np.zeros((n, 1, Am.shape[-1]))
        contacts[:, 0, 0] = 1.0                       # body 0's velocity: the chain's first state
        share, sensed = np.ones(1), np.repeat(Cm, n_out, axis=1)
    else:
        if n != 1:
            raise ParameterError("the tilt model is realised for one plant at a time")
        Am, Bm, Cm = _tilt_mechanics(plants, tilt)
        contacts, sensed = Cm, Cm
        share = np.array([float(np.asarray(x, float).reshape(-1)[0]) for x in plants.motor_shares()])
    # the drive factors a simulator applies exactly to the command (``realised_as`` "applied") by their Pade
    # approximants only when asked
    drive = [e for e in plants.effects if pade_order is not None or e.realised_as != "applied"]
    E = effects_state_space(drive, "drive", n, **({} if pade_order is None else {"pade_order": pade_order}))
    H = effects_state_space(plants.effects, "sensor", n, **({} if pade_order is None else {"pade_order": pade_order}))
    kt = column(plants.force_constant_n_per_a, n)
    n_sensors = 1 if tilt is None else n_out                  # one sensor chain per distinct velocity
    ne, nm, nh = E.order, Am.shape[-1], H.order
    k = Bm.shape[-1]
    m = ne + nm + n_sensors * nh
    e, g = slice(0, ne), slice(ne, ne + nm)
    A = np.zeros((n, m, m))
    B = np.zeros((n, m, 1 + k))
    A[:, e, e], B[:, e, :1] = E.A, E.B
    # the motor force K_t i shared over the contacts, i = C_e x_e + D_e i_c
    push = Bm @ (share[:, None] * kt[:, None, None])                # (n, nm, 1)
    A[:, g, e] = push @ E.C
    B[:, g, :1] = push @ E.D
    A[:, g, g], B[:, g, 1:] = Am, Bm
    outputs = np.zeros((n, n_out, m))
    velocity = np.zeros((n, n_out, m))
    velocity[:, :, g] = sensed
    for j in range(n_out):
        q = j if n_sensors > 1 else 0
        h = slice(ne + nm + q * nh, ne + nm + (q + 1) * nh)
        if j == q:
            A[:, h, h] = H.A
            A[:, h, g] = H.B @ sensed[:, j:j + 1]
        outputs[:, j, h] = H.C[:, 0]
        outputs[:, j, g] = H.D[:, 0] * sensed[:, j]
    scale = plants.effect("rail_scale")
    if scale is not None:                                     # rail Y2 read to another scale
        outputs[:, 1, :] *= column(scale.y2_scale, n)[:, None]
    contact_rows = np.zeros((n, k, m))
    contact_rows[:, :, g] = contacts
    current = np.zeros((n, m + 1))
    current[:, e], current[:, m] = E.C[:, 0], E.D[:, 0, 0]
    ground = np.zeros((n, m))
    if tilt is None and plants.mechanics().grounded:
        ground[:, g.stop - 1] = 1.0                   # the chain's last state: body 0's position
    return Realisation(A, B, outputs, velocity, contact_rows, current, kt, share, e, g, slice(ne + nm, m), ground)
