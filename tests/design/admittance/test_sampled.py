"""The exact sampled-data interaction loop (``design.admittance.sampled``) against references that share no code
with it: Newton's-law state space discretised by scipy (``independent_admittance``), a converged alias sum of
that model's continuous response, a fine-step Runge-Kutta simulation of the coupled loop with the law run at
the rig's rate, and python-control's margins, at the corners of the bundled spec where the answer is hardest
(gain crossings near the law's Nyquist frequency)."""

import itertools
import math
from pathlib import Path

import independent_admittance as ref
import numpy as np
import pytest

from design.admittance.model import AdmittanceEvaluator, PiLoops, coupled_gain, mice
from design.admittance.mouse import MouseModel, stack
from design.admittance.rig import RigTiming
from design.admittance.sampled import closed_loop_radius, discretised_paths, mouse_loads
from design.loop.controller import PI
from design.spec.schema import load_spec
from design.synth.scenarios import Scenarios

ROOT = Path(__file__).resolve().parents[3]
SPEC = ROOT / "specs" / "stage_x_admittance.toml"
T = 0.01                                   # the bundled rig: the law at 100 Hz, forward Euler
CORNER = {"payload_kg": 40.0, "damping_n_s_per_m": 330.0, "delay.seconds": 0.0008, "current_loop.bandwidth_hz": 700.0}
FLOATING = MouseModel(0.002, 0.035, 200.0, 0.2, 0.0, 0.0)
BRACED = MouseModel(0.010, 0.020, 20.0, 1.0, 1.0e4, 0.5)
#: (Kp, Ki, m_v, b_v): the issue's near-Nyquist case, the light design, the lab's setting with the co-designed PI
#: and with the spec's PI, and a stiff one
DESIGNS = [(178.5, 300.0, 0.05, 8.0), (209.9, 14.12, 0.0436, 5.05), (209.9, 14.12, 0.04, 4.0),
           (178.5, 19150.0, 0.33, 7.6), (400.0, 2000.0, 0.2, 20.0)]


def _scenario(row=CORNER) -> Scenarios:
    return Scenarios(np.array([row["payload_kg"]]), {k: np.array([v]) for k, v in row.items() if k != "payload_kg"})


def _newton(kp, ki, mouse: MouseModel, row=CORNER, pade=8):
    return ref.coupled_path(mass_kg=row["payload_kg"], damping=row["damping_n_s_per_m"], kt=20.0, kp=kp, ki=ki,
                            delay_s=row["delay.seconds"], current_hz=row["current_loop.bandwidth_hz"],
                            head_kg=mouse.head_mass_kg, body_kg=mouse.body_mass_kg,
                            neck_k=mouse.neck_stiffness_n_per_m, neck_c=mouse.neck_damping_n_s_per_m,
                            leg_k=mouse.leg_stiffness_n_per_m, leg_c=mouse.leg_damping_n_s_per_m, pade=pade)


def _tool_gain(kp, ki, mouse, w, row=CORNER):
    spec = load_spec(SPEC).problem()
    timing = RigTiming(T, rule="forward_euler")
    return coupled_gain(PiLoops.of(spec, PI(kp, ki)), _scenario(row), stack([mouse]), w, timing)[0, 0]


def _reference_margins(kp, ki, m_v, b_v, mouse, row=CORNER, law="forward_euler"):
    """python-control's margins of the scipy-discretised Newton loop on a dense grid to the Nyquist frequency,
    with the phase-crossover frequency (Hz) of the gain margin (the law forward Euler, or "zoh")."""
    import control

    loop = ref.sampled_loop(_newton(kp, ki, mouse, row), m_v=m_v, b_v=b_v, period_s=T,
                            forward_euler=law == "forward_euler", zoh=law == "zoh")
    w = np.geomspace(2 * math.pi * 1e-3, math.pi / T, 8000)
    L = ref.response(loop, np.exp(1j * w * T))
    gm, pm, _, wpc, _, _ = control.stability_margins(control.frd(L, w))
    gm_db, f_pc = 20 * math.log10(gm) if np.isfinite(gm) else math.inf, wpc / (2 * math.pi)
    # the discrete loop's Nyquist curve ends on the real axis at the Nyquist frequency: a phase crossover there
    if L[-1].real < 0 and -20 * math.log10(-L[-1].real) < gm_db:
        gm_db, f_pc = -20 * math.log10(-L[-1].real), 1 / (2 * T)
    return pm, gm_db, f_pc, ref.closed_loop_stable(loop, discrete=True)


@pytest.mark.parametrize("mouse", [FLOATING, BRACED], ids=["floating", "braced"])
def test_exact_discretisation_equals_scipys_zero_order_hold_of_newtons_model(mouse):
    from scipy.signal import cont2discrete

    w = np.geomspace(2 * math.pi * 1e-3, math.pi / T, 400)
    Ad, Bd, Cd, Dd, _ = cont2discrete(_newton(178.5, 300.0, mouse), T, method="zoh")
    Kd = ref.response((Ad, Bd, Cd, Dd), np.exp(1j * w * T))
    # scipy's own discretisation is the looser side here: against a 40-digit matrix exponential (mpmath) the tool is
    # within 1e-9 over this grid and scipy 1.17's cont2discrete 1.2e-7 off at the Nyquist frequency (floating mouse)
    assert np.max(np.abs(_tool_gain(178.5, 300.0, mouse, w) / Kd - 1)) < 2.5e-7


def _newton_frd(kp, ki, mouse: MouseModel, s, row=CORNER):
    """K(s) of Newton's model with the exact delay e^(-s tau), written out: the gantry 1/(M s + b) under
    F_m = K_t E (kp + ki/s)(u - v), E = e^(-s tau) w_c / (s + w_c), loaded by the mouse's impedance Z_m."""
    wc = 2 * math.pi * row["current_loop.bandwidth_hz"]
    drive = 20.0 * np.exp(-s * row["delay.seconds"]) * wc / (s + wc) * (kp + ki / s)
    G = 1.0 / (row["payload_kg"] * s + row["damping_n_s_per_m"])
    zn = mouse.neck_damping_n_s_per_m + mouse.neck_stiffness_n_per_m / s
    zb = mouse.body_mass_kg * s + mouse.leg_damping_n_s_per_m + mouse.leg_stiffness_n_per_m / s
    zm = mouse.head_mass_kg * s + zn * zb / (zn + zb)
    S = 1.0 / (1.0 + drive * G)
    return zm * drive * G * S / (1.0 + S * G * zm)


def test_a_converged_alias_sum_of_the_continuous_model_reaches_the_exact_discretisation():
    # (1/T) sum_k K(jw_k) (1 - e^(-jw_k T)) / (jw_k) over k = -N-1 .. N of Newton's continuous response with the
    # exact delay: near the Nyquist frequency the 8-term sum is > 5 % off; at N = 3000 the sum is within 1e-4
    # of the tool's K_d (the Pade order's share of the difference: ``test_pade_order_is_converged``)
    w = np.geomspace(2 * math.pi * 0.5, 0.999 * math.pi / T, 60)
    exact = _tool_gain(178.5, 300.0, FLOATING, w)
    errors = []
    for n in (3, 30, 3000):
        k = np.arange(-n - 1, n + 1)
        s = 1j * (w[None, :] + 2 * math.pi * k[:, None] / T)
        total = (_newton_frd(178.5, 300.0, FLOATING, s) * -np.expm1(-s * T) / (s * T)).sum(axis=0)
        errors.append(np.max(np.abs(total / exact - 1)))
    assert errors[0] > 0.05
    assert errors[1] < errors[0] / 5 and errors[2] < 1e-4, errors


@pytest.mark.parametrize("period_s", [T, 0.005], ids=["100 Hz", "200 Hz"])
@pytest.mark.parametrize("mouse", [FLOATING, BRACED], ids=["floating", "braced"])
def test_pade_order_is_converged(period_s, mouse):
    # the delay's Pade order the tool picks for the law's period (0.8 ms: order 4 at 100 Hz, 6 at 200 Hz) against
    # order 12, up to the law's Nyquist frequency
    from design.admittance import sampled

    spec = load_spec(SPEC).problem()
    w = np.geomspace(2 * math.pi * 1e-3, math.pi / period_s, 300)
    timing = RigTiming(period_s, rule="forward_euler")
    plants = _scenario().plants(spec.plant.plant())
    gains = []
    for order in (sampled.pade_order_for(plants, period_s), 12):
        free = sampled.free_gantry(plants, 1, controller=PI(178.5, 300.0), pade_order=order)

        class Loops:
            def free_state_space(self, scenarios, *, period_s=None, free=free):
                return free

        paths = discretised_paths(Loops(), _scenario(), mouse_loads(stack([mouse])), timing)
        gains.append(sampled.sampled_gain(paths, w, timing)[0])
    assert sampled.pade_order_for(plants, period_s) < 12
    assert np.max(np.abs(gains[0] / gains[1] - 1)) < 1e-7


def test_a_law_as_fast_as_the_delay_is_within_three_percent_of_the_exact_delay():
    # at 1 kHz the 0.8 ms delay is most of a sample: the Pade path (order 8) against the alias sum of the exact
    # delay's response over 40,000 terms, up to the Nyquist frequency
    w = np.geomspace(2 * math.pi, 0.999 * math.pi / 0.001, 40)
    spec = load_spec(SPEC).problem()
    timing = RigTiming(0.001, rule="forward_euler")
    exact = coupled_gain(PiLoops.of(spec, PI(178.5, 300.0)), _scenario(), stack([FLOATING]), w, timing)[0, 0]
    k = np.arange(-20001, 20001)
    s = 1j * (w[None, :] + 2 * math.pi * k[:, None] / 0.001)
    alias = (_newton_frd(178.5, 300.0, FLOATING, s) * -np.expm1(-s * 0.001) / (s * 0.001)).sum(axis=0)
    assert np.max(np.abs(exact / alias - 1)) < 0.03


def test_margins_agree_with_the_independent_sampled_loop_at_five_designs():
    # the tool's worst floating and braced curves at the spec's corners, each against python-control on the
    # scipy-discretised Newton loop: within 0.2 dB and 0.2 deg; one design's gain margin is read within 15 % of
    # the law's Nyquist frequency, where an 8-term alias sum was 1.2 dB wrong
    spec = load_spec(SPEC).problem()
    sc = Scenarios(np.array([5.0, 40.0]).repeat(8), {
        "damping_n_s_per_m": np.tile(np.repeat([330.0, 550.0], 4), 2),
        "delay.seconds": np.tile(np.repeat([0.0003, 0.0008], 2), 4),
        "current_loop.bandwidth_hz": np.tile([700.0, 1300.0], 8)})
    near_nyquist = False
    for kp, ki, m_v, b_v in DESIGNS:
        ev = AdmittanceEvaluator(spec, sc, loops=PiLoops.of(spec, PI(kp, ki)))
        check = ev.evaluate(m_v, b_v, screen=False)
        for arr in (check.phase_margin_deg, check.gain_margin_db):
            k, j = np.unravel_index(np.nanargmin(arr), arr.shape)
            pm, gm, f_pc, stable = _reference_margins(kp, ki, m_v, b_v, check.mice[k], sc.row(j).as_dict())
            assert bool(check.stable[k, j]) == stable, (kp, ki, m_v, b_v)
            if not stable:
                continue
            assert abs(check.phase_margin_deg[k, j] - pm) < 0.2, (kp, ki, m_v, b_v, check.phase_margin_deg[k, j], pm)
            assert abs(check.gain_margin_db[k, j] - gm) < 0.2, (kp, ki, m_v, b_v, check.gain_margin_db[k, j], gm)
            near_nyquist |= f_pc > 0.85 / (2 * T)
    assert near_nyquist


def _simulate_growth(kp, ki, m_v, b_v, mouse, *, seconds=6.0, substeps=200):
    """Peak |force| over the last and the first second of the coupled loop started from a 1 mm/s reference kick:
    the continuous Newton model stepped by classical Runge-Kutta at T / substeps, the sensed force sampled and the
    forward-Euler law updated once per T, its output held."""
    A, B, C, D = _newton(kp, ki, mouse)
    h = T / substeps
    x = np.zeros(A.shape[0])
    v_law, u = 1e-3, 1e-3

    def f(x, u):
        return A @ x + B[:, 0] * u

    peaks = []
    for k in range(int(seconds / T)):
        force = -(C[0] @ x + D[0, 0] * u)            # F_s = -K u
        v_law = v_law + T * (force - b_v * v_law) / m_v
        u = v_law
        for _ in range(substeps):
            k1 = f(x, u)
            k2 = f(x + 0.5 * h * k1, u)
            k3 = f(x + 0.5 * h * k2, u)
            k4 = f(x + h * k3, u)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        peaks.append(abs(force))
    n = int(1.0 / T)
    return max(peaks[-n:]) / max(max(peaks[:n]), 1e-30)


def test_gain_margin_and_stability_agree_with_a_fine_step_simulation():
    # the tool's gain margin of the near-Nyquist design, shrinking (m_v, b_v) together: 20 % inside it the loop's
    # oscillation decays in a Runge-Kutta simulation of the sampled loop, 20 % beyond it grows; the tool's
    # discrete closed-loop poles say the same
    spec = load_spec(SPEC).problem()
    kp, ki, m_v, b_v = DESIGNS[0]
    ev = AdmittanceEvaluator(spec, _scenario(), loops=PiLoops.of(spec, PI(kp, ki)), corners=[FLOATING])
    gm_db = float(ev.evaluate(m_v, b_v, screen=False).gain_margin_db[0, 0])
    g = 10 ** (gm_db / 20)
    timing = RigTiming(T, rule="forward_euler")
    paths = discretised_paths(PiLoops.of(spec, PI(kp, ki)), _scenario(), mouse_loads(stack([FLOATING])), timing)
    for factor, grows in ((0.8, False), (1.2, True)):
        scale = 1.0 / (g * factor)
        ratio = _simulate_growth(kp, ki, m_v * scale, b_v * scale, FLOATING)
        radius = closed_loop_radius(paths, timing.law(m_v * scale, b_v * scale), 0)[0]
        assert (ratio > 1.0) == grows and (radius > 1.0) == grows, (factor, ratio, radius)


def test_closed_loop_radius_with_computation_delay_equals_the_reference_eigenvalues():
    # the law's output d samples late: the tool's spectral radius against the eigenvalues of the reference loop
    # with d unit delays in series
    spec = load_spec(SPEC).problem()
    timing = RigTiming(T, rule="forward_euler")
    paths = discretised_paths(PiLoops.of(spec, PI(209.9, 14.12)), _scenario(), mouse_loads(stack([FLOATING])), timing)
    A, B, C, D = ref.sampled_loop(_newton(209.9, 14.12, FLOATING), m_v=0.0436, b_v=5.05, period_s=T,
                                  forward_euler=True)
    for d in (0, 1, 2):
        n = A.shape[0]
        # d delays after the loop: states [loop, z1..zd], output the last
        Ad = np.zeros((n + d, n + d))
        Ad[:n, :n] = A
        Bd = np.vstack([B, np.zeros((d, 1))])
        if d:
            Ad[n, :n], Bd[n, 0] = C[0], D[0, 0]
            for i in range(1, d):
                Ad[n + i, n + i - 1] = 1.0
            Cd, Dd = np.eye(n + d)[-1:], np.zeros((1, 1))
        else:
            Cd, Dd = C, D
        kf = 1.0 / (1.0 + Dd[0, 0])
        expected = np.max(np.abs(np.linalg.eigvals(Ad - kf * Bd @ Cd)))
        got = closed_loop_radius(paths, timing.law(0.0436, 5.05), d)[0]
        assert abs(got - expected) < 1e-7, (d, got, expected)


def test_every_corner_mouse_is_in_the_spec_set():
    # the two mice these tests single out are corners the design holds for
    corners = {tuple(m.as_dict().values()) for m in mice(load_spec(SPEC).problem())}
    assert tuple(FLOATING.as_dict().values()) in corners and tuple(BRACED.as_dict().values()) in corners


def test_delay_margin_of_an_integrator_with_delay_is_its_closed_form():
    # L = k e^(-s tau) / s crosses |L| = 1 at w = k with phase -90 deg - k tau: the margin is (pi/2) / k - tau
    from design.admittance.latency import delay_margin_s

    w = np.geomspace(1.0, 1e4, 4000)
    for k, tau in ((50.0, 0.001), (300.0, 0.002)):
        L = k * np.exp(-1j * w * tau) / (1j * w)
        assert abs(delay_margin_s(w, L) - (math.pi / 2 / k - tau)) < 1e-6


def test_latency_check_with_one_more_sample_agrees_with_the_reference_loop():
    # the light design of the bundled spec at its binding corner: with one more sample of computation delay
    # the reference loop (scipy-discretised Newton model, a unit delay in series) decides stability as the tool
    from design.admittance.latency import latency_check

    spec = load_spec(SPEC).problem()
    kp, ki, m_v, b_v = DESIGNS[1]
    timing = RigTiming(T, rule="forward_euler")
    for mouse in (FLOATING, BRACED):
        lat = latency_check(_scenario(), [mouse], loops=PiLoops.of(spec, PI(kp, ki)), timing=timing, m_v=m_v, b_v=b_v)
        A, B, C, D = ref.sampled_loop(_newton(kp, ki, mouse), m_v=m_v, b_v=b_v, period_s=T, forward_euler=True)
        n = A.shape[0]
        Ad = np.zeros((n + 1, n + 1))
        Ad[:n, :n], Ad[n, :n] = A, C[0]
        Bd = np.vstack([B, [[D[0, 0]]]])
        Cd = np.eye(n + 1)[-1:]
        stable = bool(np.max(np.abs(np.linalg.eigvals(Ad - Bd @ Cd))) < 1)
        assert lat.one_more_stable == stable and lat.delay_samples == 0
        assert lat.margin_samples > 0 and (lat.margin_samples < 1) == (not stable)


def test_the_labs_setting_is_unstable_where_the_reference_says():
    # m_v 0.04 kg, b_v 4 N*s/m (bsbrl/exoskeleton's hand-tuned X axis) with the spec's PI: the corner check names
    # the one unstable corner of the dense set, and the reference loop there has a pole outside the unit circle
    from design.admittance.corners import corner_check

    spec = load_spec(SPEC).problem()
    check = corner_check(spec, controller=PI(178.5, 19150.0), m_v=0.04, b_v=4.0)
    assert check.unstable == 1 and not check.stable
    assert check.unstable_at[0].startswith("40.0 kg, current_loop.bandwidth_hz = 700, damping_n_s_per_m = 330, "
                                           "delay.seconds = 0.0008 with mouse (head 2 g, body 20 g")
    mouse = MouseModel(0.002, 0.020, 200.0, 0.2, 0.0, 0.0)
    assert not _reference_margins(178.5, 19150.0, 0.04, 4.0, mouse)[3]
    assert _reference_margins(178.5, 19150.0, 0.04, 4.0, FLOATING)[3]        # the 35 g body there is stable


def test_tustin_law_is_the_bilinear_transform_and_its_loop_agrees_with_the_reference():
    # the law's difference equation rebuilt: scipy's bilinear discretisation of 1/(m_v s + b_v) gives the same
    # coefficients; the coupled loop's radius with it equals the eigenvalues of the reference loop with that law
    from scipy.signal import cont2discrete

    from design.admittance.rig import DiscreteAdmittance

    m_v, b_v = 0.0436, 5.05
    timing = RigTiming(T, rule="tustin")
    law = DiscreteAdmittance.of_timing(m_v, b_v, timing)
    num, den, _ = cont2discrete(([1.0], [m_v, b_v]), T, method="bilinear")
    num, den = np.ravel(num) / den[0], np.ravel(den) / den[0]
    assert np.allclose([law.beta_m_per_s_per_n, law.beta_prev_m_per_s_per_n, law.alpha], [num[0], num[1], -den[1]])
    assert "Tustin" in law.rule
    spec = load_spec(SPEC).problem()
    paths = discretised_paths(PiLoops.of(spec, PI(209.9, 14.12)), _scenario(), mouse_loads(stack([FLOATING])), timing)
    Ad, Bd, Cd, Dd = (np.asarray(x, float) for x in cont2discrete(_newton(209.9, 14.12, FLOATING), T, method="zoh")[:4])
    # the law as a state space (state s = beta_prev F[k-1] + alpha v[k-1]): v[k] = s + beta F[k]
    a, b, bp = law.alpha, law.beta_m_per_s_per_n, law.beta_prev_m_per_s_per_n
    n = Ad.shape[0]
    # x[k+1] = Ad x + Bd v[k], F[k] = -(Cd x + Dd v[k]); s[k+1] = alpha v[k] + beta_prev F[k]
    g = 1.0 / (1.0 + b * Dd[0, 0])
    vx, vs = -b * g * Cd[0], g                               # v[k] = vx x + vs s
    fx, fs = -Cd[0] - Dd[0, 0] * vx, -Dd[0, 0] * vs          # F[k] = fx x + fs s
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n] = Ad + Bd @ vx[None, :], Bd[:, 0] * vs
    M[n, :n], M[n, n] = a * vx + bp * fx, a * vs + bp * fs
    expected = np.max(np.abs(np.linalg.eigvals(M)))
    assert abs(closed_loop_radius(paths, timing.law(m_v, b_v), 0)[0] - expected) < 1e-7


def test_zoh_law_is_the_step_invariant_transform_and_its_loop_agrees_with_the_reference():
    # the law's difference equation rebuilt: scipy's zero-order-hold discretisation of 1/(m_v s + b_v) is
    # c z^-1 / (1 - a z^-1); the law is the same without the z^-1 (driven by the newest force sample). The coupled
    # loop's radius and its margins with that law equal the reference loop's (scipy-discretised Newton model)
    from scipy.signal import cont2discrete

    from design.admittance.rig import DiscreteAdmittance

    m_v, b_v = 0.0436, 5.05
    timing = RigTiming(T, rule="zoh")
    law = DiscreteAdmittance.of_timing(m_v, b_v, timing)
    num, den, _ = cont2discrete(([1.0], [m_v, b_v]), T, method="zoh")
    num, den = np.ravel(num) / den[0], np.ravel(den) / den[0]
    assert num[0] == pytest.approx(0.0, abs=1e-15)
    assert np.allclose([law.beta_m_per_s_per_n, law.beta_prev_m_per_s_per_n, law.alpha], [num[1], 0.0, -den[1]],
                       rtol=1e-12)
    assert "ZOH" in law.rule
    spec = load_spec(SPEC).problem()
    for mouse in (FLOATING, BRACED):
        paths = discretised_paths(PiLoops.of(spec, PI(209.9, 14.12)), _scenario(), mouse_loads(stack([mouse])), timing)
        loop = ref.sampled_loop(_newton(209.9, 14.12, mouse), m_v=m_v, b_v=b_v, period_s=T, zoh=True)
        A, B, C, D = loop
        expected = np.max(np.abs(np.linalg.eigvals(A - B @ C / (1.0 + D[0, 0]))))
        assert abs(closed_loop_radius(paths, timing.law(m_v, b_v), 0)[0] - expected) < 1e-7
        pm, gm_db, _, stable = _reference_margins(209.9, 14.12, m_v, b_v, mouse, law="zoh")
        ev = AdmittanceEvaluator(spec, _scenario(), loops=PiLoops.of(spec, PI(209.9, 14.12)), timing=timing,
                                 corners=[mouse])
        check = ev.evaluate(m_v, b_v, screen=False)
        assert stable and bool(check.stable[0, 0])
        assert float(check.phase_margin_deg[0, 0]) == pytest.approx(pm, abs=0.2)
        assert float(check.gain_margin_db[0, 0]) == pytest.approx(gm_db, abs=0.2)


def test_the_verifications_margin_grid_is_converged(monkeypatch):
    # python-control reads the margins through a spline over the verification's grid: its MARGIN_POINTS give the
    # margins of 6,000 points within 0.005 deg and 0.002 dB, for the light design and the one read near Nyquist
    from design.admittance import verify

    spec = load_spec(SPEC).problem()
    parts = verify.gantry_parts(_scenario().plant(spec.plant.plant(), 0))
    timing = RigTiming(T, rule="forward_euler")
    finite_gm = 0
    for (kp, ki, m_v, b_v), mouse in itertools.product(DESIGNS[:2], (FLOATING, BRACED)):
        L, _ = verify.interaction_loop_model(parts, mouse, controller=PI(kp, ki), m_v=m_v, b_v=b_v, timing=timing)
        pm, gm = verify._margins(L, timing)
        monkeypatch.setattr(verify, "MARGIN_POINTS", 6000)
        pm_fine, gm_fine = verify._margins(L, timing)
        monkeypatch.undo()
        assert math.isfinite(pm) and abs(pm - pm_fine) < 0.005, (kp, ki, pm, pm_fine)
        assert gm == gm_fine or abs(gm - gm_fine) < 0.002, (kp, ki, gm, gm_fine)
        finite_gm += math.isfinite(gm)
    assert finite_gm
