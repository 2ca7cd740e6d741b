"""Self-contained HTML reports: figures embedded as inline SVG, no network, opens offline."""

from __future__ import annotations

import html
import io
import re
from dataclasses import dataclass, field

import matplotlib.pyplot as plt

from plant.host.files import atomic_write_text
from plant.story import Story

STYLE = """
body { font-family: system-ui, -apple-system, Segoe UI, Roboto, sans-serif; max-width: 1100px; margin: 2em auto;
       padding: 0 1em; color: #222; line-height: 1.45; }
h1 { border-bottom: 2px solid #444; padding-bottom: .2em; }
h2 { margin-top: 1.8em; border-bottom: 1px solid #bbb; }
table { border-collapse: collapse; margin: .6em 0; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: .25em .6em; text-align: right; }
th { background: #f0f0f0; } td.l, th.l { text-align: left; }
.ok { color: #17702a; font-weight: bold; } .bad { color: #b00020; font-weight: bold; }
.summary { background: #f6f8fa; border-left: 4px solid #444; padding: .6em 1em; }
svg { max-width: 100%; height: auto; }
figure { margin: 1em 0; } figcaption { font-size: .9em; color: #555; }
figure.row { display: flex; flex-wrap: wrap; gap: .4em 1.2em; align-items: flex-start; }
figure.row > svg { flex: 1 1 380px; min-width: 0; } figure.row > figcaption { flex-basis: 100%; }
pre { background: #f6f8fa; padding: .6em; overflow-x: auto; font-size: .85em; white-space: pre-wrap;
      overflow-wrap: anywhere; }
.table { overflow-x: auto; max-width: 100%; }
@media (max-width: 700px) {
  body { margin: 1em auto; padding: 0 .5em; font-size: 15px; }
  table { font-size: .8em; } th, td { padding: .2em .35em; }
  h1 { font-size: 1.4em; }
}
"""


def svg(fig) -> str:
    """The figure as an inline ``<svg>`` element (and close it). Text stays text (the browser sets it,
    instead of matplotlib turning every glyph into a path). A figure laid out by its own layout engine
    is saved as it is; cropping to the drawn extent (``bbox_inches="tight"``) would draw it twice."""
    buf = io.StringIO()
    with plt.rc_context({"svg.fonttype": "none"}):
        fig.savefig(buf, format="svg", bbox_inches=None if fig.get_layout_engine() is not None else "tight")
    plt.close(fig)
    text = buf.getvalue()
    return text[text.index("<svg"):]


def table(header: list[str], rows: list[list], *, left: int = 1) -> str:
    """HTML table (scrolling sideways on a narrow screen); the first ``left`` columns and every column of text
    (not a number) are left-aligned."""
    text_columns = {k for k in range(len(header)) if rows and not all(_numeric(r[k]) for r in rows if k < len(r))}

    def cell(tag, k, v):
        cls = ' class="l"' if k < left or k in text_columns else ""
        return f"<{tag}{cls}>{v if isinstance(v, Markup) else html.escape(str(v))}</{tag}>"
    head = "".join(cell("th", k, h) for k, h in enumerate(header))
    body = "".join("<tr>" + "".join(cell("td", k, v) for k, v in enumerate(r)) + "</tr>" for r in rows)
    return f"<div class='table'><table><tr>{head}</tr>{body}</table></div>"


def _numeric(v) -> bool:
    """A cell that reads as a number (right-aligned): 12.3, -4, 1e+05, ∞, 5 / 10000, 0.03 %."""
    t = str(v).replace("∞", "1").replace(" %", "").replace(" / ", "").replace("−", "-").strip()
    try:
        float(t)
        return True
    except ValueError:
        return False


#: verdict words a summary marks: failing ones red, passing ones green (the first alternative that matches at a
#: place wins: "does NOT meet the requirements" before "meet the requirements")
VERDICT = re.compile(r"(?P<bad>does NOT meet the requirements|FAIL the requirements|CANNOT drive|NOT verified|"
                     r"verified: no|\bFAILED\b|\bfails\b|\bunstable\b|not explained)|"
                     r"(?P<ok>meets? the requirements|can drive|verified: yes|\bpassed\b|\bholds\b)")


def marked(text: str) -> str:
    """HTML ``text`` with its verdict words (``VERDICT``) in the report's pass and fail colours."""
    return VERDICT.sub(lambda m: f"<span class='{m.lastgroup}'>{m.group(0)}</span>", text)


class Markup(str):
    """A string that is already HTML (not escaped by ``table``/``Report.text``)."""


@dataclass
class Report:
    """An HTML document built section by section."""

    title: str
    parts: list[str] = field(default_factory=list)

    def heading(self, text: str, level: int = 2) -> None:
        self.parts.append(f"<h{level}>{html.escape(text)}</h{level}>")

    def text(self, text: str, *, cls: str | None = None) -> None:
        body = text if isinstance(text, Markup) else html.escape(text)
        self.parts.append(f'<p class="{cls}">{body}</p>' if cls else f"<p>{body}</p>")

    def pre(self, text: str) -> None:
        self.parts.append(f"<pre>{html.escape(text)}</pre>")

    def figure(self, fig, caption: str) -> None:
        self.parts.append(f"<figure>{svg(fig)}<figcaption>{html.escape(caption)}</figcaption></figure>")

    def figures(self, figs, caption: str) -> None:
        """Figures side by side under one caption, stacked on a narrow screen."""
        self.parts.append("<figure class='row'>" + "".join(svg(f) for f in figs)
                          + f"<figcaption>{html.escape(caption)}</figcaption></figure>")

    def headline(self, story: Story) -> None:
        """A story's headline (``plant.story``) in the summary box, one labelled sentence a line, its verdict
        words marked (``marked``)."""
        if story.headline:
            self.parts.append("<div class='summary'>" + "<br>".join(
                f"<b>{html.escape(label)}:</b> {marked(html.escape(sentence))}" for label, sentence in story.headline)
                + "</div>")

    def sections(self, story: Story, level: int = 3) -> None:
        """A story's sections: each titled, its table, then its lines (a numbered list, notes, or a list)."""
        for s in story.sections:
            self.heading(s.title + (f" {s.aside}" if s.aside else ""), level)
            if s.table is not None:
                self.raw(table(list(s.table.columns), [list(r) for r in s.table.rows]))
            if not s.lines:
                continue
            if s.kind == "notes":
                for line in s.lines:
                    self.text(f"Note: {line}")
            else:
                tag = "ol" if s.kind == "numbered" else "ul"
                self.raw(f"<{tag}>" + "".join(f"<li>{html.escape(line)}</li>" for line in s.lines) + f"</{tag}>")

    def raw(self, markup: str) -> None:
        self.parts.append(markup)

    def render(self) -> str:
        return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{html.escape(self.title)}'
                f"</title><style>{STYLE}</style></head><body><h1>{html.escape(self.title)}</h1>\n"
                + "\n".join(self.parts) + "\n</body></html>\n")

    def write(self, path) -> None:
        atomic_write_text(path, self.render())
