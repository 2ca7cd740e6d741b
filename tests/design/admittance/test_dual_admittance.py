"""Stage Y admittance on the two-motor loops (``design.admittance.dual``), held against the gantry, its loops and
the mouse written out from Newton's law in ``independent_dual_drive.clamp_path`` (nothing from the tool), sampled
by scipy and judged by python-control (``independent_admittance``)."""

from __future__ import annotations

import json
from pathlib import Path

import control
import independent_admittance as adm_ref
import numpy as np
import pytest
from in_process import gantry
from independent_dual_drive import Rig, channel_loop, clamp_path, unstable_poles

from design.admittance.codesign import KI_FACTORS, KP_FACTORS
from design.admittance.dual import DualLoops, synthesise_dual_admittance
from design.admittance.dual_codesign import candidates
from design.admittance.model import AdmittanceEvaluator, admittance_problem, mice
from design.admittance.mouse import MouseModel
from design.admittance.rig import RigTiming
from design.loop.dual import CommonDifferential, MasterSlave, PerMotor
from design.spec.schema import load_spec
from design.synth.dual import dual_scenarios
from plant.errors import SpecError
from plant.physics.dual_drive import DualDriveStageY
from plant.physics.effects import make_effect

ROOT = Path(__file__).parents[3]
SPEC = ROOT / "specs" / "stage_y_admittance.toml"
MICE = {"floating": dict(head_kg=0.002, body_kg=0.035, neck_k=200.0, neck_c=0.2),
        "on its legs": dict(head_kg=0.01, body_kg=0.02, neck_k=20.0, neck_c=1.0, leg_k=3000.0, leg_c=0.5)}
CONTROLLERS = {"per_motor": PerMotor(124.8, 1.776e4), "common_differential": CommonDifferential(219.1, 1.962e4,
                                                                                                  191.2, 1.0),
               "master_slave": MasterSlave(60.0, 4000.0)}


def tool(rig: Rig) -> tuple[DualDriveStageY, object]:
    """The rig as the tool's model and as a one-plant scenario set."""
    model = DualDriveStageY(beam_mass_kg=rig.beam_mass_kg, beam_inertia_kg_m2=rig.beam_inertia_kg_m2,
                            carriage_mass_kg=rig.carriage_mass_kg, carriage_inertia_kg_m2=rig.carriage_inertia_kg_m2,
                            rail_separation_m=rig.rail_separation_m, carriage_position_m=rig.carriage_position_m,
                            damping1_n_s_per_m=rig.b1, damping2_n_s_per_m=rig.b2, force_constant1_n_per_a=rig.k1,
                            force_constant2_n_per_a=rig.k2, yaw_stiffness_n_m_per_rad=rig.yaw_stiffness,
                            effects=(make_effect("delay", seconds=rig.delay_s),
                                     make_effect("current_loop", bandwidth_hz=rig.current_loop_hz)))
    return model, dual_scenarios(model, [rig.carriage_position_m], [rig.carriage_mass_kg], {})


def mouse_model(m: dict) -> MouseModel:
    return MouseModel(m["head_kg"], m["body_kg"], m["neck_k"], m["neck_c"], m.get("leg_k", 0.0), m.get("leg_c", 0.0))


def gains(structure: str) -> tuple[float, ...]:
    return tuple(CONTROLLERS[structure].gains().values())


RIGS = [Rig(carriage_mass_kg=56.0, carriage_position_m=0.08, delay_s=8e-4, current_loop_hz=700.0, b1=330.0, b2=330.0),
        Rig(carriage_mass_kg=21.0, carriage_position_m=0.4, delay_s=3e-4, current_loop_hz=1300.0),
        Rig(beam_mass_kg=14.0, beam_inertia_kg_m2=0.9, carriage_mass_kg=42.0, carriage_inertia_kg_m2=0.3,
            carriage_position_m=0.17, b1=380.0, b2=520.0, k1=19.0, k2=21.5, yaw_stiffness=8.0e4, delay_s=5e-4,
            current_loop_hz=900.0)]


@pytest.mark.parametrize("structure", list(CONTROLLERS))
@pytest.mark.parametrize("rig", RIGS, ids=["end-heavy", "centre-light", "skewed"])
@pytest.mark.parametrize("mouse", list(MICE))
def test_interaction_path_matches_newtons_model_on_and_off_the_axis(structure, rig, mouse):
    """K = Z_m R / (1 + S G Z_m) at complex s (the sampled sum evaluates it at w + k 2 pi / T, both signs) against
    the state-space path from the translation command to the clamp force, loops and mouse closed."""
    _, sc = tool(rig)
    w = 2 * np.pi * np.geomspace(0.05, 300.0, 60)
    s = np.concatenate([1j * w, -1j * w[::7], 0.3 * w[::5] + 1j * w[::5]])
    loop = DualLoops(CONTROLLERS[structure]).at(s, sc)
    zm = mouse_model(MICE[mouse]).impedance(s)
    k_tool = zm * loop.reference[0] / (1 + loop.sensitivity_mobility[0] * zm)
    k_ref = adm_ref.response(clamp_path(rig, structure, gains(structure), **MICE[mouse]), s)
    assert np.allclose(k_tool, k_ref, rtol=1e-6, atol=1e-9 * np.abs(k_ref).max())


def test_centred_symmetric_carriage_is_the_one_loop_stage_y():
    """With the carriage midway between equal rails, per-motor PI c on each rail is thesis Eq. 3.16 on the total
    current: R = 2 k C / (M s + 2 b + 2 k C), S G = 1 / (M s + 2 b + 2 k C) and each motor's force per sensed force
    -k C S G (closed forms)."""
    model = DualDriveStageY(carriage_position_m=0.4)
    sc = dual_scenarios(model, [0.4], [51.0], {})
    s = 1j * 2 * np.pi * np.geomspace(0.1, 500.0, 40)
    loop = DualLoops(PerMotor(100.0, 5000.0)).at(s, sc)
    M, b, k, C = 16.0 + 51.0, 440.0, 20.0, 100.0 + 5000.0 / s
    den = M * s + 2 * b + 2 * k * C
    assert np.allclose(loop.reference[0], 2 * k * C / den, rtol=1e-10)
    assert np.allclose(loop.sensitivity_mobility[0], 1 / den, rtol=1e-10)
    assert np.allclose(loop.motor_force[:, 0], -k * C / den, rtol=1e-10)


@pytest.mark.parametrize("structure", ["per_motor", "common_differential"])
def test_sampled_margins_match_python_control_on_the_discretised_loop(structure):
    """The exact grid margins of the 100 Hz forward-Euler law (the bundled spec's rig) against python-control on
    scipy's zero-order-hold discretisation of the Newton model, at the carriage ends and the middle."""
    problem = load_spec(SPEC).problem()
    timing = RigTiming.of(admittance_problem(problem).rig)
    m_v, b_v = 0.81, 10.6
    rigs = [Rig(carriage_mass_kg=56.0, carriage_position_m=p, delay_s=8e-4, current_loop_hz=700.0, b1=330.0, b2=550.0)
            for p in (0.08, 0.4, 0.72)]
    for rig in rigs:
        _, sc = tool(rig)
        corners = tuple(mouse_model(m) for m in MICE.values())
        ev = AdmittanceEvaluator(problem, sc, loops=DualLoops(CONTROLLERS[structure]), timing=timing,
                                 corners=corners)
        pm, gm, stable = ev.exact_margins(m_v, b_v, np.arange(len(corners)), np.zeros(len(corners), int))
        for k, m in enumerate(MICE.values()):
            loop = adm_ref.sampled_loop(clamp_path(rig, structure, gains(structure), **m), m_v=m_v, b_v=b_v,
                                        period_s=timing.period_s, forward_euler=True)
            # on 6,000 points python-control's margins of these 18 loops move by at most 2e-3 deg and 1e-4 dB
            w = np.geomspace(2 * np.pi * 1e-3, np.pi / timing.period_s, 2000)
            L = adm_ref.response(loop, np.exp(1j * w * timing.period_s))
            ref_pm, ref_gm = adm_ref.margins_from_response(w, L)
            assert stable[k] == adm_ref.closed_loop_stable(loop, discrete=True)
            assert pm[k] == pytest.approx(ref_pm, abs=0.1)
            if min(gm[k], ref_gm) < 30:     # python-control reads no crossover where the phase ends at -180 deg
                assert gm[k] == pytest.approx(ref_gm, abs=0.05)


@pytest.mark.slow
def test_bundled_stage_y_admittance_spec_holds_on_newtons_model(tmp_path):
    """``gantry synth`` on the bundled spec: the virtual dynamics on the recommended structure, 0 of 10,000 Monte
    Carlo draws over carriage position x payload x uncertainty x mouse failing; then at every carriage position it
    reports (the ends, where the margin is least) the design's interaction loop rebuilt from Newton's law for the
    heaviest payload, slowest drive, least damping and each corner mouse, discretised by scipy and judged by
    python-control, keeps the requirements."""
    out = gantry("synth", str(SPEC), "--json")
    assert out.returncode in (0, 3), out.stderr
    doc = json.loads(out.stdout)
    adm = doc["admittance"]
    assert adm["status"] in ("optimal", "mouse_cannot_drive")
    assert adm["monte_carlo"]["samples"] == 10000 and adm["monte_carlo"]["violations"] == 0
    structure, g = adm["structure"], tuple(adm["gains"].values())
    problem = load_spec(SPEC).problem()
    a = admittance_problem(problem)
    timing = RigTiming.of(a.rig)
    w = np.geomspace(2 * np.pi * 1e-3, np.pi / timing.period_s, 2000)
    worst = min(r["carriage_position_m"] for r in adm["by_carriage_position"]), adm["worst_carriage_position_m"]
    for p in worst:
        rig = Rig(carriage_mass_kg=16.0 + 40.0, carriage_position_m=p, delay_s=8e-4, current_loop_hz=700.0,
                  b1=330.0, b2=330.0)
        for mouse in mice(problem)[::7]:
            m = dict(head_kg=mouse.head_mass_kg, body_kg=mouse.body_mass_kg, neck_k=mouse.neck_stiffness_n_per_m,
                     neck_c=mouse.neck_damping_n_s_per_m, leg_k=mouse.leg_stiffness_n_per_m,
                     leg_c=mouse.leg_damping_n_s_per_m)
            loop = adm_ref.sampled_loop(clamp_path(rig, structure, g, **m), m_v=adm["m_v"], b_v=adm["b_v"],
                                        period_s=timing.period_s, forward_euler=True)
            pm, gm = adm_ref.margins_from_response(w, adm_ref.response(loop, np.exp(1j * w * timing.period_s)))
            assert adm_ref.closed_loop_stable(loop, discrete=True)
            assert pm >= a.phase_margin_deg - 0.1 and gm >= a.gain_margin_db - 0.05
    # the search between the dense check's points (carriage position x payload x uncertainty x mouse): its least
    # point holds, and Newton's model gives the margins it reports there
    b = adm["between_grid"]
    x = dict(zip(b["coordinates"], b["values"]))
    assert b["holds"] and b["coordinates"][:2] == ["carriage_position_m", "payload_kg"]
    rig = Rig(carriage_mass_kg=16.0 + x["payload_kg"], carriage_position_m=x["carriage_position_m"],
              delay_s=x["delay.seconds"], current_loop_hz=x.get("current_loop.bandwidth_hz", 1000.0),
              b1=x["damping1_n_s_per_m"], b2=x["damping2_n_s_per_m"])
    m = dict(head_kg=x["head_mass_kg"], body_kg=x["body_mass_kg"], neck_k=x["neck_stiffness_n_per_m"],
             neck_c=x["neck_damping_n_s_per_m"], leg_k=x["leg_stiffness_n_per_m"], leg_c=x["leg_damping_n_s_per_m"])
    loop = adm_ref.sampled_loop(clamp_path(rig, structure, g, **m), m_v=adm["m_v"], b_v=adm["b_v"],
                                period_s=timing.period_s, forward_euler=True)
    pm, gm = adm_ref.margins_from_response(w, adm_ref.response(loop, np.exp(1j * w * timing.period_s)))
    assert gm == pytest.approx(b["gain_margin_db"], abs=0.05)
    assert pm == pytest.approx(b["phase_margin_deg"] if b["phase_margin_deg"] is not None else np.inf, abs=0.1)


def test_codesign_on_two_motors_scales_only_the_translation_channel_and_needs_its_record(tmp_path):
    """The co-design's candidates keep the yaw channel's design and try every factor pair once; the spec takes
    ``codesign = true`` beside ``[dual_drive]``, and the synthesis refuses to run it without the co-design's record."""
    given = CONTROLLERS["common_differential"]
    tried = candidates(given)
    assert tried[0] == given and len(set(tried)) == len(tried) == len(KP_FACTORS) * len(KI_FACTORS)
    assert {(c.kp_differential, c.ki_differential) for c in tried} == {(given.kp_differential, given.ki_differential)}
    assert {round(c.ki_common / given.ki_common, 9) for c in tried} == set(KI_FACTORS)
    assert {round(c.kp, 9) for c in candidates(PerMotor(100.0, 1e4))} == {round(100.0 * f, 9) for f in KP_FACTORS}
    path = tmp_path / "codesign.toml"
    path.write_text(SPEC.read_text().replace("codesign = false", "codesign = true"))
    problem = load_spec(path).problem()
    assert admittance_problem(problem).codesign
    with pytest.raises(SpecError, match="admittance.codesign"):
        synthesise_dual_admittance(problem, structure="common_differential", controller=given,
                                   model=DualDriveStageY(), travel_m=(0.08, 0.72), design_positions=2,
                                   stage_x_mass_kg=16.0, ranges={})


@pytest.mark.slow
def test_codesigned_stage_y_holds_on_newtons_model(tmp_path):
    """``gantry synth`` on the bundled spec with ``admittance.codesign = true``: the structure's yaw channel keeps
    its design, the translation gains are those of the co-design, and on Newton's model at the travel's ends x the
    payload's ends x the least and most damping (slowest drive: 0.8 ms, 700 Hz) the co-designed loops are stable,
    keep every channel's margins (python-control, within the Pade approximant's 1 deg and 0.2 dB), stay stable
    with both motors' gains raised together by up to the common-mode gain margin, and the interaction loop with
    each corner mouse keeps the admittance's margins."""
    spec = tmp_path / "codesign.toml"
    spec.write_text(SPEC.read_text().replace("codesign = false", "codesign = true"))
    out = gantry("synth", str(spec), "--json")
    assert out.returncode in (0, 3), out.stderr
    adm = json.loads(out.stdout)["admittance"]
    co = adm["codesign"]
    assert co is not None and co["verified"] and adm["monte_carlo"]["violations"] == 0
    structure = adm["structure"]
    assert co["gains"] == adm["gains"]
    kp, ki = ("kp_common", "ki_common") if structure == "common_differential" else ("kp", "ki")
    assert {k: v for k, v in co["gains"].items() if k not in (kp, ki)} == \
        {k: v for k, v in co["given_gains"].items() if k not in (kp, ki)}
    g = tuple(adm["gains"].values())
    problem = load_spec(spec).problem()
    a = admittance_problem(problem)
    timing = RigTiming.of(a.rig)
    w_adm = np.geomspace(2 * np.pi * 1e-3, np.pi / timing.period_s, 2000)
    w = 2 * np.pi * np.logspace(-2, 3.3, 1000)
    common_gain = 10 ** (problem.requirements.gain_margin_db / 20)
    for p in (0.08, 0.72):
        for payload in (5.0, 40.0):
            for b1, b2 in ((330.0, 330.0), (330.0, 550.0), (550.0, 550.0)):
                rig = Rig(carriage_mass_kg=16.0 + payload, carriage_position_m=p, delay_s=8e-4,
                          current_loop_hz=700.0, b1=b1, b2=b2)
                assert unstable_poles(rig, structure, g) == 0, rig
                for j in range(2):
                    gm, pm, *_ = control.stability_margins(control.frd(channel_loop(rig, structure, g, j), w))
                    assert pm >= 45.0 - 1.0 and 20 * np.log10(gm) >= 6.0 - 0.2, (rig, j)
                for k in np.linspace(1.0, common_gain * 0.98, 6):
                    assert unstable_poles(rig, structure, tuple(k * x for x in g)) == 0, (rig, k)
                if b1 != b2 or payload == 5.0:
                    continue
                for mouse in mice(problem)[::7]:
                    m = dict(head_kg=mouse.head_mass_kg, body_kg=mouse.body_mass_kg,
                             neck_k=mouse.neck_stiffness_n_per_m, neck_c=mouse.neck_damping_n_s_per_m,
                             leg_k=mouse.leg_stiffness_n_per_m, leg_c=mouse.leg_damping_n_s_per_m)
                    loop = adm_ref.sampled_loop(clamp_path(rig, structure, g, **m), m_v=adm["m_v"], b_v=adm["b_v"],
                                                period_s=timing.period_s, forward_euler=True)
                    pm, gm = adm_ref.margins_from_response(w_adm, adm_ref.response(loop, np.exp(1j * w_adm
                                                                                                * timing.period_s)))
                    assert adm_ref.closed_loop_stable(loop, discrete=True)
                    assert pm >= a.phase_margin_deg - 0.1 and gm >= a.gain_margin_db - 0.05, (rig, mouse)


@pytest.mark.slow
def test_the_report_shows_the_admittance_by_carriage_position(tmp_path):
    """On the bundled spec made small (3 positions, 2 payloads, one structure, 500 draws): the admittance section
    of the report carries the JSON's design, its table by carriage position and the rendered-admittance figure."""
    spec = tmp_path / "small.toml"
    spec.write_text(SPEC.read_text().replace("points = 3 }", "points = 2 }").replace("points = 5 }", "points = 3 }")
                    .replace('structures = ["per_motor", "common_differential"]', 'structures = ["per_motor"]')
                    .replace("monte_carlo_samples = 10000", "monte_carlo_samples = 500"))
    out = tmp_path / "y.html"
    r = gantry("synth", str(spec), "--json", "--report", str(out))
    assert r.returncode in (0, 3), r.stderr
    adm = json.loads(r.stdout)["admittance"]
    text = out.read_text()
    assert "Admittance for the mouse" in text
    assert f"m_v = {adm['m_v']:.4g} kg, b_v = {adm['b_v']:.4g} N*s/m" in text
    for row in adm["by_carriage_position"]:
        assert f">{row['carriage_position_m']:.3g}</td>" in text
    assert text.count("<svg") == 3


@pytest.mark.parametrize("structure", list(CONTROLLERS))
def test_free_state_space_equals_the_loops_frequency_response(structure):
    # the state space the sampled loop is discretised from, against the 2 x 2 frequency-response algebra the
    # other tests hold to Newton's model (the delay's Pade approximant exact to 1e-9 below 300 Hz)
    _, sc = tool(Rig(carriage_position_m=0.25, b2=330.0, delay_s=8e-4, current_loop_hz=700.0, carriage_mass_kg=51.0))
    s = 1j * np.geomspace(0.1, 300.0, 60) * 2 * np.pi
    loops = DualLoops(CONTROLLERS[structure])
    free, loop = loops.free_state_space(sc, period_s=None), loops.at(s, sc)
    A, B, C, D = free.A[0], free.B[0], free.C[0], free.D[0]
    x = np.linalg.solve(s[:, None, None] * np.eye(A.shape[0]) - A, np.broadcast_to(B, (s.size, *B.shape)))
    H = C @ x + D                                            # (n_f, [v, a], [u, f])
    assert np.allclose(H[:, 0, 0], loop.reference[0], rtol=1e-8)
    assert np.allclose(H[:, 0, 1], loop.sensitivity_mobility[0], rtol=1e-8)
    assert np.allclose(H[:, 1, 1], s * loop.sensitivity_mobility[0], rtol=1e-8)
