"""One shape for every report the tool tells (a fit, a diagnosis): the answer first, then the evidence.

A ``Story`` is a headline (labelled sentences: the verdict, where the model fails) and titled sections, each
a table, lines, a numbered path of sentences or notes. ``Story.text`` lays it out as plain text (lmfit's
``fit_report`` layout: ``[[Title]]`` and indented lines); ``design.views.console.print_story`` on a terminal and
``design.views.html.Report.story`` in HTML. The three say the same thing because they read the same story:
a result builds its story once (``Fit.story``, ``Diagnosis.story``, ``TimeDiagnosis.story``) and a view only
lays it out.

May import: nothing of the tool.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal


@dataclass(frozen=True)
class Table:
    """Rows of cells (text, already formatted); ``text_columns`` are left-aligned, the others are numbers."""

    columns: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    text_columns: frozenset[int] = frozenset({0})

    def __post_init__(self):
        for row in self.rows:
            if len(row) != len(self.columns):
                raise ValueError(f"a row of {len(row)} cells under {len(self.columns)} columns: {row}")

    def lines(self) -> list[str]:
        """The table as aligned plain-text lines (header first)."""
        cells = [self.columns, *self.rows]
        width = [max(len(r[k]) for r in cells) for k in range(len(self.columns))]
        return ["  ".join(c.ljust(w) if k in self.text_columns else c.rjust(w)
                          for k, (c, w) in enumerate(zip(r, width))).rstrip() for r in cells]


@dataclass(frozen=True)
class Section:
    """A titled part of a story: a table (when there is one) and then its lines. ``kind`` says how the lines
    read: ``lines`` as they are, ``numbered`` a path of sentences (1., 2., ...), ``notes`` caveats."""

    title: str
    lines: tuple[str, ...] = ()
    table: Table | None = None
    kind: Literal["lines", "numbered", "notes"] = "lines"
    #: the rest of the title line, in brackets or as a remark (lmfit's "(unreported correlations are < 0.100)")
    aside: str = ""

    def numbered(self) -> list[str]:
        """The lines as the reader sees them: numbered when ``kind`` is ``numbered``."""
        if self.kind == "numbered":
            return [f"{k}. {line}" for k, line in enumerate(self.lines, start=1)]
        return list(self.lines)


@dataclass(frozen=True)
class Story:
    """The headline ((label, sentence) pairs, read first) and the sections of a report."""

    headline: tuple[tuple[str, str], ...] = ()
    sections: tuple[Section, ...] = ()

    def section(self, title: str) -> Section:
        """The section titled ``title`` (KeyError naming the titles there are)."""
        for s in self.sections:
            if s.title == title:
                return s
        raise KeyError(f"no section {title!r}; the story has {[s.title for s in self.sections]}")

    def text(self) -> str:
        """Plain text: the headline as ``label: sentence`` lines, each section as ``[[Title]] aside`` with its
        table and lines indented by four spaces."""
        out = [f"{label}: {sentence}" for label, sentence in self.headline]
        for s in self.sections:
            out.append(f"[[{s.title}]]" + (f" {s.aside}" if s.aside else ""))
            body = (s.table.lines() if s.table is not None else []) + s.numbered()
            out += [f"    {line}" for line in body]
        return "\n".join(out)


def unit_text(unit: str) -> str:
    """The models' ASCII units N*s/m, m/s^2 and N/A written as the reports write units: N·s/m, m/s² and N·A⁻¹
    (a force constant's "N/A" reads as "not applicable" in a table)."""
    return re.sub(r"(?<![\w)])N/A\b", "N·A⁻¹", unit.replace("N*s/m", "N·s/m").replace("m/s^2", "m/s²"))
