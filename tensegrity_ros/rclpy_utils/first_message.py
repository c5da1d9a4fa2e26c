"""Holding a publisher's first message to new subscribers until they have matched it.

A lockstep controller answers the simulator's first state on its command topic at once; the
simulator's command reader may not yet have matched the controller's writer (each side
learns of the other from discovery messages of its own: :mod:`.matching`), and a volatile
reader drops what comes before. The lost first command cost the run one step of
``lockstep_timeout`` under ``safe_force`` (or the held rest lengths). A
:class:`HeardPublisher` waits before a message goes to a set of subscriptions it has not
sent to yet, as the
service clients do before their first request
(:func:`~tensegrity_ros.rclpy_utils.matching.wait_until_service_heard`): until the publisher
counts a subscription and every subscribing node has answered its ``get_parameters``,
which proves its participant has matched the writer
(:func:`~tensegrity_ros.rclpy_utils.matching.wait_until_subscribers_heard`). The wait is
bounded by ``timeout_s`` and happens once per new set of subscriptions: a topic nobody
reads (a client publishing states without taking commands) costs one such wait, then the
messages go out as before.

The probe runs on a node of its own in the publisher's context (the same participant: the
proof covers the publisher's writer), spun by an executor of its own here, so the caller's
executor thread may block in :meth:`HeardPublisher.publish` without a deadlock. The probe
node goes with the context (``on_shutdown``).
"""

from __future__ import annotations

from typing import Any

from tensegrity_ros.rclpy_utils.futures import spin_until_done
from tensegrity_ros.rclpy_utils.matching import wait_for_matches, wait_until_subscribers_heard

#: Longest wait [s] for the proof before a first message goes out anyway (a subscriber's
#: ``get_parameters`` answers in milliseconds; a loaded machine's discovery in about 1 s).
HEARD_TIMEOUT_S = 2.0


class HeardPublisher:
    """A publisher of ``node`` (``create_publisher(msg_type, topic, qos)``) whose first
    message to each new set of subscriptions waits at most ``timeout_s`` [s] until they have
    matched it. ``own_subscriptions``: how many subscriptions ``node``'s own process keeps on
    the topic (a controller reading back the commands it shares the topic with), which need
    no proof and do not count."""

    def __init__(self, node: Any, msg_type: Any, topic: str, qos: Any, *, own_subscriptions: int = 0,
                 timeout_s: float = HEARD_TIMEOUT_S) -> None:
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node

        self.publisher = node.create_publisher(msg_type, topic, qos)
        self.own = own_subscriptions
        self.timeout_s = timeout_s
        self._probe = Node(f"_{node.get_name()}_probe", namespace=node.get_namespace(), context=node.context,
                           use_global_arguments=False, start_parameter_services=False, enable_rosout=False)
        self._executor = SingleThreadedExecutor(context=node.context)
        self._executor.add_node(self._probe)
        self._heard: int | None = None      # the others' subscriptions last proven heard (None: not yet)
        node.context.on_shutdown(self._destroy)

    def publish(self, msg: Any) -> None:
        """Publish ``msg`` (a message or its serialized bytes), after the bounded wait for
        the proof when the topic has subscriptions not proven to have matched the writer."""
        others = self.publisher.get_subscription_count() - self.own
        if self._heard is None or others > self._heard:
            if wait_for_matches([self.publisher], self.own + 1, self.timeout_s, settle_s=0.0):
                wait_until_subscribers_heard(self._probe, [self.publisher],
                                             lambda future, s: spin_until_done(self._executor, future, s),
                                             self.timeout_s)
            others = self.publisher.get_subscription_count() - self.own
        self._heard = others                # a subscriber that left: a new one is waited for again
        self.publisher.publish(msg)

    def _destroy(self) -> None:
        self._executor.shutdown(timeout_sec=0.0)
        self._probe.destroy_node()
