"""Ticks on a fixed grid of wall time: the view's render thread and a bag's timeline.

A thread that waits one period after each tick's start drifts later by every wake-up that
comes late (a busy machine wakes a waiting thread some milliseconds after it asked), so it
ticks less often than it should. :class:`Pacer` keeps the ticks on a grid
``t0 + k period`` instead: a tick that starts late shortens the wait to the next one, so the
rate holds as long as wake-ups are late by less than a period; one later than that restarts
the grid at that tick (no burst of ticks to catch up), and one that starts early (a thread
woken on purpose: Play, a seek) keeps the deadline it had.
"""

from __future__ import annotations


class Pacer:
    """Deadlines [s, ``time.monotonic()``] every ``period`` s (see the module docstring)."""

    def __init__(self, period: float):
        if not period > 0:
            raise ValueError(f"period must be > 0 s, got {period!r}")
        self.period = float(period)
        self._next: float | None = None

    def tick(self, start: float) -> float:
        """A tick started at ``start`` [s]: the deadline of the next one [s]."""
        if self._next is None or start >= self._next + self.period:
            self._next = start + self.period       # the first tick, or a period late: a new grid
        elif start >= self._next:
            self._next += self.period
        return self._next
