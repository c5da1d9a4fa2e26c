"""Taking raw messages straight from a subscription, without an executor.

One executor ``spin_once`` per message costs about 0.5 ms of CPU here (rclpy rebuilds its
wait set each time); a take costs ~40 us (measured with a backlog: 680 against 20,800
messages/s). The recorder and the 1 kHz benchmark probe therefore poll their
subscriptions with :func:`take_all`. The subscription must be created with ``raw=True``;
its callback is never called. :func:`take_waiting` takes from an executor's subscription
what the executor has not yet handed to its callback.
"""

from __future__ import annotations

from typing import Any


def take_all(subscription: Any) -> list[tuple[bytes, dict[str, Any]]]:
    """Every message queued on ``subscription`` now, oldest first: ``(CDR bytes, rmw
    message info)`` with ``received_timestamp`` and ``source_timestamp`` [ns]."""
    taken: list[tuple[bytes, dict[str, Any]]] = []
    with subscription.handle:
        while (item := subscription.handle.take_message(subscription.msg_type, True)) is not None:
            taken.append(item)
    return taken


def take_waiting(subscription: Any) -> list[Any]:
    """Every message queued on ``subscription`` now, oldest first, in the form its callback
    takes (bytes when it was created with ``raw=True``): for a callback of the same executor
    that must see them before it judges, since rclpy's executor runs a ready timer before a
    ready subscription (a late executor's timer then finds a message still waiting)."""
    taken: list[Any] = []
    with subscription.handle:
        while (item := subscription.handle.take_message(subscription.msg_type, subscription.raw)) is not None:
            taken.append(item[0])
    return taken
