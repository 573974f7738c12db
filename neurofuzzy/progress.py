"""Progress of long work on stderr: one mechanism for learners, the diagnosis and the CLI.

The kernels compile once (numba, cached in ``neurofuzzy/kernels/__pycache__``): the first run
on a clean install spends half a minute in it for a spring model, two or three minutes for a
model with elements (on one core). :func:`announced` says so on stderr when a
compilation starts (only on a cold cache: a kernel loaded from the cache compiles nothing),
and a :class:`Stopwatch` (the learners', the demo's and :class:`Progress`' timings) leaves the
time spent compiling out.
"""

from __future__ import annotations

import contextlib
import sys
import time

import numpy as np

__all__ = ["Progress", "note", "announced", "compile_seconds", "Stopwatch", "COMPILING"]

#: what is said on stderr when the kernels start compiling
COMPILING = ("compiling the simulation kernels, once: half a minute for springs, two or three "
             "minutes with elements (cached for later runs; not counted in the timings)")


class _Compilations:
    """numba's ``numba:compile`` events (fired on a cache miss only), outermost ones timed."""

    def __init__(self):
        self.depth, self.seconds, self.began = 0, 0.0, 0.0
        self.announcing, self.announced, self.registered = 0, False, False

    def register(self) -> None:
        if not self.registered:
            from numba.core import event

            listener = type("_Listener", (event.Listener,), {
                "on_start": lambda _, ev: self.start(), "on_end": lambda _, ev: self.end()})()
            event.register("numba:compile", listener)
            self.registered = True

    def start(self) -> None:
        if self.depth == 0:
            self.began = time.perf_counter()
            if self.announcing and not self.announced:
                self.announced = True
                print(COMPILING, file=sys.stderr, flush=True)
        self.depth += 1

    def end(self) -> None:
        self.depth -= 1
        if self.depth == 0:
            self.seconds += time.perf_counter() - self.began


_COMPILATIONS = _Compilations()


def compile_seconds() -> float:
    """Seconds this process has spent compiling kernels so far (since first asked)."""
    _COMPILATIONS.register()
    if _COMPILATIONS.depth:                # asked while compiling (from another thread)
        return _COMPILATIONS.seconds + time.perf_counter() - _COMPILATIONS.began
    return _COMPILATIONS.seconds


@contextlib.contextmanager
def announced(enabled: bool = True):
    """Within: the first compilation of a kernel in this process is said on stderr
    (:data:`COMPILING`), once, when ``enabled`` (which imports numba: not for work that
    runs no kernel)."""
    if enabled:
        _COMPILATIONS.register()
    _COMPILATIONS.announcing += bool(enabled)
    try:
        yield
    finally:
        _COMPILATIONS.announcing -= bool(enabled)


class Stopwatch:
    """Wall time since it was made, less the time spent compiling kernels meanwhile
    (:attr:`compiling`): what a timing of a fit or a simulation reports."""

    def __init__(self):
        self.started, self.compiled = time.perf_counter(), compile_seconds()

    @property
    def compiling(self) -> float:
        """Seconds spent compiling kernels since the start."""
        return compile_seconds() - self.compiled

    @property
    def seconds(self) -> float:
        return time.perf_counter() - self.started - self.compiling


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
        self.watch = Stopwatch()
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
        text = f"{self.label}: {done}/{self.total} {message} ({self.watch.seconds:.1f} s)"
        if self.tty:
            print("\r" + text, end="\n" if final else "", file=sys.stderr, flush=True)
        else:
            print(text, file=sys.stderr, flush=True)
