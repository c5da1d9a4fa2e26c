"""The simulator node warns before the state reaches a singular set, then stops there with
the state held and keeps publishing (issue 9), over DDS on loopback."""

from __future__ import annotations

import math
import time

import pytest

from tensegrity_core.class2 import PAPER_PARAMS, dynamics_singularity
from tensegrity_ros.rclpy_utils.matching import wait_for_matches, wait_until_answered

pytestmark = pytest.mark.ros


def test_pushing_the_actuators_apart_warns_near_lambda1_then_stops_and_keeps_publishing(cli, ros_context):
    """f = -3 N on both actuators (compressive) opens rho1 + rho2 towards 2L: the core run
    reaches lambda1 = 1e-3 L at t = 1.036 s. The node warns (lambda1/L below 0.05) before
    the stop, stops with the state held, and joint_states keep coming, finite."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import JointState
    from simulation_interfaces.srv import GetSimulationState
    from tensegrity_msgs.msg import ActuatorForces

    from tensegrity_ros.rclpy_utils.futures import spin_until_done

    sim = cli("node", "sim", "--ros-args", "-p", "command_timeout:=0.0", log_name="sim")
    sim.wait_for("publishing at")
    node = rclpy.create_node("singular_test", context=ros_context)
    got: list[JointState] = []
    node.create_subscription(JointState, "joint_states", got.append, 100)
    pub = node.create_publisher(ActuatorForces, "actuator_forces", 10)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    wait_for_matches([pub], 1, 30, poll=lambda s: ex.spin_once(timeout_sec=s))
    # the writer's count proves its side only: the simulator's answer to a client made after the
    # publisher proves its reader has matched it too (a command sent before that is lost)
    assert wait_until_answered(node, GetSimulationState, "get_simulation_state",
                               lambda f, t: spin_until_done(ex, f, t), 60), sim.stderr()
    pub.publish(ActuatorForces(name=["f1", "f2"], force=[-3.0, -3.0]))
    deadline = time.monotonic() + 30
    while "simulation stopped" not in sim.stderr() and time.monotonic() < deadline:
        ex.spin_once(timeout_sec=0.05)
    log = sim.stderr()
    assert "state near the singular set lambda1" in log
    assert log.index("state near the singular set lambda1") < log.index("simulation stopped")
    n_before = len(got)
    deadline = time.monotonic() + 60                      # a guard against a hang, not a timing
    while len(got) - n_before < 50:                       # still publishing after the stop
        assert time.monotonic() < deadline, f"{len(got) - n_before} states in 60 s after the stop"
        ex.spin_once(timeout_sec=0.05)
    last = got[-1].position
    assert all(math.isfinite(v) for v in last)
    name, distance = dynamics_singularity(last[0], last[1], PAPER_PARAMS)
    assert name == "lambda1" and 1e-3 <= distance < 0.05     # held at the last good sample
    assert [list(m.position) for m in got[-20:]] == [list(last)] * 20
    assert sim.stop() == 0
