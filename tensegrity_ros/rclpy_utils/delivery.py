"""Waiting, before a publisher goes, until its subscribers have everything it published.

A reliable Fast DDS writer that is deleted can no longer repair what its readers missed: a
sample written but not yet received (a shared-memory port full, a datagram dropped) is
sent again only when the reader asks for it, and only while the writer exists. A node
stopped while it publishes fast (a robot simulator at thousands of states a second on a
loaded machine) lost its last states that way, and up to 190 of 213 messages of a slower
topic whose repairs were pending. :func:`wait_for_delivery` waits for every publisher's
acknowledgements (``Publisher.wait_for_all_acked``) within one bound, so that a subscriber
that never answers (a process that died unnoticed) cannot hold the stop up. Readers
acknowledge in answer to the writer's heartbeats, which the suite's Fast DDS profile sends
every 50 ms while something is unacknowledged (``fastdds_loopback.xml``): the wait is then
~40 ms (~2 s under Fast DDS's default period of 3 s).
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from typing import Any

#: Seconds a stopping node waits, in all, for its subscribers' acknowledgements (well within
#: the 10 s after which a stopping process reports a hang).
DELIVERY_S = 3.0


def wait_for_delivery(publishers: Iterable[Any], timeout_s: float = DELIVERY_S) -> list[str]:
    """Wait until every subscriber matched by each of ``publishers`` has acknowledged all it
    was published (best-effort publishers at once), ``timeout_s`` seconds at most in all;
    the topics still unacknowledged then. The publishers' context must still be valid."""
    from rclpy.duration import Duration

    deadline = time.monotonic() + timeout_s
    late = []
    for publisher in publishers:
        left = max(0.0, deadline - time.monotonic())
        if not publisher.wait_for_all_acked(Duration(nanoseconds=round(left * 1e9))):
            late.append(publisher.topic_name)
    return late
