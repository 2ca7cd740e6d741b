"""Design report: self-contained HTML with its figures, rendered by headless Chromium."""

import html as html_lib
import re
from pathlib import Path

import numpy as np
import pytest
from in_process import gantry

from design.views.browser import chromium, dom, screenshot
from plant import Delay, stage_x
from plant.data.writers import write_recording_csv
from plant.experiment.simulate import simulate_stepped_sine

ROOT = Path(__file__).resolve().parents[3]
SPEC = ROOT / "specs" / "thesis_stage_x.toml"


@pytest.fixture(scope="module")
def report_html(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("report")
    rec = simulate_stepped_sine(stage_x(mass_kg=38.0) * Delay(0.001), f_hz=np.geomspace(2, 75, 12),
                                current_amplitude_a=0.5, duration_s=2.0, noise_fraction=0.02, seed=1)
    write_recording_csv(rec, tmp / "rec.csv")
    out = tmp / "design.views.html"
    proc = gantry("report", str(SPEC), "--data", str(tmp / "rec.csv"), "--samples", "50", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    return out


def test_report_is_self_contained_with_its_figures(report_html):
    html = report_html.read_text()
    # no network: nothing loaded from elsewhere (SVG namespaces are identifiers, not loads)
    assert not re.search(r"""(src|href)\s*=\s*["']https?://""", html)
    assert "<script" not in html
    # Bode, Nyquist, step, payload sweep, and the diagnosis (comparison, error by step, residuals)
    assert html.count("<svg") >= 8
    assert "Closed velocity loop: sensitivity |S|" in html and "bandwidth " in html
    for heading in ("Plant", "Loop over the payload range", "Margins and bandwidth against payload",
                    "Measurements against the model", "Reproducibility"):
        assert f">{heading}</h2>" in html
    # summary first, with the recomputed worst case of the thesis gains (thesis Figure 4.31 payload range)
    assert html.index("class='summary'") < html.index(">Plant</h2>")
    assert "Worst case over 5-40 kg" in html
    assert "delay" in html and "sha256" in html


@pytest.mark.slow
@pytest.mark.skipif(chromium() is None, reason="Chromium not installed (Debian package 'chromium'); "
                                                ".ci/run installs it")
def test_report_renders_in_headless_chromium(report_html, tmp_path):
    rendered = dom(report_html)
    assert rendered.count("<svg") >= 7
    png = tmp_path / "shot.png"
    screenshot(report_html, png, height=2000)
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 50_000  # a page with plots, not a blank one


def test_report_bad_spec_exits_2(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('[plant]\nstage = "z"\n')
    proc = gantry("report", str(bad), "--out", str(tmp_path / "r.html"))
    assert proc.returncode == 2
    assert "plant.stage" in proc.stderr and proc.stderr.count("\n") == 1
    assert not (tmp_path / "r.html").exists()


@pytest.mark.slow
def test_admittance_report_has_its_section_beside_the_nominal_design(tmp_path):
    spec = ROOT / "specs" / "stage_x_admittance.toml"
    out = tmp_path / "adm.html"
    proc = gantry("report", str(spec), "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    html = out.read_text()
    # the verdict on the mouse comes first in the summary
    summary = html[html.index("<div class='summary'>"):]
    assert summary.index("<b>Admittance:</b> the mouse") < summary.index("<b>Gains:</b>")
    assert ">Admittance (mouse following)</h2>" in html
    section = html[html.index(">Admittance (mouse following)</h2>"):html.index(">Reproducibility</h2>")]
    text = html_lib.unescape(re.sub(r"<[^>]+>", "", section))        # the words, the summary's marks aside
    assert "python-control checked the rational model (sampled by c2d)" in text and ": passed." in text
    assert "floating mice: PM" in text and "grounded mice: PM" in text
    assert "Latency: it tolerates" in text
    assert "Monte Carlo: 0 of 10000 independent draws over payload, uncertainty and mouse violate" in text
    # force felt, apparent mass, rendered admittance, margins by mouse, the simulated run; the front when the
    # mouse cannot drive the design
    assert section.count("<svg") >= 5 and "A simulated run through the sampled loop" in section
    # the lab's hand-tuned setting on the same plant, and the lab's own model's number
    assert "the lab&#x27;s hand-tuned setting" in section or "the lab's hand-tuned setting" in section
    assert "reproduced from the published live script" in section
    # the design for the nominal parameters alone beside it, on the same draws over the uncertainty
    row = section[section.index("nominal parameters only"):]
    assert " of 10000 (" in row[:row.index("</tr>")]


def test_report_samples_without_uncertainty_exits_2_at_once(tmp_path):
    spec = ROOT / "specs" / "stage_x_resonant_motor.toml"
    proc = gantry("report", str(spec), "--samples", "10", "--out", str(tmp_path / "r.html"))
    assert proc.returncode == 2 and "plant.uncertainty" in proc.stderr and proc.stderr.count("\n") == 1
    assert not (tmp_path / "r.html").exists()


@pytest.fixture(scope="module")
def synth_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("synth_report") / "design.html"
    proc = gantry("report", str(ROOT / "specs" / "stage_x_synth.toml"), "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    return out.read_text()


def test_the_binding_scenario_of_the_summary_is_drawn_with_its_margins(synth_report):
    html = synth_report
    limiting = re.search(r"<b>Limiting:</b> phase margin ([\d.]+) deg \(required 45\) at ([\d.]+) kg, "
                         r"current_loop.bandwidth_hz = (\d+), damping_n_s_per_m = (\d+), delay.seconds = ([\d.]*\d)",
                         html)
    assert limiting, html[:3000]
    pm, kg, bw, damping, delay = limiting.groups()
    label = (f"binding: {float(kg):.3g} kg, current_loop.bandwidth_hz {bw}, damping_n_s_per_m {damping}, "
             f"delay.seconds {delay}")
    bode, nyquist, step = (html.split("<figure>")[k] for k in (1, 3, 4))
    assert all(label in fig for fig in (bode, nyquist, step))
    assert f"PM {float(pm):.1f}°" in bode                 # the binding loop's phase margin, marked
    assert "dB re 1 (m/s)/A" in bode and "dB re 1 (dimensionless)" in bode


def test_one_monte_carlo_and_honest_verdicts_on_every_panel(synth_report):
    html = synth_report
    summary = html[html.index("<div class='summary'>"):html.index(">Plant</h2>")]
    draws = re.search(r"\((\d+) independent draws, seed (\d+)\)", summary).groups()
    assert draws == ("10000", "20261124")
    payload = html.split("<figure>")[5]
    assert f"{draws[0]} draws (seed {draws[1]})" in payload and "200 samples" not in html
    # the thesis gains fail this spec's requirements (worst PM 40 deg < 45): said in the summary and the legend
    assert "<span class='bad'>FAIL the requirements</span>" in summary
    assert "thesis gains (Kp 236, Ki 47): FAILS" in payload
    assert "worst over the uncertainty" in payload
    # text columns left-aligned, numbers right-aligned
    assert '<td class="l">330 – 550</td>' in html
    assert re.search(r"<td>172\.\d\d</td>", html)


def test_the_diagnosis_figure_draws_models_through_a_resonance_and_measured_phase():
    # a lightly damped mode between measured frequencies: the final model's curve must reach the mode's peak,
    # which the measured frequencies alone miss (closed form of the plant's peak via plant.frd on a fine grid)
    from design.views.diagnosis import comparison_figure, model_curves, output_title
    from plant import Resonance
    from plant.diagnose.diagnosis import diagnose
    from plant.estimate.lockin import estimate_response

    plant = stage_x(mass_kg=20.0) * Resonance(40.0, 30.0, 0.03)
    rec = simulate_stepped_sine(plant, f_hz=np.geomspace(2, 100, 25), current_amplitude_a=0.5, duration_s=2.0,
                                noise_fraction=0.01, seed=3)
    data = estimate_response(rec)
    diag = diagnose(stage_x(mass_kg=20.0), data)
    w, g = model_curves(diag.final, data)
    assert w.size > 5 * data.f_hz.size
    fine = np.geomspace(2 * np.pi * 30, 2 * np.pi * 60, 20000)        # around the mode
    peak = np.max(np.abs(plant.frd(fine)))
    near = (w >= fine[0]) & (w <= fine[-1])
    assert np.max(np.abs(g[0, near])) == pytest.approx(peak, rel=0.05)
    measured_near = (data.f_hz >= 30) & (data.f_hz <= 60)
    assert np.max(np.abs(data.response[0, measured_near])) < 0.9 * peak
    fig = comparison_figure(diag, data)
    phase_axis = fig.axes[1]
    measured = [line for line in phase_axis.get_lines() if line.get_marker() == "o"]
    assert len(measured) == 1 and measured[0].get_xdata().size == data.f_hz.size
    assert fig.axes[0].get_title() == output_title(data.output_names[0]) == "velocity per current, (m/s)/A"


def test_the_summary_box_is_the_summary_story_with_its_verdicts_coloured(synth_report):
    """The summary is laid out from a story (one labelled sentence a line, in the story's order); a passing verdict
    is green and a failing one red, and no failing word is coloured as passing."""
    from design.views.html import marked

    summary = synth_report[synth_report.index("<div class='summary'>"):synth_report.index(">Plant</h2>")]
    labels = re.findall(r"<b>([^<]+):</b>", summary)
    assert labels[:3] == ["Gains", "Worst case over 5-40 kg", "Limiting"]
    assert labels[-2:] == ["Thesis gains on the same plant", "Synthesis"]
    assert "<span class='ok'>meets the requirements</span>" in summary
    assert marked("does NOT meet the requirements") == "<span class='bad'>does NOT meet the requirements</span>"
    assert marked("the mouse CANNOT drive this design") == "the mouse <span class='bad'>CANNOT drive</span> this design"
    assert marked("it holds; it fails") == "it <span class='ok'>holds</span>; it <span class='bad'>fails</span>"


def test_the_least_margins_and_bandwidth_of_the_rows_drawn_are_labelled():
    """Beside the binding scenario (here a heavy, slow-loop corner whose phase margin binds), the Bode figure labels
    the least phase margin and the least gain margin of all rows drawn (the light payload's gain margin), and the
    closed-loop figure the least bandwidth."""
    from design.loop.controller import PI
    from design.loop.curves import loop_curves
    from design.loop.requirement import ScenarioPoint
    from design.views.report import closed_loop_figure, loop_bode_figure
    from design.workflows import load_problem

    thesis = load_problem(SPEC).loop.controller                # the thesis gains on the synthesis spec's plant
    problem = load_problem(ROOT / "specs" / "stage_x_synth.toml").loop   # (its delay: finite gain margins)
    binding = ScenarioPoint(40.0, (("current_loop.bandwidth_hz", 700.0), ("damping_n_s_per_m", 330.0),
                                   ("delay.seconds", 0.0008)))
    c = loop_curves(problem, PI(float(thesis.kp.value), float(thesis.ki.value)), binding)
    assert np.isfinite(c.gain_margin_db).all() and np.argmin(c.gain_margin_db) != c.binding_row
    texts = [t.get_text() for ax in loop_bode_figure(c).axes for t in ax.texts]
    assert f"PM {np.nanmin(c.phase_margin_deg):.1f}°" in texts
    assert f"GM {np.nanmin(c.gain_margin_db):.1f} dB" in texts
    texts = [t.get_text() for ax in closed_loop_figure(c, problem.requirements).axes for t in ax.texts]
    assert f"bandwidth {np.nanmin(c.bandwidth_hz):.3g} Hz" in texts
