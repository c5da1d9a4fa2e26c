"""The robot's gait action as a client written for ros2_control's joint_trajectory_controller
uses it: ``control_msgs/action/FollowJointTrajectory`` on ``tensegrity_cable_controller``,
driving the 6-bar of ``six_bar_rest`` (a free-running simulator, as ``tensegrity up`` starts it).

Expectations come from control_msgs and joint_trajectory_controller, and issue 30: joint names
= cable names in any order, positions = rest lengths [m] inside the motors' range (0.45, 1.05) m
(the robot's description), result codes SUCCESSFUL 0, INVALID_GOAL -1, INVALID_JOINTS -2,
OLD_HEADER_TIMESTAMP -3, PATH_TOLERANCE_VIOLATED -4, GOAL_TOLERANCE_VIOLATED -5, each failure
with an ``error_string``; feedback desired/actual/error over the goal's joint names with
error = desired - actual; a cancel ends the goal CANCELED; a newer goal preempts the running
one with INVALID_GOAL (joint_trajectory_controller's code). A refused goal is accepted and
aborted at once with its code (the documented choice of docs/ros.md: ROS 2's goal response
carries no reason).

The motors trail a command (lag 0.02 s, slew 0.5 m/s, from the robot's description): a tiny
path tolerance on a moving trajectory is violated, and a 0.1 m step in 0.05 s cannot be
reached within 1 ns after its end.
"""

from __future__ import annotations

import math
from contextlib import contextmanager

import pytest

from tests.contract.client import Client, stamp_ns, start_sim

pytestmark = pytest.mark.ros

SCENE = "six_bar_rest"
ACTION = "/tensegrity_cable_controller/follow_joint_trajectory"
FEEDBACK = f"{ACTION}/_action/feedback"     # the action's feedback topic (ROS 2's action design)
STATE = "/tensegrity_cable_controller/controller_state"    # joint_trajectory_controller's ~/controller_state
NOMINAL = 0.996                       # every motor's drawn rest length [m] (six_bar.yaml)
SUCCESSFUL, INVALID_GOAL, INVALID_JOINTS = 0, -1, -2
# goal_time_tolerance -1 (control_msgs: no limit): a goal whose subject is not its timing waits
# for its tolerance. The simulator runs free at real time, so a fixed goal time is a window of
# wall time for the controller to keep up in: a controller starved of CPU for longer (a loaded
# run: 2.2 mm short 2 s after a 0.2 s move's end; a controller stopped 3 s mid-move here: 3.9 mm)
# misses it, as joint_trajectory_controller would, while its following is right.
UNTIL_REACHED = -1.0
OLD_HEADER_TIMESTAMP, PATH_TOLERANCE_VIOLATED, GOAL_TOLERANCE_VIOLATED = -3, -4, -5


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    from control_msgs.action import FollowJointTrajectory
    from control_msgs.msg import JointTrajectoryControllerState
    from sensor_msgs.msg import JointState
    from tensegrity_msgs.msg import CableCommand, CableStates

    from tests.ros_support import Proc

    folder = tmp_path_factory.mktemp("fjt")
    sim = start_sim(folder, SCENE)
    ctl = Proc(["node", "cables", "--ros-args", "-p", f"scene:={SCENE}"], folder / "cables.log")
    client = Client("jtc_client")
    try:
        ctl.wait_for("cable controller ready")
        client.listen(JointState, "joint_states")
        client.listen(CableStates, "cable_states")
        client.listen(CableCommand, "cable_commands")
        client.listen(FollowJointTrajectory.Impl.FeedbackMessage, FEEDBACK)   # before the probe: matched
        client.listen(JointTrajectoryControllerState, STATE, qos=10)           # rclpy's default QoS
        action = client.action_client(FollowJointTrajectory, ACTION)
        # its first answer says it is active (it has joint_states and cable_states): it takes goals
        client.wait(lambda: client.received["cable_commands"], "the cable controller's first answer to a state")
        client.wait(lambda: client.received["cable_states"], "a cable state")    # another topic: may come later
        yield client, action
    finally:
        client.close()
        for p in (ctl, sim):
            p.stop()


def _goal(points, names, *, stamp_ns_=0, goal_time=None, path=(), goal=(), velocities=None):
    """A goal as a joint_trajectory_controller client builds it: ``points`` as (t [s], positions),
    ``velocities`` one row per point or None."""
    from builtin_interfaces.msg import Duration, Time
    from control_msgs.action import FollowJointTrajectory
    from control_msgs.msg import JointTolerance
    from trajectory_msgs.msg import JointTrajectoryPoint

    def duration(t: float) -> Duration:
        return Duration(sec=math.floor(t), nanosec=round((t - math.floor(t)) * 1e9))

    g = FollowJointTrajectory.Goal()
    g.trajectory.header.stamp = Time(sec=stamp_ns_ // 1_000_000_000, nanosec=stamp_ns_ % 1_000_000_000)
    g.trajectory.joint_names = list(names)
    g.trajectory.points = [JointTrajectoryPoint(positions=list(p), time_from_start=duration(t)) for t, p in points]
    for point, v in zip(g.trajectory.points, velocities or ()):
        point.velocities = list(v)
    g.path_tolerance = [JointTolerance(name=n, position=v) for n, v in path]
    g.goal_tolerance = [JointTolerance(name=n, position=v) for n, v in goal]
    if goal_time is not None:
        g.goal_time_tolerance = goal_time if isinstance(goal_time, Duration) else duration(goal_time)
    return g


class _Feedback:
    """The feedback the server published for one goal, in order, as it arrives: read on the
    action's feedback topic, because rclpy's ActionClient (Jazzy) drops a goal's feedback
    once the goal's result has come, and the result comes on another topic, so the feedback
    of the state that ended a goal may reach the client after its result. The topic's
    messages from ``since`` on are sorted as they come, each once: a condition of
    ``Client.wait`` is evaluated at every arrival (see ``Client.wait_for``)."""

    def __init__(self, client, goal_id, since: int) -> None:
        self._client = client
        self._received, self._id = client.received[FEEDBACK], bytes(goal_id.uuid)
        self._sorted, self._ours = since, []

    def _update(self) -> list:
        received = self._received
        while self._sorted < len(received):
            message = received[self._sorted]
            self._sorted += 1
            if bytes(message.goal_id.uuid) == self._id:
                self._ours.append(message.feedback)
        return self._ours

    def __iter__(self):
        return iter(list(self._update()))

    def __len__(self) -> int:
        return len(self._update())

    def wait_for(self, found, what: str):
        """The goal's first feedback for which ``found(feedback)`` is true, each tested once."""
        checked = 0

        def scan():
            nonlocal checked
            ours = self._update()
            while checked < len(ours):
                checked += 1
                if found(ours[checked - 1]):
                    return (ours[checked - 1],)
            return None

        return self._client.wait(scan, what)[0]


def _send(client, action, goal):
    """The goal's handle and its :class:`_Feedback`."""
    since = len(client.received[FEEDBACK])          # the goal's feedback comes after this
    handle = client.ask(lambda: action.send_goal_async(goal), "the goal response")
    return handle, _Feedback(client, handle.goal_id, since)


def _until_the_end(client, feedback, duration_ns: int) -> None:
    """Until the feedback of a state at or after the trajectory's end (``duration_ns``) has
    come, and with it, on the server's one feedback writer, every earlier feedback."""
    feedback.wait_for(lambda fb: stamp_ns(fb.desired.time_from_start) >= duration_ns,
                      "the feedback of a state after the trajectory's end")


def _outcome(client, handle):
    answer = client.ask(handle.get_result_async, "the goal's result")
    return answer.status, answer.result


@contextmanager
def _paused(client):
    """The simulator paused (set_simulation_state) while the block runs, played again after
    it; yields the simulation time [ns] it stands at: that of two joint states in a row with
    the same stamp (a paused simulator republishes its state), received after the pause."""
    from simulation_interfaces.msg import SimulationState
    from simulation_interfaces.srv import SetSimulationState

    def set_state(state: int) -> None:
        request = SetSimulationState.Request(state=SimulationState(state=state))
        result = client.call(SetSimulationState, "set_simulation_state", request).result
        assert result.result == result.RESULT_OK, result.error_message

    states = client.received["joint_states"]
    mark = len(states)
    set_state(SimulationState.STATE_PAUSED)
    try:
        standing = client.wait(lambda: len(states) >= mark + 2 and (
            t := stamp_ns(states[-1].header.stamp)) == stamp_ns(states[-2].header.stamp) and (t,),
            "a joint state republished at a standing time")[0]
        yield standing
    finally:
        set_state(SimulationState.STATE_PLAYING)


def _rest(client, names):
    """The rest lengths [m] of ``names`` in the latest cable_states."""
    msg = client.received["cable_states"][-1]
    rest = dict(zip(msg.name, msg.rest_length))
    return [rest[n] for n in names]


def _held(state, names):
    """The rest lengths [m] an idle ``controller_state`` says the controller holds ``names`` at
    (its ``output``: the latest command, the simulator's motors' aim), or None for a goal's."""
    if stamp_ns(state.reference.time_from_start) != 0:
        return None
    output = dict(zip(state.joint_names, state.output.positions))
    return [output[n] for n in names]


def test_a_goal_in_any_joint_order_is_followed_and_reported_as_joint_trajectory_controller_does(suite):
    from action_msgs.msg import GoalStatus

    client, action = suite
    names = ("c7_10", "c0_4")                     # not the description's order
    target = (0.97, 0.98)
    tol = 1e-3
    goal = _goal([(0.1, (0.985, 0.99)), (0.3, target)], names, goal_time=UNTIL_REACHED,
                 goal=[(n, tol) for n in names])
    handle, feedback = _send(client, action, goal)
    assert handle.accepted
    status, result = _outcome(client, handle)
    assert (status, result.error_code) == (GoalStatus.STATUS_SUCCEEDED, SUCCESSFUL), result.error_string
    # feedback and result are separate topics: the result may come before the last
    # feedbacks, up to that of the state that ended the goal (after the trajectory's end,
    # within the goal tolerance)
    feedback.wait_for(lambda fb: stamp_ns(fb.desired.time_from_start) >= 300_000_000
                      and all(abs(e) <= tol for e in fb.error.positions), "the feedback of the state that ended the goal")
    feedback = list(feedback)
    states = {stamp_ns(m.header.stamp): m for m in client.received["cable_states"]}
    for fb in feedback:
        assert list(fb.joint_names) == list(names)
        assert len(fb.desired.positions) == len(fb.actual.positions) == len(fb.error.positions) == 2
        for d, a, e in zip(fb.desired.positions, fb.actual.positions, fb.error.positions):
            assert e == pytest.approx(d - a, abs=1e-12)          # control_msgs: error = desired - actual
        state = states.get(stamp_ns(fb.header.stamp))
        if state is not None:                    # actual = the rest lengths the simulator reports
            rest = dict(zip(state.name, state.rest_length))
            assert list(fb.actual.positions) == [rest[n] for n in names]
    # the goal ends at the first state after the trajectory's end within the goal tolerance:
    # every earlier one after the end is outside it (that state's feedback, and the states, may
    # reach this client after the result: the simulator's rest lengths get there)
    after_end = [fb for fb in feedback if stamp_ns(fb.desired.time_from_start) >= 300_000_000]
    within = [all(abs(e) <= tol for e in fb.error.positions) for fb in after_end]
    assert not any(within[:-1]), "the goal ran on after the rest lengths were within its tolerance"
    client.wait(lambda: all(abs(a - t) <= tol for a, t in zip(_rest(client, names), target)),
                "the rest lengths within the goal tolerance")
    desired = [list(fb.desired.positions) for fb in feedback]
    assert desired[-1] == pytest.approx(list(target), abs=1e-12)
    assert any(0.97 < d[0] < 0.996 for d in desired), "no desired position between the start and the end"
    joints = client.received["joint_states"][-1]
    assert set(names) <= set(joints.name)         # the goal's joints are joint_states' joints


@pytest.mark.parametrize("case, goal_args, code", [
    ("unknown joint", ([(0.1, (0.99,))], ("no_such_cable",)), INVALID_JOINTS),
    ("a joint named twice", ([(0.1, (0.99, 0.99))], ("c0_7", "c0_7")), INVALID_JOINTS),
    ("positions length mismatch", ([(0.1, (0.99,))], ("c0_7", "c5_8")), INVALID_GOAL),
    ("non-increasing time_from_start", ([(0.2, (0.99,)), (0.2, (0.98,))], ("c0_7",)), INVALID_GOAL),
    ("decreasing time_from_start", ([(0.2, (0.99,)), (0.1, (0.98,))], ("c0_7",)), INVALID_GOAL),
    ("no points", ([], ("c0_7",)), INVALID_GOAL),
    ("NaN position", ([(0.1, (math.nan,))], ("c0_7",)), INVALID_GOAL),
    ("rest length above the motor range", ([(0.1, (1.2,))], ("c0_7",)), INVALID_GOAL),
    ("rest length below the motor range", ([(0.1, (0.3,))], ("c0_7",)), INVALID_GOAL),
])
def test_a_goal_joint_trajectory_controller_rejects_ends_with_the_standard_code_and_a_reason(suite, case, goal_args,
                                                                                           code):
    from action_msgs.msg import GoalStatus

    client, action = suite
    names = ("c0_7", "c5_8")
    # what the cables are held at, not where the motors are: an earlier goal's motor may still
    # be on its way or settling within its tolerance. An idle state no older than the latest
    # joint state here came after every state of an earlier goal (one writer, in order; a state
    # a controller's reader was behind with, published while that goal ran, is older)
    now = stamp_ns(client.received["joint_states"][-1].header.stamp)
    idle = client.wait_for(STATE, lambda s: _held(s, names) is not None and stamp_ns(s.header.stamp) >= now,
                           "an idle controller_state", since=len(client.received[STATE]))
    handle, _ = _send(client, action, _goal(*goal_args))
    status, result = _outcome(client, handle)
    assert (status, result.error_code) == (GoalStatus.STATUS_ABORTED, code), (case, result.error_string)
    assert result.error_string.strip(), case
    after = client.wait_count(STATE, 5)                          # states after the refusal
    assert [_held(s, names) for s in after] == [_held(idle, names)] * 5     # nothing commanded


@pytest.mark.parametrize("case, kwargs, code", [
    ("a tolerance for a joint the controller does not have", {"goal": [("no_such_cable", 1e-3)]}, INVALID_JOINTS),
    ("a NaN tolerance", {"path": [("c0_4", math.nan)]}, INVALID_GOAL),
    # joint_trajectory_controller (validate_trajectory_msg), allow_nonzero_velocity_at_trajectory_end
    # false by default: "Velocity of last trajectory point of joint ... is not zero"
    ("a last point that does not end at rest", {"velocities": [(0.01,)]}, INVALID_GOAL),
])
def test_bad_tolerances_are_refused(suite, case, kwargs, code):
    from action_msgs.msg import GoalStatus

    client, action = suite
    handle, _ = _send(client, action, _goal([(0.1, (0.99,))], ("c0_4",), **kwargs))
    status, result = _outcome(client, handle)
    assert (status, result.error_code) == (GoalStatus.STATUS_ABORTED, code), (case, result.error_string)
    assert result.error_string.strip(), case


def test_a_goal_time_tolerance_of_minus_one_waits_as_long_as_the_goal_takes(suite):
    """control_msgs' JointTolerance: -1 "erased"; joint_trajectory_controller reads a goal's
    goal_time_tolerance through the same rule (tolerances.hpp, resolve_tolerance_source) and a
    goal time of 0 waits "a potentially infinite amount of time": the 0.1 m step that the
    motor reaches some 0.2 s after a 0.05 s trajectory's end (a goal time of 1 ns: violated,
    above) succeeds, however long it took."""
    from action_msgs.msg import GoalStatus
    from builtin_interfaces.msg import Duration

    client, action = suite
    start = _rest(client, ("c1_7",))[0]
    target = start - 0.1                          # 0.1 m at 0.5 m/s takes the motor >= 0.2 s
    goal = _goal([(0.05, (target,))], ("c1_7",), goal_time=Duration(sec=-1), goal=[("c1_7", 1e-4)])
    handle, feedback = _send(client, action, goal)
    status, result = _outcome(client, handle)
    assert (status, result.error_code) == (GoalStatus.STATUS_SUCCEEDED, SUCCESSFUL), result.error_string
    # it ran on past the trajectory's end: feedback 0.1 s after it, still outside the tolerance
    feedback.wait_for(lambda fb: stamp_ns(fb.desired.time_from_start) >= 150_000_000,
                      "feedback 0.1 s after the trajectory's end")
    assert any(stamp_ns(fb.desired.time_from_start) >= 150_000_000 and abs(fb.error.positions[0]) > 1e-4
               for fb in feedback)
    handle, _ = _send(client, action, _goal([(0.5, (NOMINAL,))], ("c1_7",), goal_time=UNTIL_REACHED))   # back
    assert _outcome(client, handle)[1].error_code == SUCCESSFUL


def test_tolerances_for_every_joint_of_the_controller_go_with_a_partial_trajectory(suite):
    """A client that fills path and goal tolerances for all the controller's joints (they may
    name any of them: joint_trajectory_controller's get_segment_tolerances looks each up among
    its joints) and moves one: the goal is taken and succeeds. The path tolerance is wider
    than the whole move (NOMINAL - 0.985 = 11 mm), so no lag of a loaded machine's real-time
    loop can violate it: what is tested is the names (an unknown one is INVALID_JOINTS)."""
    from action_msgs.msg import GoalStatus

    client, action = suite
    joints = list(client.received["joint_states"][-1].name)
    assert len(joints) == 24 and "c2_6" in joints
    path, goal_tolerance = [(n, 0.05) for n in joints], [(n, 5e-3) for n in joints]
    goal = _goal([(0.2, (0.985,))], ("c2_6",), goal_time=UNTIL_REACHED, path=path, goal=goal_tolerance)
    handle, _ = _send(client, action, goal)
    status, result = _outcome(client, handle)
    assert (status, result.error_code) == (GoalStatus.STATUS_SUCCEEDED, SUCCESSFUL), result.error_string
    handle, _ = _send(client, action, _goal([(0.2, (NOMINAL,))], ("c2_6",), goal_time=UNTIL_REACHED))   # back
    assert _outcome(client, handle)[1].error_code == SUCCESSFUL


def test_an_empty_trajectory_is_refused(suite):
    from action_msgs.msg import GoalStatus

    client, action = suite
    handle, _ = _send(client, action, _goal([], ()))
    status, result = _outcome(client, handle)
    assert status == GoalStatus.STATUS_ABORTED and result.error_code in (INVALID_GOAL, INVALID_JOINTS)
    assert result.error_string.strip()


def test_a_trajectory_that_ended_before_now_is_an_old_header_timestamp(suite):
    from action_msgs.msg import GoalStatus

    client, action = suite
    now = stamp_ns(client.received["joint_states"][-1].header.stamp)
    assert now > 20_000_000                       # the simulation has run past the trajectory's end
    handle, _ = _send(client, action, _goal([(0.01, (0.99,))], ("c0_4",), stamp_ns_=1))
    status, result = _outcome(client, handle)
    assert (status, result.error_code) == (GoalStatus.STATUS_ABORTED, OLD_HEADER_TIMESTAMP), result.error_string
    assert result.error_string.strip()


def test_a_path_tolerance_the_motors_cannot_keep_is_violated(suite):
    from action_msgs.msg import GoalStatus

    client, action = suite
    start = _rest(client, ("c0_7",))[0]
    target = 0.96 if start > 0.98 else 0.995
    handle, _ = _send(client, action, _goal([(0.5, (target,))], ("c0_7",), path=[("c0_7", 1e-9)]))
    status, result = _outcome(client, handle)
    assert (status, result.error_code) == (GoalStatus.STATUS_ABORTED, PATH_TOLERANCE_VIOLATED), result.error_string
    assert "c0_7" in result.error_string


def test_a_goal_the_motors_cannot_reach_in_the_goal_time_is_violated(suite):
    from action_msgs.msg import GoalStatus
    from builtin_interfaces.msg import Duration

    client, action = suite
    start = _rest(client, ("c1_4",))[0]
    target = start - 0.1                          # 0.1 m at 0.5 m/s takes the motor >= 0.2 s
    goal = _goal([(0.05, (target,))], ("c1_4",), goal_time=Duration(sec=0, nanosec=1), goal=[("c1_4", 1e-4)])
    handle, _ = _send(client, action, goal)
    status, result = _outcome(client, handle)
    assert (status, result.error_code) == (GoalStatus.STATUS_ABORTED, GOAL_TOLERANCE_VIOLATED), result.error_string
    assert "c1_4" in result.error_string
    handle, _ = _send(client, action, _goal([(0.5, (NOMINAL,))], ("c1_4",), goal_time=UNTIL_REACHED))   # back
    assert _outcome(client, handle)[1].error_code == SUCCESSFUL


def test_a_cancelled_goal_ends_canceled_and_the_cables_hold(suite):
    from action_msgs.msg import GoalStatus

    client, action = suite
    handle, feedback = _send(client, action, _goal([(30.0, (0.9,))], ("c2_5",)))
    assert handle.accepted
    client.wait(lambda: feedback, "feedback of the running goal")
    answer = client.ask(handle.cancel_goal_async, "the cancel response")
    assert len(answer.goals_canceling) == 1
    status, result = _outcome(client, handle)
    assert status == GoalStatus.STATUS_CANCELED and result.error_code == SUCCESSFUL
    held = _rest(client, ("c2_5",))[0]
    client.wait_count("cable_states", 5)
    assert _rest(client, ("c2_5",))[0] == pytest.approx(held, abs=2e-3)   # the motor settles, no more travel
    assert _rest(client, ("c2_5",))[0] > 0.98                               # far from the cancelled target


def test_a_second_goal_preempts_the_first_as_joint_trajectory_controller_does(suite):
    from action_msgs.msg import GoalStatus

    client, action = suite
    first, feedback = _send(client, action, _goal([(30.0, (0.9,))], ("c3_5",)))
    assert first.accepted
    client.wait(lambda: feedback, "feedback of the first goal")
    second, _ = _send(client, action, _goal([(0.3, (NOMINAL,))], ("c3_5",), goal_time=UNTIL_REACHED))
    assert second.accepted
    status, result = _outcome(client, first)
    # joint_trajectory_controller (preempt_active_goal, Jazzy 4.41 on): ABORTED with INVALID_GOAL
    assert status == GoalStatus.STATUS_ABORTED
    assert result.error_code == INVALID_GOAL and result.error_string.strip()
    status, result = _outcome(client, second)
    assert (status, result.error_code) == (GoalStatus.STATUS_SUCCEEDED, SUCCESSFUL), result.error_string
    client.wait(lambda: abs(_rest(client, ("c3_5",))[0] - NOMINAL) <= 1e-4, "c3_5 back at its nominal rest length")


def test_an_invalid_goal_leaves_the_running_goal_running(suite):
    """joint_trajectory_controller rejects an invalid goal before it is accepted, so only a
    valid goal preempts (goal_received_callback, then goal_accepted_callback): here the invalid
    goal ends at once with its code and the running goal goes on until it is cancelled."""
    from action_msgs.msg import GoalStatus

    client, action = suite
    first, feedback = _send(client, action, _goal([(30.0, (0.9,))], ("c6_9",)))
    assert first.accepted
    client.wait(lambda: feedback, "feedback of the first goal")
    bad, _ = _send(client, action, _goal([(0.1, (2.0,))], ("c6_9",)))        # outside the motor's range
    status, result = _outcome(client, bad)
    assert (status, result.error_code) == (GoalStatus.STATUS_ABORTED, INVALID_GOAL), result.error_string
    seen = len(feedback)
    client.wait(lambda: len(feedback) > seen + 2, "feedback of the first goal after the invalid one")
    client.ask(first.cancel_goal_async, "the cancel response")
    status, _ = _outcome(client, first)
    assert status == GoalStatus.STATUS_CANCELED                # running until the cancel, not preempted
    handle, _ = _send(client, action, _goal([(0.2, (NOMINAL,))], ("c6_9",), goal_time=UNTIL_REACHED))   # back
    assert _outcome(client, handle)[1].error_code == SUCCESSFUL


def test_a_trajectory_stamped_in_the_future_starts_then(suite):
    from action_msgs.msg import GoalStatus

    client, action = suite
    # sent to a paused simulator: the goal is taken before its start however loaded the machine
    # (in a running one, a goal taken after its trajectory's end would be OLD_HEADER_TIMESTAMP)
    with _paused(client) as now:
        start = now + 500_000_000
        handle, feedback = _send(client, action, _goal([(0.2, (0.98,))], ("c4_8",), stamp_ns_=start,
                                                       goal_time=UNTIL_REACHED))
    status, result = _outcome(client, handle)
    assert (status, result.error_code) == (GoalStatus.STATUS_SUCCEEDED, SUCCESSFUL), result.error_string
    _until_the_end(client, feedback, 200_000_000)
    assert all(stamp_ns(fb.header.stamp) >= start for fb in feedback)
    # every state between the goal and its start (0.5 s of them: a loaded run may lose a few)
    before = [dict(zip(m.name, m.rest_length))["c4_8"] for t, m in client.stamped_copy("cable_states").items()
              if now <= t < start]
    assert before and set(before) == {NOMINAL}                     # the motor waited for the start
    handle, _ = _send(client, action, _goal([(0.2, (NOMINAL,))], ("c4_8",), goal_time=UNTIL_REACHED))   # back
    assert _outcome(client, handle)[1].error_code == SUCCESSFUL


def test_a_trajectory_stamped_in_the_past_is_joined_where_it_is_now(suite):
    """joint_trajectory_controller takes a trajectory whose start is past and whose end is not
    (validate_trajectory_msg refuses only one that has ended) and samples it at the present
    time: the first feedback is already 0.2 s into it, and the desired positions are the
    trajectory's (linear from the rest length at its start) from there."""
    from action_msgs.msg import GoalStatus

    client, action = suite
    # 0.2 s past, sent to a paused simulator: the goal is taken at the time read here however
    # loaded the machine (in a running one, a goal taken after its trajectory's end would be
    # OLD_HEADER_TIMESTAMP)
    with _paused(client) as now:
        start = now - 200_000_000
        handle, feedback = _send(client, action, _goal([(1.0, (0.976,))], ("c5_8",), stamp_ns_=start,
                                                       goal_time=UNTIL_REACHED))
    status, result = _outcome(client, handle)
    assert (status, result.error_code) == (GoalStatus.STATUS_SUCCEEDED, SUCCESSFUL), result.error_string
    _until_the_end(client, feedback, 1_000_000_000)
    taus = [stamp_ns(fb.desired.time_from_start) for fb in feedback]
    assert min(taus) >= 200_000_000, min(taus)
    for fb in feedback:
        tau = stamp_ns(fb.desired.time_from_start) / 1e9
        # tau: the state's time from the start, in seconds as floats (1 ns of rounding)
        assert abs(stamp_ns(fb.header.stamp) - start - stamp_ns(fb.desired.time_from_start)) <= 1
        assert fb.desired.positions[0] == pytest.approx(NOMINAL + (0.976 - NOMINAL) * min(tau, 1.0), abs=1e-9)
    handle, _ = _send(client, action, _goal([(0.2, (NOMINAL,))], ("c5_8",), goal_time=UNTIL_REACHED))   # back
    assert _outcome(client, handle)[1].error_code == SUCCESSFUL


def test_points_with_velocities_are_followed_as_cubic_hermite_segments(suite):
    """joint_trajectory_controller's interpolation with positions and velocities: a cubic
    Hermite segment between points, the first from the current rest length at rest at time 0
    (computed here with scipy's CubicHermiteSpline)."""
    from action_msgs.msg import GoalStatus
    from scipy.interpolate import CubicHermiteSpline

    client, action = suite
    times, positions, velocities = [0.2, 0.4], [0.985, 0.975], [-0.05, 0.0]
    goal = _goal(list(zip(times, [(p,) for p in positions])), ("c5_11",), velocities=[(v,) for v in velocities],
                 goal_time=UNTIL_REACHED)
    handle, feedback = _send(client, action, goal)
    status, result = _outcome(client, handle)
    assert (status, result.error_code) == (GoalStatus.STATUS_SUCCEEDED, SUCCESSFUL), result.error_string
    _until_the_end(client, feedback, 400_000_000)
    spline = CubicHermiteSpline([0.0, *times], [NOMINAL, *positions], [0.0, *velocities])
    inside = [fb for fb in feedback if stamp_ns(fb.desired.time_from_start) < 400_000_000]
    assert len(inside) >= 5
    for fb in inside:
        tau = stamp_ns(fb.desired.time_from_start) / 1e9
        assert fb.desired.positions[0] == pytest.approx(spline(tau), abs=1e-8), tau
        assert fb.desired.velocities[0] == pytest.approx(spline(tau, 1), abs=1e-6), tau
    handle, _ = _send(client, action, _goal([(0.2, (NOMINAL,))], ("c5_11",), goal_time=UNTIL_REACHED))   # back
    assert _outcome(client, handle)[1].error_code == SUCCESSFUL


def test_the_controller_state_is_published_as_joint_trajectory_controller_publishes_it(suite):
    """joint_trajectory_controller publishes control_msgs/JointTrajectoryControllerState on
    ``~/controller_state`` at every update, over all its joints in its order, error = reference
    - feedback; a subscriber with rclpy's default QoS (reliable, volatile, keep last 10) reads
    it. Here, with every cable_states sample: feedback = that sample's rest lengths, output =
    the command sent on cable_commands for the same stamp, reference = the trajectory for the
    goal's joint and the held rest length for the others; after the goal the joint holds its
    last command: the target. The step of 0.02 m takes 1 s, ~100 cable states: the goal's
    states reach a controller or a client that stalled under load for part of it (a 0.05 s
    step, ~5 states, was missed whole by one loaded run)."""
    client, action = suite
    joints = list(client.received["joint_states"][-1].name)    # the simulator's commanded cables
    name = joints[-1]
    column = joints.index(name)
    start = _rest(client, (name,))[0]
    target = start - 0.02
    states = client.received[STATE]
    # the states come in order from one writer: after an idle one (time_from_start 0), every
    # state of an earlier goal has come, and those with a time_from_start are this goal's
    mark = len(states)
    mark = client.wait(lambda: next((mark + i + 1 for i, s in enumerate(states[mark:])
                                     if stamp_ns(s.reference.time_from_start) == 0), None), "an idle controller_state")
    handle, _ = _send(client, action, _goal([(1.0, (target,))], (name,), goal_time=UNTIL_REACHED, goal=[(name, 1e-4)]))
    assert _outcome(client, handle)[1].error_code == SUCCESSFUL

    def split():
        """This goal's states (time_from_start > 0) and the first idle one after them, once it came."""
        ours = list(states[mark:])
        running = [i for i, s in enumerate(ours) if stamp_ns(s.reference.time_from_start) > 0]
        after = [s for s in ours[running[0]:] if stamp_ns(s.reference.time_from_start) == 0] if running else []
        return (ours[running[0]:running[-1] + 1], after[0]) if after else None

    during, held = client.wait(split, "the controller_state of the goal and one after it")
    assert all(stamp_ns(s.reference.time_from_start) > 0 for s in during)
    # every command the controller sent for these states has come (one writer, in stamp order)
    client.wait(lambda: stamp_ns(client.received["cable_commands"][-1].header.stamp) >= stamp_ns(held.header.stamp),
                "the controller's commands up to the state after the goal")
    cables = client.stamped["cable_states"]
    commands = client.stamped["cable_commands"]
    for s in [*during, held]:
        n = len(joints)
        assert list(s.joint_names) == joints
        assert len(s.reference.velocities) == len(s.reference.accelerations) == len(s.feedback.effort) == n
        assert len(s.reference.positions) == len(s.feedback.positions) == len(s.error.positions) == n
        assert s.speed_scaling_factor == 1.0
        for r, f, e in zip(s.reference.positions, s.feedback.positions, s.error.positions):
            assert e == pytest.approx(r - f, abs=1e-12)                 # control_msgs: reference - feedback
        sample = cables.get(stamp_ns(s.header.stamp))
        if sample is not None:                                          # feedback = the simulator's rest lengths
            rest = dict(zip(sample.name, sample.rest_length))
            assert list(s.feedback.positions) == [rest[j] for j in joints]
        command = commands.get(stamp_ns(s.header.stamp))
        if command is not None and name in command.name:                # output = the command sent
            assert s.output.positions[column] == command.rest_length[list(command.name).index(name)]
        others = [j for j in range(n) if j != column]
        assert [s.output.positions[j] for j in others] == [s.reference.positions[j] for j in others]
    assert any(target < s.reference.positions[column] < start for s in during), "no reference between start and end"
    assert stamp_ns(held.reference.time_from_start) == 0
    assert held.reference.positions[column] == pytest.approx(target, abs=1e-12)
    assert held.output.positions[column] == pytest.approx(target, abs=1e-12)
    handle, _ = _send(client, action, _goal([(0.2, (start,))], (name,), goal_time=UNTIL_REACHED))     # back
    assert _outcome(client, handle)[1].error_code == SUCCESSFUL


def test_a_trajectory_on_the_joint_trajectory_topic_takes_over_and_is_followed(suite):
    """joint_trajectory_controller's topic interface: a JointTrajectory on
    ``~/joint_trajectory`` replaces what runs and is followed (seen on ``~/controller_state``
    and in the rest lengths); the action goal it takes over from ends ABORTED with INVALID_GOAL
    (docs/ros.md: this suite's one difference). It is published until that goal has ended (a
    publication before the controller's reader has matched the writer may be lost); each copy
    starts the same move again from its arrival."""
    import threading
    import time

    from action_msgs.msg import GoalStatus
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    client, action = suite
    joints = list(client.received["joint_states"][-1].name)
    name = joints[0]
    column = joints.index(name)
    start = _rest(client, (name,))[0]
    target = start - 0.02
    pub = client.publisher(JointTrajectory, "/tensegrity_cable_controller/joint_trajectory")
    handle, feedback = _send(client, action, _goal([(30.0, (start - 0.01,))], (name,)))
    client.wait(lambda: len(feedback) > 0, "the feedback of the running goal")
    ended = client.request(handle.get_result_async, "the goal's result")
    arrived = threading.Event()
    ended.add_done_callback(lambda _f: arrived.set())
    trajectory = JointTrajectory(joint_names=[name], points=[
        JointTrajectoryPoint(positions=[target], time_from_start=Duration(nanosec=50_000_000))])
    deadline = time.monotonic() + 60.0
    mark = len(client.received[STATE])       # this trajectory's states come after
    pub.publish(trajectory)
    while not arrived.wait(1.0):
        assert time.monotonic() < deadline, "waited 60 s for the topic's trajectory to take over"
        pub.publish(trajectory)
    answer = ended.result()
    assert (answer.status, answer.result.error_code) == (GoalStatus.STATUS_ABORTED, INVALID_GOAL)
    assert "preempted" in answer.result.error_string
    client.wait_for(STATE, lambda s: stamp_ns(s.reference.time_from_start) >= 50_000_000
                    and s.reference.positions[column] == pytest.approx(target, abs=1e-12),
                    "a controller_state after the topic trajectory's end", since=mark)
    client.wait(lambda: abs(_rest(client, (name,))[0] - target) <= 1e-3, "the rest length at the target")
    handle, _ = _send(client, action, _goal([(0.2, (start,))], (name,), goal_time=UNTIL_REACHED))     # back
    assert _outcome(client, handle)[1].error_code == SUCCESSFUL
