"""Fixtures of the bag tests: a private rclpy context, the CLI executable, subprocess runs.

Every test talks over real DDS on loopback (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, set
by the top-level conftest) in the run's own ROS_DOMAIN_ID.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

TENSEGRITY = str(Path(sys.executable).with_name("tensegrity"))


@pytest.fixture
def ros_context():
    """A private rclpy context. At teardown every node still alive in it is destroyed, so
    its endpoints leave the graph before the next test's processes look for matches (a
    lingering subscription would satisfy a player's --wait-for-subscribers)."""
    import gc

    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node

    ctx = Context()
    rclpy.init(args=[], context=ctx)
    yield ctx
    for obj in gc.get_objects():
        if isinstance(obj, Node) and obj.context is ctx:
            obj.destroy_node()
    rclpy.try_shutdown(context=ctx)


class Proc:
    """A CLI subprocess whose stderr is collected in a file."""

    def __init__(self, args: list[str], log: Path):
        self.log = log
        self._f = open(log, "w")
        self.popen = subprocess.Popen([TENSEGRITY, *args], stdout=subprocess.PIPE,
                                      stderr=self._f, text=True, env=dict(os.environ))

    def stderr(self) -> str:
        return self.log.read_text()

    def wait_for(self, text: str, timeout: float = 30.0) -> None:
        deadline = time.monotonic() + timeout
        while text not in self.stderr():
            if self.popen.poll() is not None or time.monotonic() > deadline:
                raise AssertionError(f"never saw {text!r}; stderr:\n{self.stderr()}")
            time.sleep(0.05)

    def stop(self, sig=signal.SIGINT, timeout: float = 60.0) -> int:
        if self.popen.poll() is None:
            self.popen.send_signal(sig)
        try:
            rc = self.popen.wait(timeout)
        finally:
            self._f.close()
        return rc

    def kill(self) -> None:
        if self.popen.poll() is None:
            self.popen.kill()
            self.popen.wait(30)
        self._f.close()


@pytest.fixture
def cli(tmp_path):
    procs: list[Proc] = []

    def start(*args: str, log_name: str = "proc") -> Proc:
        proc = Proc(list(args), tmp_path / f"{log_name}{len(procs)}.log")
        procs.append(proc)
        return proc

    yield start
    for p in procs:
        p.kill()


def run_cli(*args: str, timeout: float = 120.0) -> subprocess.CompletedProcess:
    return subprocess.run([TENSEGRITY, *args], capture_output=True, text=True, timeout=timeout)


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
