"""The player: real publishers over DDS, checked by real subscribers.

A bag is recorded once per module by the real recorder from the suite publishers; the
tests replay it with ``tensegrity play`` (a subprocess) or with :class:`PlayerNode` driven
by a virtual clock (to check the schedule exactly without timed assertions), and compare
what arrives with what was published when recording.
"""

from __future__ import annotations

import signal
import time
from pathlib import Path

import pytest
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile

from tensegrity_ros.bag.player import PlayerNode
from tensegrity_ros.bag.reader import BagReader
from tensegrity_ros.bag.recorder import message_class
from tensegrity_ros.bag.schedule import PlaybackOptions
from tests.bags.compare import plain
from tests.bags.conftest import Proc, rosbags_cdr_samples
from tests.bags.suite_publishers import TYPE_NAMES, SuitePublisher, make_message
from tests.ros_support import open_context

pytestmark = pytest.mark.ros

RATES = {"joint_states": 200.0, "end_effector": 100.0, "mechanism_state": 50.0,
         "markers": 20.0, "/clock": 100.0}
COUNTS = {"joint_states": 100, "end_effector": 50, "mechanism_state": 25, "markers": 10,
          "/clock": 50}


def absolute(topic: str) -> str:
    return topic if topic.startswith("/") else f"/{topic}"


@pytest.fixture(scope="module")
def recorded_bag(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("play") / "source"
    rec = Proc(["record", "-o", str(folder)], folder.parent / "record.log")
    try:
        with open_context() as ctx:
            rec.wait_for("recording to")
            node = SuitePublisher(RATES, context=ctx, name="source_publisher")
            assert node.wait_for_subscribers(60)
            node.run(counts=COUNTS)
            for pub in node.pubs.values():
                assert pub.wait_for_all_acked(Duration(seconds=30))
            assert rec.stop() == 0
    finally:
        rec.kill()
    return folder


class Collector(Node):
    """Subscribes to topics and keeps every message received, in order."""

    def __init__(self, context, topics: dict[str, str], **kwargs):
        super().__init__("collector", context=context, **kwargs)
        self.got = {t: [] for t in topics}
        for topic, type_name in topics.items():
            self.create_subscription(message_class(type_name), topic,
                                     lambda msg, t=topic: self.got[t].append(msg),
                                     QoSProfile(depth=1000))

    def spin_until(self, done, timeout: float = 60.0) -> None:
        executor = SingleThreadedExecutor(context=self.context)
        executor.add_node(self)
        deadline = time.monotonic() + timeout
        while not done():
            assert time.monotonic() < deadline, {t: len(v) for t, v in self.got.items()}
            executor.spin_once(timeout_sec=0.05)
        executor.remove_node(self)


def all_topics() -> dict[str, str]:
    return {absolute(t): name for t, name in TYPE_NAMES.items()}


def expected(topic: str, indices) -> list:
    return [plain(make_message(topic, k, RATES[topic])) for k in indices]


def test_replay_delivers_every_message_in_order(recorded_bag, ros_context, cli):
    sink = Collector(ros_context, all_topics())
    play = cli("play", str(recorded_bag), "--wait-for-subscribers", "60")
    sink.spin_until(lambda: all(len(sink.got[absolute(t)]) >= n for t, n in COUNTS.items()))
    assert play.popen.wait(60) == 0, play.stderr()
    for topic, n in COUNTS.items():
        assert [plain(m) for m in sink.got[absolute(topic)]] == expected(topic, range(n)), topic
    summary = next(line for line in play.stderr().splitlines() if line.startswith("played "))
    assert "/clock 50" in summary.removeprefix("played ").split(", ")   # in the bag's topic order


def test_topic_filter_and_start_offset(recorded_bag, ros_context, cli):
    reader = BagReader(recorded_bag)
    t0 = reader.start_ns + 250_000_000
    want = {}
    for topic in ("joint_states", "end_effector"):
        times = [m.log_time_ns for m in reader.messages([absolute(topic)])]
        want[topic] = [k for k, t in enumerate(times) if t >= t0]
    sink = Collector(ros_context, all_topics())
    play = cli("play", str(recorded_bag), "--topics", "joint_states", "/end_effector",
               "--start-offset", "0.25", "--wait-for-subscribers", "60")
    # spun meanwhile: the player waits for the sink's answer (its readers matched) before it plays
    sink.spin_until(lambda: all(len(sink.got[absolute(t)]) >= len(v) for t, v in want.items()))
    assert play.popen.wait(60) == 0, play.stderr()
    for topic, indices in want.items():
        assert 0 < len(indices) < COUNTS[topic]
        assert [plain(m) for m in sink.got[absolute(topic)]] == expected(topic, indices)
    for other in ("/markers", "/mechanism_state", "/clock"):
        assert sink.got[other] == []


class _Timed:
    """Wraps a real publisher; notes the virtual time of each publish."""

    def __init__(self, pub, log, clock, topic):
        self.pub, self.log, self.clock, self.topic = pub, log, clock, topic

    def publish(self, msg):
        # the player reuses its Clock message: note the time it carries now
        noted = msg if isinstance(msg, bytes) else msg.clock.sec * 10**9 + msg.clock.nanosec
        self.log.append((self.clock[0], self.topic, noted))
        self.pub.publish(msg)


@pytest.mark.parametrize("rate", [2.0, 0.5])
def test_schedule_rate_offset_and_clock_on_a_virtual_clock(recorded_bag, ros_context, rate):
    """Every message leaves at (t - t0)/rate after start, /clock ticks at k/hz carrying
    t0 + rate*k/hz, a tick precedes a message due at the same instant."""
    reader = BagReader(recorded_bag)
    opts = PlaybackOptions(rate=rate, start_offset_s=0.1, clock_hz=50.0)
    player = PlayerNode(reader, opts, ["joint_states", "markers"], log=lambda _: None,
                        node_name="virtual_player", context=ros_context)
    virtual = [10_000]
    log: list = []
    for topic, pub in list(player.publishers_by_topic.items()):
        player.publishers_by_topic[topic] = _Timed(pub, log, virtual, topic)
    player.clock_publisher = _Timed(player.clock_publisher, log, virtual, "/clock")

    def wait(deadline):
        assert deadline >= virtual[0]          # the player never waits into the past
        virtual[0] = deadline

    result = player.play(now_ns=lambda: virtual[0], wait=wait)
    player.destroy_node()
    t0 = reader.start_ns + 100_000_000
    msgs = [m for m in reader.messages(["/joint_states", "/markers"]) if m.log_time_ns >= t0]
    sent = [(t, topic, data) for t, topic, data in log if topic != "/clock"]
    assert [(topic, data) for _, topic, data in sent] == [(m.topic, m.data) for m in msgs]
    assert [t - 10_000 for t, _, _ in sent] == [round((m.log_time_ns - t0) / rate) for m in msgs]
    ticks = [(t - 10_000, ns) for t, topic, ns in log if topic == "/clock"]
    end = reader.end_ns
    regular = [(round(k * 1e9 / 50.0), t0 + round(rate * k * 1e9 / 50.0))
               for k in range(len(ticks)) if t0 + round(rate * k * 1e9 / 50.0) <= end]
    assert ticks[:len(regular)] == regular
    assert ticks[-1] == (round((end - t0) / rate), end)
    assert result.clock_ticks == len(ticks) and result.published == {
        "/joint_states": sum(m.topic == "/joint_states" for m in msgs),
        "/markers": sum(m.topic == "/markers" for m in msgs)}
    first_msg = log.index(sent[0])
    assert log[first_msg - 1][1] == "/clock" and log[first_msg - 1][0] <= sent[0][0]


def test_clock_drives_a_use_sim_time_node(recorded_bag, ros_context, cli):
    """With --clock, a node using sim time reads the recorded times while messages arrive;
    the recorded /clock topic is not replayed on top."""
    reader = BagReader(recorded_bag)
    # one reader of /joint_states (the player waits for a subscriber, not for each of several)
    sink = Collector(ros_context, {"/clock": "rosgraph_msgs/msg/Clock"},
                     parameter_overrides=[Parameter("use_sim_time", value=True)])
    seen_at: list[int] = []
    sink.create_subscription(message_class(TYPE_NAMES["joint_states"]), "/joint_states",
                             lambda _m: seen_at.append(sink.get_clock().now().nanoseconds),
                             QoSProfile(depth=1000))
    play = cli("play", str(recorded_bag), "--topics", "joint_states", "/clock", "--clock", "200",
               "--wait-for-subscribers", "60")
    sink.spin_until(lambda: len(seen_at) >= COUNTS["joint_states"] and play.popen.poll() is not None)
    assert play.popen.returncode == 0, play.stderr()
    sink.spin_until(lambda: any(c.clock.sec * 10**9 + c.clock.nanosec == reader.end_ns
                                for c in sink.got["/clock"]))
    clock = [c.clock.sec * 10**9 + c.clock.nanosec for c in sink.got["/clock"]]
    assert clock == sorted(clock)
    assert clock[0] == reader.start_ns and clock[-1] == reader.end_ns
    # the recorded /clock carried 1.7e18-ns stamps; none of those was replayed
    assert all(reader.start_ns <= c <= reader.end_ns for c in clock)
    assert len(seen_at) == COUNTS["joint_states"]
    # DDS keeps the order within a topic, not across topics: the first joint states may reach
    # the node before the first /clock does, and read the unset sim time 0. From the first
    # tick on every message reads a recorded time.
    ticked = [t for t in seen_at if t != 0]
    assert seen_at[len(seen_at) - len(ticked):] == ticked, "a message read time 0 after a tick"
    assert len(ticked) >= len(seen_at) // 2
    assert all(reader.start_ns <= t <= reader.end_ns for t in ticked)
    assert ticked == sorted(ticked) and ticked[-1] > ticked[0]
    assert "is not replayed" in play.stderr()


def test_loop_replays_the_bag_again_and_refuses_parameter_requests_of_wrong_types(recorded_bag, ros_context, cli):
    """``--loop`` starts the bag again after its end; ``ros2 param set`` on the looping player
    is answered (refused, with a reason) while it plays, its parameters unchanged and the
    replay going on (one player for both: the same command)."""
    from rcl_interfaces.msg import Parameter as ParameterMsg
    from rcl_interfaces.msg import ParameterType, ParameterValue
    from rcl_interfaces.srv import GetParameters, SetParameters

    sink = Collector(ros_context, {"/end_effector": TYPE_NAMES["end_effector"]})
    got = sink.got["/end_effector"]
    n = COUNTS["end_effector"]
    play = cli("play", str(recorded_bag), "--topics", "end_effector", "--loop", "--rate", "4",
               "--wait-for-subscribers", "60")
    sink.spin_until(lambda: len(got) >= 1)
    setter = sink.create_client(SetParameters, "/tensegrity_player/set_parameters")
    getter = sink.create_client(GetParameters, "/tensegrity_player/get_parameters")

    def call(client, request):
        future = client.call_async(request)
        sink.spin_until(future.done)
        return future.result()

    hostile = [ParameterMsg(name="use_sim_time", value=ParameterValue(type=ParameterType.PARAMETER_STRING,
                                                                        string_value="yes")),
               ParameterMsg(name="use_sim_time", value=ParameterValue(type=200))]
    results = call(setter, SetParameters.Request(parameters=hostile)).results
    assert [r.successful for r in results] == [False, False]
    assert "Wrong parameter type" in results[0].reason          # rclpy's own refusal
    assert results[1].reason == ("parameter 'use_sim_time': value type 200 is not a parameter type "
                                 "(rcl_interfaces/ParameterType: 0-9)")
    (value,) = call(getter, GetParameters.Request(names=["use_sim_time"])).values
    assert (value.type, value.bool_value) == (ParameterType.PARAMETER_BOOL, False)
    seen = len(got)
    # a whole loop more after the requests, and the bag twice and its first message a third time
    sink.spin_until(lambda: len(got) >= max(seen + n, 2 * n + 1))
    assert play.stop(signal.SIGINT) == 0, play.stderr()     # stopped on request: a clean exit
    assert "Traceback" not in play.stderr()
    received = [plain(m) for m in got]
    assert received[:2 * n] == expected("end_effector", range(n)) * 2
    assert received[2 * n] == expected("end_effector", [0])[0]


def test_bag_written_by_rosbags_plays(tmp_path, ros_context, cli):
    """A rosbag2 MCAP bag from another writer (rosbags) replays with its content."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    samples = rosbags_cdr_samples(30)
    folder = tmp_path / "from_rosbags"
    with Writer(folder, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {}
        for topic, type_name, t, data, _ in samples:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, type_name, typestore=store)
            writer.write(connections[topic], t, data)
    sink = Collector(ros_context, {"/joint_states": "sensor_msgs/msg/JointState",
                                   "/end_effector": "geometry_msgs/msg/PointStamped"})
    play = cli("play", str(folder), "--wait-for-subscribers", "60")
    sink.spin_until(lambda: all(len(v) >= 30 for v in sink.got.values()))
    assert play.popen.wait(60) == 0, play.stderr()
    assert [list(m.position) for m in sink.got["/joint_states"]] == \
        [v for topic, *_, v in samples if topic == "/joint_states"]
    assert [(m.point.x, m.point.y, m.point.z) for m in sink.got["/end_effector"]] == \
        [v for topic, *_, v in samples if topic == "/end_effector"]
    assert [m.header.stamp.nanosec for m in sink.got["/end_effector"]] == \
        [k * 10_000_000 for k in range(30)]


def test_the_player_imports_without_the_simulator():
    """`tensegrity play` reads a bag's custom_data, never a scene: the simulator package (about
    1 s of CPU to import, paid by every play) stays out of the player's process."""
    import subprocess
    import sys

    probe = "import sys; import tensegrity_ros.bag.player; print('tensegrity_core.sim' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True, timeout=120)
    assert out.stdout.split() == ["False"]
