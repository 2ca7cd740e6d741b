"""The admittance section's figures state what its summary states, and the diagnosis story reads as a list."""

import html as html_lib
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
from in_process import gantry

from plant import stage_x
from plant.bode import wrapped_phase_deg
from plant.experiment.simulate import simulate_stepped_sine

ROOT = Path(__file__).resolve().parents[3]
SPEC = ROOT / "specs" / "stage_x_admittance.toml"


@pytest.fixture(scope="module")
def section(tmp_path_factory):
    """The admittance section of the report of SPEC: (summary text, list of its figures' SVG texts)."""
    out = tmp_path_factory.mktemp("adm") / "adm.html"
    proc = gantry("report", str(SPEC), "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    page = out.read_text()
    part = page[page.index(">Admittance (mouse following)</h2>"):page.index(">Reproducibility</h2>")]
    summary = html_lib.unescape(re.sub(r"<[^>]+>", "", part[part.index("<div class='summary'>"):
                                                             part.index("</div>")]))
    svgs = [[html_lib.unescape(t) for t in re.findall(r"<text[^>]*>([^<]*)</text>", s)]
            for s in re.findall(r"<svg.*?</svg>", part, flags=re.S)]
    return summary, svgs, part


def figure_with(svgs, text: str) -> list[str]:
    found = [s for s in svgs if any(text in t for t in s)]
    assert len(found) == 1, text
    return found[0]


@pytest.mark.slow                 # one admittance report build (~30 s)
def test_the_rendered_admittance_marks_the_summarys_passive_band_and_bandwidth(section):
    summary, svgs, _ = section
    passive = re.search(r"Passive up to ([\d.]+) Hz", summary).group(1)
    bandwidth = re.search(r"within 3 dB / 30° of 1/\(m_v s \+ b_v\) up to ([\d.]+) Hz", summary).group(1)
    fig = figure_with(svgs, "Rendered admittance v/F")
    assert f"passive up to {passive} Hz (worst scenario)" in fig
    assert f"within 3 dB / 30° up to {bandwidth} Hz (worst scenario)" in fig
    assert {f"{passive} Hz", f"{bandwidth} Hz"} <= set(fig)          # the lines' own labels on the axes
    assert "magnitude (dB re 1 (m/s)/N)" in fig and "frequency (Hz)" in fig and "phase (deg)" in fig
    ticks = [float(t.replace("−", "-")) for t in fig if re.fullmatch(r"−?\d+", t)]
    assert min(ticks) >= -180                                          # the phase is wrapped, not unwrapped


@pytest.mark.slow                 # one admittance report build (~30 s)
def test_the_binding_scenario_of_the_summary_is_circled_on_its_margin(section):
    summary, svgs, _ = section
    b = re.search(r"Binding: interaction-loop phase margin \(admittance.phase_margin_deg = [\d.]+\) at ([\d.]+) kg, "
                  r"current_loop.bandwidth_hz = (\d+), damping_n_s_per_m = (\d+), delay.seconds = ([\d.]+) "
                  r"with mouse \(([^)]*)\)", summary)
    assert b, summary
    kg, bw, damping, delay, mouse = b.groups()
    label = (f"binding: {float(kg):.3g} kg, current_loop.bandwidth_hz {bw}, damping_n_s_per_m {damping}, "
             f"delay.seconds {delay},")
    fig = figure_with(svgs, "Interaction-loop phase margin, worst over the uncertainty")
    assert label in fig
    legs = "floating" if "floating" in mouse else "braced"
    worst = re.search(rf"{'floating' if legs == 'floating' else 'grounded'} mice: PM ([\d.]+)°", summary).group(1)
    assert f"{legs} mouse: {worst} deg" in fig                        # the binding one is the worst of its mice


@pytest.mark.slow                 # one admittance report build (~30 s)
def test_every_margin_and_force_limit_says_whether_it_is_met(section):
    summary, svgs, part = section
    spec = tomllib.loads(SPEC.read_text())["admittance"]
    pm_fig = figure_with(svgs, "Interaction-loop phase margin, worst over the uncertainty")
    gm_fig = figure_with(svgs, "Interaction-loop gain margin, worst over the uncertainty (gaps: ∞)")
    for name, legs in (("floating", "floating"), ("grounded", "braced")):
        pm, gm = map(float, re.search(rf"{name} mice: PM ([\d.]+)°, GM ([\d.]+) dB", summary).groups())
        assert f"{legs} mice: worst {pm:.1f} deg: {'meets' if pm >= spec['phase_margin_deg'] else 'FAILS'}" in pm_fig
        assert f"{legs} mice: worst {gm:.1f} dB: {'meets' if gm >= spec['gain_margin_db'] else 'FAILS'}" in gm_fig
    assert f"required {spec['phase_margin_deg']:g} deg" in pm_fig
    assert f"required {spec['gain_margin_db']:g} dB" in gm_fig
    felt, push = re.search(r"it feels ([\d.]+) N peak .* can push ([\d.]+) N", summary).groups()
    fig = figure_with(svgs, "Force felt on the locomotion profile")
    verdict = "EXCEEDED" if float(felt) > float(push) else "met"
    assert f"the mouse's peak force, {float(push):g} N: {verdict} (peak {felt} N)" in fig
    assert "|apparent mass| (kg)" in figure_with(svgs, "Apparent mass Im(1/Y_r)/ω")
    assert "N*s/m" not in part and "m/s^2" not in part


@pytest.mark.slow                 # one admittance report build (~30 s)
def test_the_admittance_figures_stack_on_a_narrow_screen(section):
    _, svgs, part = section
    rows = re.findall(r"<figure class='row'>(.*?)</figure>", part, flags=re.S)
    assert rows and all(r.count("<svg") == 2 for r in rows)
    assert all(max(len(t) for t in s) < 120 for s in svgs)               # titles and labels that fit a panel


def test_wrapped_phase_breaks_where_it_wraps_and_keeps_the_angle():
    w = np.geomspace(1, 1e4, 500)
    resp = np.exp(-1j * w * 1e-3) / (1 + 1j * w / 100)                   # a delay: the phase falls through -180
    p = wrapped_phase_deg(resp)
    kept = np.isfinite(p)
    assert np.all((p[kept] > -180) & (p[kept] <= 180))
    turns = np.floor((np.degrees(np.unwrap(np.angle(resp))) + 180) / 360)
    assert (~kept).sum() == np.count_nonzero(np.diff(turns)) >= 1    # one break per wrap of the unwrapped phase
    assert np.allclose(np.exp(1j * np.radians(p[kept])), resp[kept] / np.abs(resp[kept]))
    jumps = np.flatnonzero(~kept)
    assert np.all(np.abs(np.angle(resp[jumps], deg=True) - np.angle(resp[jumps - 1], deg=True)) > 180)


def test_the_diagnosis_story_is_a_list_that_agrees_with_the_steps_table():
    from design.views.diagnosis import diagnosis_report
    from plant import Resonance
    from plant.diagnose.diagnosis import diagnose
    from plant.estimate.lockin import estimate_response

    rec = simulate_stepped_sine(stage_x(mass_kg=20.0) * Resonance(40.0, 30.0, 0.03), f_hz=np.geomspace(2, 100, 25),
                                current_amplitude_a=0.5, duration_s=2.0, noise_fraction=0.01, seed=3)
    data = estimate_response(rec)
    diag = diagnose(stage_x(mass_kg=20.0), data)
    page = diagnosis_report(diag, data, title="t", provenance="p").render()
    story = page[page.index(">The path to the model</h3>"):page.index(">Reproducibility</h3>")]
    assert "<pre>" not in story and story.count("<ol>") == 1
    items = [html_lib.unescape(i) for i in re.findall(r"<li>(.*?)</li>", story)]
    assert len(items) == len(diag.steps) + 1
    steps = page[page.index(">The error, step by step</h3>"):]
    chi2 = re.findall(r"<tr><td class=\"l\">[^<]*</td><td>([^<]+)</td>", steps[:steps.index("</table>")])
    assert len(chi2) == len(diag.steps)
    assert f"reduced χ² {chi2[0]}," in items[0]
    for k, item in enumerate(items[1:-1], start=1):
        assert item.endswith(f"reduced χ² {chi2[k - 1]} → {chi2[k]}.")
        added = [e for e in diag.steps[k].effects if e not in diag.steps[k - 1].effects]
        assert item.startswith(f"Adding {', '.join(added)}: ΔBIC ")
    assert items[-1].startswith(f"{len(diag.models)} models searched") and "Verdict: " in items[-1]
