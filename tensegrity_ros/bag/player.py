"""The playback node: publishes a bag's recorded CDR bytes with the recorded timing.

One publisher per played topic, with the message type stored in the bag and the QoS
rosbag2 would offer (:func:`tensegrity_ros.bag.qos.offer_for_replay`), with a history
deep enough for the whole topic (``keep_last(max(100, count))``, at most
``REPLAY_HISTORY_CAP``): a reliable writer can resend only what it still holds); messages are published as serialized bytes (``publish(bytes)``), so
what subscribers receive is byte for byte what was recorded. Timing, rate, start offset,
looping and ``/clock`` follow :mod:`tensegrity_ros.bag.schedule`. With ``clock_hz`` set a
``/clock`` topic stored in the bag is not replayed (there would be two time sources).

Its parameter services (``ros2 param``) are answered by an executor on a thread of its own
(:func:`play`) while the main thread publishes; a request of a wrong or unknown type is
refused with a reason (:mod:`tensegrity_ros.rclpy_utils.parameter_guard`) and the replay
goes on.

Waiting: the player sleeps until 1 ms before an event is due and then polls the monotonic
clock, so events leave within a few microseconds of their due time on an idle machine.
"""

from __future__ import annotations

import statistics
import sys
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock

from tensegrity_core.excerpt import clip, excerpt
from tensegrity_ros.bag.acks import Unacknowledged, report, wait_for_acks
from tensegrity_ros.bag.errors import BagError
from tensegrity_ros.bag.qos import DEFAULT_REPLAY_DEPTH, dict_to_profile, offer_for_replay
from tensegrity_ros.bag.reader import BagReader
from tensegrity_ros.bag.recorder import message_class
from tensegrity_ros.bag.scene import unread_custom_data
from tensegrity_ros.bag.schedule import PlaybackOptions, timeline
from tensegrity_ros.rclpy_utils.futures import wait_done
from tensegrity_ros.rclpy_utils.matching import wait_for_matches, wait_until_subscribers_heard
from tensegrity_ros.rclpy_utils.parameter_guard import guard_parameter_services
from tensegrity_ros.rclpy_utils.spin_thread import SpinThread
from tensegrity_ros.rclpy_utils.stop_signals import stop_on_signals

CLOCK_TOPIC = "/clock"
#: Largest writer history per replayed topic [messages].
REPLAY_HISTORY_CAP = 10_000
#: s a subscribing node gets to answer the player's probe (a hang guard: a node that is not
#: spinning cannot answer, and the replay then goes on as when nothing could be asked)
HEARD_S = 10.0
_SPIN_NS = 1_000_000  # poll the clock for the last 1 ms before an event


def sleep_until(deadline_ns: int, now_ns: Callable[[], int] = time.monotonic_ns,
                should_stop: Callable[[], bool] = lambda: False) -> None:
    """Return at ``deadline_ns`` (monotonic): sleep in slices of at most 50 ms (returning
    early once ``should_stop()``), then poll the clock for the last millisecond."""
    while (remaining := deadline_ns - now_ns()) > _SPIN_NS:
        if should_stop():
            return
        time.sleep(min(remaining - _SPIN_NS, 50_000_000) / 1e9)
    while now_ns() < deadline_ns:
        pass


@dataclass
class PlaybackResult:
    """What :meth:`PlayerNode.play` published."""

    published: dict[str, int] = field(default_factory=dict)
    clock_ticks: int = 0
    loops: int = 0
    stopped: bool = False          # interrupted before the end (signal or should_stop)


class PlayerNode(Node):
    """Publishes the messages of ``reader`` (only ``topics`` if given) per ``opts``."""

    def __init__(self, reader: BagReader, opts: PlaybackOptions | None = None,
                 topics: Iterable[str] | None = None, *, node_name: str = "tensegrity_player",
                 context: Context | None = None, log: Callable[[str], None] | None = None):
        super().__init__(node_name, context=context)
        guard_parameter_services(self)
        self.reader = reader
        self.opts = opts = opts or PlaybackOptions()
        self._log = log or (lambda text: print(text, file=sys.stderr, flush=True))
        bag_topics = {t.name: t for t in reader.topics()}
        if topics:
            selected = []
            for name in topics:
                resolved = name if name in bag_topics else self.resolve_topic_name(name)
                if resolved not in bag_topics:
                    raise BagError(f"topic {excerpt(name)} is not in bag {reader.folder} (it has "
                                   f"{excerpt(', '.join(sorted(bag_topics)), 200) if bag_topics else 'no topics'})")
                selected.append(resolved)
        else:
            selected = list(bag_topics)
        if opts.clock_hz and CLOCK_TOPIC in selected:
            selected.remove(CLOCK_TOPIC)
            self._log(f"note: the bag's {CLOCK_TOPIC} is not replayed; /clock comes from "
                      "the recorded times (--clock)")
        self.publishers_by_topic = {}
        for name in selected:
            info = bag_topics[name]
            try:
                if info.serialization_format != "cdr":
                    raise BagError(f"topic {excerpt(name)} is stored as {excerpt(info.serialization_format)};"
                                   " only 'cdr' can be replayed")
                cls = message_class(info.type)
            except BagError as err:
                if topics:      # asked for by name: an error; otherwise skip it, as rosbag2 does
                    raise
                self._log(f"warning: not playing {excerpt(name)}: {err}")
                continue
            # a writer can resend only what its history still holds: keep the whole topic
            # (up to REPLAY_HISTORY_CAP), so a reader that missed a stretch under load
            # gets it again (with 100, stretches of 30-260 messages were lost for good)
            depth = max(DEFAULT_REPLAY_DEPTH, min(info.message_count, REPLAY_HISTORY_CAP))
            qos = dict_to_profile(offer_for_replay(info.offered_qos_profiles, depth))
            self.publishers_by_topic[name] = self.create_publisher(cls, name, qos)
        if not self.publishers_by_topic and not opts.clock_hz:
            raise BagError(f"nothing to play: no topic of bag {reader.folder} can be replayed")
        if self.publishers_by_topic and not any(bag_topics[t].message_count
                                                for t in self.publishers_by_topic):
            raise BagError(f"nothing to play: bag {reader.folder} has no messages on "
                           + excerpt(", ".join(self.publishers_by_topic), 200))
        self.clock_publisher = None
        if opts.clock_hz:
            self.clock_publisher = self.create_publisher(
                Clock, CLOCK_TOPIC, QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))

    def wait_for_subscribers(self, timeout_s: float, should_stop: Callable[[], bool] = lambda: False
                             ) -> bool:
        """Wait until every publisher has a matched subscription
        (:func:`tensegrity_ros.rclpy_utils.matching.wait_for_matches`; False on timeout), then
        until every subscribing node has proven by an answer that its readers matched them
        (:func:`~tensegrity_ros.rclpy_utils.matching.wait_until_subscribers_heard`: a reader
        that matches later drops the first messages), at most :data:`HEARD_S` s, after which
        a note says that the first messages may be lost. Another thread spins the node."""
        pubs = list(self.publishers_by_topic.values())
        if self.clock_publisher is not None:
            pubs.append(self.clock_publisher)
        if not wait_for_matches(pubs, 1, timeout_s, should_stop=should_stop):
            return False
        if not wait_until_subscribers_heard(self, pubs, wait_done, HEARD_S, should_stop=should_stop) \
                and not should_stop():
            self._log(f"note: not every subscribing node answered within {HEARD_S:g} s (is it spinning?): "
                      "a reader that has not matched the player yet loses the first messages")
        return True

    def play(self, should_stop: Callable[[], bool] = lambda: False,
             now_ns: Callable[[], int] = time.monotonic_ns,
             wait: Callable[[int], None] | None = None) -> PlaybackResult:
        """Publish everything due, in order, on time; return what was published.

        ``now_ns`` and ``wait`` (sleep until a ``now_ns`` instant) default to the
        monotonic clock and :func:`sleep_until`.
        """
        wait = wait or (lambda deadline: sleep_until(deadline, now_ns, should_stop))
        result = PlaybackResult(published={t: 0 for t in self.publishers_by_topic})
        start, end = self.reader.start_ns, self.reader.end_ns
        if start is None or end is None or (not self.publishers_by_topic and self.clock_publisher is None):
            return result
        topics = list(self.publishers_by_topic)
        t0 = start + round(self.opts.start_offset_s * 1e9)
        spacing = None
        if self.opts.loop:
            times = [m.log_time_ns for m in self.reader.messages(topics, t0)]
            gaps = [b - a for a, b in zip(times, times[1:]) if b > a]
            spacing = int(statistics.median(gaps)) if gaps else None
        events = timeline(lambda: self.reader.messages(topics, t0), start, end, self.opts,
                          spacing)
        begin = now_ns()
        clock_msg = Clock()
        for event in events:
            wait(begin + event.wall_ns)
            if should_stop():
                result.stopped = True
                break
            result.loops = event.loop + 1
            if event.message is None:
                assert self.clock_publisher is not None       # clock ticks come with opts.clock_hz
                clock_msg.clock.sec, clock_msg.clock.nanosec = divmod(event.clock_ns, 1_000_000_000)
                self.clock_publisher.publish(clock_msg)
                result.clock_ticks += 1
            else:
                self.publishers_by_topic[event.message.topic].publish(event.message.data)
                result.published[event.message.topic] += 1
        return result

    def wait_for_all_acked(self, timeout_s: float) -> list[Unacknowledged]:
        """Wait until every reliable subscriber acknowledged everything published, at most
        ``timeout_s`` s, a subscriber that is gone not waited for (:mod:`.acks`); the topics
        left. A writer that goes away first cannot resend what its readers missed: the
        last messages of a replay were lost that way under load. Another thread spins the node."""
        pubs = list(self.publishers_by_topic.values())
        if self.clock_publisher is not None:
            pubs.append(self.clock_publisher)
        return wait_for_acks(self, pubs, timeout_s)


def play(bag: str, topics: Iterable[str] | None = None, opts: PlaybackOptions | None = None,
         *, delay_s: float = 0.0, wait_for_subscribers_s: float | None = None,
         wait_for_all_acked_s: float = 10.0, ros_args: list[str] | None = None,
         log: Callable[[str], None] | None = None) -> PlaybackResult:
    """Open ``bag`` and play it until the end (or forever with loop) or SIGINT/SIGTERM
    (handled here: the player stops between two messages and exits cleanly). Before its
    publishers go away it waits up to ``wait_for_all_acked_s`` s (0: not at all) until
    every reliable subscriber acknowledged every message."""
    opts = opts or PlaybackOptions()
    if not delay_s >= 0:
        raise BagError(f"delay must be >= 0 s, got {delay_s!r}")
    log = log or (lambda text: print(text, file=sys.stderr, flush=True))
    reader = BagReader(bag)
    if reader.start_ns is None or reader.end_ns is None:
        raise BagError(f"nothing to play: bag {bag} holds no messages")
    if opts.start_offset_s * 1e9 > reader.end_ns - reader.start_ns:
        raise BagError(f"nothing to play: the start offset {opts.start_offset_s:g} s is beyond "
                       f"the end of bag {bag} ({(reader.end_ns - reader.start_ns) / 1e9:g} s)")
    if reader.recovered:
        log(f"warning: {bag} was not closed properly; playing what the recovery scan found")
    unread = unread_custom_data(reader, bag)
    if unread:
        log(f"warning: {unread}")
    with stop_on_signals() as stop_request:
        stop_request.enter_running()
        node: PlayerNode | None = None
        executor: SingleThreadedExecutor | None = None
        services: SpinThread | None = None
        try:
            rclpy.init(args=list(ros_args or []), signal_handler_options=SignalHandlerOptions.NO)
            node = PlayerNode(reader, opts, topics, log=log)
            executor = SingleThreadedExecutor()
            executor.add_node(node)
            services = SpinThread(executor, "player_services", poll_s=1.0).start()   # stop() wakes it
            log(f"playing {bag}: {clip(', '.join(node.publishers_by_topic) or '/clock only', 200)} "
                "(stop with Ctrl-C)")

            def stop() -> bool:
                return stop_request.is_set() or not rclpy.ok()

            if wait_for_subscribers_s is not None and not node.wait_for_subscribers(
                    wait_for_subscribers_s, stop):
                log(f"warning: not every topic had a subscriber after {wait_for_subscribers_s} s")
            stop_request.wait(delay_s)
            result = node.play(should_stop=stop)
            result.stopped = result.stopped or stop()
            # asked to stop: go now (a subscriber that never acknowledges must not hold us)
            if wait_for_all_acked_s > 0 and not result.stopped:
                line = report(node.wait_for_all_acked(wait_for_all_acked_s), wait_for_all_acked_s)
                if line is not None:
                    log(line)
        finally:
            if services is not None:
                services.stop()          # joined before the executor and the node go
            if executor is not None:
                executor.shutdown()
            if node is not None:
                node.destroy_node()  # type: ignore[no-untyped-call]  # rclpy's, on a subclass: not excluded by name
            rclpy.try_shutdown()
    log("played " + ", ".join(f"{t} {n}" for t, n in result.published.items())
        + (f", /clock {result.clock_ticks} ticks" if opts.clock_hz else "")
        + (" (stopped)" if result.stopped else ""))
    return result
