"""Progress of long work on stderr: one mechanism for learners, the diagnosis and the CLI."""

from __future__ import annotations

import sys
import time

import numpy as np

__all__ = ["Progress", "note"]


def note(enabled: bool, message: str) -> None:
    """Print one line of progress on stderr when ``enabled``."""
    if enabled:
        print(message, file=sys.stderr, flush=True)


class Progress:
    """Counted progress (``paper learner: 12/100 E=0.0312 (1.2 s)``).

    On a terminal one line is rewritten in place; otherwise a line is printed at most every
    ``interval`` seconds and at the end. Quiet when ``enabled`` is False.
    """

    def __init__(self, label: str, total: int, enabled: bool = True, interval: float = 2.0):
        self.label, self.total, self.enabled = label, total, enabled
        self.start = time.perf_counter()
        self.last = -np.inf
        self.done = False
        self.tty = enabled and sys.stderr.isatty()
        self.interval = 0.2 if self.tty else interval

    def update(self, done: int, message: str = "") -> None:
        if not self.enabled or self.done:
            return
        now = time.perf_counter()
        final = done >= self.total
        if now - self.last < self.interval and not final:
            return
        self.last = now
        self.done = final
        text = f"{self.label}: {done}/{self.total} {message} ({now - self.start:.1f} s)"
        if self.tty:
            print("\r" + text, end="\n" if final else "", file=sys.stderr, flush=True)
        else:
            print(text, file=sys.stderr, flush=True)
