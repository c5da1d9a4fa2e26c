"""Replay timing: when each recorded message and each ``/clock`` tick is due.

Times: ``t`` are recorded log times (ns since the epoch); playback starts at bag time
``t0 = start + start_offset`` (``start`` = first log time of the bag). With rate ``r`` a
message logged at ``t`` is due ``(t - t0) / r`` ns of wall time after playback starts; so
the recorded spacing ``dt`` becomes ``dt / r``. Messages logged before ``t0`` are skipped.

``/clock`` ticks (``clock_hz`` > 0) are due every ``1/clock_hz`` s of wall time from the
start (tick ``k`` at ``k / clock_hz`` s) and carry the bag time at that instant,
``t0 + r * k / clock_hz``; the last tick is the one at or before the last message's bag
time, and a final tick carries exactly the last message's bag time. A tick due at the same
instant as a message is published first, so nodes with ``use_sim_time`` already have the
time when the message arrives.

Looping: iteration ``j`` is shifted by ``j * period`` with
``period = (end - t0) / r + gap`` where ``gap`` is the median recorded spacing divided by
``r`` (1 ms if the bag has fewer than two messages), so a loop's first message does not
land on the previous loop's last one.
"""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

from tensegrity_ros.bag.errors import BagError
from tensegrity_ros.bag.reader import BagMessage


@dataclass(frozen=True)
class PlaybackOptions:
    """Validated replay options (see the module docstring for their meaning)."""

    rate: float = 1.0
    start_offset_s: float = 0.0
    loop: bool = False
    clock_hz: float | None = None

    def __post_init__(self) -> None:
        if not (isinstance(self.rate, (int, float)) and 0 < self.rate < float("inf")):
            raise BagError(f"rate must be a finite number > 0, got {self.rate!r}")
        if not (0 <= self.start_offset_s < float("inf")):
            raise BagError(f"start offset must be >= 0 s, got {self.start_offset_s!r}")
        if self.clock_hz is not None and not (0 < self.clock_hz <= 10_000):
            raise BagError(f"clock rate must be in (0, 10000] Hz, got {self.clock_hz!r}")


@dataclass(frozen=True)
class PlaybackEvent:
    """Something due ``wall_ns`` after playback start: a message, or a clock tick."""

    wall_ns: int
    message: BagMessage | None = None   # None for a clock tick
    clock_ns: int = 0                   # bag time carried by a clock tick
    loop: int = 0


def _due(t_ns: int, t0_ns: int, rate: float) -> int:
    return round((t_ns - t0_ns) / rate)


def _clock_ticks(t0_ns: int, end_ns: int, opts: PlaybackOptions, clock_hz: float, shift_ns: int,
                 loop: int) -> Iterator[PlaybackEvent]:
    period_wall = 1e9 / clock_hz
    for k in itertools.count():
        bag_ns = t0_ns + round(opts.rate * k * period_wall)
        if bag_ns > end_ns:
            break
        yield PlaybackEvent(shift_ns + round(k * period_wall), clock_ns=bag_ns, loop=loop)
        if bag_ns == end_ns:
            return
    yield PlaybackEvent(shift_ns + _due(end_ns, t0_ns, opts.rate), clock_ns=end_ns, loop=loop)


def timeline(messages: Callable[[], Iterable[BagMessage]], start_ns: int, end_ns: int,
             opts: PlaybackOptions, median_spacing_ns: int | None = None) -> Iterator[PlaybackEvent]:
    """All events in due order. ``messages()`` yields the bag's messages in log-time order
    (it is called once per loop); ``start_ns``/``end_ns`` are the bag's first and last log
    times; ``median_spacing_ns`` sets the gap between loops."""
    t0 = start_ns + round(opts.start_offset_s * 1e9)
    if t0 > end_ns:
        raise BagError(f"start offset {opts.start_offset_s} s is past the end of the bag "
                       f"({(end_ns - start_ns) / 1e9:.3f} s long)")
    gap = round((median_spacing_ns if median_spacing_ns else 1_000_000) / opts.rate)
    period = _due(end_ns, t0, opts.rate) + gap
    for loop in itertools.count():
        shift = loop * period
        msgs = (PlaybackEvent(shift + _due(m.log_time_ns, t0, opts.rate), message=m, loop=loop)
                for m in messages() if m.log_time_ns >= t0)
        if opts.clock_hz:
            # clock ticks sort before messages due at the same instant
            ticks = _clock_ticks(t0, end_ns, opts, opts.clock_hz, shift, loop)
            merged = heapq.merge(((e.wall_ns, 0, i, e) for i, e in enumerate(ticks)),
                                 ((e.wall_ns, 1, i, e) for i, e in enumerate(msgs)))
            events = (item[3] for item in merged)
        else:
            events = msgs
        count = 0
        for event in events:
            count += 1
            yield event
        if not opts.loop or count == 0:
            return
