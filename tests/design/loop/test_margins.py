"""Margins and bandwidth (design.loop.margins, design.loop.analysis) against python-control 0.10.2 and closed forms.

Which comparison is fair. python-control has no pure delay, so a loop with a delay can reach it
in two ways, each with its own approximation:

1. the Pade rational loop (``Plant.to_control``, order 6). ``stability_margins`` then finds the
   crossings exactly from polynomial roots and ``bandwidth`` bisects on the rational T, so it is an
   exact reference for *that* loop. Evaluating the same rational loop on our grid isolates what our
   functions add: crossing detection, choice among several crossings and refinement between grid
   points. This is the main test, on 60 random loops, at 1e-3 relative (measured: <= 1e-5).
2. the exact-delay response as an FRD (``control.frd(..., smooth=True)``). Both sides then work from
   the same samples and both interpolate (python-control: cubic splines of Re and Im against w;
   ours: cubics of log|L| and phase against log w), so neither is the truth. The truth is the exact
   model: roots found with scipy's brentq on ``Plant.frd`` evaluated at any frequency. We check ours
   against that exact root on all 60 loops, and against python-control's FRD method on a subset
   (its FRD evaluation loops over frequencies in Python: ~0.25 s a loop); all 60 are in a slow test.
"""

import math

import control
import numpy as np
import pytest
import scipy.optimize

from design.loop.analysis import ANALYSIS_GRID_RAD_S as W
from design.loop.analysis import analyse_loop, payload_sweep
from design.loop.controller import PI
from design.loop.loops import (
    closed_loop_frd,
    closed_loop_tf,
    open_loop_frd,
    open_loop_tf,
)
from design.loop.margins import closed_loop_bandwidth_hz, loop_margins, phase_change
from plant import CurrentLoop, Delay, Resonance, stage_x, stage_y
from plant.errors import GridError
from plant.grid import log_grid_rad_s

SEED = 20260611
N_LOOPS = 60
DBDROP = -20 * math.log10(math.sqrt(2))      # our bandwidth definition: |T(0)| / sqrt(2)
# thesis section 3.1 and Appendix A
KT, B, M, L_M, L_POS, KP, KI = 20.0, 440.0, 35.0, 0.8, 0.4, 236.0, 47.0


def random_loops(n=N_LOOPS, seed=SEED):
    """Stage X / Y plants, payload 5-40 kg, damping 330-550, delay 0.1-2 ms, current loop 100-2000 Hz,
    every fourth with a resonance (60-400 Hz, notch 0.5-0.9 of it, notch damping 0.03-0.2); PI gains
    Kp log-uniform 30-3000, Ki / Kp 0.2-300 1/s. Some of these loops are unstable (negative margins)."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        make = stage_x if k % 2 else stage_y
        p = make(mass_kg=rng.uniform(5, 40), damping_n_s_per_m=rng.uniform(330, 550)) \
            * Delay(rng.uniform(1e-4, 2e-3)) * CurrentLoop(rng.uniform(100, 2000))
        if k % 4 == 0:
            fr, ratio = rng.uniform(60, 400), rng.uniform(0.5, 0.9)
            # notch damping 0.03-0.2; with a viscous coupling the peak is damped fr / fa times more
            p = p * Resonance(fr, fr * ratio, rng.uniform(0.03, 0.2) / ratio)
        kp = float(np.exp(rng.uniform(math.log(30), math.log(3000))))
        out.append((p, kp, kp * float(rng.uniform(0.2, 300))))
    return out


LOOPS = random_loops()


def approx(ref, rel=1e-3):
    return pytest.approx(ref, rel=rel, abs=0)


# --- 1. the same rational loop: python-control's exact polynomial method ---------------------------

@pytest.mark.parametrize("k", range(N_LOOPS))
def test_margins_and_bandwidth_match_python_control_on_the_pade_loop(k):
    plant, kp, ki = LOOPS[k]
    L = plant.to_control(pade_order=6) * PI(kp, ki).tf()
    resp = L(1j * W)
    ours = loop_margins(W, resp)
    gm, pm, _, wpc, wgc, _ = control.stability_margins(L)           # python-control 0.10.2
    assert ours.phase_margin_deg == approx(pm)
    assert ours.gain_crossover_hz == approx(wgc / (2 * math.pi))
    assert math.isfinite(gm)            # every loop has a delay: the phase always reaches -180 deg
    assert ours.gain_margin_db == approx(20 * math.log10(gm))
    assert ours.phase_crossover_hz == approx(wpc / (2 * math.pi))
    T = control.feedback(L, 1)
    bw = control.bandwidth(T, dbdrop=DBDROP) / (2 * math.pi)       # python-control 0.10.2
    assert closed_loop_bandwidth_hz(W, resp / (1 + resp), dc_gain=1.0) == approx(bw)


def test_the_random_loops_cover_hard_cases():
    # the comparison above is only as good as its loops: unstable ones, small margins, resonances
    pms = []
    for plant, kp, ki in LOOPS:
        _, pm, _, _, _, _ = control.stability_margins(plant.to_control(pade_order=6) * PI(kp, ki).tf())
        pms.append(pm)
    pms = np.array(pms)
    assert (pms < 0).sum() >= 3 and ((pms > 0) & (pms < 30)).sum() >= 5 and (pms > 60).sum() >= 10
    assert sum("resonance" in p.effect_names for p, _, _ in LOOPS) == N_LOOPS // 4


@pytest.mark.parametrize("k", range(0, N_LOOPS, 6))
def test_disk_margin_matches_python_control(k):
    plant, kp, ki = LOOPS[k]
    L = plant.to_control(pade_order=6) * PI(kp, ki).tf()
    resp = L(1j * W)
    ours = loop_margins(W, resp)
    # python-control 0.10.2, balanced (skew 0): on the same grid, and on a 10x denser one (the reference)
    dm, dgm, dpm = control.disk_margins(L, W)
    dense = np.geomspace(W[0], W[-1], 10 * W.size)
    dm_ref = control.disk_margins(L, dense)[0]
    # ours is refined between the grid points: never above the grid's value, and closer to the reference
    assert ours.disk_margin <= dm * (1 + 1e-12)
    assert abs(ours.disk_margin - dm_ref) <= abs(dm - dm_ref) + 1e-6 * dm_ref
    # the disk gain and phase margins are the closed forms of alpha (Seiler et al. 2020), as python-control's
    half = ours.disk_margin / 2
    assert ours.disk_phase_margin_deg == pytest.approx(math.degrees(2 * math.atan(half)), rel=1e-12)
    if half < 1:
        assert ours.disk_gain_margin_db == pytest.approx(20 * math.log10((1 + half) / (1 - half)), rel=1e-12)
    assert dpm == pytest.approx(math.degrees(2 * math.atan(dm / 2)), rel=1e-9)
    S = control.feedback(1, L)                   # peak sensitivity from python-control's own S
    ms_grid, ms_ref = np.max(np.abs(S(1j * W))), np.max(np.abs(S(1j * dense)))
    assert ours.peak_sensitivity >= ms_grid * (1 - 1e-12)
    assert abs(ours.peak_sensitivity - ms_ref) <= abs(ms_grid - ms_ref) + 1e-6 * ms_ref


# --- 2. exact delay: the exact model, and python-control's FRD method ------------------------------

def exact_crossings(plant, kp, ki, near_wc, near_wpc):
    """PM (deg) and GM (dB) of the exact loop: scipy brentq on the model's response evaluated at any
    frequency, bracketed within +-1 % of the given frequencies."""
    def L(w):
        w = np.atleast_1d(w)
        return (plant.frd(w) * PI(kp, ki).frd(w))[0]
    wc = scipy.optimize.brentq(lambda w: abs(L(w)) - 1, 0.99 * near_wc, 1.01 * near_wc, xtol=1e-13, rtol=1e-14)
    wp = scipy.optimize.brentq(lambda w: L(w).imag, 0.99 * near_wpc, 1.01 * near_wpc, xtol=1e-13, rtol=1e-14)
    assert L(wp).real < 0
    return np.remainder(np.degrees(np.angle(L(wc))), 360) - 180, -20 * math.log10(abs(L(wp)))


def test_exact_delay_margins_match_the_exact_model():
    worst = 0.0
    for plant, kp, ki in LOOPS:
        resp = plant.frd(W) * PI(kp, ki).frd(W)
        ours = loop_margins(W, resp)
        pm, gm = exact_crossings(plant, kp, ki, 2 * math.pi * ours.gain_crossover_hz,
                                 2 * math.pi * ours.phase_crossover_hz)
        assert ours.phase_margin_deg == approx(pm) and ours.gain_margin_db == approx(gm)
        worst = max(worst, abs(ours.phase_margin_deg / pm - 1), abs(ours.gain_margin_db / gm - 1))
    assert worst < 1e-4          # measured 1e-5 (GM) and 5.5e-6 (PM) on the default grid


def check_against_python_control_frd(k):
    plant, kp, ki = LOOPS[k]
    w = log_grid_rad_s(0.1, 1e4, 1200)       # a shorter grid than the default: python-control is slow
    resp = plant.frd(w) * PI(kp, ki).frd(w)
    ours = loop_margins(w, resp)
    gm, pm, _, wpc, wgc, _ = control.stability_margins(control.frd(resp, w, smooth=True))
    assert ours.phase_margin_deg == approx(pm)
    assert ours.gain_margin_db == approx(20 * math.log10(gm))
    assert ours.gain_crossover_hz == approx(wgc / (2 * math.pi))
    assert ours.phase_crossover_hz == approx(wpc / (2 * math.pi))


@pytest.mark.parametrize("k", [0, 5, 12, 24, 31, 47])    # 12 and 24 are the hardest (resonance near crossover)
def test_exact_delay_margins_match_python_control_frd(k):
    check_against_python_control_frd(k)


@pytest.mark.slow
def test_exact_delay_margins_match_python_control_frd_on_all_loops():
    for k in range(N_LOOPS):
        check_against_python_control_frd(k)


# --- closed forms --------------------------------------------------------------------------------

@pytest.mark.parametrize("stage", ["x", "y"])
@pytest.mark.parametrize("w_grid", [W, log_grid_rad_s(1e-3, 1e4, 280)], ids=["default-grid", "40-per-decade"])
def test_thesis_loop_margins_and_bandwidth_closed_forms(stage, w_grid):
    # plant K_t / (m_e s + b_e) (Eq. 3.15; Eq. 3.16 with m_e = 2 M l / L, b_e = 2 b)
    m_e, b_e = (M, B) if stage == "x" else (2 * M * L_POS / L_M, 2 * B)
    # |L| = 1 (Eq. 3.17/3.18): m_e^2 x^2 + (b_e^2 - K_t^2 Kp^2) x - K_t^2 Ki^2 = 0, x = w^2
    x = max(np.roots([m_e**2, b_e**2 - (KT * KP) ** 2, -((KT * KI) ** 2)]).real)
    wc = math.sqrt(x)
    Lc = KT / (m_e * 1j * wc + b_e) * (KP + KI / (1j * wc))
    pm = 180 + math.degrees(np.angle(Lc))
    # |T|^2 = 1/2 of Eq. 3.19/3.20: m_e^2 x^2 + ((b_e + K_t Kp)^2 - 2 m_e K_t Ki - 2 K_t^2 Kp^2) x - K_t^2 Ki^2 = 0
    xb = max(np.roots([m_e**2, (b_e + KT * KP) ** 2 - 2 * m_e * KT * KI - 2 * (KT * KP) ** 2,
                       -((KT * KI) ** 2)]).real)
    plant = stage_x() if stage == "x" else stage_y()
    a = analyse_loop(plant, PI(KP, KI), w_rad_s=w_grid)
    # the cubic refinement keeps 1e-6 even on the 40-points-per-decade grid
    assert a.margins.phase_margin_deg == pytest.approx(pm, rel=1e-6)
    assert a.margins.gain_crossover_hz == pytest.approx(wc / (2 * math.pi), rel=1e-6)
    assert a.closed_loop_bandwidth_hz == pytest.approx(math.sqrt(xb) / (2 * math.pi), rel=1e-6)
    assert a.open_loop_corner_hz == pytest.approx(b_e / (2 * math.pi * m_e), rel=1e-6)
    # PI plus a first-order plant never reaches -180 deg: no phase crossover (thesis Fig. 3.13b/3.14b)
    assert math.isinf(a.margins.gain_margin_db) and math.isnan(a.margins.phase_crossover_hz)


def test_third_order_loop_gain_margin_closed_form():
    # L = K / (s (s + 1)(s + 2)): phase -180 deg at w = sqrt(2), where |L| = K / 6 -> GM = 6 / K
    K = 1.7
    s = 1j * W
    m = loop_margins(W, K / (s * (s + 1) * (s + 2)))
    assert m.phase_crossover_hz == pytest.approx(math.sqrt(2) / (2 * math.pi), rel=1e-8)
    assert m.gain_margin_db == pytest.approx(20 * math.log10(6 / K), rel=1e-8)


def test_second_order_loop_phase_margin_closed_form():
    # L = wn^2 / (s (s + 2 zeta wn)): PM = atan(2 zeta / sqrt(sqrt(1 + 4 zeta^4) - 2 zeta^2))
    wn, zeta = 30.0, 0.35
    s = 1j * W
    m = loop_margins(W, wn**2 / (s * (s + 2 * zeta * wn)))
    wc = wn * math.sqrt(math.sqrt(1 + 4 * zeta**4) - 2 * zeta**2)
    assert m.gain_crossover_hz == pytest.approx(wc / (2 * math.pi), rel=1e-8)
    assert m.phase_margin_deg == pytest.approx(math.degrees(math.atan(2 * zeta * wn / wc)), rel=1e-8)


def test_integrator_disk_margin_closed_form():
    # L = k / s: S - 1/2 = (s - k) / (2 (s + k)) is all-pass with gain 1/2, so alpha = 2, the disk
    # phase margin 2 atan(alpha / 2) = 90 deg and the disk gain margin infinite; |S| < 1 everywhere
    m = loop_margins(W, 25.0 / (1j * W))
    assert m.disk_margin == pytest.approx(2.0, rel=1e-12)
    assert m.disk_phase_margin_deg == pytest.approx(90.0, rel=1e-10)
    assert math.isinf(m.disk_gain_margin_db)
    assert m.phase_margin_deg == pytest.approx(90.0, rel=1e-10)      # the integrator's -90 deg
    assert m.peak_sensitivity < 1.0


# --- batches -------------------------------------------------------------------------------------

def test_batch_equals_one_by_one():
    resp = np.array([p.frd(W) * PI(kp, ki).frd(W) for p, kp, ki in LOOPS[:12]])
    batch = loop_margins(W, resp.reshape(3, 4, -1))
    assert batch.phase_margin_deg.shape == (3, 4)
    for k in range(12):
        one = loop_margins(W, resp[k])
        for field in ("phase_margin_deg", "gain_margin_db", "gain_crossover_hz", "disk_margin", "peak_sensitivity"):
            assert getattr(batch, field).reshape(-1)[k] == getattr(one, field), (k, field)
    T = resp / (1 + resp)
    bw = closed_loop_bandwidth_hz(W, T.reshape(3, 4, -1), dc_gain=np.ones((3, 4)))
    assert bw.shape == (3, 4)
    assert all(bw.reshape(-1)[k] == closed_loop_bandwidth_hz(W, T[k], dc_gain=1.0) for k in range(12))


def test_payload_sweep_equals_analysis_per_payload():
    plant = stage_y() * Delay(0.0005) * CurrentLoop(300.0)
    payloads = np.linspace(5.0, 40.0, 8)
    sweep = payload_sweep(plant, PI(KP, KI), payloads)
    for k, m in enumerate(payloads):
        a = analyse_loop(plant.with_payload(m), PI(KP, KI))
        assert sweep.phase_margin_deg[k] == a.margins.phase_margin_deg
        assert sweep.gain_margin_db[k] == a.margins.gain_margin_db
        assert sweep.closed_loop_bandwidth_hz[k] == a.closed_loop_bandwidth_hz
        assert sweep.open_loop_corner_hz[k] == a.open_loop_corner_hz


def test_no_crossing_gives_infinite_margins_and_nan_frequencies():
    small = loop_margins(W, 0.01 * stage_x().frd(W))          # |L| < 1 everywhere, phase > -90 deg
    assert math.isinf(small.phase_margin_deg) and math.isnan(small.gain_crossover_hz)
    assert math.isinf(small.gain_margin_db) and math.isnan(small.phase_crossover_hz)
    flat = np.full(W.size, 0.5 + 0j)                          # |T| never drops
    assert math.isnan(closed_loop_bandwidth_hz(W, flat))


def test_response_and_grid_must_match():
    with pytest.raises(GridError, match="3000"):
        loop_margins(W, np.ones(10, complex))
    with pytest.raises(GridError, match="strictly increasing"):
        closed_loop_bandwidth_hz([1.0, 1.0, 2.0], np.ones(3))


def test_a_three_point_grid_falls_back_to_linear_interpolation():
    # too few points for a cubic: L = 2 / (j w) on w = 1, 2, 4 has |L| = 2, 1, 0.5 -> crossover at 2 rad/s
    w = np.array([1.0, 2.0, 4.0])
    m = loop_margins(w, 2 / (1j * w))
    assert m.gain_crossover_hz == pytest.approx(2 / (2 * math.pi), rel=1e-12)
    assert m.phase_margin_deg == pytest.approx(90.0, rel=1e-12)
    # T = 1/(1 + j w / 2) on w = 1, 4, 8: |T|^2 = 0.8, 0.2, 1/17; log|T|^2 linear in log w between the
    # first two points reaches 1/2 at w = 1.6 rad/s (the true -3 dB point, 2 rad/s, needs a finer grid)
    w = np.array([1.0, 4.0, 8.0])
    assert closed_loop_bandwidth_hz(w, 1 / (1 + 1j * w / 2), dc_gain=1.0) == pytest.approx(1.6 / (2 * math.pi),
                                                                                           rel=1e-12)


# --- the loops themselves (design.loop.loops, thesis Eq. 3.17-3.24) --------------------------------------

@pytest.mark.parametrize("stage", ["x", "y"])
def test_open_and_closed_loop_are_eq_3_17_to_3_20(stage):
    s = 1j * W
    plant = stage_x() if stage == "x" else stage_y()
    if stage == "x":
        open_ref = KT / (B + M * s) * (KP + KI / s)                                          # Eq. 3.17
        closed_ref = (KP * s + KI) * KT / (M * s**2 + s * (B + KP * KT) + KI * KT)            # Eq. 3.19
        den = [M, B + KP * KT, KI * KT]
    else:
        open_ref = KT * L_M / (2 * M * L_POS * s + 2 * B * L_M) * (KP + KI / s)              # Eq. 3.18
        closed_ref = KT * L_M * (KP * s + KI) / (2 * M * L_POS * s**2 + s * (2 * B * L_M + KT * KP * L_M)
                                                 + KT * L_M * KI)                              # Eq. 3.20
        den = [2 * M * L_POS, 2 * B * L_M + KT * KP * L_M, KT * L_M * KI]
    L = open_loop_frd(plant, W, PI(KP, KI))
    assert np.allclose(L, open_ref, rtol=1e-12)
    assert np.allclose(closed_loop_frd(L), closed_ref, rtol=1e-12)
    assert np.allclose(open_loop_tf(plant, PI(KP, KI))(s), open_ref, rtol=1e-10)
    T = closed_loop_tf(plant, PI(KP, KI))
    assert np.allclose(T(s), closed_ref, rtol=1e-10)
    # its poles are the roots of the Eq. 3.19 / 3.20 denominator
    assert np.allclose(np.sort_complex(T.poles()), np.sort_complex(np.roots(den)), rtol=1e-8)


@pytest.mark.parametrize("kp,ki", [(275.0, 4.46e4), (1500.0, 2e5), (2000.0, 1e6), (3000.0, 1e6), (600.0, 5e5)])
def test_closed_loop_stability_agrees_with_the_closed_loop_poles(kp, ki):
    # an unstable loop can show a large positive PM (3000, 1e6: +179 deg): the verdict must not trust it
    plant = stage_x(mass_kg=5.0) * Delay(0.0005) * CurrentLoop(1000.0)
    a = analyse_loop(plant, PI(kp, ki))
    L = plant.to_control(pade_order=8) * control.tf([kp, ki], [1, 0])
    poles_stable = bool(np.all(np.real(control.poles(control.feedback(L, 1))) < 0))   # python-control 0.10.2
    assert bool(a.margins.closed_loop_stable) == poles_stable


def test_the_grid_grows_to_hold_a_crossover_below_it():
    # L ~ ki P(0) / (j w) at low frequency: crossover at ki kt / b = 2e-3 x 20 / 440 = 9.09e-5 rad/s, below the
    # default grid's 1 mHz; on the fixed grid the margin reads infinite
    plant = stage_x(mass_kg=5.0) * Delay(0.0005) * CurrentLoop(1000.0)
    fixed = loop_margins(W, open_loop_frd(plant, W, PI(5e-4, 2e-3)))
    assert np.isinf(fixed.phase_margin_deg) and not fixed.crossings_on_grid
    a = analyse_loop(plant, PI(5e-4, 2e-3))
    assert a.margins.crossings_on_grid
    assert 2 * np.pi * a.margins.gain_crossover_hz == pytest.approx(2e-3 * 20.0 / 440.0, rel=2e-3)
    gm, pm, _, _ = control.margin(plant.to_control(pade_order=8) * control.tf([5e-4, 2e-3], [1, 0]))
    assert a.margins.phase_margin_deg == pytest.approx(pm, abs=1e-3)


@pytest.mark.parametrize("k", [0.5, 1.0, 2.0])
def test_peak_sensitivity_and_disk_margin_are_refined_between_grid_points(k):
    # L = k e^{-0.3 s} / (s (s + 1)) on 15 points per decade; reference: the same loop on 200,001 points
    coarse, dense = np.geomspace(0.01, 100, 60), np.geomspace(0.01, 100, 200_001)

    def loop(w):
        return k / (1j * w * (1j * w + 1)) * np.exp(-0.3j * w)

    ref, got = loop_margins(dense, loop(dense)), loop_margins(coarse, loop(coarse))
    on_grid = float(np.max(1 / np.abs(1 + loop(coarse))))
    assert got.peak_sensitivity == pytest.approx(ref.peak_sensitivity, rel=5e-3)
    assert got.disk_margin == pytest.approx(ref.disk_margin, rel=5e-3)
    # the grid maximum alone misses up to 10 % at k = 2
    assert abs(got.peak_sensitivity - ref.peak_sensitivity) <= abs(on_grid - ref.peak_sensitivity)


@pytest.mark.parametrize("definition", ["half_power", "minus_3_db"])
def test_bandwidth_definitions_match_python_control(definition):
    from design.loop.fast import fast_analyse_loop
    from design.loop.margins import BANDWIDTH_LEVELS2

    level2 = BANDWIDTH_LEVELS2[definition]
    plant = stage_x(mass_kg=20.0) * Delay(0.0005) * CurrentLoop(1000.0)
    T = control.feedback(plant.to_control(pade_order=8) * control.tf([275.0, 4.46e4], [1, 0]), 1)
    ref = control.bandwidth(T, dbdrop=10 * math.log10(level2)) / (2 * math.pi)   # python-control 0.10.2
    controller = PI(275.0, 4.46e4)
    assert analyse_loop(plant, controller, level2=level2).closed_loop_bandwidth_hz == pytest.approx(ref, rel=1e-5)
    assert fast_analyse_loop(plant, PI(275.0, 4.46e4), level2=level2).closed_loop_bandwidth_hz == pytest.approx(ref,
                                                                                                           rel=1e-5)


def test_phase_change_is_that_of_numpys_unwrap_on_curves_that_circle_the_origin():
    # random smooth curves: radius and phase random walks (steps well below pi), some circling the origin
    # several times either way, some passing near it; numpy.unwrap is the reference
    rng = np.random.default_rng(7)
    n_curves, n = 400, 600
    phase = np.cumsum(rng.normal(0.0, 0.3, (n_curves, n)), axis=1) + rng.uniform(-np.pi, np.pi, (n_curves, 1))
    radius = np.exp(np.cumsum(rng.normal(0.0, 0.05, (n_curves, n)), axis=1))
    z = (radius * np.exp(1j * phase)).reshape(20, 20, n)
    reference = np.unwrap(np.angle(z), axis=-1)
    assert np.allclose(phase_change(z), reference[..., -1] - reference[..., 0], rtol=0, atol=1e-9)
    assert np.ptp(np.round((reference[..., -1] - reference[..., 0]) / (2 * np.pi))) >= 4     # many windings


def test_the_crossing_root_is_the_one_bisection_finds_to_the_bracket_width():
    # the refinement's Newton steps (kept inside the bracket) against 80 halvings of the bracket on the same cubics:
    # smooth ones, steep ones, flat-bottomed ones and ones with three roots in the interval's neighbourhood
    from design.loop.margins import _cubic, _root

    rng = np.random.default_rng(11)
    n = 4000
    x = np.sort(rng.uniform(-1.0, 1.0, (n, 4)), axis=1) * rng.uniform(0.01, 3.0, (n, 1))
    y = rng.normal(size=(n, 4)) * rng.uniform(1e-6, 1e3, (n, 1))
    flat = np.arange(n) < n // 4
    y[flat] = (x[flat] - x[flat].mean(axis=1, keepdims=True)) ** 3      # a triple root: flat, inflecting
    ia = rng.integers(0, 3, n)
    k = np.arange(n)
    keep = np.sign(y[k, ia]) != np.sign(y[k, ia + 1])
    x, y, ia, flat, k = x[keep], y[keep], ia[keep], flat[keep], np.arange(int(keep.sum()))
    c = _cubic(x, y)

    def f(t):
        return c[:, 0] + (t - x[:, 0]) * (c[:, 1] + (t - x[:, 1]) * (c[:, 2] + (t - x[:, 2]) * c[:, 3]))

    a, b = x[k, ia].copy(), x[k, ia + 1].copy()
    fa = y[k, ia].copy()
    for _ in range(80):
        m = 0.5 * (a + b)
        same = np.sign(f(m)) == np.sign(fa)
        a, fa, b = np.where(same, m, a), np.where(same, f(m), fa), np.where(same, b, m)
    root = _root(x, y, ia)
    step = x[k, ia + 1] - x[k, ia]
    assert k.size > 1500
    assert np.all((root >= x[k, ia]) & (root <= x[k, ia + 1]))
    # the same root to 1e-12 of the step, or (a triple root, where the cubic is flat to rounding around it, or
    # another of three roots in the interval) a point where the cubic is zero to rounding
    near = np.abs(root - 0.5 * (a + b)) <= 1e-12 * step
    scale = np.max(np.abs(y), axis=1)
    assert np.all(near | (np.abs(f(root)) <= 1e-12 * scale))
    assert near[~flat].mean() > 0.99
