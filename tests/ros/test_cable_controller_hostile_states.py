"""A running `tensegrity node cables` with a goal running, fed ``cable_states`` no simulator
sends (a rogue publisher: arrays shorter than the names, the goal's cable missing, a rest
length that is not finite): it ignores them with a warning, stays up, and goes on with the
next usable state (real node, DDS on loopback; this process plays the simulator).

An array shorter than the names raised IndexError, and a missing cable KeyError, out of the
state callback, which ended the node with a traceback.
"""

from __future__ import annotations

import math
import time

import pytest

from tensegrity_ros.rclpy_utils.futures import spin_until_done
from tensegrity_ros.rclpy_utils.matching import wait_for_action_server, wait_for_matches, wait_until_server_heard
from tests.process_groups import exited
from tests.ros_support import FeedbackLog, Proc, heard_by, probe

pytestmark = pytest.mark.ros

NS = "/hostile_cables"
CABLES = ["long1", "long2", "long3"]
ACTION = f"{NS}/tensegrity_cable_controller/follow_joint_trajectory"
#: (names, rest lengths [m], tensions [N]) of cable_states the controller cannot use.
UNUSABLE = [
    (CABLES, [0.9], [1.0, 1.0, 1.0]),                    # fewer rest lengths than names
    (CABLES, [0.9, 0.9, 0.9], []),                       # no tensions
    (["long2", "long3"], [0.9, 0.9], [1.0, 1.0]),         # the goal's cable missing
    (CABLES, [math.nan, 0.9, 0.9], [1.0, 1.0, 1.0]),     # a rest length that is not finite
    (["long1", "long1", "long2"], [0.9, 0.8, 0.9], [1.0, 1.0, 1.0]),   # a cable named twice
]


def test_unusable_cable_states_during_a_goal_are_ignored_and_the_goal_goes_on(tmp_path):
    from builtin_interfaces.msg import Duration
    from control_msgs.action import FollowJointTrajectory
    from rclpy.action import ActionClient
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState
    from tensegrity_msgs.msg import CableCommand, CableStates
    from trajectory_msgs.msg import JointTrajectoryPoint

    proc = Proc(["node", "cables", "--ros-args", "-r", f"__ns:={NS}", "-p", "scene:=table_actuated"],
                tmp_path / "cables.log")
    try:
        with probe("hostile_cables_probe") as client_probe:
            node, executor = client_probe.node, client_probe.executor
            commands: list = []
            node.create_subscription(CableCommand, f"{NS}/cable_commands", commands.append, QoSProfile(depth=100))
            feedback = FeedbackLog(node, FollowJointTrajectory, ACTION)
            joints = node.create_publisher(JointState, f"{NS}/joint_states", QoSProfile(depth=100))
            cables = node.create_publisher(CableStates, f"{NS}/cable_states", QoSProfile(depth=100))
            proc.wait_for("cable controller ready", timeout=120)
            spin = lambda s: executor.spin_once(timeout_sec=s)            # noqa: E731
            assert wait_for_matches([joints, cables], 1, 120, poll=spin), proc.stderr()
            # each state is sent once: the controller's readers must have matched ours first
            heard_by(node, [f"{NS}/tensegrity_cable_controller"], lambda f, t: spin_until_done(executor, f, t))

            def until(done, what):
                deadline = time.monotonic() + 120
                while not done():
                    assert time.monotonic() < deadline and not exited(proc.popen), f"{what}: {proc.stderr()}"
                    executor.spin_once(timeout_sec=0.1)

            until(lambda: node.count_publishers(f"{NS}/cable_commands") >= 1, "the controller's command publisher")

            def states(sec, names=CABLES, rest=(0.9, 0.9, 0.9), tension=(1.0, 1.0, 1.0)):
                msg = CableStates(name=list(names), rest_length=list(rest), tension=list(tension))
                msg.header.stamp.sec = sec
                cables.publish(msg)

            def joint_state(sec):
                msg = JointState(name=CABLES, position=[0.9] * 3, velocity=[0.0] * 3, effort=[1.0] * 3)
                msg.header.stamp.sec = sec
                joints.publish(msg)
                until(lambda: any(c.header.stamp.sec == sec for c in commands), f"the answer to the state at {sec} s")

            states(1)
            joint_state(1)                                    # active: it answers
            action = ActionClient(node, FollowJointTrajectory, ACTION)
            assert wait_for_action_server(node, action, 120)
            assert wait_until_server_heard(node, ACTION, lambda f, t: spin_until_done(executor, f, t), 120)
            goal = FollowJointTrajectory.Goal()
            goal.trajectory.joint_names = ["long1"]
            goal.trajectory.points = [JointTrajectoryPoint(positions=[0.85], time_from_start=Duration(sec=100))]
            sent = action.send_goal_async(goal)
            assert spin_until_done(executor, sent, 120) and sent.result().accepted
            handle = sent.result()

            for k, (names, rest, tension) in enumerate(UNUSABLE, start=2):
                states(k, names, rest, tension)
                states(k)                                     # a usable one after it, on the same topic
                until(lambda k=k: any(f.header.stamp.sec == k for f in feedback.of(handle)), f"feedback at {k} s")
                joint_state(k)
            assert [f.header.stamp.sec for f in feedback.of(handle)] == list(range(2, 2 + len(UNUSABLE)))
            assert all(f.actual.positions.tolist() == [0.9] for f in feedback.of(handle))
            answers = [c for c in commands if c.header.stamp.sec > 1]
            assert [c.header.stamp.sec for c in answers] == list(range(2, 2 + len(UNUSABLE)))
            assert all(list(c.name) == ["long1"] and all(math.isfinite(v) for v in c.rest_length) for c in answers)
            log = proc.stderr()
            assert "Traceback" not in log and not exited(proc.popen)
            assert "cable_states ignored" in log
            cancel = handle.cancel_goal_async()
            assert spin_until_done(executor, cancel, 60)
            action.destroy()
    finally:
        proc.stop()
