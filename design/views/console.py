"""Results as text on the console: the output of the commands without ``--json``."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
from rich import box
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from plant.experiment.simulate_time import travel_notes
from plant.story import Section, Story

if TYPE_CHECKING:
    from design.results import DiagnosisOutcome, FitOutcome
    from plant.data.recordings import Recording
    from plant.experiment.excitation import Multisine, SteppedSine, VariancePrediction

def print_story(console: Console, story: Story) -> None:
    """A story (``plant.story``) on the terminal, laid out as ``Story.text`` lays it out: the headline's labels in
    bold, each section as ``[[Title]]`` with its table (a rich table) and its lines; notes as notes."""
    for label, sentence in story.headline:
        console.print(f"[bold]{escape(label)}:[/] {escape(sentence)}", soft_wrap=True)
    for s in story.sections:
        if s.kind == "notes" and s.table is None:
            for line in s.lines:
                console.print(f"[yellow]{escape(s.title.rstrip('s'))}:[/] {escape(line)}", soft_wrap=True)
            continue
        console.print(f"[bold]\\[[{escape(s.title)}]][/]" + (f" {escape(s.aside)}" if s.aside else ""), soft_wrap=True)
        if s.table is not None:
            t = Table(box=box.SIMPLE_HEAD, pad_edge=False)
            for k, column in enumerate(s.table.columns):
                t.add_column(escape(column), justify="left" if k in s.table.text_columns else "right")
            for row in s.table.rows:
                t.add_row(*(escape(c) for c in row))
            console.print(t)
        for line in s.numbered():
            console.print(f"    {escape(line)}", soft_wrap=True, highlight=False)


def print_fit(console: Console, outcome: FitOutcome) -> None:
    """The text of ``gantry fit``: the fit's story, the estimator's data checks, and the rational fit when
    there is one."""
    story = outcome.result.story()
    if outcome.measured is not None and outcome.measured.notes:
        story = replace(story, sections=(*story.sections, Section("Data", tuple(outcome.measured.notes))))
    if outcome.rails is not None:
        story = replace(story, sections=(outcome.rails.section(), *story.sections))
    print_story(console, story)
    if outcome.rational is not None:
        console.print()
        print_story(console, outcome.rational.story())


def print_diagnosis_outcome(console: Console, outcome: DiagnosisOutcome) -> None:
    """The text of ``gantry diagnose``: the diagnosis's story, frequency or time domain."""
    print_story(console, outcome.diagnosis.story())


def print_time_simulation(console: Console, rec, out, sidecar) -> None:
    """``gantry simulate --form continuous|chirp``: what was written, how far the carriage went, and what that
    travel cannot show."""

    md = rec.metadata
    ex = md["excitation"]
    if "f_hz" in ex:
        what = f"{len(ex['f_hz'])} sines {ex['f_hz'][0]:g}-{ex['f_hz'][-1]:g} Hz x {ex['block_s']:g} s in one run"
    else:
        what = f"a chirp {ex['f0_hz']:g}-{ex['f1_hz']:g} Hz"
    lines = [f"wrote {out}: stage {md['stage'].upper()}, effects {', '.join(md['effects']) or 'none'}, {what} "
             f"({md['duration_s']:g} s at {md['sample_rate_hz']:g} Hz), {ex['amplitude_a']:g} A; the carriage "
             f"covered {1e3 * float(np.ptp(rec.output[0])):.4g} mm; noise {md['current_noise_std_a']:g} A / "
             f"{md['noise_std']:g} m, seed {md['seed']} (settings in {sidecar.name})"]
    lines += [f"note: {n}" for n in travel_notes(rec)]
    console.print("\n".join(lines), markup=False, highlight=False, soft_wrap=True)


def excitation_text(out, written: str, ms: Multisine, pred: VariancePrediction, stepped: SteppedSine, *,
                    chosen: bool) -> str:
    """``gantry excite``: what was written and why, both designs, their predicted variance per second and the
    verdict (composed before the file is written)."""
    if written == "stepped_sine":
        what = (f"wrote {out}: the stepped sine, {stepped.f_hz.size} log-spaced frequencies {stepped.f_hz[0]:g} to "
                f"{stepped.f_hz[-1]:g} Hz, {stepped.block_s:g} s each at {stepped.amplitude_a:g} A, "
                f"{stepped.samples_per_block} samples per block at {stepped.sample_rate_hz:g} Hz = "
                f"{stepped.duration_s:g} s of machine time")
    else:
        what = (f"wrote {out}: the multisine, {ms.current_a.size} samples at {ms.sample_rate_hz:g} Hz, {ms.periods} "
                f"periods of {ms.period_s:g} s = {ms.duration_s:g} s of machine time")
    why = ("(--form auto: the lower predicted variance per second of machine time)" if chosen
           else "(asked for by --form)")
    lines = [
        f"{what} {why}",
        f"multisine: {ms.f_hz.size} odd harmonics of {1 / ms.period_s:g} Hz, {ms.f_hz[0]:g} to {ms.f_hz[-1]:g} Hz, "
        f"{ms.amplitudes[0]:.4g} A each; peak {ms.peak_a:.4g} A, RMS {ms.rms_a:.4g} A, crest factor "
        f"{ms.crest_factor:.3f} ({ms.phase_method} phases)",
        f"predicted FRF variance for {pred.noise_m_per_s:g} m/s velocity noise, mean per line x machine time:",
        f"  multisine    {pred.multisine_variance_s:.4g} (m/s per A)^2 s  ({ms.f_hz.size} lines in "
        f"{pred.multisine_time_s:g} s, first period dropped)",
        f"  stepped sine {pred.stepped_variance_s:.4g} (m/s per A)^2 s  ({pred.stepped_f_hz.size} log-spaced "
        f"frequencies, {stepped.block_s:g} s blocks at {stepped.amplitude_a:g} A, {pred.stepped_time_s:g} s)",
        f"  ratio stepped / multisine: {pred.ratio:.3g} (> 1: the multisine is better per second)",
        pred.verdict(ms.crest_factor),
    ]
    return "\n".join(lines)


def print_simulation(console: Console, rec: Recording, out, sidecar, *, amplitude_a: float) -> None:
    """``gantry simulate``: one line saying what was written."""
    md = rec.metadata
    noise = (f"noise {100 * md['noise_fraction']:g} %" if md["noise_fraction"] is not None
             else f"noise {np.max(md['current_noise_std_a']):g} A / {np.max(md['velocity_noise_std_m_per_s']):g} m/s")
    f = md["f_hz"]
    console.print(f"wrote {out}: stage {md['stage'].upper()}, effects {', '.join(md['effects']) or 'none'}, "
                  f"{len(rec.blocks)} blocks {f[0]:g}-{f[-1]:g} Hz x {md['duration_s']:g} s at "
                  f"{md['sample_rate_hz']:g} Hz, {amplitude_a:g} A, {noise}, seed {md['seed']} (settings in "
                  f"{sidecar.name})", highlight=False, soft_wrap=True)
