"""joint_states reports the tensions the robot measures (issue 30): a 6-bar whose description
names two tension sensors, read as a ros2_control user reads joint_states.

sensor_msgs/JointState holds each array full or empty; joint_state_broadcaster fills a joint
without an effort state interface with NaN. So with a subset measured: effort has one value
per joint, the measured cables' tension [N] (cable_states' of the same stamp, the simulator's
truth), NaN for the others. (No sensor at all, the 3-bar: empty effort, test_three_bar.py.)
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from tensegrity_core.robot import examples
from tests.contract.client import Client, start_sim

pytestmark = pytest.mark.ros

MEASURED = ("c0_4", "c1_7")


def test_a_subset_of_tension_sensors_gives_nan_for_the_other_joints(tmp_path):
    from sensor_msgs.msg import JointState
    from tensegrity_msgs.msg import CableStates

    robot = yaml.safe_load((Path(examples.__file__).parent / "six_bar.yaml").read_text())
    robot["sensors"]["cable_tension"] = list(MEASURED)
    (tmp_path / "six_bar_two_sensors.yaml").write_text(yaml.safe_dump(robot))
    scene = {"name": "two_sensors", "model": {"kind": "robot", "robot": "six_bar_two_sensors.yaml"},
             "initial": {"drawn": True},
             "effects": ["inertia", "cables", "motors", "gravity", "contact", "friction", "sensors"],
             "duration": 1.0}
    (tmp_path / "two_sensors.yaml").write_text(yaml.safe_dump(scene))
    sim = start_sim(tmp_path, str(tmp_path / "two_sensors.yaml"), "marker_rate:=0.0", "publish_rate:=20.0",
                    "state_rate:=20.0")
    client = Client("joint_effort_client")
    try:
        client.listen(JointState, "joint_states")
        client.listen(CableStates, "cable_states")
        stamp = client.wait(lambda: next((s for s in reversed(client.stamped["joint_states"])
                                          if s in client.stamped["cable_states"]), None),
                            "joint_states and cable_states of one stamp")
        joints, cables = client.stamped["joint_states"][stamp], client.stamped["cable_states"][stamp]
        tension = dict(zip(cables.name, cables.tension))
        assert len(joints.effort) == len(joints.name) == len(joints.position)
        for name, effort in zip(joints.name, joints.effort):
            if name in MEASURED:
                assert effort == tension[name] and effort >= 0.0, name
            else:
                assert math.isnan(effort), name
    finally:
        client.close()
        sim.stop()
