"""The one shape of a report (``plant.story``): plain-text layout, alignment, and refusals."""

import pytest

from plant.story import Section, Story, Table, unit_text


def test_text_lays_out_the_headline_then_each_section_as_lmfit_does():
    story = Story((("Verdict", "explained"),),
                  (Section("Model", ("stage X",)),
                   Section("Correlations", ("C(a, b) = +0.5000",), aside="(unreported correlations are < 0.100)"),
                   Section("Path", ("first", "second"), kind="numbered")))
    assert story.text() == ("Verdict: explained\n[[Model]]\n    stage X\n"
                            "[[Correlations]] (unreported correlations are < 0.100)\n    C(a, b) = +0.5000\n"
                            "[[Path]]\n    1. first\n    2. second")


def test_a_table_aligns_text_left_and_numbers_right_before_its_lines():
    rows = (("base", "6605.9"), ("base + delay", "93.8"))
    s = Section("Steps", ("→ add delay",), table=Table(("model", "BIC"), rows))
    assert Story(sections=(s,)).text().splitlines() == [
        "[[Steps]]",
        "    model            BIC",
        "    base          6605.9",
        "    base + delay    93.8",
        "    → add delay"]


def test_a_row_of_the_wrong_length_and_an_unknown_section_are_refused_by_name():
    with pytest.raises(ValueError, match="2 cells under 3 columns"):
        Table(("a", "b", "c"), (("1", "2"),))
    with pytest.raises(KeyError, match="'Model'"):
        Story(sections=(Section("Model"),)).section("Variables")


def test_units_are_written_as_the_reports_write_them():
    assert unit_text("N*s/m") == "N·s/m" and unit_text("m/s^2") == "m/s²" and unit_text("kg") == "kg"
    assert unit_text("N/A") == "N·A⁻¹" and unit_text("(m/s)/A") == "(m/s)/A" and unit_text("mN/A") == "mN/A"
