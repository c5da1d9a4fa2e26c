"""Small real publishers of the suite's topics, standing in for the simulator node.

The lead's simulator node is not merged yet; these publish the same topics and types
(``joint_states``, ``end_effector``, ``mechanism_state``, ``markers``, ``/clock``) from
a kinematic path of the class-2 mechanism (node positions and member lengths from
:mod:`tensegrity_core.class2.geometry`), so the bags look like the suite's. Every message
is a pure function of its topic and index (:func:`make_message`), so a test can rebuild
exactly what was published and compare it with what a bag holds.

Run as a process (used by the benchmarks)::

    python -m tests.bags.suite_publishers --rate joint_states=1000 --rate markers=30 \
        --duration 5 --wait-subscribers 10

prints one JSON line ``{"published": {topic: count}}`` when done.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np
import rclpy
from builtin_interfaces.msg import Duration as DurationMsg
from geometry_msgs.msg import Point, PointStamped
from rclpy.context import Context
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import ColorRGBA
from tensegrity_msgs.msg import MechanismState
from visualization_msgs.msg import Marker, MarkerArray

from tensegrity_core.class2.geometry import MEMBERS, NODE_NAMES, member_lengths, node_positions
from tensegrity_core.class2.params import Class2Params
from tensegrity_ros.rclpy_utils.matching import wait_for_matches

PARAMS = Class2Params()
STAMP0_NS = 1_700_000_000_000_000_000   # header stamp of message 0 of every topic
DEFAULT_RATES = {"joint_states": 100.0, "end_effector": 100.0, "mechanism_state": 50.0,
                 "markers": 10.0, "/clock": 100.0}
TYPES = {"joint_states": JointState, "end_effector": PointStamped,
         "mechanism_state": MechanismState, "markers": MarkerArray, "/clock": Clock}
TYPE_NAMES = {"joint_states": "sensor_msgs/msg/JointState",
              "end_effector": "geometry_msgs/msg/PointStamped",
              "mechanism_state": "tensegrity_msgs/msg/MechanismState",
              "markers": "visualization_msgs/msg/MarkerArray",
              "/clock": "rosgraph_msgs/msg/Clock"}


def wavy_path(t: float) -> tuple[np.ndarray, np.ndarray]:
    """A smooth path inside the workspace: (q, qdot) at time t [s], q = (rho1, rho2, beta)."""
    q = np.array([0.6 + 0.2 * math.sin(0.7 * t), 0.5 + 0.2 * math.cos(0.5 * t),
                  0.8 + 0.3 * math.sin(0.9 * t)])
    qdot = np.array([0.14 * math.cos(0.7 * t), -0.1 * math.sin(0.5 * t),
                     0.27 * math.cos(0.9 * t)])
    return q, qdot


def _stamp(msg, t_ns: int, frame: str = "base") -> None:
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t_ns, 1_000_000_000)
    msg.header.frame_id = frame


def joint_state(t_ns: int, q, qdot) -> JointState:
    msg = JointState()
    _stamp(msg, t_ns, "")
    msg.name = ["rho1", "rho2", "beta"]
    msg.position = [float(v) for v in q]
    msg.velocity = [float(v) for v in qdot]
    return msg


def end_effector(t_ns: int, q) -> PointStamped:
    d = node_positions(q, PARAMS)[3]
    msg = PointStamped()
    _stamp(msg, t_ns)
    msg.point = Point(x=float(d[0]), y=float(d[1]), z=0.0)
    return msg


def mechanism_state(t_ns: int, q, qdot) -> MechanismState:
    nodes = node_positions(q, PARAMS)
    msg = MechanismState()
    _stamp(msg, t_ns)
    msg.q = [float(v) for v in q]
    msg.qdot = [float(v) for v in qdot]
    msg.actuator_force = [0.5, 0.25]
    msg.node_names = list(NODE_NAMES)
    msg.nodes = [Point(x=float(x), y=float(y), z=0.0) for x, y in nodes]
    msg.member_names = [m.label for m in MEMBERS]
    msg.member_lengths = [float(v) for v in member_lengths(q, PARAMS)]
    msg.member_forces = [float(v) for v in 0.5 * member_lengths(q, PARAMS)]
    msg.end_effector = Point(x=float(nodes[3][0]), y=float(nodes[3][1]), z=0.0)
    msg.potential_energy = float(np.sum(member_lengths(q, PARAMS) ** 2))
    msg.kinetic_energy = float(np.sum(qdot ** 2))
    msg.folded = bool(min(q[0], q[1]) <= 0.0)
    return msg


def markers(t_ns: int, q) -> MarkerArray:
    nodes = node_positions(q, PARAMS)
    members = Marker()
    _stamp(members, t_ns)
    members.ns, members.id, members.type = "members", 0, Marker.LINE_LIST
    members.pose.orientation.w = 1.0
    members.scale.x = 0.02
    members.color = ColorRGBA(r=0.25, g=0.5, b=1.0, a=1.0)   # float32-exact values
    for m in MEMBERS:
        i, j = m.nodes
        members.points += [Point(x=float(nodes[i][0]), y=float(nodes[i][1])),
                           Point(x=float(nodes[j][0]), y=float(nodes[j][1]))]
    joints = Marker()
    _stamp(joints, t_ns)
    joints.ns, joints.id, joints.type = "nodes", 1, Marker.SPHERE_LIST
    joints.pose.orientation.w = 1.0
    joints.scale.x = joints.scale.y = joints.scale.z = 0.05
    joints.color = ColorRGBA(r=1.0, g=0.5, b=0.0, a=1.0)
    joints.points = [Point(x=float(x), y=float(y)) for x, y in nodes]
    joints.lifetime = DurationMsg(sec=0, nanosec=500_000_000)
    label = Marker()
    _stamp(label, t_ns)
    label.ns, label.id, label.type = "label", 2, Marker.TEXT_VIEW_FACING
    label.pose.position = Point(x=float(nodes[3][0]), y=float(nodes[3][1]), z=0.1)
    label.pose.orientation.w = 1.0
    label.scale.z = 0.05
    label.color = ColorRGBA(r=1.0, g=1.0, b=1.0, a=1.0)
    label.text = f"D ({nodes[3][0]:.3f}, {nodes[3][1]:.3f})"
    return MarkerArray(markers=[members, joints, label])


def make_message(topic: str, index: int, rate_hz: float, path=wavy_path):
    """Message number ``index`` of ``topic`` published at ``rate_hz`` while the mechanism
    follows ``path`` (t -> (q, qdot)); a pure function of its arguments."""
    t_ns = STAMP0_NS + round(index * 1e9 / rate_hz)
    q, qdot = path((t_ns - STAMP0_NS) / 1e9)
    if topic == "joint_states":
        return joint_state(t_ns, q, qdot)
    if topic == "end_effector":
        return end_effector(t_ns, q)
    if topic == "mechanism_state":
        return mechanism_state(t_ns, q, qdot)
    if topic == "markers":
        return markers(t_ns, q)
    if topic == "/clock":
        msg = Clock()
        msg.clock.sec, msg.clock.nanosec = divmod(t_ns, 1_000_000_000)
        return msg
    raise ValueError(f"unknown suite topic {topic!r}")


class SuitePublisher(Node):
    """Publishes the suite's topics at given rates (Hz); keeps count of what it published."""

    def __init__(self, rates: dict[str, float], *, context: Context | None = None,
                 depth: int = 1000, name: str = "suite_publisher", path=wavy_path):
        super().__init__(name, context=context)
        self.rates = dict(rates)
        self.path = path
        self.pubs = {t: self.create_publisher(TYPES[t], t, QoSProfile(depth=depth))
                     for t in self.rates}
        self.published = {t: 0 for t in self.rates}

    def wait_for_subscribers(self, timeout_s: float) -> bool:
        return wait_for_matches(self.pubs.values(), 1, timeout_s)

    def run(self, *, counts: dict[str, int] | None = None, duration_s: float | None = None
            ) -> dict[str, int]:
        """Publish message k of each topic at k / rate s after start, until ``counts`` (per
        topic) or ``duration_s`` is reached. Messages are built before their due time."""
        if counts is None:
            counts = {t: int(duration_s * r) for t, r in self.rates.items()}
        queue = sorted((k / self.rates[t], t, k) for t in counts for k in range(counts[t]))
        start = time.monotonic()
        for due, topic, k in queue:
            msg = make_message(topic, k, self.rates[topic], self.path)
            delay = start + due - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            self.pubs[topic].publish(msg)
            self.published[topic] += 1
        return dict(self.published)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tests.bags.suite_publishers")
    ap.add_argument("--rate", action="append", default=[], metavar="TOPIC=HZ")
    ap.add_argument("--duration", type=float, required=True, metavar="S")
    ap.add_argument("--wait-subscribers", type=float, default=10.0, metavar="S")
    args = ap.parse_args(argv)
    rates = dict(DEFAULT_RATES)
    for item in args.rate:
        topic, _, hz = item.partition("=")
        rates[topic] = float(hz)
    rates = {t: r for t, r in rates.items() if r > 0}
    rclpy.init(args=[])
    node = SuitePublisher(rates)
    try:
        if not node.wait_for_subscribers(args.wait_subscribers):
            print(json.dumps({"error": "no subscriber"}), flush=True)
            return 1
        published = node.run(duration_s=args.duration)
        time.sleep(0.5)  # let reliable retransmissions finish before the writers go away
        print(json.dumps({"published": published}), flush=True)
        return 0
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
