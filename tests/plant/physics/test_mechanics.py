"""The mechanics as a network of masses, springs and dampers, against independent references.

References: python-control state spaces of the physical networks written out here from
Newton's law (masses, spring, viscous coupling, rail damping), and the closed forms of the
two-mass system (notch sqrt(k/m2), peak sqrt(k (m1 + m2) / (m1 m2))).
"""

import math

import control
import numpy as np
import pytest

from plant import stage_x
from plant.errors import EffectError
from plant.physics.effects import PayloadResonance, Resonance, SecondResonance

W = 2 * np.pi * np.geomspace(0.5, 500, 300)
S = 1j * W
KT = 20.0


def network(masses, springs, dampers, rail_b, sensed):
    """Force on body 0, velocity of body ``sensed``: states (positions, velocities)."""
    n = len(masses)
    K = np.zeros((n, n))
    D = np.zeros((n, n))
    D[0, 0] = rail_b
    for i, (k, c) in enumerate(zip(springs, dampers)):
        for mat, v in ((K, k), (D, c)):
            mat[i:i + 2, i:i + 2] += v * np.array([[1, -1], [-1, 1]])
    Minv = np.diag(1 / np.asarray(masses, float))
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ D]])
    B = np.concatenate([np.zeros(n), Minv[:, 0]])[:, None]
    C = np.zeros((1, 2 * n))
    C[0, n + sensed] = 1
    return control.ss(A, B, C, 0)


def test_two_mass_motor_sensed_is_the_physical_network():
    m1, m2, k, c, b = 8.0, 27.0, 3.0e6, 150.0, 440.0
    mu = m1 * m2 / (m1 + m2)
    zeta = c / (2 * math.sqrt(k * mu))
    r = Resonance.from_two_mass(motor_mass_kg=m1, load_mass_kg=m2, stiffness_n_per_m=k, damping_ratio=zeta)
    p = stage_x(mass_kg=m1 + m2, damping_n_s_per_m=b) * r
    ref = KT * network([m1, m2], [k], [c], b, 0)(S)
    assert np.allclose(p.frd(W), ref, rtol=1e-10)
    # viscous coupling: the notch pair is damped zeta * f_a / f_r, the peak pair zeta (module doc)
    zeros = control.ss2tf(network([m1, m2], [k], [c], 0.0, 0)).num[0][0]
    wa = math.sqrt(k / m2)
    assert zeros[1] / zeros[0] == pytest.approx(2 * zeta * wa * r.antiresonance_hz / r.frequency_hz, rel=1e-9)


def test_payload_sensed_has_no_notch_and_loses_180_deg():
    m1, m2, k, c, b = 12.0, 23.0, 2.0e6, 80.0, 440.0
    r = PayloadResonance.from_two_mass(motor_mass_kg=m1, load_mass_kg=m2, stiffness_n_per_m=k,
                                       damping_ratio=c / (2 * math.sqrt(k * m1 * m2 / (m1 + m2))))
    p = stage_x(mass_kg=m1 + m2, damping_n_s_per_m=b) * r
    assert np.allclose(p.frd(W), KT * network([m1, m2], [k], [c], b, 1)(S), rtol=1e-10)
    rigid = stage_x(mass_kg=m1 + m2, damping_n_s_per_m=b)
    phase = np.unwrap(np.angle(p.frd(W) / rigid.frd(W)))
    assert phase[0] == pytest.approx(0, abs=1e-3) and phase[-1] == pytest.approx(-math.pi, abs=0.2)
    assert p.antiresonances_hz().size == 0


def test_three_mass_chain_and_its_modes():
    m, k, c = [6.0, 20.0, 9.0], [2.5e6, 1.2e6], [60.0, 30.0]
    first = Resonance.from_two_mass(motor_mass_kg=m[0], load_mass_kg=m[1] + m[2], stiffness_n_per_m=k[0],
                                    damping_ratio=1e-9)
    # the second mode splits the payload m2 + m3 the same way (its own free pair)
    second = SecondResonance.from_two_mass(motor_mass_kg=m[1], load_mass_kg=m[2], stiffness_n_per_m=k[1],
                                           damping_ratio=1e-9)
    mu = [m[0] * (m[1] + m[2]) / sum(m), m[1] * m[2] / (m[1] + m[2])]
    first = first.with_values(damping_ratio=c[0] / (2 * math.sqrt(k[0] * mu[0])))
    second = second.with_values(damping_ratio=c[1] / (2 * math.sqrt(k[1] * mu[1])))
    p = stage_x(mass_kg=sum(m), damping_n_s_per_m=300.0) * first * second
    ref = network(m, k, c, 300.0, 0)
    assert np.allclose(p.frd(W), KT * ref(S), rtol=1e-9)
    # modes: eigenvalues of M^-1 K of the undamped chain (numpy, independent of the ladder)
    K = np.array([[k[0], -k[0], 0], [-k[0], k[0] + k[1], -k[1]], [0, -k[1], k[1]]])
    lam = np.sort(np.linalg.eigvals(np.diag(1 / np.array(m)) @ K).real)[1:]
    assert p.modes_hz() == pytest.approx(np.sqrt(lam) / (2 * np.pi), rel=1e-9)
    assert np.allclose(p.to_control()(S), p.frd(W), rtol=1e-7)


def test_mode_effects_compose_by_their_physics():
    with pytest.raises(EffectError, match="second_resonance needs one of resonance, payload_resonance"):
        stage_x() * SecondResonance()
    with pytest.raises(EffectError, match="cannot be combined"):
        stage_x() * Resonance() * PayloadResonance()
