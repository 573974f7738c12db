"""The diagnosis's time (:class:`Clock`): how long its fits take, for the estimates its
progress gives, and the ``max_time`` after which it answers with what it has."""

from __future__ import annotations

import time

from ..errors import InputError
from ..progress import Stopwatch

__all__ = ["Clock"]


class Clock:
    """Wall time since the diagnosis began (what ``max_time`` limits: the user's wait), the
    duration of every fit it ran, and what it left out once ``max_time`` (seconds, or None:
    no limit) was spent."""

    def __init__(self, max_time: float | None):
        if max_time is not None and not max_time > 0:      # also NaN
            raise InputError(f"got {max_time!r}; expected a positive number of seconds",
                             key="max_time")
        self.started, self.max_time = time.perf_counter(), max_time
        self.fits: list[float] = []
        self.skipped: list[str] = []

    def timed(self, run):
        """``run()`` (a fit), its duration kept without the kernels' compilation (a cold
        first fit would make every estimate a minute long): :class:`~..progress.Stopwatch`."""
        watch = Stopwatch()
        result = run()
        self.fits.append(watch.seconds)
        return result

    def out(self) -> bool:
        """Is ``max_time`` spent?"""
        return (self.max_time is not None
                and time.perf_counter() - self.started >= self.max_time)

    def left_out(self, what: str) -> None:
        """Record work not done for want of time (the answer becomes provisional)."""
        self.skipped.append(what)

    @property
    def stopped(self) -> bool:
        return bool(self.skipped)

    @property
    def provisional(self) -> str | None:
        """Why the answer is provisional, or None when nothing was left out."""
        if not self.skipped:
            return None
        spent = time.perf_counter() - self.started
        return (f"stopped after {spent:.0f} s of max_time {self.max_time:g} s: "
                + "; ".join(self.skipped))

    def estimate(self, fits_left: int) -> str:
        """The time the round's ``fits_left`` refits will take, from the mean fit so far (a
        refit that stays above the noise is tried from a second start: the upper end)."""
        mean = sum(self.fits) / max(len(self.fits), 1)
        return f"about {fits_left * mean:.0f}-{2 * fits_left * mean:.0f} s left in this round"
