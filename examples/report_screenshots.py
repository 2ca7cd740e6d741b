"""The three reports an engineer reads, written and photographed in headless Chromium (Debian's chromium):
the PI design report, the admittance design report and a diagnosis report, each at desktop width and at
600 px (a phone or a narrow window). Run from the checkout: ``python examples/report_screenshots.py [OUT]``
(default ``screenshots/``); it prints the files it wrote."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from design.views.browser import screenshot

ROOT = Path(__file__).resolve().parents[1]
#: screenshot heights (px) at 1200 and 600 px wide; the admittance report's own section lies below the PI part
HEIGHTS = {"admittance": (8800, 10500)}


def gantry(*args) -> None:
    subprocess.run([sys.executable, "-m", "design", *map(str, args)], check=True, cwd=ROOT,
                   stdout=subprocess.DEVNULL)


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    recording = out / "resonant_stage.csv"
    gantry("simulate", "--stage", "x", "--effects",
           "resonance.frequency_hz=40,resonance.antiresonance_hz=30,resonance.damping_ratio=0.03",
           "--f-hz", "2:100:30", "--duration-s", "2", "--seed", "1", "--out", recording)
    pages = {"design": ("report", "specs/stage_x_synth.toml", "--out"),
             "admittance": ("report", "specs/stage_x_admittance.toml", "--out"),
             "diagnosis": ("diagnose", recording, "--stage", "x", "--report")}
    for name, command in pages.items():
        html = out / f"{name}.html"
        gantry(*command, html)
        desktop, narrow = HEIGHTS.get(name, (5200, 7000))
        for width, height, tag in ((1200, desktop, ""), (600, narrow, "_600px")):
            png = out / f"{name}{tag}.png"
            screenshot(html, png, width=width, height=height)
            print(png)


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "screenshots")
