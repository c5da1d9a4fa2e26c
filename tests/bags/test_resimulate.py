"""`tensegrity play BAG --resimulate` (issue 14): a bag's commands fed into a lockstep
simulator at their recorded steps; the recorded and re-simulated joint states compared.

The bags here are written with the project's BagWriter from the core's sampled-data run of
the paper's fold law (no ROS node made them), so a correct re-simulation must find no
difference at all, and a joint state perturbed by a known amount must be reported with
exactly that difference at exactly its stamp."""

from __future__ import annotations

import json

import pytest
from rclpy.serialization import serialize_message

from tensegrity_ros.bag.metadata import TopicInfo
from tensegrity_ros.bag.writer import BagWriter
from tests.ros_support import run_cli_here

pytestmark = pytest.mark.ros

STEP_NS = 10_000_000
STEPS = 120


def _write_bag(folder, *, perturb: tuple[int, float] | None = None, with_joints: bool = True):
    from builtin_interfaces.msg import Time
    from sensor_msgs.msg import JointState
    from tensegrity_msgs.msg import ActuatorForces

    from tensegrity_core.class2.fold_law import paper_fold_forces
    from tensegrity_core.sim.sampled import run_sampled

    run = run_sampled("class2_at_rest", paper_fold_forces, step_ns=STEP_NS, steps=STEPS)
    with BagWriter(folder) as w:
        w.add_topic(TopicInfo("/joint_states", "sensor_msgs/msg/JointState"))
        w.add_topic(TopicInfo("/actuator_forces", "tensegrity_msgs/msg/ActuatorForces"))
        for k, sample in enumerate(run.samples):
            stamp = Time(sec=k * STEP_NS // 10**9, nanosec=k * STEP_NS % 10**9)
            log = 1_700_000_000_000_000_000 + k * STEP_NS
            if with_joints:
                position = [float(v) for v in sample.q]
                if perturb is not None and perturb[0] == k:
                    position[0] += perturb[1]
                js = JointState(name=["rho1", "rho2", "beta"], position=position,
                                velocity=[float(v) for v in sample.qdot])
                js.header.stamp = stamp
                w.write("/joint_states", serialize_message(js), log)
            if k < STEPS:
                cmd = ActuatorForces(name=["f1", "f2"], force=list(run.commands[k]))
                cmd.header.stamp = stamp
                w.write("/actuator_forces", serialize_message(cmd), log + 1)
    return run


def test_a_lockstep_recording_resimulates_with_no_difference(tmp_path):
    folder = tmp_path / "lockstep"
    _write_bag(folder)
    r = run_cli_here("play", str(folder), "--resimulate", "--json")
    assert r.returncode == 0, r.stderr
    report = json.loads(r.stdout)
    assert report["steps"] == STEPS and report["step_ns"] == STEP_NS and report["commands"] == STEPS
    assert report["compared"] == STEPS + 1 and report["off_grid"] == 0
    assert report["max_position_difference"] == 0.0 and report["max_velocity_difference"] == 0.0
    assert report["first_difference_ns"] is None


def test_a_perturbed_joint_state_is_reported_with_its_size_and_time(tmp_path):
    folder = tmp_path / "perturbed"
    run = _write_bag(folder, perturb=(77, 1e-3))
    r = run_cli_here("play", str(folder), "--resimulate", "--json")
    assert r.returncode == 0, r.stderr
    report = json.loads(r.stdout)
    expected = abs((float(run.samples[77].q[0]) + 1e-3) - float(run.samples[77].q[0]))
    assert report["max_position_difference"] == expected
    assert report["joints"] == ["rho1", "rho2", "beta"] and report["units"] == ["m", "m", "rad"]
    assert report["position_differences"] == [expected, 0.0, 0.0]
    assert report["first_difference_ns"] == 77 * STEP_NS
    assert report["max_velocity_difference"] == 0.0
    assert report["start_difference"] == [0.0, 0.0, 0.0] and r.stderr == ""     # it starts where the scene does


def test_a_bag_that_does_not_start_at_the_scenes_initial_state_is_warned_about(tmp_path):
    """The first recorded joint state 5 cm off the scene's initial state in rho1: a warning
    says so, with the unit, and the summary gives each joint's difference with its unit."""
    folder = tmp_path / "elsewhere"
    run = _write_bag(folder, perturb=(0, 0.05))
    r = run_cli_here("play", str(folder), "--resimulate")
    assert r.returncode == 0, r.stderr
    off = abs((float(run.samples[0].q[0]) + 0.05) - float(run.samples[0].q[0]))
    assert r.stderr.strip().splitlines() == [
        f"warning: the bag's first joint state is not the initial state of the scene 'class2_at_rest': "
        f"rho1 {off:.3g} m, rho2 0 m, beta 0 rad apart; the re-simulation starts from the scene's, so the runs "
        "differ from the start (--scene names the bag's scene)"]
    assert (f": largest difference in position rho1 {off:.3g} m, rho2 0 m, beta 0 rad, in velocity rho1 0 m/s, "
            "rho2 0 m/s, beta 0 rad/s; first difference at t = 0.000000000 s") in r.stdout


def test_a_bag_without_joint_states_is_one_error_line(tmp_path):
    folder = tmp_path / "commands_only"
    _write_bag(folder, with_joints=False)
    r = run_cli_here("play", str(folder), "--resimulate")
    assert r.returncode == 1
    assert r.stderr.count("\n") == 1 and "no joint states to compare with" in r.stderr


def test_a_bag_too_long_to_resimulate_is_refused(tmp_path):
    """A bag from outside is bounded: joint states 30 days apart at a 1 ms spacing would
    need 2.6e9 steps; the limit is said in one line, no simulator is started."""
    from builtin_interfaces.msg import Time
    from sensor_msgs.msg import JointState

    folder = tmp_path / "long"
    with BagWriter(folder) as w:
        w.add_topic(TopicInfo("/joint_states", "sensor_msgs/msg/JointState"))
        for k, sec in enumerate((0, 0, 30 * 86400)):
            js = JointState(name=["rho1", "rho2", "beta"], position=[0.7, 0.7, 0.8])
            js.header.stamp = Time(sec=sec, nanosec=1_000_000 * k if sec == 0 else 0)
            w.write("/joint_states", serialize_message(js), 1_700_000_000_000_000_000 + k)
    r = run_cli_here("play", str(folder), "--resimulate")
    assert r.returncode == 1
    assert r.stderr.count("\n") == 1 and "more than the limit 2000000" in r.stderr
