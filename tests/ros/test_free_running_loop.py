"""The 6-bar simulator free-running (not lockstep: it steps on at real time whether or not a
command came) with tensegrity_cable_controller closing the loop over real DDS: the controller
answers every joint_states with the rest lengths of a FollowJointTrajectory goal, sent here
as a ros2_control client sends it, and checks the goal on cable_states.

The outcome is read from the simulator's ``cable_states`` (what the motors did, in
simulation time) against the robot description's motor model (``tensegrity_core.robot.motor``:
``dl0/dt = clip((target - l0) / tau, -max_speed, max_speed)``), not against timings: the goal
succeeds; both cables come to their commanded rest lengths within the goal tolerance; no
rest length moves faster than its motor's slew limit between two states, so each needs at
least ``distance / max_speed`` of simulation time from its last state at rest; the other 22
motors hold their rest lengths exactly. A loaded machine slows the run (real time is a
ceiling, not a promise) and delays the controller's answers, for as long as the machine
starves the controller: the goal's time tolerance is -1 (control_msgs: no limit), so that the
goal waits for its tolerance; a fixed one (5 s of simulation time, i.e. of wall time here) is
missed by a controller starved that long, while its following is right.
"""

from __future__ import annotations

import threading

import pytest

from tests.ros.test_cable_controller import _goal, _result, _send, cable_rig

pytestmark = [pytest.mark.ros, pytest.mark.slow]

CABLES = ("c0_4", "c0_7")
TARGETS = (0.90, 0.95)         # m, from the drawn 0.996: a 0.096 m and a 0.046 m reel-in
GOAL_TOLERANCE = 1e-4          # m: the controller's default
NS_PER_S = 1_000_000_000


def test_a_free_running_robot_follows_a_trajectory_goal_within_its_motors_slew_limit(tmp_path):
    from action_msgs.msg import GoalStatus
    from builtin_interfaces.msg import Duration
    from rclpy.qos import QoSProfile
    from simulation_interfaces.msg import SimulationState
    from tensegrity_msgs.msg import CableStates

    from tensegrity_core.robot.loading import load_robot
    from tensegrity_core.sim.joint_trajectory import SUCCESSFUL

    robot = load_robot("six_bar")
    motor_names = [robot.cables.names[c] for c in robot.motors.cable]
    max_speed = {name: float(robot.motors.max_speed[i]) for i, name in enumerate(motor_names)}
    states: list = []
    arrived = threading.Condition()

    def on_cables(msg) -> None:
        with arrived:
            states.append(msg)
            arrived.notify_all()

    def rest(msg) -> dict[str, float]:
        return dict(zip(msg.name, msg.rest_length))

    def arrived_at_targets() -> bool:
        return bool(states) and all(abs(rest(states[-1])[c] - t) <= GOAL_TOLERANCE for c, t in zip(CABLES, TARGETS))

    params = ("step_size:=0.001", "real_time_factor:=1.0", "paused_publish_rate:=20.0", "publish_rate:=100.0",
              "state_rate:=100.0", "imu_rate:=0.0", "marker_rate:=0.0")
    with cable_rig(tmp_path, "six_bar_drop", params, "free_running_loop_client", before=lambda client: (
            client.node.create_subscription(CableStates, "cable_states", on_cables, QoSProfile(depth=1000)))) as (
            client, action, _, _, _):
        client.set_state(SimulationState.STATE_PLAYING)
        goal = _goal([(0.1, TARGETS)], names=CABLES, goal_time_tolerance=Duration(sec=-1))
        handle = _send(client, action, goal)
        assert handle.accepted
        status, result = _result(client, handle, timeout=300.0)
        assert status == GoalStatus.STATUS_SUCCEEDED and result.error_code == SUCCESSFUL, result.error_string
        with arrived:        # the controller saw it on a cable_states this client may not have taken yet
            assert arrived.wait_for(arrived_at_targets, timeout=60.0), "no cable_states at the goal arrived"
            run = list(states)

    stamps = [m.header.stamp.sec * NS_PER_S + m.header.stamp.nanosec for m in run]
    assert stamps == sorted(stamps)
    first = rest(run[0])
    for name in motor_names:
        if name not in CABLES:
            assert all(rest(m)[name] == first[name] for m in run), name      # held exactly
    for name, target in zip(CABLES, TARGETS):
        values = [rest(m)[name] for m in run]
        for (t0, r0), (t1, r1) in zip(zip(stamps, values), zip(stamps[1:], values[1:])):
            assert abs(r1 - r0) <= max_speed[name] * (t1 - t0) / NS_PER_S + 1e-12, (name, t0, t1, r0, r1)
        at_rest = max(i for i, v in enumerate(values) if v == first[name])  # the last state before it moved
        reached = next(i for i, v in enumerate(values) if abs(v - target) <= GOAL_TOLERANCE)
        distance = abs(target - first[name]) - GOAL_TOLERANCE
        assert (stamps[reached] - stamps[at_rest]) / NS_PER_S >= distance / max_speed[name], name
        assert distance > 0.04                                # a move the slew limit shapes (>= 80 ms)
