"""The recorder as a real subprocess (``tensegrity record``) against real publishers.

Every bag is opened with mcap-ros2-support and with rosbags, and every message is compared
with the message the test published (rebuilt from its index by ``make_message``): content,
count and order per topic. Stops are real signals sent to the recorder process.
"""

from __future__ import annotations

import signal
import time

import pytest
from geometry_msgs.msg import PointStamped
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState

from tensegrity_ros.bag.metadata import read_metadata
from tensegrity_ros.bag.reader import BagReader
from tensegrity_ros.bag.recorder import message_class
from tensegrity_ros.bag.repair import repair_bag
from tensegrity_ros.rclpy_utils.matching import wait_for_matches
from tests.bags.compare import plain, read_with_mcap_ros2, read_with_rosbags
from tests.bags.conftest import run_cli_here
from tests.bags.suite_publishers import TYPE_NAMES, SuitePublisher, make_message

pytestmark = pytest.mark.ros

RATES = {"joint_states": 400.0, "end_effector": 100.0, "mechanism_state": 50.0,
         "markers": 20.0, "/clock": 100.0}
COUNTS = {"joint_states": 200, "end_effector": 50, "mechanism_state": 25, "markers": 10,
          "/clock": 50}


def absolute(topic: str, ns: str = "") -> str:
    return topic if topic.startswith("/") else f"{ns}/{topic}"


def publish_all(ros_context, counts=COUNTS, rates=RATES):
    node = SuitePublisher(rates, context=ros_context, name="test_publisher")
    assert node.wait_for_subscribers(60), "the recorder never subscribed to every topic"
    published = node.run(counts=counts)
    for pub in node.pubs.values():
        assert pub.wait_for_all_acked(Duration(seconds=30))
    return node, published


def expected_plain(topic: str, count: int, rate: float) -> list:
    return [plain(make_message(topic, k, rate)) for k in range(count)]


def check_bag_content(folder, counts, rates=RATES, ns: str = ""):
    """Both independent readers and our reader return exactly what was published."""
    by_mcap = read_with_mcap_ros2(folder)
    by_rosbags = read_with_rosbags(folder)
    ours = {}
    for m in BagReader(folder).messages():
        ours.setdefault(m.topic, []).append(m)
    for topic, count in counts.items():
        name = absolute(topic, ns)
        expected = expected_plain(topic, count, rates[topic])
        assert [p for _, _, p in by_mcap.get(name, [])] == expected, f"mcap-ros2-support {name}"
        assert [p for _, p in by_rosbags.get(name, [])] == expected, f"rosbags {name}"
        cls = message_class(TYPE_NAMES[topic])
        assert [deserialize_message(m.data, cls) for m in ours[name]] == \
            [make_message(topic, k, rates[topic]) for k in range(count)], f"rclpy {name}"
        # log time = receive time, publish time = sender's time: sent before received
        assert all(p <= log for log, p, _ in by_mcap[name])
    assert set(by_mcap) == {absolute(t, ns) for t in counts}
    return by_mcap


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_signal_finishes_bag_with_every_message(cli, ros_context, tmp_path, sig):
    folder = tmp_path / "run"
    rec = cli("record", "-o", str(folder))
    rec.wait_for("recording to")
    _, published = publish_all(ros_context)
    assert published == COUNTS
    assert rec.stop(sig) == 0
    check_bag_content(folder, COUNTS)
    meta = read_metadata(folder)
    assert meta.version == 9 and meta.storage_identifier == "mcap"
    assert {t.name: t.message_count for t in meta.topics} == \
        {absolute(t): n for t, n in COUNTS.items()}
    assert meta.message_count == sum(COUNTS.values())
    assert f"recorded {sum(COUNTS.values())} messages" in rec.stderr()
    types = {absolute(t): name for t, name in TYPE_NAMES.items()}
    for t in meta.topics:
        assert t.type == types[t.name]
        assert t.type_description_hash.startswith("RIHS01_")
        assert [p["reliability"] for p in t.offered_qos_profiles] == ["reliable"]
    reader = BagReader(folder)
    assert not reader.recovered
    assert meta.starting_time_ns == reader.start_ns
    assert meta.duration_ns == reader.end_ns - reader.start_ns


def test_named_topics_only_and_namespace(cli, ros_context, tmp_path):
    """Positional topics are recorded and nothing else; relative names follow __ns."""
    folder = tmp_path / "ns"
    rec = cli("record", "joint_states", "end_effector", "-o", str(folder),
              "--ros-args", "-r", "__ns:=/robot1")
    rec.wait_for("recording to")
    node = Node("ns_publisher", namespace="/robot1", context=ros_context)
    pubs = {"joint_states": node.create_publisher(JointState, "joint_states", QoSProfile(depth=100)),
            "end_effector": node.create_publisher(PointStamped, "end_effector", QoSProfile(depth=100)),
            "markers": node.create_publisher(message_class(TYPE_NAMES["markers"]), "markers", 10)}
    assert wait_for_matches([pubs["joint_states"], pubs["end_effector"]], 1, 60)
    for k in range(20):
        pubs["joint_states"].publish(make_message("joint_states", k, RATES["joint_states"]))
        pubs["end_effector"].publish(make_message("end_effector", k, RATES["end_effector"]))
        pubs["markers"].publish(make_message("markers", k, RATES["markers"]))
    for name in ("joint_states", "end_effector"):
        assert pubs[name].wait_for_all_acked(Duration(seconds=30))
    assert pubs["markers"].get_subscription_count() == 0
    assert rec.stop() == 0
    check_bag_content(folder, {"joint_states": 20, "end_effector": 20}, ns="/robot1")


def _recovered_counts(folder):
    counts = {}
    for m in BagReader(folder).messages():
        counts[m.topic] = counts.get(m.topic, 0) + 1
    return counts


def test_sigkill_recovers_every_flushed_chunk(cli, ros_context, tmp_path):
    """Killed after its last flush, the recording loses nothing: repair restores all."""
    folder = tmp_path / "killed"
    rec = cli("record", "-o", str(folder), "--chunk-size", "4096", "--flush-interval", "0.2")
    rec.wait_for("recording to")
    publish_all(ros_context)
    want = {absolute(t): n for t, n in COUNTS.items()}
    deadline = time.monotonic() + 60
    while _recovered_counts(folder) != want:   # wait until the recorder has flushed it all
        assert time.monotonic() < deadline, _recovered_counts(folder)
        time.sleep(0.1)
    rec.popen.send_signal(signal.SIGKILL)
    rec.popen.wait(30)
    assert not (folder / "metadata.yaml").exists()
    assert BagReader(folder).recovered
    done = run_cli_here("bag", "repair", str(folder))       # a real process of it: test_hostile_bags.py
    assert done.returncode == 0, done.stderr
    assert f"recovered {sum(COUNTS.values())} messages" in done.stdout
    check_bag_content(folder, COUNTS)
    meta = read_metadata(folder)
    assert {t.name: t.message_count for t in meta.topics} == want
    assert not BagReader(folder).recovered
    assert (folder / "killed_0.mcap.orig").exists()


def test_sigkill_mid_stream_keeps_a_clean_prefix(cli, ros_context, tmp_path):
    """Killed while messages still flow: what is recovered is, per topic, exactly the first
    n published messages (nothing torn, nothing reordered), and at least what was on disk
    before the kill."""
    folder = tmp_path / "torn"
    rec = cli("record", "-o", str(folder), "--chunk-size", "2048", "--flush-interval", "0.1")
    rec.wait_for("recording to")
    node = SuitePublisher(RATES, context=ros_context, name="torn_publisher")
    assert node.wait_for_subscribers(60)
    node.run(counts={t: n // 2 for t, n in COUNTS.items()})
    deadline = time.monotonic() + 60
    while sum(_recovered_counts(folder).values()) < 100:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    before = sum(_recovered_counts(folder).values())
    rec.popen.send_signal(signal.SIGKILL)
    rec.popen.wait(30)
    result = repair_bag(folder, keep_original=False)
    assert result.rewritten and result.message_count >= before
    by_mcap = read_with_mcap_ros2(folder)
    by_rosbags = read_with_rosbags(folder)
    for topic, rate in RATES.items():
        got = [p for _, _, p in by_mcap.get(absolute(topic), [])]
        assert got == expected_plain(topic, len(got), rate)
        assert [p for _, p in by_rosbags.get(absolute(topic), [])] == got
    assert {t.name: t.message_count for t in read_metadata(folder).topics} == \
        {name: len(v) for name, v in by_mcap.items()} | {
            n: 0 for n in (absolute(t) for t in RATES) if n not in by_mcap}
