"""The sample bags in ``bags/``: each is small, replays completely, and shows its scenario.

What arrives at real subscribers is compared byte for byte with the bag; the scenario
checks use only the scenario's definition (fold: actuators retract monotonically to zero
and the mechanism ends folded with D on the Y axis at (0, L); IK: every end-effector
point lies on the commanded circle).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message

from tensegrity_ros.bag.reader import BagReader
from tensegrity_ros.bag.recorder import message_class
from tests.bags.sample_scenarios import CIRCLE_CENTER, CIRCLE_RADIUS

pytestmark = pytest.mark.ros

BAGS = Path(__file__).resolve().parents[2] / "bags"


def replay(folder: Path, ros_context, cli) -> dict[str, list[bytes]]:
    reader = BagReader(folder)
    topics = {t.name: t for t in reader.topics()}
    node = Node("sample_sink", context=ros_context)
    got = {name: [] for name in topics}
    for name, info in topics.items():
        node.create_subscription(message_class(info.type), name,
                                 lambda data, n=name: got[n].append(data),
                                 QoSProfile(depth=1000), raw=True)
    play = cli("play", str(folder), "--rate", "4", "--wait-for-subscribers", "60")
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(node)
    deadline = time.monotonic() + 120
    while any(len(got[n]) < t.message_count for n, t in topics.items()):
        assert time.monotonic() < deadline, {n: len(v) for n, v in got.items()}
        executor.spin_once(timeout_sec=0.05)
    assert play.popen.wait(60) == 0, play.stderr()
    return got


@pytest.mark.parametrize("name", ["fold", "ik_circle"])
def test_sample_bag_is_small_and_replays_exactly(name, ros_context, cli):
    folder = BAGS / name
    assert sum(p.stat().st_size for p in folder.iterdir()) < 2 * 1024 * 1024
    reader = BagReader(folder)
    assert not reader.recovered
    stored = {}
    for m in reader.messages():
        stored.setdefault(m.topic, []).append(m.data)
    got = replay(folder, ros_context, cli)
    assert got == stored
    js_type = message_class("sensor_msgs/msg/JointState")
    ee_type = message_class("geometry_msgs/msg/PointStamped")
    ms_type = message_class("tensegrity_msgs/msg/MechanismState")
    joints = [deserialize_message(b, js_type) for b in got["/joint_states"]]
    points = [deserialize_message(b, ee_type).point for b in got["/end_effector"]]
    states = [deserialize_message(b, ms_type) for b in got["/mechanism_state"]]
    if name == "fold":
        rho1 = [j.position[0] for j in joints]
        rho2 = [j.position[1] for j in joints]
        assert rho1[0] == pytest.approx(0.7) and rho2[0] == pytest.approx(0.7)
        assert all(b <= a for a, b in zip(rho1, rho1[1:]))
        assert all(b <= a for a, b in zip(rho2, rho2[1:]))
        assert not states[0].folded and states[-1].folded
        assert (points[-1].x, points[-1].y) == pytest.approx((0.0, 1.0), abs=1e-12)
    else:
        radii = [math.hypot(p.x - CIRCLE_CENTER[0], p.y - CIRCLE_CENTER[1]) for p in points]
        assert max(abs(r - CIRCLE_RADIUS) for r in radii) < 1e-9
        angles = sorted(math.atan2(p.y - CIRCLE_CENTER[1], p.x - CIRCLE_CENTER[0])
                        for p in points)
        assert angles[-1] - angles[0] > 1.9 * math.pi        # the whole circle is covered
