"""Partial commands from two publishers over real DDS: every one reaches the lockstep gate.

Two controllers each command one actuator of the class-2 mechanism for the same lockstep
step. Their messages arrive back to back: the simulator's process is stopped (SIGSTOP)
while both are published, so both are in its reader's queue before its command thread
can take either (when DDS delivers them as the simulator resumes; a send it repairs later
comes alone). Both are acknowledged by the simulator's reader before the step is requested:
a command received before a stepping request counts for its step, even one its command
thread has not taken yet (docs/ros.md: several commands for t_k that arrive while paused
make one command). The step must run under both (the gate merges them in arrival order)."""

from __future__ import annotations

import os
import signal
import time

import pytest

pytestmark = pytest.mark.ros

STEP_NS = 10_000_000          # 10 ms


def test_two_partial_actuator_forces_for_one_step_back_to_back_both_apply(cli, ros_context):
    import rclpy
    from rclpy.duration import Duration
    from rclpy.qos import QoSProfile
    from tensegrity_msgs.msg import ActuatorForces

    from tensegrity_ros.apps.sim_client import SimClient
    from tensegrity_ros.rclpy_utils.matching import wait_for_matches

    proc = cli("node", "sim", "--ros-args", "-p", f"step_size:={STEP_NS / 1e9}", "-p", "publish_rate:=100.0",
               "-p", "lockstep:=true", "-p", "initial_state:=paused", "-p", "paused_publish_rate:=0.0",
               "-p", "lockstep_timeout:=30.0", log_name="sim")
    proc.wait_for("publishing at")
    client = SimClient(rclpy, "partial_commands_test", context=ros_context)
    other = rclpy.create_node("partial_commands_other", context=ros_context)
    try:
        first = client.pub
        second = other.create_publisher(ActuatorForces, "actuator_forces", QoSProfile(depth=10))
        # made after both publishers (one participant: one context), the client's probe
        # proves the simulator's reader has matched both writers; a writer's own count
        # proves its side only, and a stopped simulator discovers nothing
        client.wait_for_services(30)
        assert wait_for_matches([second], 1, 30, settle_s=0.0)
        client.set_law(None)
        for round_ in range(3):                  # three steps, each under two partial commands
            f1, f2 = 0.25 + 0.1 * round_, 0.65 - 0.1 * round_
            stamp = round_ * STEP_NS
            a = ActuatorForces(name=["f1"], force=[f1])
            b = ActuatorForces(name=["f2"], force=[f2])
            a.header.stamp.nanosec = b.header.stamp.nanosec = stamp
            os.killpg(proc.popen.pid, signal.SIGSTOP)    # its session: the simulator alone
            try:
                first.publish(a)
                second.publish(b)
                time.sleep(0.2)                  # both are on their way to the stopped reader
            finally:
                os.killpg(proc.popen.pid, signal.SIGCONT)
            # a reliable writer's first send to a stopped process may be lost and repaired
            # later, from each writer on its own (seen under load: the two came 20-40 ms after
            # the step request, in reverse order): the step waits until both are received
            for pub in (first, second):
                assert pub.wait_for_all_acked(Duration(seconds=30)), "the simulator never received a command"
            client.step(1)
            joint = client.wait_joint(stamp + STEP_NS)
            assert tuple(joint.effort[:2]) == (f1, f2), (round_, tuple(joint.effort[:2]), proc.stderr()[-2000:])
        assert proc.stop() == 0
        assert "rejected commands: 0;" in proc.stderr()
    finally:
        other.destroy_node()
        client.close()
