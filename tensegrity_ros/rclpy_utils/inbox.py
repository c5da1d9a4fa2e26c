"""Subscriptions taken on the caller's own thread: one wait set, no executor.

An rclpy executor's ``spin_once`` rebuilds a wait set from every entity of its nodes, wraps
each ready callback in a task and runs it through its handler chain: ~170 us of CPU per
message for the simulator's two command subscriptions (measured as the simulator's CPU
per lockstep step, 670 against 500 us). :class:`Inbox` keeps one wait set for its
subscriptions and a wake-up guard condition, waits on it and hands each message taken to
its subscription's callback, oldest first: the same calls rclpy's own
``rclpy.wait_for_message`` makes, kept for the life of the node.

The subscriptions are made on a node that no executor spins (their callbacks are called
only from :meth:`Inbox.wait` and :meth:`Inbox.take_queued`); :meth:`Inbox.wake` ends a wait
at once (a stop). Messages are taken and handed on under one lock, so a message taken by one
thread has been handled when another thread's :meth:`Inbox.take_queued` returns, and each
subscription's messages reach its callback in the order they came.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.subscription import Subscription

NS_PER_S = 1_000_000_000


class Inbox:
    """The subscriptions of ``node`` (spun by no executor), waited on and taken by :meth:`wait`."""

    def __init__(self, node: Node) -> None:
        self._node = node
        self._subscriptions: list[Subscription] = []
        self._wake = node.create_guard_condition(lambda: None)
        self._wait_set: Any = None
        self._taking = threading.Lock()      # a take and its callback: one thread at a time

    def subscribe(self, msg_type: Any, topic: str, callback: Callable[[Any], None],
                  qos: QoSProfile | int, *, raw: bool = False) -> Subscription:
        """A subscription whose messages :meth:`wait` hands to ``callback`` (``raw``: as
        their serialized bytes)."""
        subscription = self._node.create_subscription(msg_type, topic, callback, qos, raw=raw)
        self._subscriptions.append(subscription)
        self._wait_set = None
        return subscription

    def wait(self, timeout_s: float) -> int:
        """Wait up to ``timeout_s`` seconds for a message (or :meth:`wake`), then hand every
        message queued now to its callback, oldest first per subscription; how many."""
        if self._wait_set is None:
            self._wait_set = _rclpy.WaitSet(len(self._subscriptions), 1, 0, 0, 0, 0, self._node.context.handle)
        wait_set = self._wait_set
        wait_set.clear_entities()
        for subscription in self._subscriptions:
            wait_set.add_subscription(subscription.handle)
        wait_set.add_guard_condition(self._wake.handle)
        wait_set.wait(max(0, int(timeout_s * NS_PER_S)))
        ready = wait_set.get_ready_entities("subscription")
        return self._take([s for s in self._subscriptions if s.handle.pointer in ready])

    def take_queued(self) -> int:
        """Hand every message queued now to its callback, without waiting (from any thread:
        one that must act on every message already received); how many."""
        return self._take(self._subscriptions)

    def _take(self, subscriptions: list[Subscription]) -> int:
        handled = 0
        with self._taking:
            for subscription in subscriptions:
                while True:
                    with subscription.handle:
                        taken = subscription.handle.take_message(subscription.msg_type, subscription.raw)
                    if taken is None:
                        break
                    subscription.callback(taken[0])
                    handled += 1
        return handled

    def wake(self) -> None:
        """End a :meth:`wait` now (from another thread)."""
        self._wake.trigger()


class InboxThread:
    """An :class:`Inbox` on a node of its own beside ``beside`` (same context and namespace,
    spun by no executor, named ``_<beside>_<suffix>``), taken on a thread of its own from
    :meth:`start` until :meth:`close` or until the context shuts down. Subscribe first, then
    start: the thread's wait set is built from the subscriptions it finds."""

    def __init__(self, beside: Node, suffix: str) -> None:
        self.node = Node(f"_{beside.get_name()}_{suffix}", namespace=beside.get_namespace(), context=beside.context,
                         use_global_arguments=False, start_parameter_services=False, enable_rosout=False)
        self.inbox = Inbox(self.node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._take, name=f"{beside.get_name()}_{suffix}", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def _take(self) -> None:
        """Hand the messages on as they come (joined like
        :class:`~tensegrity_ros.rclpy_utils.spin_thread.SpinThread`, for the same reason)."""
        context = self.node.context
        try:
            while not self._stop.is_set() and context.ok():
                self.inbox.wait(0.05)
        except Exception:
            if context.ok():     # shut down between the check and the wait: rclpy raises RCLError
                raise

    def close(self) -> None:
        """Stop the thread (a wait ends at once), join it and destroy the node."""
        self._stop.set()
        if self.node.context.ok():
            self.inbox.wake()
        if self._thread.is_alive():
            self._thread.join()
        self.node.destroy_node()
