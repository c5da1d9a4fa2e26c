"""``~/controller_state``'s reference of a joint no goal moves is what the simulator holds,
also when someone else commanded it on ``cable_commands``.

A simulator (not lockstep, paused; this process steps it) and the cable controller. The
test commands ``long1`` itself; once a step has run under that command (the simulator
reports the new rest length), the controller's reference for ``long1`` is that rest length
and its error zero; a command the simulator refuses changes neither. Before, the reference
stayed at the rest length the controller became active on (0.9 m).
"""

from __future__ import annotations

import threading

import pytest

from tensegrity_ros.rclpy_utils.futures import on_executor, wait_done
from tests.ros.test_cable_controller import STEP_NS, cable_rig
from tests.ros_support import heard_by

pytestmark = pytest.mark.ros

#: Steps allowed for one command to reach the simulator and the controller (each step waits
#: for its state: an event bound, not a time).
STEPS = 200


class States:
    """Every ``controller_state`` the client receives, by stamp [ns]."""

    def __init__(self) -> None:
        self.by_stamp: dict[int, object] = {}
        self.changed = threading.Condition()

    def add(self, msg) -> None:
        with self.changed:
            self.by_stamp[msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec] = msg
            self.changed.notify_all()

    def at(self, stamp_ns: int, timeout: float = 60.0):
        with self.changed:
            assert self.changed.wait_for(lambda: stamp_ns in self.by_stamp, timeout), f"no controller_state at {stamp_ns}"
            return self.by_stamp[stamp_ns]


@pytest.fixture
def rig(tmp_path):
    from control_msgs.msg import JointTrajectoryControllerState
    from rclpy.qos import QoSProfile

    states = States()

    def subscribe(client) -> None:
        client.node.create_subscription(JointTrajectoryControllerState, "/tensegrity_cable_controller/controller_state",
                                        states.add, QoSProfile(depth=100))

    with cable_rig(tmp_path, "table_actuated", (f"step_size:={STEP_NS / 1e9}", "paused_publish_rate:=20.0"),
                   "reference_client", before=subscribe) as (client, _action, sim, _ctl, _log):
        yield client, sim, states


def _step_until(client, states, accept):
    """Step one step at a time until the controller_state of a step is ``accept``ed; that state."""
    client.take_joints()
    t = client.wait_joint().stamp_ns              # the state the simulator waits at (republished)
    for _ in range(STEPS):
        client.step(1)
        t += STEP_NS
        client.wait_joint(t)
        state = states.at(t)
        if accept(state):
            return state
    raise AssertionError(f"no controller_state accepted in {STEPS} steps; the last: {state}")


def test_the_reference_of_a_joint_no_goal_moves_is_the_rest_length_another_commanded(rig):
    from tensegrity_msgs.msg import CableCommand

    from tensegrity_ros.rclpy_utils.matching import wait_for_matches

    client, sim, states = rig
    joints = list(_step_until(client, states, lambda s: True).joint_names)
    assert joints == ["long1", "long2", "long3"]
    pub = client.node.create_publisher(CableCommand, "cable_commands", 10)
    try:
        assert wait_for_matches([pub], 2, 60)                     # the simulator and the controller
        heard_by(client.node, ["/tensegrity_sim", "/tensegrity_cable_controller"], wait_done)   # sent once
        pub.publish(CableCommand(name=["long1"], rest_length=[0.85]))
        state = _step_until(client, states, lambda s: s.feedback.positions[0] == 0.85
                            and s.reference.positions[0] == 0.85)
        assert list(state.reference.positions) == [0.85, 0.9, 0.9]
        assert list(state.error.positions) == [0.0, 0.0, 0.0]
        assert list(state.output.positions) == [0.85, 0.9, 0.9]
        # out of long1's range: the simulator refuses it, and the reference stays
        logged = len(sim.stderr())
        pub.publish(CableCommand(name=["long1"], rest_length=[-1.0]))
        sim.wait_for("long1", timeout=60, since=logged)
        for _ in range(3):
            state = _step_until(client, states, lambda s: True)
            assert list(state.reference.positions) == [0.85, 0.9, 0.9]
            assert list(state.feedback.positions) == [0.85, 0.9, 0.9]
    finally:   # by the spinning thread, which may be building its wait set from the publisher's events
        destroyed = on_executor(client.executor, lambda: client.node.destroy_publisher(pub))
        assert wait_done(destroyed, 60), "the client's thread did not destroy the publisher"


class Answers:
    """The idle controller's answers on ``cable_commands`` (empty commands), counted by stamp [ns]."""

    def __init__(self) -> None:
        self.count: dict[int, int] = {}
        self.changed = threading.Condition()

    def add(self, msg) -> None:
        if msg.name or msg.rest_length:
            return                                    # not the controller's idle answer
        with self.changed:
            stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            self.count[stamp] = self.count.get(stamp, 0) + 1
            self.changed.notify_all()

    def more(self, stamp_ns: int, than: int, timeout: float = 60.0) -> None:
        with self.changed:
            assert self.changed.wait_for(lambda: self.count.get(stamp_ns, 0) > than, timeout), \
                f"the controller answered the state at {stamp_ns} ns no more than {than} times"


@pytest.fixture
def lockstep_rig(tmp_path):
    from control_msgs.msg import JointTrajectoryControllerState
    from rclpy.qos import QoSProfile
    from tensegrity_msgs.msg import CableCommand

    states, answers = States(), Answers()

    def subscribe(client) -> None:
        client.node.create_subscription(JointTrajectoryControllerState, "/tensegrity_cable_controller/controller_state",
                                        states.add, QoSProfile(depth=100))
        client.node.create_subscription(CableCommand, "cable_commands", answers.add, QoSProfile(depth=100))

    with cable_rig(tmp_path, "table_actuated", (f"step_size:={STEP_NS / 1e9}", "lockstep:=true",
                                                "paused_publish_rate:=20.0", "lockstep_timeout:=30.0"),
                   "lockstep_reference_client", before=subscribe) as (client, _action, _sim, _ctl, _log):
        yield client, states, answers


def test_in_lockstep_a_clients_rest_length_survives_the_controllers_empty_answer_to_the_same_step(lockstep_rig):
    """The paused simulator waits at t0 and republishes its state; the idle controller answers
    each with an empty command stamped t0. The test commands ``long1`` for t0, waits until the
    controller has read it (its reference shows it) and has answered t0 twice more, then steps
    once: the step runs under the client's rest length, not under the controller's later
    empty answer, and the reference equals it."""
    from tensegrity_msgs.msg import CableCommand

    from tensegrity_ros.rclpy_utils.matching import wait_for_matches

    client, states, answers = lockstep_rig
    client.take_joints()
    t0 = client.wait_joint().stamp_ns                   # the state the simulator waits at (republished)
    assert list(states.at(t0).reference.positions) == [0.9, 0.9, 0.9]
    pub = client.node.create_publisher(CableCommand, "cable_commands", 10)
    try:
        assert wait_for_matches([pub], 2, 60)                     # the simulator and the controller
        heard_by(client.node, ["/tensegrity_sim", "/tensegrity_cable_controller"], wait_done)   # sent once
        command = CableCommand(name=["long1"], rest_length=[0.85])
        command.header.stamp.sec, command.header.stamp.nanosec = divmod(t0, 10**9)
        pub.publish(command)
        with states.changed:                                       # the controller read it
            assert states.changed.wait_for(lambda: states.by_stamp[t0].reference.positions[0] == 0.85, 60), \
                "the controller's reference never showed the client's command"
        with answers.changed:
            seen = answers.count.get(t0, 0)
        answers.more(t0, seen + 1)                                 # answered t0 twice since: after the command
        client.step(1)
        client.wait_joint(t0 + STEP_NS)
        state = states.at(t0 + STEP_NS)
        assert list(state.feedback.positions) == [0.85, 0.9, 0.9]   # the step ran under the client's command
        assert list(state.reference.positions) == [0.85, 0.9, 0.9]
        assert list(state.error.positions) == [0.0, 0.0, 0.0]
    finally:   # by the spinning thread, which may be building its wait set from the publisher's events
        destroyed = on_executor(client.executor, lambda: client.node.destroy_publisher(pub))
        assert wait_done(destroyed, 60), "the client's thread did not destroy the publisher"
