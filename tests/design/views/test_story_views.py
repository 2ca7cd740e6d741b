"""The terminal and the HTML report tell the same story (``plant.story``): every cell and every line of a
diagnosis's story, a time-domain diagnosis's and a fit's appears in both views, in the story's order."""

import html as html_lib
import io
import re

import numpy as np
import pytest
from rich.console import Console

from design.views.console import print_story
from design.views.html import Report
from plant import Resonance
from plant.diagnose.diagnosis import diagnose
from plant.estimate.lockin import estimate_response
from plant.experiment.simulate import simulate_stepped_sine
from plant.physics.models import stage_x


@pytest.fixture(scope="module")
def diagnosis():
    rec = simulate_stepped_sine(stage_x(mass_kg=20.0) * Resonance(40.0, 30.0, 0.03), f_hz=np.geomspace(2, 100, 25),
                                current_amplitude_a=0.5, duration_s=2.0, noise_fraction=0.01, seed=3)
    return diagnose(stage_x(mass_kg=20.0), estimate_response(rec))


def _pieces(story):
    """Every piece of text a view must show, in order."""
    out = [p for pair in story.headline for p in pair]
    for s in story.sections:
        out.append(s.title)
        if s.table is not None:
            out += list(s.table.columns) + [c for row in s.table.rows for c in row if c]
        out += list(s.lines)
    return out


def _in_order(text: str, pieces) -> None:
    flat = " ".join(text.split())
    at = 0
    for piece in pieces:
        found = flat.find(" ".join(piece.split()), at)
        assert found >= 0, f"{piece!r} is missing (or out of order) in:\n{text[:3000]}"
        at = found


def test_the_terminal_and_the_html_show_every_piece_of_a_diagnosis_story(diagnosis):
    story = diagnosis.story()
    assert [s.title for s in story.sections][:2] == ["Candidates tried on the base model", "The error, step by step"]
    buf = io.StringIO()
    print_story(Console(file=buf, width=400, color_system=None), story)
    _in_order(buf.getvalue(), _pieces(story))
    report = Report("t")
    report.headline(story)
    report.sections(story)
    page = html_lib.unescape(re.sub(r"<[^>]+>", " ", report.render()))
    _in_order(page, _pieces(story))


def test_a_fit_report_is_its_story_as_text_and_the_terminal_shows_it(diagnosis):
    fit = diagnosis.final
    story = fit.story()
    assert [s.title for s in story.sections][:3] == ["Model", "Fit Statistics", "Variables"]
    buf = io.StringIO()
    print_story(Console(file=buf, width=400, color_system=None), story)
    assert buf.getvalue().split() == story.text().split()
