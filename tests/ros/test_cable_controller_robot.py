"""tensegrity_cable_controller driving a robot's motor cables over real DDS: control_msgs'
FollowJointTrajectory on the 6-bar (``six_bar_drop``), joint names = cable names, with a
lockstep simulator stepped from this process.

Oracles: the core simulator stepped in this process under the core's trajectory sampled at
the same times (equal to the last bit), and the motor model: the rest length a motor reports
trails the commanded one. The trajectory moves c0_4 0.096 m in 0.1 s (up to 0.92 m/s); its
motor slews at 0.5 m/s at most with a 0.02 s lag, so at the trajectory's end it trails by
several centimetres and needs the goal's ``goal_time_tolerance`` (0.2 s) to come within
the goal tolerance (1e-4 m).
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.ros.test_cable_controller import _ended, _goal, _result, _send, _t0, cable_rig

pytestmark = pytest.mark.ros

STEP_NS = 1_000_000
CABLES = ("c0_4", "c0_7")


@pytest.fixture
def rig(tmp_path):
    with cable_rig(tmp_path, "six_bar_drop",
                   (f"step_size:={STEP_NS / 1e9}", "lockstep:=true", "paused_publish_rate:=20.0",
                    "lockstep_timeout:=30.0", "publish_rate:=1000.0", "state_rate:=1000.0", "imu_rate:=0.0",
                    "marker_rate:=0.0"), "robot_cable_test_client") as parts:
        yield parts


def test_a_gait_of_two_motor_cables_is_followed_as_the_core_runs_it_and_settles_through_the_motors_lag(rig):
    from action_msgs.msg import GoalStatus
    from builtin_interfaces.msg import Duration

    from tensegrity_core.sim import Simulator
    from tensegrity_core.sim.joint_trajectory import SUCCESSFUL, plan_trajectory
    from tensegrity_core.sim.sampled import step_time

    client, action, sim, _, feedback_log = rig
    t0 = _t0(client)
    points = [(0.05, (0.95, 0.97)), (0.1, (0.9, 0.95))]
    goal = _goal(points, names=CABLES, goal_time_tolerance=Duration(sec=0, nanosec=200_000_000))
    handle = _send(client, action, goal)
    assert handle.accepted
    steps = 300                                    # the trajectory's 0.1 s, then the motors settle
    client.step_received(steps, t0, STEP_NS, chunk=50)
    status, result = _result(client, handle)
    assert status == GoalStatus.STATUS_SUCCEEDED and result.error_code == SUCCESSFUL, result.error_string
    ros = {j.stamp_ns: j for j in client.joints_since(t0)}
    feedback = feedback_log.until(handle, lambda fbs: any(_ended(fb, 0.1, 1e-4) for fb in fbs),
                                  "the feedback of the state that ended the goal")    # the default tolerance
    last = feedback[-1]
    assert list(last.joint_names) == list(CABLES)
    np.testing.assert_allclose(last.actual.positions, [0.9, 0.95], atol=1e-4)     # the goal tolerance
    lagging = [f for f in feedback if abs(f.desired.positions[0] - 0.9) < 1e-12]
    assert lagging and abs(lagging[0].actual.positions[0] - 0.9) > 1e-3     # the motor trails at the end
    # the core under the same trajectory, sampled at each t_k and held, from the same state
    assert t0 == 0                                 # a new paused simulator waits at its start
    core = Simulator("six_bar_drop")
    held = list(core.command)
    tr = plan_trajectory(list(CABLES), [t for t, _ in points], [p for _, p in points],
                         interface=core.interface, start=held)
    motors = list(core.interface.members)
    for k in range(steps):
        core.set_command(tr.command(step_time(k, STEP_NS), held))
        core.advance(step_time(k + 1, STEP_NS))
    np.testing.assert_array_equal(ros[steps * STEP_NS].position, core.observe().member_lengths[motors])
    assert "no command for step" not in sim.stderr()
