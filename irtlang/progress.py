"""Progress on long work: a rich progress bar per TRACE (frame k of n, rays traced, rate, time left).

The tracer calls ``start(total)`` when a TRACE begins (it returns the object whose ``update(done)`` and
``close()`` it then calls).  The bar goes to stderr, and only when both stdout and stderr are terminals, unless
``enabled=True`` asks for it (``irt run --progress``); ``irt run --quiet`` and the Python API show none.  Asked for on a stream that is
not a terminal (a CI log), it writes a plain line every few seconds instead of a bar.
Without rich it falls back to the tracer's one-line display.
"""
from __future__ import annotations

import sys
import time

PLAIN_EVERY_S = 5.0     # seconds between progress lines on a stream that is not a terminal


def _tty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


class RunProgress:
    def __init__(self, frames: int = 0, *, enabled: bool | None = None, stream=None):
        self.stream = stream or sys.stderr
        self.enabled = (_tty(sys.stdout) and _tty(self.stream)) if enabled is None else bool(enabled)
        self.frames = frames          # TRACE steps the checked program reaches (0: unknown)
        self.frame = 0
        self.total = 0
        self._bar = self._task = None
        self._line = None

    # ------------------------------------------------------------------ the tracer's interface
    def start(self, total: int) -> "RunProgress":
        self.frame += 1
        self.total = int(total)
        if not self.enabled:
            return self
        label = f"frame {self.frame}/{self.frames}" if self.frames > 1 else "TRACE"
        self._t0 = time.perf_counter()
        if not _tty(self.stream):   # asked for on a log file or a pipe: a plain line every few seconds
            self._plain, self._label, self._last = True, label, 0.0
            return self
        try:
            from rich.console import Console
            from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn,
                                       TimeRemainingColumn)
        except ImportError:   # pragma: no cover - rich is a dependency; the plain line still works
            from .tracer import Progress as Line
            self._line = Line(total, enabled=True, stream=self.stream)
            return self
        self._bar = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                             TextColumn("rays  {task.fields[rate]}"), TimeElapsedColumn(), TextColumn("elapsed,"),
                             TimeRemainingColumn(), TextColumn("left"), console=Console(file=self.stream), transient=True,
                             redirect_stdout=False, redirect_stderr=False)
        self._bar.start()
        self._task = self._bar.add_task(label, total=max(self.total, 1), rate="")
        self._t0 = time.perf_counter()
        return self

    def note(self, text: str) -> None:
        """A line above the bar (or before the plain lines) where progress is shown; nothing otherwise."""
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.console.print(text, highlight=False, markup=False)
        else:
            self.stream.write(text + "\n")
            self.stream.flush()

    def update(self, done: int, force: bool = False) -> None:
        if getattr(self, "_plain", False):
            now = time.perf_counter()
            if force or now - self._last >= PLAIN_EVERY_S:
                self._last = now
                self.stream.write(self.text(done) + "\n")
                self.stream.flush()
        elif self._line is not None:
            self._line.update(done, force)
        elif self._bar is not None:
            dt = max(time.perf_counter() - self._t0, 1e-9)
            self._bar.update(self._task, completed=min(done, self.total), rate=f"{done / dt / 1e6:.2f} Mrays/s")

    def text(self, done: int) -> str:
        """irt: frame k/n: done/total rays, rate, time left (the plain progress line)."""
        dt = max(time.perf_counter() - self._t0, 1e-9)
        rate = done / dt
        left = (self.total - done) / rate if rate > 0 and self.total > done else 0.0
        return (f"irt: {self._label}: {done:,}/{self.total:,} rays, {rate / 1e6:.2f} Mrays/s, "
                f"{left:.0f} s left")

    def close(self) -> None:
        self._plain = False
        if self._line is not None:
            self._line.close()
            self._line = None
        if self._bar is not None:
            self._bar.stop()
            self._bar = None
