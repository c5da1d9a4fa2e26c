"""The simulator's topics published as serialized bytes (:mod:`tensegrity_ros.nodes.sim.message_bytes`,
:mod:`~tensegrity_ros.nodes.sim.topic_bytes`) read back, with rclpy's own deserializer, as
the messages rclpy builds from the same values: the messages of :mod:`.sender` and
:mod:`.robot_messages` for the same observation, and random values of every float64 bit
pattern that is not NaN. No node, no DDS.
"""

from __future__ import annotations

import numpy as np
import pytest

pytestmark = pytest.mark.ros


@pytest.mark.parametrize("scene", ["six_bar_roll", "table_actuated"])
def test_every_topic_as_bytes_reads_back_as_the_message_of_the_same_observation(scene):
    from rclpy.serialization import deserialize_message
    from std_msgs.msg import Header

    from tensegrity_core.sim import load_scene
    from tensegrity_ros.nodes.sim import robot_messages, sender
    from tensegrity_ros.nodes.sim.outputs import Outputs
    from tensegrity_ros.nodes.sim.plant import SimPlant

    plant = SimPlant(load_scene(scene), 1_000_000)
    outputs = Outputs(plant, publish_rate=100.0, state_rate=100.0, marker_rate=100.0, imu_rate=100.0)
    interface = plant.interface
    as_bytes = set()
    for publication in range(4):
        for _ in range(40):                               # moving: lengths, rates, poses change
            plant.step(plant.initial_command)
        hdr = sender.header(plant.time_ns + publication, "world")
        obs = plant.observe()
        expected = {"joint_states": sender.cable_joint_state_msg(obs, interface, hdr),
                    "cable_states": sender.cable_states_msg(obs, interface, hdr),
                    "end_effector": sender.end_effector_msg(obs, hdr)}
        if obs.body_names:
            expected["body_states"] = sender.body_states_msg(obs, hdr)
        for i, name in enumerate(obs.imu_names):
            expected[f"imu/{name}"] = robot_messages.imu_msg(obs, i, Header(stamp=hdr.stamp, frame_id=name))
        for topic, msg in outputs.messages(hdr, lambda t: True):
            if isinstance(msg, bytes):
                as_bytes.add(topic)
                assert deserialize_message(msg, outputs.topics[topic]) == expected[topic], topic
    assert as_bytes == set(expected)                      # every fixed-shape topic, none as a message
    assert {"joint_states", "cable_states", "body_states"} <= as_bytes
    assert len(as_bytes) == 4 + len(plant.observe().imu_names)


def test_cable_states_bytes_read_back_every_value_and_refuse_a_run_of_another_length():
    from rclpy.serialization import deserialize_message
    from tensegrity_msgs.msg import CableStates

    from tensegrity_core.sim import load_scene
    from tensegrity_ros.nodes.sim.plant import SimPlant
    from tensegrity_ros.nodes.sim.topic_bytes import cable_states_bytes

    plant = SimPlant(load_scene("six_bar_roll"), 1_000_000)
    obs = plant.observe()
    cdr = cable_states_bytes(obs, plant.interface, "lab")
    assert cdr.ok
    n = len(obs.member_names)
    rng = np.random.default_rng(11)
    for _ in range(30):
        sec, nanosec = int(rng.integers(0, 2**31)), int(rng.integers(0, 10**9))
        runs = {f: rng.integers(0, 2**64, n, dtype=np.uint64).view(np.float64)
                for f in ("length", "length_rate", "rest_length", "tension")}
        runs = {f: np.where(np.isnan(v), 0.5, v) for f, v in runs.items()}
        runs["slack"] = rng.random(n) < 0.5
        got = deserialize_message(cdr.fill(sec, nanosec, runs), CableStates)
        assert (got.header.stamp.sec, got.header.stamp.nanosec, got.header.frame_id) == (sec, nanosec, "lab")
        assert list(got.name) == list(obs.member_names) and list(got.kind) == list(obs.member_kinds)
        for f in ("length", "length_rate", "rest_length", "tension"):
            assert np.array_equal(np.array(got.__getattribute__(f)), runs[f]), f
        assert list(got.slack) == runs["slack"].tolist()
    with pytest.raises(ValueError, match=f"run length of {n} values, got {n - 1}"):
        cdr.fill(0, 0, {**runs, "length": runs["length"][1:]})


def test_a_message_whose_stamp_is_not_in_one_place_is_not_taken_as_bytes():
    """Two stamps (a TFMessage of two transforms) leave no one place for the stamp: the
    template does not check out and the caller publishes messages."""
    from builtin_interfaces.msg import Time
    from geometry_msgs.msg import TransformStamped
    from std_msgs.msg import Header
    from tf2_msgs.msg import TFMessage

    from tensegrity_ros.nodes.sim.message_bytes import MessageBytes

    def build(sec, nanosec, runs):
        x = list(runs.get("x", (0.0,)))
        out = TFMessage()
        for child in ("a", "b"):
            t = TransformStamped(header=Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id="world"),
                                 child_frame_id=child)
            t.transform.translation.x = x[0]
            out.transforms.append(t)
        return out

    assert not MessageBytes(TFMessage, build, {"x": 1}).ok
