"""A running `tensegrity node controller` fed joint states no simulator of its scene would send
(a rogue publisher on ``joint_states``): it answers none of them, logs why, stays up, and
answers the next usable state as before (real node, DDS on loopback).

The folded mechanism, rho = (0, 0), has no stabilising LQR gain: scipy's Riccati solver
raised LinAlgError out of the state callback, which ended the node with a traceback.
"""

from __future__ import annotations

import math
import time

import pytest

from tensegrity_ros.rclpy_utils.futures import spin_until_done
from tests.process_groups import exited
from tests.ros_support import Proc, heard_by, probe

pytestmark = pytest.mark.ros

NS = "/hostile_states"
NAMES = ["rho1", "rho2", "beta"]
#: States the mechanism cannot hold (rho1, rho2, beta [m, m, rad]; at rest).
UNHOLDABLE = [
    (0.0, 0.0, math.pi / 2),          # folded: no stabilising gain
    (5.0, 5.0, 0.0),                  # beyond the strut length
    (1.0, 1.0, 0.0),                  # on lambda1 = 0
    (-1.0, 0.5, 3.0),                 # a negative length
]
#: States without finite rho1, rho2, beta positions and velocities (names, positions, velocities).
UNREADABLE = [
    (NAMES, [math.nan, 0.7, 0.8], [0.0, 0.0, 0.0]),
    (NAMES, [0.7, 0.7, 0.8], [0.0, math.inf, 0.0]),
    (["rho1", "rho2"], [0.7, 0.7], [0.0, 0.0]),
    (NAMES, [0.7, 0.7], [0.0, 0.0, 0.0]),
]


def test_unusable_joint_states_get_no_answer_and_the_next_usable_one_does(tmp_path):
    """Each unholdable state comes after a usable one, stamped earlier: the controller takes it
    for a reset (its log says so: the event waited for), then tries to hold it and refuses; the
    next usable state is held and answered. The unreadable ones come in a burst before a last
    usable state: only that one is answered."""
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState
    from tensegrity_msgs.msg import ActuatorForces

    from tensegrity_core.class2 import PAPER_PARAMS, equilibrium_beta
    from tensegrity_ros.rclpy_utils.matching import wait_for_matches

    proc = Proc(["node", "controller", "--ros-args", "-r", f"__ns:={NS}"], tmp_path / "controller.log")
    try:
        with probe("hostile_states_probe") as client_probe:
            node, executor = client_probe.node, client_probe.executor
            answers: list = []
            node.create_subscription(ActuatorForces, f"{NS}/actuator_forces", answers.append, QoSProfile(depth=100))
            pub = node.create_publisher(JointState, f"{NS}/joint_states", QoSProfile(depth=100))
            proc.wait_for("controller ready", timeout=120)
            assert wait_for_matches([pub], 1, 120, poll=lambda s: executor.spin_once(timeout_sec=s)), proc.stderr()
            # each state is sent once: the controller's reader must have matched ours first
            heard_by(node, [f"{NS}/tensegrity_controller"], lambda f, t: spin_until_done(executor, f, t))
            # the answers must not be lost: the controller's publisher has matched ours first
            deadline = time.monotonic() + 120
            while node.count_publishers(f"{NS}/actuator_forces") < 1:
                assert time.monotonic() < deadline, proc.stderr()
                executor.spin_once(timeout_sec=0.1)

            def send(sec, names, positions, velocities):
                msg = JointState(name=names, position=positions, velocity=velocities, effort=[0.0] * len(positions))
                msg.header.stamp.sec = sec
                pub.publish(msg)

            beta = float(equilibrium_beta(0.7, 0.7, PAPER_PARAMS))

            def usable(sec):
                send(sec, NAMES, [0.7, 0.7, beta], [0.0, 0.0, 0.0])
                deadline = time.monotonic() + 120
                while not any(a.header.stamp.sec == sec for a in answers):
                    assert time.monotonic() < deadline and not exited(proc.popen), proc.stderr()
                    executor.spin_once(timeout_sec=0.1)

            usable(1000)
            for k, q in enumerate(UNHOLDABLE, start=1):
                send(k, NAMES, list(q), [0.0, 0.0, 0.0])
                proc.wait_for(f"its time went back from {1000 + k - 1:.3f} s to {k:.3f} s", timeout=120)
                usable(1000 + k)
            for names, positions, velocities in UNREADABLE:
                send(2000, names, positions, velocities)
            usable(3000)
            # one writer, reliable, in order: an answer to any other state would be among them
            assert [a.header.stamp.sec for a in answers] == [1000 + k for k in range(len(UNHOLDABLE) + 1)] + [3000]
            assert all(math.isfinite(f) and abs(f) <= 5.0 for a in answers for f in a.force)
            assert not exited(proc.popen)
            log = proc.stderr()
            assert "Traceback" not in log
            assert "cannot hold the measured configuration: no stabilising feedback gain at rho = (0, 0) m" in log
    finally:
        proc.stop()
