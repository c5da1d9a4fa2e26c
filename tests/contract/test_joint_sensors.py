"""joint_states reports the lengths and tensions the robot measures (issue 30): a 6-bar whose
description names two length sensors and two tension sensors (one cable has both), read as a
ros2_control user reads joint_states.

sensor_msgs/JointState holds each array full or empty; joint_state_broadcaster fills a joint
without a state interface with NaN. So with a subset measured: position and velocity have
one value per joint, the length [m] and its rate [m/s] of the cables whose length is
measured (cable_states' of the same stamp, the simulator's truth), NaN for the others; effort
the same for the tensions [N]. (No tension sensor at all, the 3-bar: empty effort,
test_three_bar.py.)
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from tensegrity_core.robot import examples
from tests.contract.client import Client, start_sim

pytestmark = pytest.mark.ros

TENSIONS = ("c0_4", "c1_7")
LENGTHS = ("c0_4", "c2_10")


def test_subsets_of_length_and_tension_sensors_give_nan_for_the_other_joints(tmp_path):
    from sensor_msgs.msg import JointState
    from tensegrity_msgs.msg import CableStates

    robot = yaml.safe_load((Path(examples.__file__).parent / "six_bar.yaml").read_text())
    robot["sensors"] |= {"cable_length": list(LENGTHS), "cable_tension": list(TENSIONS)}
    (tmp_path / "six_bar_two_sensors.yaml").write_text(yaml.safe_dump(robot))
    scene = {"name": "two_sensors", "model": {"kind": "robot", "robot": "six_bar_two_sensors.yaml"},
             "initial": {"drawn": True},
             "effects": ["inertia", "cables", "motors", "gravity", "contact", "friction", "sensors"],
             "duration": 1.0}
    (tmp_path / "two_sensors.yaml").write_text(yaml.safe_dump(scene))
    sim = start_sim(tmp_path, str(tmp_path / "two_sensors.yaml"), "marker_rate:=0.0", "publish_rate:=20.0",
                    "state_rate:=20.0")
    client = Client("joint_sensors_client")
    try:
        client.listen(JointState, "joint_states")
        client.listen(CableStates, "cable_states")
        stamp = client.wait(lambda: next((s for s in reversed(client.stamped_copy("joint_states"))
                                          if s in client.stamped["cable_states"]), None),
                            "joint_states and cable_states of one stamp")
        joints, cables = client.stamped["joint_states"][stamp], client.stamped["cable_states"][stamp]
        tension = dict(zip(cables.name, cables.tension))
        length, rate = dict(zip(cables.name, cables.length)), dict(zip(cables.name, cables.length_rate))
        assert len(joints.name) == len(joints.position) == len(joints.velocity) == len(joints.effort) == 24
        for name, position, velocity, effort in zip(joints.name, joints.position, joints.velocity, joints.effort):
            if name in TENSIONS:
                assert effort == tension[name] and effort >= 0.0, name
            else:
                assert math.isnan(effort), name
            if name in LENGTHS:
                assert position == length[name] > 0.0 and velocity == rate[name], name
            else:
                assert math.isnan(position) and math.isnan(velocity), name
    finally:
        client.close()
        sim.stop()
