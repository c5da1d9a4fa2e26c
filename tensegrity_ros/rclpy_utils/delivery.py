"""Waiting, before a publisher goes, until its subscribers have everything it published.

A reliable Fast DDS writer that is deleted can no longer repair what its readers missed: a
sample written but not yet received (a shared-memory port full, a datagram dropped) is
sent again only when the reader asks for it, and only while the writer exists. A node
stopped while it publishes fast (a robot simulator at thousands of states a second on a
loaded machine) lost its last states that way, and up to 190 of 213 messages of a slower
topic whose repairs were pending. :func:`wait_for_delivery` waits for every publisher's
acknowledgements (``Publisher.wait_for_all_acked``). Readers acknowledge in answer to the
writer's heartbeats, which the suite's Fast DDS profile sends every 50 ms while something
is unacknowledged (``fastdds_loopback.xml``): the wait is then ~40 ms, and seconds when
the readers' processes are starved of CPU (load 15-38: more than 3 s).

When to give up is :class:`AckWait`, plain logic over a clock: at once when everything is
acknowledged; otherwise as long as acknowledgements keep coming, ``LIMIT_S`` at most in
all (within the 10 s after which a stopping process reports a hang,
``stop_signals.EXIT_DEADLINE_S``). rmw tells a writer's acknowledgements only as "all or
not yet", so progress is counted per publisher: one becoming fully acknowledged, or one
losing a matched reader (what that reader had not acknowledged is owed to nobody now).
``STALL_S`` without progress is the evidence of a reader that will never answer (a
process that died unnoticed stays matched until its DDS lease ends, 20 s).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Mapping
from typing import Any

#: Seconds a stopping node waits, in all, for its subscribers' acknowledgements: the 10 s
#: exit limit less 3 s for what a stop does besides (joining threads, destroying entities).
LIMIT_S = 7.0
#: Seconds without acknowledgement progress after which the readers still owed are taken
#: for dead, and what a dead reader costs a stop (a live reader starved of CPU at load
#: 15-38 needed more than 3 s for all its topics; this bound is per completed topic).
STALL_S = 4.0
#: Seconds of one wait on a publisher before progress is looked at again.
SLICE_S = 0.25


class AckWait:
    """Whether to go on waiting for acknowledgements, given what is still owed (plain logic:
    the caller passes the clock's readings). ``why`` says, once it has said stop, why."""

    def __init__(self, now: float, *, limit_s: float = LIMIT_S, stall_s: float = STALL_S,
                 slice_s: float = SLICE_S) -> None:
        self.start = self._progress_at = now
        self.limit_s, self.stall_s, self.slice_s = limit_s, stall_s, slice_s
        self._owed: Mapping[str, int] | None = None
        self.why = ""

    def next_wait(self, now: float, owed: Mapping[str, int]) -> float | None:
        """Seconds to wait next for acknowledgements, or None: stop now. ``owed``: each
        topic not yet fully acknowledged, with its number of matched readers."""
        if not owed:
            self.why = "all acknowledged"
            return None
        if self._owed is not None and any(owed.get(topic, 0) < readers for topic, readers in self._owed.items()):
            self._progress_at = now
        self._owed = dict(owed)
        if now - self.start >= self.limit_s:
            self.why = f"still acknowledging after {self.limit_s:g} s"
            return None
        if now - self._progress_at >= self.stall_s:
            self.why = f"no acknowledgement for {self.stall_s:g} s"
            return None
        return min(self.slice_s, self.start + self.limit_s - now, self._progress_at + self.stall_s - now)


def wait_for_delivery(publishers: Iterable[Any], *, clock: Callable[[], float] = time.monotonic,
                      **bounds: float) -> tuple[list[str], str]:
    """Wait until every subscriber matched by each of ``publishers`` has acknowledged all it
    was published (best-effort publishers at once), as :class:`AckWait` (``bounds``: its
    ``limit_s``, ``stall_s``, ``slice_s``) says; the topics still unacknowledged then and
    what ended the wait, with how long it took. The publishers' context must still be valid."""
    from rclpy.duration import Duration

    def acked(publisher: Any, wait_s: float) -> bool:
        return bool(publisher.wait_for_all_acked(Duration(nanoseconds=round(wait_s * 1e9))))

    policy = AckWait(clock(), **bounds)
    late = [p for p in publishers if not acked(p, 0.0)]
    while (wait_s := policy.next_wait(clock(), {p.topic_name: p.get_subscription_count() for p in late})) is not None:
        late = [p for i, p in enumerate(late) if not acked(p, wait_s if i == 0 else 0.0)]
    return [p.topic_name for p in late], f"{policy.why} ({clock() - policy.start:.2f} s)"
