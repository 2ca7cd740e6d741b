"""Progress on a terminal's stderr for work a user waits on (rich): nothing when disabled (``--json``, a pipe).
Light to import, so a command can show it before its numerics are loaded. ``GANTRY_PROGRESS_AFTER_S`` (an
environment variable, seconds) sets when progress appears instead of each class's default (the tests set 0)."""

from __future__ import annotations

import os
import threading
import time

from rich.console import Console


def _after(default_s: float) -> float:
    text = os.environ.get("GANTRY_PROGRESS_AFTER_S", "").strip()
    try:
        return max(float(text), 0.0) if text else default_s
    except ValueError:
        return default_s


class StageProgress:
    """Progress callback for a multi-stage computation: a spinner with the current stage on stderr once the
    work has taken ``after_s`` seconds (a terminal only), also when one long stage began before that."""

    def __init__(self, enabled: bool, *, after_s: float = 0.5):
        self.enabled = enabled
        self.after_s = _after(after_s)
        self.t0 = time.perf_counter()
        self.status = None
        self.stage = ""
        self._lock = threading.Lock()
        self._timer = None

    def __call__(self, stage: str) -> None:
        if not self.enabled:
            return
        with self._lock:
            self.stage = stage
            elapsed = time.perf_counter() - self.t0
            if self.status is None and elapsed > self.after_s:
                self._show()
            elif self.status is None and self._timer is None:
                self._timer = threading.Timer(self.after_s - elapsed, self._show_later)
                self._timer.daemon = True
                self._timer.start()
            if self.status is not None:
                self.status.update(f"{stage} ({elapsed:.0f} s)")

    def _show(self) -> None:
        self.status = Console(stderr=True).status(self.stage)
        self.status.start()

    def _show_later(self) -> None:
        with self._lock:
            if self.status is None and self._timer is not None:
                self._show()

    def close(self) -> None:
        with self._lock:
            if self._timer is not None:
                self._timer.cancel()
                self._timer = None
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
        if self.bar is None and time.perf_counter() - self.t0 > _after(1.0) and done < total:
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
