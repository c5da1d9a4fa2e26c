"""Two robots in one ROS domain keep their frames apart on the one absolute ``/tf``, as
robot_state_publisher's ``frame_prefix`` does: a 6-bar simulator in namespace ``/robot1``
with ``frame_prefix:=robot1/`` names its rods' frames ``robot1/rod0`` ... in ``/tf`` (child
frames) and in its IMUs' ``frame_id``, so a second robot's ``rod0`` is another frame. The
rods' names come from the description file read with PyYAML. The simulator stands paused
(it republishes its state 10 times a second), which is all the frames need."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from tensegrity_core.robot import examples
from tests.contract.client import Client, start_sim

pytestmark = pytest.mark.ros


def test_frame_prefix_names_every_rod_frame_in_tf_and_the_imus(tmp_path):
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import Imu
    from tf2_msgs.msg import TFMessage

    rods = [r["name"] for r in yaml.safe_load((Path(examples.__file__).parent / "six_bar.yaml").read_text())["rods"]]
    sim = start_sim(tmp_path, "six_bar_rest", "frame_prefix:=robot1/", "initial_state:=paused",
                    "paused_publish_rate:=10.0", "publish_clock:=false", remap=("__ns:=/robot1",))
    client = Client("robot_frames_client")
    try:
        client.listen(TFMessage, "/tf", QoSProfile(depth=100))
        for rod in rods:
            client.listen(Imu, f"/robot1/imu/{rod}", QoSProfile(depth=10))
        tf = client.wait(lambda: next((m for m in client.received["/tf"] if m.transforms), None), "a /tf message")
        assert sorted(t.child_frame_id for t in tf.transforms) == sorted(f"robot1/{rod}" for rod in rods)
        assert {t.header.frame_id for t in tf.transforms} == {"world"}       # the parent: frame_id, unprefixed
        for rod in rods:
            imu = client.wait(lambda rod=rod: client.received[f"/robot1/imu/{rod}"][-1:], f"imu/{rod}")[0]
            assert imu.header.frame_id == f"robot1/{rod}"
    finally:
        client.close()
        sim.stop()
