"""The recording node: raw subscriptions to the wanted topics, written to a :class:`BagWriter`.

Topics are found through the ROS graph as they appear (checked every
``DISCOVERY_PERIOD`` s): a wanted topic is subscribed as soon as it has a publisher, with
the message type the graph reports and a QoS adapted to the publishers' offered QoS
(:func:`tensegrity_ros.bag.qos.request_for_offers`, rosbag2's rule). Relative topic names
are resolved against the recorder's namespace (``--ros-args -r __ns:=/robot1`` works).

Subscriptions are ``raw=True``: a take gives the exact CDR bytes that arrived on the wire
(what rosbag2 stores) and the rmw message info. No executor runs: :meth:`RecorderNode.poll`
takes every queued message every ``POLL_PERIOD`` s (an executor's per-message overhead
limited the recorder to ~700 messages/s). The log time is the rmw receive
timestamp, the publish time the sender's source timestamp, the MCAP sequence the
publication sequence number (mod 2**32); all times are system time in ns since the epoch.

Readiness: the recorder says on its log when each topic's first message arrived
(``first message on /joint_states``) and when the number of publishers its reader has
matched changes (``matched 1 publisher(s) on /events``). The graph showing the recorder's
subscription says nothing of whether the publisher's writer and the recorder's reader have
matched each other (each side learns of the other from its own discovery message; under
load that can take seconds), and a volatile message published before both sides matched is
never delivered. A message received proves both matches: a program that must record
everything from its first step (``tensegrity demo``) makes the publishers publish once
and starts only after the first message of every topic.

Stopping: SIGINT or SIGTERM (stop requests of :mod:`tensegrity_ros.rclpy_utils.stop_signals`, not
rclpy's, so that messages already delivered are written first), or ``max_duration``;
either way the bag is closed properly (summary + ``metadata.yaml``) with counts equal to
the messages received.

Durability while recording: the open chunk is written to the file at the latest
``flush_interval`` s (default :data:`~tensegrity_ros.bag.writer.DEFAULT_FLUSH_INTERVAL`)
after its first message (:class:`~tensegrity_ros.bag.writer.BagWriter`); a recorder killed
outright (SIGKILL) loses at most that, plus the messages it had not taken yet.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterable
from typing import Any

import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from rclpy.subscription import Subscription
from rclpy.topic_endpoint_info import TopicEndpointInfo
from rclpy.topic_or_service_is_hidden import topic_or_service_is_hidden

from tensegrity_core.excerpt import excerpt
from tensegrity_ros.bag.errors import BagError
from tensegrity_ros.bag.metadata import BagMetadata, TopicInfo
from tensegrity_ros.bag.qos import dict_to_profile, profile_to_dict, request_for_offers
from tensegrity_ros.bag.writer import BagWriter
from tensegrity_ros.rclpy_utils import messages as msg_utils
from tensegrity_ros.rclpy_utils.raw_take import take_all
from tensegrity_ros.rclpy_utils.stop_signals import stop_on_signals

# The suite's topics, as the nodes name them (relative names follow the namespace): the
# simulator's for the class-2 mechanism, general structures and robots (its located events
# too: a stop on the singular set), and both command topics. A name ending in "/" stands for
# every topic under it (a robot's ``imu/<rod>``).
SUITE_TOPICS = ("joint_states", "end_effector", "mechanism_state", "markers", "/clock",
                "actuator_forces", "cable_states", "body_states", "/tf", "contacts", "imu/",
                "cable_commands", "events")
DEFAULT_DEPTH = 1000       # subscription history: 1 s of backlog at 1 kHz before a drop
DISCOVERY_PERIOD = 0.1     # s
#: The recorder node's name (`tensegrity up --record` has the simulator wait for its subscriptions).
RECORDER_NODE = "tensegrity_recorder"
POLL_PERIOD = 0.005        # s between two takes; log times are rmw receive times, so this
                           # batching costs no timing accuracy (5 messages per poll at 1 kHz)


def message_class(type_name: str) -> Any:
    """The rclpy message class of ``pkg/msg/Name``; :class:`BagError` if not importable."""
    try:
        return msg_utils.message_class(type_name)
    except ValueError as err:
        raise BagError(str(err)) from None


class RecorderNode(Node):
    """Subscribe to ``topics`` (or every topic if ``record_all``) and write to ``writer``."""

    def __init__(self, writer: BagWriter, topics: Iterable[str] = SUITE_TOPICS, *,
                 record_all: bool = False, depth: int = DEFAULT_DEPTH,
                 node_name: str = RECORDER_NODE, context: Context | None = None,
                 log: Callable[[str], None] | None = None):
        # no executor spins this node (see poll), so it offers no parameter services
        super().__init__(node_name, context=context, start_parameter_services=False)
        self.writer = writer
        self.record_all = record_all
        self.depth = int(depth)
        topics = list(topics)
        self.wanted = {self.resolve_topic_name(t) for t in topics if not t.endswith("/")}
        self.wanted_under = tuple(self.resolve_topic_name(t.rstrip("/")) + "/" for t in topics
                                  if t.endswith("/") and t.rstrip("/"))
        self.received: dict[str, int] = {}
        self._skipped: set[str] = set()
        self._subscriptions_by_topic: dict[str, Subscription] = {}
        self._log = log or (lambda text: print(text, file=sys.stderr, flush=True))
        self._next_discovery = 0.0
        self._matched: dict[str, int] = {}

    def poll(self) -> int:
        """One round of the recording loop: look for new topics (every
        ``DISCOVERY_PERIOD`` s), write every queued message, close the open chunk when it
        is due; return how many messages were written."""
        now = time.monotonic()
        if now >= self._next_discovery:
            self._discover()
            self._report_matches()
            self._next_discovery = now + DISCOVERY_PERIOD
        written = len(self.take_pending())
        self.writer.maybe_flush()
        return written

    def _wants(self, name: str) -> bool:
        if self.record_all:
            return not topic_or_service_is_hidden(name)
        return name in self.wanted or name.startswith(self.wanted_under)

    def _discover(self) -> None:
        for name, types in self.get_topic_names_and_types():
            if name in self._subscriptions_by_topic or name in self._skipped or not self._wants(name):
                continue
            if len(types) != 1:
                self._skip(name, f"has several types {excerpt(types, 200)}")
                continue
            infos = self.get_publishers_info_by_topic(name)
            if not infos:
                continue  # only subscribers so far: the offered QoS is not known yet
            try:
                cls = message_class(types[0])
            except BagError as err:
                self._skip(name, str(err))
                continue
            self._subscribe(name, types[0], cls, infos)

    def _report_matches(self) -> None:
        """Log each topic whose count of publishers matched by the recorder's reader changed."""
        for name, sub in self._subscriptions_by_topic.items():
            count = sub.get_publisher_count()
            if count != self._matched.get(name, 0):
                self._matched[name] = count
                self._log(f"matched {count} publisher(s) on {name}")

    def _skip(self, name: str, why: str) -> None:
        self._skipped.add(name)
        self._log(f"warning: not recording {name}: {why}")

    def _subscribe(self, name: str, type_name: str, cls: Any, infos: list[TopicEndpointInfo]) -> None:
        offers = [profile_to_dict(i.qos_profile) for i in infos]
        hashes = {str(i.topic_type_hash) for i in infos}
        request = request_for_offers(offers, self.depth)
        if request["reliability"] == "reliable":
            # keep_all: a reader that falls behind makes reliable writers hold and resend
            # instead of overwriting its oldest unread sample (a 10 kHz command flood lost
            # ~40 % with keep_last 1000); best-effort topics cannot be made lossless anyway.
            request["history"] = "keep_all"
        self.writer.add_topic(TopicInfo(
            name=name, type=type_name, offered_qos_profiles=offers,
            type_description_hash=hashes.pop() if len(hashes) == 1 else ""))
        self.received[name] = 0
        self._subscriptions_by_topic[name] = self.create_subscription(
            cls, name, lambda *_: None, dict_to_profile(request), raw=True)  # taken in poll
        self._log(f"recording {name} [{type_name}] {request['reliability']} "
                  f"{request['durability']}")

    def _write(self, topic: str, data: bytes, info: dict[str, Any]) -> None:
        self.writer.write(topic, data, info["received_timestamp"], info["source_timestamp"],
                          info.get("publication_sequence_number") or 0)
        self.received[topic] += 1
        if self.received[topic] == 1:
            self._log(f"first message on {topic}")

    def take_pending(self) -> list[int]:
        """Write every message already queued on the subscriptions, in receive order;
        return their receive times [ns since the epoch]. Taken straight from the
        subscriptions (:func:`tensegrity_ros.rclpy_utils.raw_take.take_all`), not through an executor."""
        batch = [(info["received_timestamp"], topic, (data, info))
                 for topic, sub in self._subscriptions_by_topic.items()
                 for data, info in take_all(sub)]
        batch.sort(key=lambda item: item[0])
        for _, topic, (data, info) in batch:
            self._write(topic, data, info)
        return [t for t, _, _ in batch]


def _drain(node: RecorderNode, stop_ns: int) -> None:
    """Write what was received up to the stop request (``stop_ns``, system time): take
    until two takes 20 ms apart bring no message received before it. Publishers that go on
    sending do not keep the recorder from stopping."""
    idle = 0
    while idle < 2:
        idle = 0 if any(t <= stop_ns for t in node.take_pending()) else idle + 1
        time.sleep(0.02)


def record(folder: str, topics: Iterable[str] | None = None, *, record_all: bool = False,
           max_duration: float | None = None, chunk_size: int | None = None,
           compression: str = "zstd", flush_interval: float | None = None,
           ros_args: list[str] | None = None, custom_data: dict[str, str] | None = None,
           log: Callable[[str], None] | None = None) -> BagMetadata:
    """Record until SIGINT/SIGTERM or ``max_duration`` s; return the closed bag's metadata.

    On a stop request the recorder first writes every message already delivered to its
    subscriptions (it keeps taking until two takes 20 ms apart bring nothing received
    before the request), then closes the bag. ``custom_data`` goes into the bag's metadata
    (:class:`~tensegrity_ros.bag.writer.BagWriter`).
    """
    if max_duration is not None and not max_duration > 0:
        raise BagError(f"max_duration must be > 0 s, got {max_duration!r}")
    kwargs: dict[str, Any] = {"compression": compression, "custom_data": custom_data}
    if chunk_size is not None:
        kwargs["chunk_size"] = chunk_size
    if flush_interval is not None:
        kwargs["flush_interval"] = flush_interval
    log = log or (lambda text: print(text, file=sys.stderr, flush=True))
    topics = list(topics or []) or list(SUITE_TOPICS)
    with stop_on_signals() as stop:
        stop.enter_running()
        writer = BagWriter(folder, **kwargs)
        node = None
        try:
            rclpy.init(args=list(ros_args or []), signal_handler_options=SignalHandlerOptions.NO)
            node = RecorderNode(writer, topics, record_all=record_all, log=log)
            log(f"recording to {writer.folder} (stop with Ctrl-C)")
            deadline = None if max_duration is None else time.monotonic() + max_duration
            while not stop.is_set() and rclpy.ok() and (deadline is None or time.monotonic() < deadline):
                node.poll()
                stop.wait(POLL_PERIOD)
            if rclpy.ok():
                _drain(node, time.time_ns())
        finally:
            if node is not None:
                node.destroy_node()  # type: ignore[no-untyped-call]  # rclpy's, on a subclass: not excluded by name
            meta = writer.close()
            rclpy.try_shutdown()
    log(f"recorded {meta.message_count} messages to {writer.folder}: " + ", ".join(
        f"{t.name} {t.message_count}" for t in meta.topics))
    return meta
