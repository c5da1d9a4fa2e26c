"""Waiting until publishers are matched on *both* sides before sending what must arrive.

``Publisher.get_subscription_count()`` counts the readers the writer has matched. With
Fast DDS the reader can match the writer a little later (each side learns of the other
from its own discovery message), and a volatile reader drops what was written in that
gap although the writer already counted it (eProsima/Fast-DDS#2641). Seen here under load
on a 2-core machine: the first one or two messages of a replay at 200 Hz lost, i.e. a gap
of 5-10 ms. Nothing on the writer side reports the reader's match, so after every
publisher has its subscribers :func:`wait_for_matches` holds for ``settle_s`` more (the
count must stay up for that whole time), which covers that gap many times over.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from typing import Any

#: Seconds the matches must hold before sending (about 25x the gap seen under load).
MATCH_SETTLE_S = 0.25


def subscribed_by(node: Any, publishers: Iterable[Any], name: str) -> bool:
    """Whether the node ``name`` in ``node``'s namespace has a subscription on the topic of
    every one of ``publishers`` (the graph's endpoint lists: another subscriber of a topic,
    such as a controller on joint_states, does not count for it)."""
    ns = node.get_namespace()
    return all(any(i.node_name == name and i.node_namespace == ns
                   for i in node.get_subscriptions_info_by_topic(p.topic_name)) for p in publishers)


def wait_for_matches(publishers: Iterable[Any], minimum: int = 1, timeout_s: float | None = None,
                     *, settle_s: float = MATCH_SETTLE_S,
                     should_stop: Callable[[], bool] = lambda: False,
                     poll: Callable[[float], object] = time.sleep,
                     also: Callable[[], bool] = lambda: True) -> bool:
    """Return True once every publisher has had at least ``minimum`` matched subscriptions,
    and ``also()`` has been true, for ``settle_s`` seconds without interruption; False when they are not all matched
    after ``timeout_s`` (None: no limit) or when ``should_stop()`` turns true. ``poll(seconds)`` waits between checks (pass an
    executor's ``spin_once`` when the caller must keep spinning)."""
    pubs = list(publishers)
    deadline = None if timeout_s is None else time.monotonic() + timeout_s
    matched_since = None
    while True:
        now = time.monotonic()
        if all(p.get_subscription_count() >= minimum for p in pubs) and also():
            matched_since = now if matched_since is None else matched_since
            if now - matched_since >= settle_s:
                return True
        else:
            matched_since = None
            if deadline is not None and now > deadline:
                return False
        if should_stop():
            return False
        poll(0.01)
