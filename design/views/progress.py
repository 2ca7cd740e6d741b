"""Progress on a terminal's stderr for work a user waits on (rich): nothing when disabled (``--json``, a pipe).
Light to import, so a command can show it before its numerics are loaded."""

from __future__ import annotations

import time

from rich.console import Console


class StageProgress:
    """Progress callback for a multi-stage computation: a spinner with the current stage on stderr once the
    work has taken ``after_s`` seconds (a terminal only)."""

    def __init__(self, enabled: bool, *, after_s: float = 0.5):
        self.enabled = enabled
        self.after_s = after_s
        self.t0 = time.perf_counter()
        self.status = None
        self.stage = ""

    def __call__(self, stage: str) -> None:
        if not self.enabled:
            return
        self.stage = stage
        if self.status is None and time.perf_counter() - self.t0 > self.after_s:
            self.status = Console(stderr=True).status(stage)
            self.status.start()
        if self.status is not None:
            self.status.update(f"{stage} ({time.perf_counter() - self.t0:.0f} s)")

    def close(self) -> None:
        if self.status is not None:
            self.status.stop()


class LazyProgress:
    """Progress callback ``(done, total)`` that shows a rich progress bar on stderr once the work has taken a
    second: ``label`` before the bar, ``unit`` after the count."""

    def __init__(self, enabled: bool, *, label: str = "sweep", unit: str = "plants"):
        self.enabled = enabled
        self.label = label
        self.unit = unit
        self.t0 = time.perf_counter()
        self.bar = None
        self.task = None

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        if self.bar is None and time.perf_counter() - self.t0 > 1.0 and done < total:
            from rich.progress import BarColumn, Progress, TimeRemainingColumn

            self.bar = Progress(self.label, BarColumn(), "{task.completed}/{task.total} " + self.unit,
                                TimeRemainingColumn(), console=Console(stderr=True), transient=True)
            self.bar.start()
            self.task = self.bar.add_task(self.label, total=total)
        if self.bar is not None:
            self.bar.update(self.task, completed=done)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.stop()
