"""The player's last wait: until its subscribers have acknowledged every message, a
subscriber that is gone not waited for.

A reliable writer can resend what a reader missed only while it exists, so the player
waits at its end until every matched reader has acknowledged everything, ``timeout_s``
(``--wait-for-all-acked``) at most. A reader whose process was killed (SIGKILL, a crash)
never acknowledges, yet stays matched until its participant's DDS lease ends (Fast DDS:
20 s after its last announcement): the wait lasted its whole bound. So a topic still
unacknowledged :data:`PROBE_AFTER_S` after the wait began has its subscribers' nodes asked
whether they are there: their parameter service, which every rclpy and rclcpp node serves
unless told not to (``get_parameters`` with no names: no effect), asked every
:data:`ASK_EVERY_S` (a request sent before the server has matched the asking client is
lost). A node without parameter services (a node made with ``start_parameter_services=False``,
such as the simulator's command node) is asked through another node of its process that
has them: nodes of one ROS context share one DDS participant, named by the first 12 bytes
of every endpoint's GUID (:func:`_participant_sibling`). When none of a topic's nodes has
answered within :data:`ANSWER_S`, the topic is given up. A node that answers, or one
without parameter services alone in its process (nothing can tell), is waited for up to
the bound: a live reader still repairing what it missed under load gets it all. A live
node answers within its executor's latency, milliseconds on an idle machine.

The wait polls every publisher every :data:`POLL_S` (the suite's heartbeat period, when
readers acknowledge), :func:`report` turns what is left into one line.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, Final

from rclpy.duration import Duration

from tensegrity_core.excerpt import clip

#: Seconds between two looks at every publisher's acknowledgements.
POLL_S: Final = 0.05
#: Seconds after which the nodes of a topic still unacknowledged are asked whether they are
#: there (a live reader acknowledges within a heartbeat period, 50 ms, of the last message).
PROBE_AFTER_S: Final = 0.5
#: Seconds a node has to answer before its topic is given up,
ANSWER_S: Final = 2.5
#: asked again every this many seconds meanwhile.
ASK_EVERY_S: Final = 0.5


@dataclass(frozen=True)
class Unacknowledged:
    """A topic not acknowledged by every subscriber: its subscribers' nodes (fully qualified)
    and whether none of them answered (``gone``: given up) or the bound ran out."""

    topic: str
    nodes: tuple[str, ...]
    gone: bool


class _Probe:
    """Asks one node's parameter service, again every :data:`ASK_EVERY_S`, whether it is there."""

    def __init__(self, node: Any, fq_name: str, now: float):
        from rcl_interfaces.srv import GetParameters

        self._request = GetParameters.Request()
        self._client = node.create_client(GetParameters, f"{fq_name.rstrip('/')}/get_parameters")
        self._node = node
        self._asked: list[Any] = []
        self._began = now
        self._last = -float("inf")

    def answered(self, now: float) -> bool | None:
        """True once the node answered, False after :data:`ANSWER_S` without an answer."""
        if any(f.done() for f in self._asked):
            return True
        if now - self._began > ANSWER_S:
            return False
        if now - self._last >= ASK_EVERY_S and self._client.service_is_ready():
            self._asked.append(self._client.call_async(self._request))
            self._last = now
        return None

    def close(self) -> None:
        self._node.destroy_client(self._client)


def _verdict(probe: _Probe | None, now: float) -> bool | None:
    return None if probe is None else probe.answered(now)


def _serves_parameters(node: Any, fq_name: str) -> bool:
    """Whether the node ``fq_name`` has parameter services (False when the graph does not know it)."""
    namespace, _, name = fq_name.rpartition("/")
    try:
        services = node.get_service_names_and_types_by_node(name, namespace or "/")
    except Exception:      # rclpy's NodeNameNonExistentError: a node the graph no longer (or not yet) has
        return False
    return any(service == f"{fq_name}/get_parameters" for service, _types in services)


def _fq(info: Any) -> str:
    return f"{info.node_namespace.rstrip('/')}/{info.node_name}"


#: Bytes of an endpoint's gid that name its DDS participant (rmw_fastrtps: the GUID prefix).
PARTICIPANT_BYTES: Final = 12


def _participant_sibling(node: Any, topic: str, fq_name: str) -> str | None:
    """Another node with parameter services in the process of ``fq_name`` (a subscriber of
    ``topic``): one whose ``/rosout`` publisher is of the same participant; None if none."""
    participants = {bytes(i.endpoint_gid[:PARTICIPANT_BYTES]) for i in node.get_subscriptions_info_by_topic(topic)
                    if _fq(i) == fq_name}
    siblings = sorted({_fq(i) for i in node.get_publishers_info_by_topic("/rosout")
                       if bytes(i.endpoint_gid[:PARTICIPANT_BYTES]) in participants} - {fq_name})
    return next((name for name in siblings if _serves_parameters(node, name)), None)


def _subscriber_nodes(node: Any, topic: str) -> tuple[str, ...]:
    """The fully qualified names of the nodes subscribed to ``topic`` (graph view)."""
    return tuple(sorted({f"{i.node_namespace.rstrip('/')}/{i.node_name}"
                         for i in node.get_subscriptions_info_by_topic(topic)}))


def wait_for_acks(node: Any, publishers: Iterable[Any], timeout_s: float, *,
                  now: Callable[[], float] = time.monotonic,
                  sleep: Callable[[float], object] = time.sleep) -> list[Unacknowledged]:
    """Wait until every subscriber of each of ``publishers`` (of ``node``, which another
    thread spins) has acknowledged everything published, at most ``timeout_s`` seconds; the
    topics left, by their names as remapped (the module docstring)."""
    began = now()
    pending = {publisher.topic_name: publisher for publisher in publishers}
    nodes: dict[str, tuple[str, ...]] = {}
    probes: dict[str, _Probe | None] = {}          # None: a node without parameter services
    gone: list[Unacknowledged] = []
    try:
        while True:
            for topic, publisher in list(pending.items()):
                if publisher.wait_for_all_acked(Duration(nanoseconds=0)):
                    del pending[topic]
            t = now()
            if not pending or t - began >= timeout_s:
                break
            if t - began >= PROBE_AFTER_S:
                for topic in list(pending):
                    names = nodes.setdefault(topic, _subscriber_nodes(node, topic))
                    for name in names:
                        if name not in probes:
                            asked = name if _serves_parameters(node, name) else _participant_sibling(node, topic, name)
                            probes[name] = _Probe(node, asked, t) if asked else None
                    verdicts = [_verdict(probes[n], t) for n in names]
                    if names and all(v is False for v in verdicts):
                        gone.append(Unacknowledged(topic, names, gone=True))
                        del pending[topic]
                if not pending:
                    break
            sleep(POLL_S)
    finally:
        for probe in probes.values():
            if probe is not None:
                probe.close()
    return gone + [Unacknowledged(topic, nodes.get(topic) or _subscriber_nodes(node, topic), gone=False)
                   for topic in pending]


def report(left: list[Unacknowledged], timeout_s: float) -> str | None:
    """One line naming the topics not acknowledged and why, or None when there are none."""
    if not left:
        return None
    parts = []
    for u in left:
        who = ", ".join(u.nodes) or "a subscriber that left the graph"
        why = ("none of them answers: not waited for" if u.gone
               else f"not within {timeout_s:g} s")
        parts.append(f"{u.topic} (subscribed by {who}; {why})")
    hint = (" -- a subscriber killed while subscribed stays matched until its DDS lease ends and never acknowledges"
            if any(u.gone for u in left) else "")
    return clip("warning: not every subscriber acknowledged every message: " + "; ".join(parts) + hint, 600)
