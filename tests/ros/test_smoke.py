"""Foundation smoke test: two real nodes in two processes exchange a tensegrity_msgs
message and a service call over DDS on loopback."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.ros_support import probe

pytestmark = pytest.mark.ros


def _discovery_range_seen_by_a_new_process(env_value: str | None, **extra: str) -> str:
    """The range a new process asks for (LOCALHOST also when the suite's loopback profile
    carries it out, see tests/ros/test_loopback.py) and the profile file it uses."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "FASTRTPS_DEFAULT_PROFILES_FILE")}
    if env_value is not None:
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = env_value
    env.update(extra)
    code = (
        "import os; from tensegrity_ros.rclpy_utils.env import discovery_range, require_rclpy; "
        "require_rclpy(); print(discovery_range(), os.environ.get('FASTRTPS_DEFAULT_PROFILES_FILE'))"
    )
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, check=True).stdout.strip()


def test_discovery_defaults_to_localhost_and_a_user_choice_wins():
    from tensegrity_ros.rclpy_utils.env import LOOPBACK_PROFILE

    assert _discovery_range_seen_by_a_new_process(None) == f"LOCALHOST {LOOPBACK_PROFILE}"
    assert _discovery_range_seen_by_a_new_process("SUBNET") == "SUBNET None"
    # a profile of the user's own is respected as it is (the range stays theirs too)
    assert _discovery_range_seen_by_a_new_process(
        None, FASTRTPS_DEFAULT_PROFILES_FILE="/their/profile.xml") == "LOCALHOST /their/profile.xml"


def test_tests_run_in_their_own_domain():
    assert os.environ.get("ROS_DOMAIN_ID", "0") not in {"", "0"}


def test_message_and_service_between_two_processes():
    from tensegrity_msgs.msg import ActuatorForces
    from tensegrity_msgs.srv import SolveIK

    from tensegrity_ros.rclpy_utils.futures import spin_until_done
    from tensegrity_ros.rclpy_utils.matching import wait_for_service

    # a namespace of its own, so nodes of other tests in this domain cannot answer instead
    namespace = f"/smoke_{os.getpid()}"
    peer = subprocess.Popen(
        [sys.executable, str(Path(__file__).with_name("peer_node.py")), "--ros-args", "-r", f"__ns:={namespace}"],
        stdout=subprocess.PIPE, text=True, env=dict(os.environ),
    )
    try:
        with probe("smoke_client", namespace=namespace) as client_probe:
            node, executor = client_probe.node, client_probe.executor
            assert peer.stdout.readline().strip() == "ready"
            got: list[ActuatorForces] = []
            node.create_subscription(ActuatorForces, "pong", got.append, 10)
            pub = node.create_publisher(ActuatorForces, "ping", 10)
            client = node.create_client(SolveIK, "solve_ik")

            assert wait_for_service(client, 20.0), "service never appeared"
            deadline = time.monotonic() + 20.0
            while not got and time.monotonic() < deadline:
                pub.publish(ActuatorForces(name=["f1", "f2"], force=[1.5, -2.0]))
                executor.spin_once(timeout_sec=0.1)
            assert got, "no echo received"
            assert list(got[0].name) == ["f1", "f2"]
            assert list(got[0].force) == [3.0, -4.0]

            future = client.call_async(SolveIK.Request(x=0.25, y=0.5))
            assert spin_until_done(executor, future, 20.0)
            res = future.result()
            assert res is not None and res.success
            assert (res.solutions[0].rho1, res.solutions[0].rho2) == (0.25, 0.5)
    finally:
        peer.terminate()
        peer.wait(timeout=10)
