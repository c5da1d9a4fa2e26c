"""tensegrity_cable_controller before it has the simulator's states, over real DDS.

As joint_trajectory_controller is active only with its state interfaces, the cable
controller is active only once it has joint_states and cable_states (their subscriptions
match separately): before, it answers no joint state, and a goal waits for both at most
``state_timeout`` s of wall time, then is refused INVALID_GOAL naming what did not come.

Two rigs: the controller started before any simulator, a goal sent and cancelled (it ends
at once), another sent, then the simulator started (the goal is held and succeeds); and one
running simulator (:func:`running_sim`) beside which a controller starts with its
cable_states remapped to a topic nobody publishes (no answer to any joint state, the goal
refused after its state_timeout), or a controller that becomes active and then sees the
simulator stop.
"""

from __future__ import annotations

import pytest

from tests.contract.client import PATIENCE, Client, start_sim
from tests.ros_support import Proc

pytestmark = pytest.mark.ros

SCENE = "table_actuated"
ACTION = "/tensegrity_cable_controller/follow_joint_trajectory"
SUCCESSFUL, INVALID_GOAL = 0, -1
#: the namespace of the rig without a simulator until its test starts one (apart from :func:`running_sim`)
HELD_NS = "/held"
REST = 0.9            # table_actuated's rest length of long1 [m] (tensegrity_table_actuated.yaml)


@pytest.fixture(scope="module")
def running_sim(tmp_path_factory):
    """One simulator of ``SCENE`` for the tests that start their controller beside a running
    one (a start costs ~2 s of CPU): each test's controller is its own, and a test that stops
    the simulator (SIGSTOP) lets it go on (SIGCONT) before it ends."""
    sim = start_sim(tmp_path_factory.mktemp("running_sim"), SCENE)
    yield sim
    sim.stop()


def _goal(t: float, position: float):
    from builtin_interfaces.msg import Duration
    from control_msgs.action import FollowJointTrajectory
    from trajectory_msgs.msg import JointTrajectoryPoint

    goal = FollowJointTrajectory.Goal()
    goal.trajectory.joint_names = ["long1"]
    sec = int(t)
    goal.trajectory.points = [JointTrajectoryPoint(positions=[position],
                                                   time_from_start=Duration(sec=sec, nanosec=round((t - sec) * 1e9)))]
    return goal


def _send(client: Client, action, goal):
    feedback: list = []
    handle = client.ask(lambda: action.send_goal_async(goal, feedback_callback=lambda f: feedback.append(f.feedback)),
                        "the goal response")
    return handle, feedback


def _ended(result) -> str:
    """How a goal whose result has come ended: status, error code and error string."""
    answer = result.result()
    return f"status {answer.status}, error_code {answer.result.error_code}: {answer.result.error_string!r}"


def test_a_goal_sent_before_the_simulator_runs_is_held_cancelled_at_once_or_followed_once_the_states_come(tmp_path):
    """One controller before any simulator (in a namespace of its own), a state_timeout
    longer than the test's patience: a held goal that is cancelled ends CANCELED at once (the
    cancel, not the timeout, ends it); a second held goal is followed once the simulator,
    started after it, sends its states."""
    from action_msgs.msg import GoalStatus
    from control_msgs.action import FollowJointTrajectory
    from tensegrity_msgs.msg import CableStates

    ctl = Proc(["node", "cables", "--ros-args", "-r", f"__ns:={HELD_NS}", "-p", f"scene:={SCENE}", "-p",
                f"state_timeout:={10 * PATIENCE}"], tmp_path / "cables.log")
    client = Client("held_goal_client")
    sim = None
    try:
        ctl.wait_for("cable controller ready")
        client.listen(CableStates, f"{HELD_NS}/cable_states")
        action = client.action_client(FollowJointTrajectory, HELD_NS + ACTION)
        handle, _ = _send(client, action, _goal(0.2, REST - 0.02))
        assert handle.accepted
        result = client.request(handle.get_result_async, "the cancelled goal's result")
        client.ask(handle.cancel_goal_async, "the cancel response")
        answer = client.wait_future(result, "the cancelled goal's result")
        assert (answer.status, answer.result.error_code) == (GoalStatus.STATUS_CANCELED, SUCCESSFUL)
        assert answer.result.error_string == "cancelled before the controller was active"

        handle, _ = _send(client, action, _goal(0.2, REST - 0.02))
        assert handle.accepted
        result = client.request(handle.get_result_async, "the held goal's result")
        sim = start_sim(tmp_path, SCENE, remap=(f"__ns:={HELD_NS}",))   # after the goal: no state came before
        answer = client.wait_future(result, "the held goal's result")
        assert (answer.status, answer.result.error_code) == (GoalStatus.STATUS_SUCCEEDED, SUCCESSFUL), \
            answer.result.error_string
        held = client.received[f"{HELD_NS}/cable_states"]
        client.wait(lambda: any(abs(dict(zip(m.name, m.rest_length))["long1"] - (REST - 0.02)) <= 1e-4
                                for m in held), "long1 at the goal (its tolerance)")
        assert "active: joint_states and cable_states received" in ctl.stderr()
    finally:
        client.close()
        for p in (ctl, sim):
            if p is not None:
                p.stop()


def test_without_cable_states_no_joint_state_is_answered_and_a_goal_is_refused_after_state_timeout(tmp_path,
                                                                                                   running_sim):
    from action_msgs.msg import GoalStatus
    from control_msgs.action import FollowJointTrajectory
    from sensor_msgs.msg import JointState
    from tensegrity_msgs.msg import CableCommand

    ctl = Proc(["node", "cables", "--ros-args", "-p", f"scene:={SCENE}", "-p", "state_timeout:=1.0",
                "-r", "cable_states:=cable_states_withheld"], tmp_path / "cables.log")
    client = Client("withheld_client")
    try:
        ctl.wait_for("cable controller ready")
        client.listen(JointState, "joint_states")
        client.listen(CableCommand, "cable_commands")
        action = client.action_client(FollowJointTrajectory, ACTION)
        # the controller's joint_states reader and its cable_commands writer in the graph, this
        # client's cable_commands reader matched with that writer
        client.wait_until(lambda: any(i.node_name == "tensegrity_cable_controller"
                                      for i in client.node.get_subscriptions_info_by_topic("/joint_states")),
                          "the controller's joint_states subscription")
        client.wait_until(lambda: client.node.count_publishers("/cable_commands") >= 1, "the controller's publisher")
        handle, _ = _send(client, action, _goal(0.2, REST - 0.02))
        answer = client.ask(handle.get_result_async, "the refusal")
        assert (answer.status, answer.result.error_code) == (GoalStatus.STATUS_ABORTED, INVALID_GOAL)
        message = answer.result.error_string
        assert "not active after state_timeout = 1 s" in message and "no cable_states" in message, message
        assert "table_actuated" in message, message
        client.wait_count("joint_states", 20)        # the simulator keeps publishing: still no answer
        assert not client.received["cable_commands"]
        assert "active:" not in ctl.stderr()
    finally:
        client.close()
        ctl.stop()


def test_a_running_goal_without_a_goal_time_ends_when_the_simulator_stops(tmp_path, running_sim):
    """A goal with goal_time_tolerance -1 (no limit) waits for its tolerance, which a
    simulator that stops (SIGSTOP: no state at all, not even a paused one's repeats) never
    brings: after ``state_timeout`` s without a joint state the goal ends ABORTED with
    INVALID_GOAL and the reason, where it ran forever. The controller's own stall as long
    (SIGSTOP 2 s, its state_timeout 1 s) is not the simulator's: the goal goes on.

    The goal is sent once the controller is active: sent before, it would be held for at most
    the same 1 s of wall time, which a loaded machine's discovery of the simulator can exceed
    (the goal then ends refused, before any process is stopped; the held goal has its own
    tests above)."""
    import os
    import signal
    import threading

    from action_msgs.msg import GoalStatus
    from builtin_interfaces.msg import Duration
    from control_msgs.action import FollowJointTrajectory

    sim = running_sim
    ctl = Proc(["node", "cables", "--ros-args", "-p", f"scene:={SCENE}", "-p", "state_timeout:=1.0"],
               tmp_path / "cables.log")
    client = Client("stopped_sim_client")
    try:
        ctl.wait_for("active: joint_states and cable_states received", timeout=PATIENCE)
        action = client.action_client(FollowJointTrajectory, ACTION)
        goal = _goal(60.0, REST - 0.02)
        goal.goal_time_tolerance = Duration(sec=-1)
        handle, feedback = _send(client, action, goal)
        result = client.request(handle.get_result_async, "the goal's result")
        client.wait_until(lambda: feedback or result.done(), "the goal's feedback")
        assert not result.done(), f"the goal ended before its first feedback: {_ended(result)}"
        os.killpg(ctl.popen.pid, signal.SIGSTOP)          # its session: the controller alone
        threading.Event().wait(2.0)
        os.killpg(ctl.popen.pid, signal.SIGCONT)
        seen = len(feedback)
        client.wait_until(lambda: len(feedback) > seen + 2, "feedback after the controller's stall")
        assert not result.done(), f"the goal ended during the controller's stall: {_ended(result)}"
        os.killpg(sim.popen.pid, signal.SIGSTOP)
        try:
            answer = client.wait_future(result, "the result of the goal whose simulator stopped")
        finally:
            os.killpg(sim.popen.pid, signal.SIGCONT)
        assert (answer.status, answer.result.error_code) == (GoalStatus.STATUS_ABORTED, INVALID_GOAL)
        assert "the simulator stopped or is gone" in answer.result.error_string, answer.result.error_string
    finally:
        client.close()
        ctl.stop()
