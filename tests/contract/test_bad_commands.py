"""Bad commands as issue 30 lists them, sent as bursts of 100 by a plain rclpy publisher: the
state is unchanged, the node stays alive, and its warnings are throttled.

The robot is the 6-bar standing on a face (``six_bar_rest``) with one motor in tension mode
(``c0_4``, limit 2000 N) and one in reel-speed mode (``c0_7``, 0.5 m/s), as docs/ros.md's
example scene puts them; the class-2 mechanism runs beside it in a namespace of its own.
Throttling is counted from the node's log: over a window of W seconds a reason throttled to
one warning per second appears at most floor(W) + 1 times, however many commands are refused
(the bound uses the measured window, so a slow machine only loosens it; 100 unthrottled
warnings of one reason would exceed it at any speed up to 98 s).
"""

from __future__ import annotations

import math
import time

import pytest

from tests.contract.client import PATIENCE, Client, start_sim
from tests.ros_support import Proc

pytestmark = pytest.mark.ros

BURST = 100
PROBE = "c5_8"                     # a rest-length motor that only valid commands move
SCENE = """\
name: six_bar_modes
model: {kind: robot, robot: six_bar}
initial: {drawn: true}
duration: 13.0
effects: [inertia, cables, {motors: {modes: {c0_4: tension, c0_7: reel_speed}}}, gravity, contact, friction, sensors]
"""


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    from sensor_msgs.msg import JointState
    from tensegrity_msgs.msg import ActuatorForces, CableCommand, CableStates

    folder = tmp_path_factory.mktemp("bad_commands")
    (folder / "six_bar_modes.yaml").write_text(SCENE)
    robot = start_sim(folder, str(folder / "six_bar_modes.yaml"), "marker_rate:=0.0")
    cables = Proc(["node", "cables", "--ros-args", "-p", f"scene:={folder / 'six_bar_modes.yaml'}"],
                  folder / "cables.log")
    class2 = start_sim(folder, "class2_at_rest", "publish_clock:=false", "marker_rate:=0.0", "command_timeout:=0.0",
                       name="class2",
                       remap=("__ns:=/class2",))
    client = Client("bad_commands_client")
    try:
        client.listen(CableStates, "cable_states")
        client.listen(JointState, "/class2/joint_states")
        client.wait(lambda: client.received["cable_states"] and client.received["/class2/joint_states"],
                    "both simulators' states")
        pubs = {"cables": client.publisher(CableCommand, "cable_commands"),
                "forces": client.publisher(ActuatorForces, "actuator_forces"),
                "class2 cables": client.publisher(CableCommand, "/class2/cable_commands")}
        cables.wait_for("cable controller ready")
        yield client, pubs, robot, class2
    finally:
        client.close()
        for p in (cables, robot, class2):
            p.stop()


def _rest(client):
    msg = client.received["cable_states"][-1]
    return dict(zip(msg.name, msg.rest_length))


def _warnings(log: str) -> int:
    return sum(1 for line in log.splitlines() if "WARN" in line and "rejected" in line)


def _move_probe(client, pubs, value: float, previous: float) -> None:
    """A valid command after a burst, each shorter than the one before; until the simulator
    shows it applied, its motor's rest length below the previous target (commands on one
    topic apply in order: the burst before it has been taken)."""
    from tensegrity_msgs.msg import CableCommand

    pubs["cables"].publish(CableCommand(name=[PROBE], rest_length=[value]))
    client.wait(lambda: _rest(client)[PROBE] < previous - 1e-9, f"the probe command moving {PROBE}")


def _robot_bad_commands():
    from tensegrity_msgs.msg import ActuatorForces, CableCommand

    return [
        ("cables", CableCommand(name=["no_such_cable"], rest_length=[0.9]), "no_such_cable"),
        ("cables", CableCommand(name=["c1_4"], rest_length=[math.nan]), "nan"),
        ("cables", CableCommand(name=["c1_4"], rest_length=[1.2]), "range"),
        ("cables", CableCommand(name=["c0_4"], tension=[2500.0]), "2500"),
        ("cables", CableCommand(name=["c0_7"], reel_speed=[0.6]), "0.6"),
        ("forces", ActuatorForces(name=["f1", "f2"], force=[0.1, 0.1]), "cable_commands"),
    ]


def test_bursts_of_bad_commands_to_a_robot_change_nothing_and_warn_throttled(suite):
    client, pubs, robot, _ = suite
    initial = _rest(client)
    rest_motors = [n for n in initial if n.startswith("c") and n not in ("c0_4", "c0_7", PROBE)]
    start, t0 = len(robot.stderr()), time.monotonic()
    for i, (topic, msg, _) in enumerate(_robot_bad_commands()):
        for _ in range(BURST):
            pubs[topic].publish(msg)
        _move_probe(client, pubs, 0.99 - 0.002 * i, 0.996 if i == 0 else 0.99 - 0.002 * (i - 1))
    window = time.monotonic() - t0
    lines = _warnings(robot.stderr()[start:])
    assert 1 <= lines <= len(_robot_bad_commands()) * (math.floor(window) + 1), (lines, window)   # per reason
    now = _rest(client)
    assert [now[n] for n in rest_motors] == [initial[n] for n in rest_motors]     # nothing else moved
    client.wait_count("cable_states", 5)                                          # alive, publishing


@pytest.mark.parametrize("index", range(6))
def test_each_bad_robot_command_is_refused_with_a_reason_that_names_the_problem(suite, index):
    """Resent until its warning appears (the throttle lets one through a second)."""
    client, pubs, robot, _ = suite
    topic, msg, named = _robot_bad_commands()[index]
    start = len(robot.stderr())
    deadline = time.monotonic() + PATIENCE
    while not any(named in line.lower() for line in robot.stderr()[start:].splitlines() if "rejected" in line):
        assert time.monotonic() < deadline, f"no warning naming {named!r}:\n{robot.stderr()[start:]}"
        pubs[topic].publish(msg)
        client.wait_count("cable_states", 10)        # about 0.1 s of simulation between tries


def test_a_burst_of_cable_commands_to_the_class2_mechanism_changes_nothing_and_warns_throttled(suite):
    from tensegrity_msgs.msg import CableCommand

    client, pubs, _, class2 = suite
    forces = list(client.received["/class2/joint_states"][-1].effort)
    start, t0 = len(class2.stderr()), time.monotonic()
    for _ in range(BURST):
        pubs["class2 cables"].publish(CableCommand(name=["c1_4"], rest_length=[0.9]))
    client.wait(lambda: "actuator_forces" in class2.stderr()[start:], "the class-2 simulator's warning")
    client.wait_count("/class2/joint_states", 20)                       # alive, publishing
    window = time.monotonic() - t0
    lines = _warnings(class2.stderr()[start:])
    assert 1 <= lines <= math.floor(window) + 1, (lines, window)
    assert list(client.received["/class2/joint_states"][-1].effort) == forces   # the applied forces hold


@pytest.mark.parametrize("motor", ["c0_4", "c0_7"])
def test_a_trajectory_for_a_motor_that_takes_no_rest_length_is_invalid_joints(suite, motor):
    """docs/ros.md: the trajectory's positions are rest lengths; a motor in tension or
    reel-speed mode is not such a joint (INVALID_JOINTS, -2, with the reason)."""
    from action_msgs.msg import GoalStatus
    from builtin_interfaces.msg import Duration
    from control_msgs.action import FollowJointTrajectory
    from trajectory_msgs.msg import JointTrajectoryPoint

    client = suite[0]
    action = client.action_client(FollowJointTrajectory, "/tensegrity_cable_controller/follow_joint_trajectory")
    goal = FollowJointTrajectory.Goal()
    goal.trajectory.joint_names = [motor]
    goal.trajectory.points = [JointTrajectoryPoint(positions=[0.99], time_from_start=Duration(sec=1))]
    handle = client.ask(lambda: action.send_goal_async(goal), "the goal response")
    answer = client.ask(handle.get_result_async, "the goal's result")
    assert (answer.status, answer.result.error_code) == (GoalStatus.STATUS_ABORTED, -2), answer.result.error_string
    assert motor in answer.result.error_string
