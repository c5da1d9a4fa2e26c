"""tensegrity_cable_controller over real DDS: control_msgs' FollowJointTrajectory on the
actuated tensegrity table, as a joint_trajectory_controller client would use it.

A lockstep simulator (paused; this process steps it) and the cable controller, which answers
every state of a running goal. Oracles: the core's trajectory sampled at the states' times
and the core simulator stepped under it in this process (equal to the last bit), the
goal's own points, and the result codes of control_msgs.
"""

from __future__ import annotations

import math
import re
import time
from contextlib import contextmanager

import numpy as np
import pytest

from tensegrity_ros.rclpy_utils.futures import on_executor, wait_done
from tensegrity_ros.rclpy_utils.matching import wait_for_action_server, wait_until_server_heard
from tests.ros_support import FeedbackLog, heard_by, open_context

pytestmark = pytest.mark.ros

STEP_NS = 10_000_000
ACTION = "/tensegrity_cable_controller/follow_joint_trajectory"


@contextmanager
def cable_rig(folder, scene: str, sim_params: tuple[str, ...], client_name: str, before=None):
    """The simulator of ``scene`` (paused, with ``-p`` parameters ``sim_params``) and the cable
    controller, a :class:`SimClient` named ``client_name``, an action client the controller
    has heard, and a :class:`FeedbackLog`, once the controller answers a state (it is active):
    yields ``(client, action, sim, ctl, feedback_log)``, then stops them all (also when
    set-up fails). ``before(client)``, if given, makes subscriptions the probe then proves
    matched."""
    import rclpy
    from control_msgs.action import FollowJointTrajectory
    from rclpy.action import ActionClient

    from tensegrity_ros.apps.sim_client import SimClient
    from tests.ros_support import Proc

    args = ["-p", f"scene:={scene}"]
    for param in ("initial_state:=paused", *sim_params):
        args += ["-p", param]
    sim = Proc(["node", "sim", "--ros-args", *args], folder / "sim.log")
    ctl = Proc(["node", "cables", "--ros-args", "-p", f"scene:={scene}"], folder / "cables.log")
    client = action = None
    try:
        sim.wait_for("publishing at")
        ctl.wait_for("cable controller ready")
        with open_context() as ctx:
            try:
                client = SimClient(rclpy, client_name, context=ctx)
                client.wait_for_services(60)
                feedback_log = FeedbackLog(client.node, FollowJointTrajectory, ACTION)   # before the probe: matched
                if before is not None:
                    before(client)
                action = ActionClient(client.node, FollowJointTrajectory, ACTION)
                assert wait_for_action_server(client.node, action, 60)
                assert wait_until_server_heard(client.node, ACTION, wait_done, 60)
                _wait_for_the_controllers_answer(client)
                yield client, action, sim, ctl, feedback_log
            finally:
                # the action client is destroyed by the thread that spins its node (between two
                # spin_once): destroyed from this one while that thread built a wait set from the
                # node's waitables, rclpy added the freed handle ("action client pointer is invalid",
                # RCLError in a loaded run's spin thread); if that thread no longer spins, from here
                destroyed = action is None or wait_done(on_executor(client.executor, action.destroy), 60)
                if not destroyed:
                    action.destroy()
                if client is not None:
                    client.close()
    finally:
        for p in (sim, ctl):
            p.stop()


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    """The simulator (lockstep, paused, republishing at 20 Hz), the cable controller, a
    stepping client and an action client (:func:`cable_rig`)."""
    with cable_rig(tmp_path_factory.mktemp("cables"), "table_actuated",
                   (f"step_size:={STEP_NS / 1e9}", "lockstep:=true", "paused_publish_rate:=20.0",
                    "lockstep_timeout:=30.0"), "cable_test_client") as parts:
        yield parts


def _wait_for_the_controllers_answer(client, timeout: float = 60.0) -> None:
    """Until the cable controller answers a state the paused simulator republishes (its
    ``cable_commands``): it answers once it has joint_states and cable_states, so from then
    on a goal starts at once (one sent before would wait for the states) at the simulation
    time the controller has, the simulator's."""
    import threading

    from tensegrity_msgs.msg import CableCommand

    seen = threading.Event()
    sub = client.node.create_subscription(CableCommand, "cable_commands", lambda _msg: seen.set(), 10)
    try:
        assert seen.wait(timeout), "the cable controller answered no state of the simulator"
    finally:   # by the spinning thread, which may be building its wait set from the subscription
        destroyed = on_executor(client.executor, lambda: client.node.destroy_subscription(sub))
        assert wait_done(destroyed, timeout), "the client's thread did not destroy the subscription"


def _goal(points, names=("long1", "long2"), velocities=None, stamp_ns=0, **extra):
    from builtin_interfaces.msg import Duration
    from control_msgs.action import FollowJointTrajectory
    from trajectory_msgs.msg import JointTrajectoryPoint

    goal = FollowJointTrajectory.Goal(**extra)
    goal.trajectory.joint_names = list(names)
    goal.trajectory.header.stamp.sec, goal.trajectory.header.stamp.nanosec = divmod(stamp_ns, 10**9)
    for k, (t, pos) in enumerate(points):
        sec = math.floor(t)
        p = JointTrajectoryPoint(positions=list(pos), time_from_start=Duration(sec=int(sec),
                                                                                nanosec=round((t - sec) * 1e9)))
        if velocities is not None:
            p.velocities = list(velocities[k])
        goal.trajectory.points.append(p)
    return goal


def _send(client, action, goal):
    """Send ``goal``; its handle (its feedback: the rig's :class:`FeedbackLog`)."""
    return _asked(client, lambda: action.send_goal_async(goal), 30)


def _asked(client, call, timeout: float):
    """The result of the future ``call()`` returns, ``call`` made by the client's spinning thread
    (rclpy_utils.futures.on_executor: from this thread the answer can be dropped)."""
    task = on_executor(client.executor, call)
    assert wait_done(task, timeout), "the spinning thread did not run the call"
    assert wait_done(task.result(), timeout), "no answer"
    return task.result().result()


def _result(client, handle, timeout: float = 60.0):
    answer = _asked(client, handle.get_result_async, timeout)
    return answer.status, answer.result


def _ended(fb, duration: float, tolerance: float) -> bool:
    """Whether feedback ``fb`` is of a state that ends a goal: at or after the trajectory's end
    (``duration`` [s] from its start), every joint within ``tolerance`` [m]."""
    t = fb.desired.time_from_start
    return t.sec + t.nanosec / 1e9 >= duration and all(abs(e) <= tolerance for e in fb.error.positions)


def _t0(client) -> int:
    """The simulation time [ns] the simulator waits at (its latest state)."""
    client.take_joints()
    return client.wait_joint().stamp_ns


def test_a_trajectory_is_followed_in_lockstep_exactly_as_the_core_samples_it(rig):
    from action_msgs.msg import GoalStatus

    from tensegrity_core.sim import Simulator
    from tensegrity_core.sim.joint_trajectory import SUCCESSFUL, plan_trajectory
    from tensegrity_core.sim.sampled import step_time

    client, action, sim, _, feedback_log = rig
    t0 = _t0(client)
    points = [(0.1, (0.88, 0.9)), (0.25, (0.85, 0.93)), (0.3, (0.86, 0.92))]
    velocities = [(-0.2, 0.1), (0.0, 0.1), (0.0, 0.0)]
    handle = _send(client, action, _goal(points, velocities=velocities))
    assert handle.accepted
    steps = 40                                     # 0.4 s: past the end (0.3 s), the goal succeeds
    client.step_received(steps, t0, STEP_NS, chunk=10)
    status, result = _result(client, handle)
    assert status == GoalStatus.STATUS_SUCCEEDED and result.error_code == SUCCESSFUL, result.error_string
    ros = {j.stamp_ns: j for j in client.joints_since(t0)}
    # the core: the same trajectory, sampled at each t_k and held, from the same state
    interface = Simulator("table_actuated").interface
    core = Simulator("table_actuated")
    assert t0 == 0 or core.t == 0
    tr = plan_trajectory(["long1", "long2"], [t for t, _ in points], [p for _, p in points], velocities,
                         interface=interface, start=[0.9, 0.9, 0.9])
    lengths = [core.observe().member_lengths[:3]]
    for k in range(steps):
        core.set_command(tr.command(step_time(k, STEP_NS) - t0 / 1e9, [0.9, 0.9, 0.9]))
        core.advance(step_time(k + 1, STEP_NS))
        lengths.append(core.observe().member_lengths[:3])
    if t0 == 0:
        np.testing.assert_array_equal(np.array([ros[k * STEP_NS].position for k in range(steps + 1)]),
                                      np.array(lengths))
    # feedback: desired from the trajectory, actual = the rest lengths the simulator reports;
    # the goal ended on the first state after the end (0.3 s) within the goal tolerance
    # (1e-4 m, the controller's default), whose feedback is the goal's last
    feedback = feedback_log.until(handle, lambda fbs: any(_ended(fb, 0.3, 1e-4) for fb in fbs),
                                  "the feedback of the state that ended the goal")
    assert len(feedback) >= steps // 2
    last = feedback[-1]
    assert list(last.joint_names) == ["long1", "long2"]
    np.testing.assert_allclose(last.desired.positions, [0.86, 0.92], atol=1e-12)
    np.testing.assert_allclose(last.actual.positions, [0.86, 0.92], atol=1e-12)
    assert all(e > 0 for e in last.actual.effort)                 # tensions [N]
    assert "no command for step" not in sim.stderr()


@pytest.mark.parametrize("goal_args, code, reason", [
    ({"points": [(0.5, (0.8,))], "names": ("long7",)}, -2, "unknown joint 'long7'; the joints are long1, long2, long3"),
    ({"points": [(0.5, (0.8,)), (0.5, (0.7,))], "names": ("long1",)}, -1, "must increase strictly"),
    ({"points": [(0.5, (-0.8,))], "names": ("long1",)}, -1, "position of long1 = -0.8 m is outside its range"),
    ({"points": [(0.5, (0.8,))], "names": ("long1",), "stamp_ns": 1}, -3, "ended before the simulation's time"),
])
def test_bad_goals_are_refused_with_control_msgs_codes(rig, goal_args, code, reason):
    from action_msgs.msg import GoalStatus

    client, action, _, _, _ = rig
    if goal_args.get("stamp_ns") == 1:             # a trajectory over before now: step to t > 0.5 s first
        goal = _goal([(0.6, (0.9,))], names=("long1",))
        handle = _send(client, action, goal)
        t0 = _t0(client)
        client.step_received(70, t0, STEP_NS, chunk=10)
        assert _result(client, handle)[0] == GoalStatus.STATUS_SUCCEEDED
    handle = _send(client, action, _goal(**goal_args))
    status, result = _result(client, handle)
    assert status == GoalStatus.STATUS_ABORTED and result.error_code == code and reason in result.error_string


@pytest.mark.parametrize("key", ["component_path_tolerance", "component_goal_tolerance"])
def test_a_goal_with_component_tolerances_is_refused_not_ignored(rig, key):
    """Component tolerances bound the x, y, z, translation or rotation of multi-DOF joints: a
    cable has none, so the bound could never be checked, and accepting it would report success
    against it. Refused INVALID_GOAL with the reason (about 0.1 s on the module's rig)."""
    from action_msgs.msg import GoalStatus
    from control_msgs.msg import JointComponentTolerance

    client, action, _, _, _ = rig
    bound = JointComponentTolerance(joint_name="long1", component=JointComponentTolerance.TRANSLATION, position=1e-3)
    handle = _send(client, action, _goal([(0.5, (0.8,))], names=("long1",), **{key: [bound]}))
    status, result = _result(client, handle)
    assert status == GoalStatus.STATUS_ABORTED and result.error_code == -1, result.error_string
    assert result.error_string.startswith(f"{key} (1 given) is not supported"), result.error_string


def test_a_tight_path_tolerance_is_violated_and_a_new_goal_preempts_the_running_one(rig):
    from action_msgs.msg import GoalStatus
    from control_msgs.msg import JointTolerance

    from tensegrity_core.sim.joint_trajectory import INVALID_GOAL, PATH_TOLERANCE_VIOLATED

    client, action, _, _, _ = rig
    t0 = _t0(client)
    # the rest lengths are held over each step: one step behind a moving reference (v h)
    tight = _goal([(0.3, (0.8, 0.8))], path_tolerance=[JointTolerance(name="long1", position=1e-6)])
    handle = _send(client, action, tight)
    client.step_received(10, t0, STEP_NS, chunk=5)
    status, result = _result(client, handle)
    assert status == GoalStatus.STATUS_ABORTED and result.error_code == PATH_TOLERANCE_VIOLATED
    # long1 comes down to 0.8 m (from 0.86 or 0.9 m, whichever test ran before) and its held rest
    # length trails above the desired one: desired - actual < 0, the sign of the feedback's error
    assert "long1: position error -" in result.error_string
    first = _send(client, action, _goal([(5.0, (0.9, 0.9))]))
    second = _send(client, action, _goal([(0.05, (0.9, 0.9))]))
    status, result = _result(client, first)
    assert status == GoalStatus.STATUS_ABORTED and result.error_code == INVALID_GOAL
    assert "preempted" in result.error_string
    _asked(client, second.cancel_goal_async, 30)
    status, result = _result(client, second)
    assert status == GoalStatus.STATUS_CANCELED and result.error_code == 0 and "cancelled" in result.error_string


def test_a_reset_of_the_simulation_ends_the_running_goal(rig):
    """ResetSimulation takes the simulation time back (to 0): the running goal's trajectory,
    timed from a start the new run has not reached, would otherwise wait that long and then
    report success over a run it never drove. It ends at the first joint state from before its
    time, as the class-2 controller's goals do (there SIMULATOR_STOPPED; control_msgs has no
    such code: ABORTED with INVALID_GOAL, as for a preempted goal). No process of its own:
    a few steps of the module's rig (~1 s)."""
    from action_msgs.msg import GoalStatus

    from tensegrity_core.sim.joint_trajectory import INVALID_GOAL

    client, action, _, _, _ = rig
    t0 = _t0(client)
    handle = _send(client, action, _goal([(5.0, (0.88, 0.88))]))
    client.step_received(5, t0, STEP_NS)
    client.restart()                    # the state at t = 0 of the new run: the controller's next state
    status, result = _result(client, handle, 15.0)
    assert status == GoalStatus.STATUS_ABORTED and result.error_code == INVALID_GOAL, result.error_string
    # the time the controller last had: the 5th state's, or the 4th's when the reset's state
    # replaced the 5th in its queue (depth 1) before it took it; it answered the 4th, or the
    # lockstep simulator would not have stepped to the 5th
    went = re.match(r"the simulation was reset: its time went back from (\S+) s to 0 s;", result.error_string)
    assert went is not None, result.error_string
    assert float(went[1]) in ((t0 + 4 * STEP_NS) / 1e9, (t0 + 5 * STEP_NS) / 1e9), result.error_string


def test_the_commands_keep_the_history_of_the_other_per_step_writers(ros_context):
    """``cable_commands`` goes out once per simulator step, as ``actuator_forces`` and the
    simulator's topics do: its reliable writer keeps the same 1,000 samples (1 s of a lockstep
    run at 1,000 steps/s) for a recorder that briefly falls behind to be repaired from."""
    from rclpy.parameter import Parameter
    from rclpy.qos import HistoryPolicy

    from tensegrity_ros.nodes.cable_controller import CableControllerNode
    from tensegrity_ros.nodes.controller import ControllerNode

    cables = CableControllerNode(context=ros_context,
                                 parameter_overrides=[Parameter("scene", value="table_actuated")])
    forces = ControllerNode(context=ros_context)
    depth = {pub.topic_name: (pub.qos_profile.history, pub.qos_profile.depth)
             for node in (cables, forces) for pub in node.publishers if pub.topic_name != "/rosout"}
    assert depth["/cable_commands"] == depth["/actuator_forces"] == (HistoryPolicy.KEEP_LAST, 1000), depth


def test_a_refused_joint_trajectory_is_logged_once_in_one_line_and_the_running_goal_goes_on(rig):
    """``~/joint_trajectory`` has no result to refuse with: a trajectory naming an unknown
    joint, with times that do not increase or a position that is not a number is refused
    with one log line each, and the goal running meanwhile ends as it would have (a taken
    trajectory would have preempted it: ABORTED)."""
    from action_msgs.msg import GoalStatus
    from trajectory_msgs.msg import JointTrajectory

    from tensegrity_core.sim.joint_trajectory import SUCCESSFUL
    from tensegrity_ros.rclpy_utils.matching import wait_for_matches

    client, action, _, ctl, feedback_log = rig
    t0 = _t0(client)
    handle = _send(client, action, _goal([(0.2, (0.87, 0.91))]))
    assert handle.accepted
    bad = {
        "unknown joint 'long7'; the joints are long1, long2, long3": _goal([(0.5, (0.8,))], names=("long7",)),
        "time_from_start must increase strictly": _goal([(0.5, (0.8,)), (0.5, (0.7,))], names=("long1",)),
        "point 0: positions[0] is not finite (nan)": _goal([(0.5, (math.nan,))], names=("long1",)),
    }
    logged = len(ctl.stderr())                                 # the module's earlier tests logged before
    pub = client.node.create_publisher(JointTrajectory, "/tensegrity_cable_controller/joint_trajectory", 10)
    try:
        assert wait_for_matches([pub], 1, 60)
        heard_by(client.node, ["/tensegrity_cable_controller"], wait_done)   # each goal is sent once
        client.step_received(5, t0, STEP_NS, chunk=5)          # the goal runs
        for reason, goal in bad.items():
            pub.publish(goal.trajectory)
            ctl.wait_for(reason, timeout=60, since=logged)    # one at a time: the subscription keeps the last only
    finally:   # by the spinning thread, which may be building its wait set from the publisher's events
        destroyed = on_executor(client.executor, lambda: client.node.destroy_publisher(pub))
        assert wait_done(destroyed, 60), "the client's thread did not destroy the publisher"
    client.step_received(25, t0 + 5 * STEP_NS, STEP_NS, chunk=5)   # to 0.3 s, past the goal's end (0.2 s)
    status, result = _result(client, handle)
    assert status == GoalStatus.STATUS_SUCCEEDED and result.error_code == SUCCESSFUL, result.error_string
    fb = feedback_log.until(handle, lambda fbs: any(_ended(f, 0.2, 1e-4) for f in fbs), "the goal's last feedback")
    np.testing.assert_allclose(fb[-1].desired.positions, [0.87, 0.91], atol=1e-12)
    log = ctl.stderr()[logged:].splitlines()
    for reason in bad:
        lines = [line for line in log if reason in line]
        assert len(lines) == 1 and "joint_trajectory ignored: " in lines[0], lines


def test_a_goal_stamped_on_the_wall_clock_waits_and_says_why(rig):
    """A client without use_sim_time stamps its trajectory with the wall clock, ~1.8e9 s: as
    joint_trajectory_controller the controller waits for that simulation time (the goal runs,
    no feedback yet), and its log says why, so the client's silent wait has a reason."""
    from action_msgs.msg import GoalStatus

    client, action, _, ctl, _ = rig
    wall = time.time_ns()
    handle = _send(client, action, _goal([(0.5, (0.9, 0.9))], stamp_ns=wall))
    assert handle.accepted
    ctl.wait_for("is its trajectory.header.stamp wall-clock time")
    _asked(client, handle.cancel_goal_async, 30)
    status, _ = _result(client, handle)
    assert status == GoalStatus.STATUS_CANCELED
