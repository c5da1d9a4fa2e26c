"""Fixtures of the bag tests (the shared ROS fixtures live in tests/ros_support.py)."""

from __future__ import annotations

import pytest

from tests.ros_support import Proc, cli, ros_context, run_cli, run_cli_here  # noqa: F401  (fixtures and helpers)


def rosbags_cdr_samples(n: int):
    """(topic, type, log_time_ns, CDR bytes, (positions, point)) for n JointState and n
    PointStamped messages, serialized by rosbags (exact CDR, independent of rclpy)."""
    import numpy as np
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    T = store.types
    out = []
    start = 1_700_000_000_000_000_000
    for k in range(n):
        stamp = T["builtin_interfaces/msg/Time"](sec=1_700_000_000, nanosec=k * 10_000_000)
        positions = [0.5 + k / 100, 0.25, 0.1 * k]
        js = T["sensor_msgs/msg/JointState"](
            header=T["std_msgs/msg/Header"](stamp=stamp, frame_id=""),
            name=["rho1", "rho2", "beta"], position=np.array(positions),
            velocity=np.array([], dtype=float), effort=np.array([], dtype=float))
        point = (k / 10, -k / 10, 0.0)
        ps = T["geometry_msgs/msg/PointStamped"](
            header=T["std_msgs/msg/Header"](stamp=stamp, frame_id="base"),
            point=T["geometry_msgs/msg/Point"](x=point[0], y=point[1], z=point[2]))
        t = start + k * 10_000_000
        out.append(("/joint_states", "sensor_msgs/msg/JointState", t,
                    bytes(store.serialize_cdr(js, js.__msgtype__)), positions))
        out.append(("/end_effector", "geometry_msgs/msg/PointStamped", t + 5,
                    bytes(store.serialize_cdr(ps, ps.__msgtype__)), point))
    return out


@pytest.fixture
def small_bag(tmp_path):
    """A bag written by BagWriter with 40 JointState + 40 PointStamped messages."""
    from tensegrity_ros.bag.metadata import TopicInfo
    from tensegrity_ros.bag.writer import BagWriter

    folder = tmp_path / "small"
    samples = rosbags_cdr_samples(40)
    with BagWriter(folder) as w:
        w.add_topic(TopicInfo("/joint_states", "sensor_msgs/msg/JointState"))
        w.add_topic(TopicInfo("/end_effector", "geometry_msgs/msg/PointStamped"))
        for topic, _type, t, data, _values in samples:
            w.write(topic, data, t, t - 1)
    return folder, samples
