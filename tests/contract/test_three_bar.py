"""The Rutgers/Yale 3-bar over ROS, read against its description file (``three_bar.yaml``, read
with PyYAML): 6 motor cables and 3 passive ones, IMUs on two of its three rods (issue 29).

Expectations (issue 30, ros2_control's shape): ``joint_states`` has one joint per actuated
cable (the passive cables are not joints: their length is in ``cable_states``) and, as the
description says ``cable_tension: none``, no effort (sensor_msgs/JointState: an array not
reported is empty); ``cable_states`` still gives every tension (the simulator's truth);
``imu/<rod>`` exists for the rods the description gives an IMU, and for no other.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from tensegrity_core.robot import examples
from tests.contract.client import Client, start_sim

pytestmark = pytest.mark.ros


@pytest.fixture(scope="module")
def robot():
    return yaml.safe_load((Path(examples.__file__).parent / "three_bar.yaml").read_text())


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    from sensor_msgs.msg import JointState
    from tensegrity_msgs.msg import CableStates

    sim = start_sim(tmp_path_factory.mktemp("three_bar"), "three_bar_drop", "marker_rate:=0.0")
    client = Client("three_bar_client")
    try:
        client.listen(JointState, "joint_states")
        client.listen(CableStates, "cable_states")
        client.wait(lambda: client.received["joint_states"] and client.received["cable_states"],
                    "the 3-bar's states")
        yield client
    finally:
        client.close()
        sim.stop()


def test_joint_states_are_the_motor_cables_only(suite, robot):
    joints = suite.received["joint_states"][-1]
    motors = [c["name"] for c in robot["cables"] if c.get("motor")]
    assert len(motors) == 6 and sorted(joints.name) == sorted(motors)
    assert len(joints.position) == len(joints.velocity) == 6
    assert robot["sensors"]["cable_tension"] == "none"
    assert len(joints.effort) == 0                 # no tension sensor: sensor_msgs/JointState's empty effort
    states = suite.received["cable_states"][-1]
    assert len(states.tension) == len(states.name) and all(t >= 0.0 for k, t in zip(states.kind, states.tension)
                                                           if k == "string")       # the simulator's truth
    assert sorted(states.name) == sorted([r["name"] for r in robot["rods"]] + [c["name"] for c in robot["cables"]])


def test_an_imu_topic_for_each_rod_the_description_equips(suite, robot):
    sim_topics = suite.topics_of("tensegrity_sim")
    imus = sorted(t for t in sim_topics if t.startswith("/imu/"))
    assert imus == sorted(f"/imu/{rod}" for rod in robot["sensors"]["imu"])
    assert all(sim_topics[t] == ["sensor_msgs/msg/Imu"] for t in imus)
