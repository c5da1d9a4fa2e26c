"""General structures and robots in the view without a browser: bags (the suite's recorded
6-bar roll; a general structure's bag written from the core's states with the simulator's own
message builders) and a running robot suite over DDS."""

from __future__ import annotations

import shutil
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from tensegrity_core.sim import scene_path
from tensegrity_ros.bag.errors import BagError
from tensegrity_ros.view.bag_source import BagSource
from tests.view.support import MALFORMED, foreign_roll

BAGS = Path(__file__).resolve().parents[2] / "bags"
ROLL = BAGS / "six_bar_roll"
WAIT = 120.0


def _lengths(frame, topology) -> np.ndarray:
    ends = topology.members
    return np.linalg.norm(frame.nodes[ends[:, 1]] - frame.nodes[ends[:, 0]], axis=1)


def _recorded(topic: str) -> dict[float, object]:
    """The bag's messages of ``topic`` by header stamp [s], decoded by an independent reader (rosbags)."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    with AnyReader([ROLL], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        conns = [c for c in reader.connections if c.topic == topic]
        msgs = [reader.deserialize(raw, c.msgtype) for c, _t, raw in reader.messages(connections=conns)]
    return {m.header.stamp.sec + m.header.stamp.nanosec * 1e-9: m for m in msgs}


def test_a_robot_bag_draws_the_lengths_and_contacts_the_simulator_published():
    """Nodes placed from the rod poses of ``body_states`` give every member the length the
    simulator put in ``cable_states`` at the same stamp (rods: 1.7 m, each cable its own);
    each contact is a cap of the frame, pressed into the floor (its centre below its radius:
    the penalty contact), with the normal
    force of ``contacts``."""
    source = BagSource(ROLL, scene="six_bar_rest")
    cables, contacts = _recorded("/six_bar/cable_states"), _recorded("/six_bar/contacts")
    assert source.topology.kind == "robot" and source.duration > 5.0
    cap_radius = source.topology.node_radius
    seen_contacts = 0
    for k in np.linspace(0, len(cables) - 1, 25).astype(int):
        frame = source.frame_at(k)
        recorded = cables[min(cables, key=lambda t: abs(t - frame.t))]
        assert abs(recorded.header.stamp.sec + recorded.header.stamp.nanosec * 1e-9 - frame.t) < 1e-9
        np.testing.assert_allclose(_lengths(frame, source.topology), recorded.length, atol=1e-9)
        np.testing.assert_array_equal(frame.member_forces, recorded.tension)
        touching = contacts[frame.t]
        assert len(frame.contacts) == len(touching.name)
        for (point, force), name, f in zip(frame.contacts, touching.name, touching.normal_force):
            np.testing.assert_allclose(point, frame.nodes[source.topology.node_names.index(name)], atol=1e-9)
            assert force == f > 0 and 0 < cap_radius - point[2] < 0.1 * cap_radius     # pressed into the floor
            seen_contacts += 1
    assert seen_contacts > 25       # it rolls on the floor: three caps down most of the time


def test_a_robot_bag_needs_its_scene_and_refuses_another_in_one_line(tmp_path):
    # the sample bag says its scene in its metadata (`tensegrity demo` records it with
    # custom_data scene=six_bar_rest, as ros2 bag record --custom-data scene=NAME writes)
    assert BagSource(ROLL).topology.node_names == BagSource(ROLL, scene="six_bar_rest").topology.node_names
    with pytest.raises(BagError, match="does not have") as err:
        BagSource(ROLL, scene="spine_bend")
    assert "\n" not in str(err.value)
    # without it, the robot is drawn from its own markers (test below)
    copy = tmp_path / "roll"
    shutil.copytree(ROLL, copy)
    meta = yaml.safe_load((copy / "metadata.yaml").read_text())
    meta["rosbag2_bagfile_information"]["custom_data"] = None
    (copy / "metadata.yaml").write_text(yaml.safe_dump(meta))
    assert BagSource(copy).label.endswith("drawn from its markers")
    # a path in a bag's metadata is never read: only shipped scene names are taken from a bag
    outside = tmp_path / "elsewhere.yaml"
    shutil.copy(scene_path("six_bar_rest"), outside)
    meta["rosbag2_bagfile_information"]["custom_data"] = {"scene": str(outside)}
    (copy / "metadata.yaml").write_text(yaml.safe_dump(meta))
    with pytest.raises(BagError, match="not a shipped scene") as err:
        BagSource(copy)
    assert "\n" not in str(err.value)


def test_a_robot_bag_with_a_malformed_custom_data_is_drawn_from_its_own_markers(tmp_path):
    """No --scene and a custom_data record that cannot be read: the robot is drawn from its
    markers (rods' and cables' segments join its caps). Every member's length between the
    caps so placed is the one the simulator put in ``cable_states`` at the same stamp (read
    by rosbags), and the caps are where the scene's drawing (body poses) puts them."""
    foreign_roll(tmp_path / "roll", MALFORMED, ("body_states", "cable_states", "contacts", "markers"))
    source = BagSource(tmp_path / "roll")
    assert source.topic == "/six_bar/markers" and source.label.endswith("drawn from its markers")
    topo = source.topology
    assert topo.kind == "robot" and topo.floor and len(topo.node_names) == 12
    assert [topo.member_kinds[i] for i in topo.of_kind("bar")] == ["bar"] * 6 and len(topo.of_kind("string")) == 24
    by_scene = BagSource(tmp_path / "roll", scene="six_bar_rest")
    cables = _recorded("/six_bar/cable_states")
    for k in np.linspace(0, len(source._times) - 1, 6).astype(int):
        frame = source.frame_at(k)
        np.testing.assert_allclose(_lengths(frame, topo), cables[frame.t].length, atol=1e-9)
        drawn = by_scene.frame_at(by_scene.index_at(frame.t - by_scene.t0))
        assert drawn.t == frame.t
        # the same caps, in another order: each marker cap is one of the scene's
        gaps = np.linalg.norm(frame.nodes[:, None, :] - drawn.nodes[None, :, :], axis=2).min(axis=1)
        assert gaps.max() < 1e-9
        assert [(tuple(p), f) for p, f in frame.contacts] == [(tuple(p), f) for p, f in drawn.contacts]


def test_a_robot_bag_with_a_malformed_custom_data_and_nothing_that_draws_it_says_what_is_missing(tmp_path):
    foreign_roll(tmp_path / "roll", MALFORMED, ("body_states", "cable_states"), seconds=0.2)
    with pytest.raises(BagError) as err:
        BagSource(tmp_path / "roll")
    line = str(err.value)
    assert "\n" not in line and "s" * 100 not in line      # the 5000-character name is quoted as an excerpt
    assert "custom_data cannot be read" in line and "no markers topic" in line and "--scene NAME" in line
    assert BagSource(tmp_path / "roll", scene="six_bar_rest").topology.kind == "robot"     # what --scene supplies


def _structure_bag(folder: Path, scene: str, commands: list[list[float]], step: float = 0.01,
                   nodes_topic: str = "body_states") -> list:
    """A bag of ``scene`` simulated by the core under ``commands`` (one per step), its
    ``cable_states`` and ``nodes_topic`` (``body_states`` or ``markers``) built by the
    simulator node's own functions; the observations."""
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Header

    from tensegrity_core.sim import Simulator
    from tensegrity_ros.bag.metadata import TopicInfo
    from tensegrity_ros.bag.writer import BagWriter
    from tensegrity_ros.nodes.sim import sender

    sim = Simulator(scene)
    observed = []
    with BagWriter(folder) as writer:
        writer.add_topic(TopicInfo(name="/cable_states", type="tensegrity_msgs/msg/CableStates"))
        kinds = {"body_states": "tensegrity_msgs/msg/RigidBodyStates", "markers": "visualization_msgs/msg/MarkerArray"}
        writer.add_topic(TopicInfo(name=f"/{nodes_topic}", type=kinds[nodes_topic]))
        for k, command in enumerate([None, *commands]):
            if command is not None:
                sim.set_command(command)
                sim.advance(k * step)
            obs = sim.observe()
            observed.append(obs)
            ns = round(obs.t * 1e9)
            hdr = Header(frame_id="world")
            hdr.stamp.sec, hdr.stamp.nanosec = divmod(ns, 10**9)
            writer.write("/cable_states", serialize_message(sender.cable_states_msg(obs, sim.interface, hdr)), ns)
            nodes_msg = sender.body_states_msg(obs, hdr) if nodes_topic == "body_states" else sender.markers_msg(obs, hdr)
            writer.write(f"/{nodes_topic}", serialize_message(nodes_msg), ns)
    return observed


def test_a_general_structures_bag_draws_the_cores_states(tmp_path):
    """The actuated table, its three rest lengths driven from 0.9 m to 0.8 m: every frame's
    nodes are the core's (the top body placed by its pose), its forces and rest lengths too."""
    commands = [[0.9 - 0.01 * k, 0.9, 0.9 - 0.005 * k] for k in range(1, 21)]
    observed = _structure_bag(tmp_path / "table", "table_actuated", commands)
    source = BagSource(tmp_path / "table", scene="table_actuated")
    assert source.topology.kind == "general" and len(source._times) == len(observed)
    for k, obs in enumerate(observed):
        frame = source.frame_at(k)
        assert frame.t == pytest.approx(obs.t, abs=1e-9)
        np.testing.assert_allclose(frame.nodes, obs.nodes, atol=1e-12)
        np.testing.assert_array_equal(frame.member_forces, obs.member_forces)
        assert [frame.series[f"u:long{i}"] for i in (1, 2, 3)] == pytest.approx(list(obs.applied_forces), abs=1e-12)
    assert frame.series["u:long1"] == pytest.approx(0.7, abs=1e-9)


def test_the_shipped_spine_bag_is_the_first_4_s_of_its_scene():
    """``bags/spine_release`` (docs/bags.md; the view's benchmark plays it): opened with the
    scene its metadata names, its 400 states 10 ms apart are the core's run of
    ``spine_release`` from its release, node for node, tension for tension, to the scene's
    integrator tolerance: another CPU's BLAS rounds DOP853's stages differently (docs/bags.md),
    and the stiff cords (EA/l0 ~ 4e4 N/m) turn a 2e-11 m difference of the nodes into 1e-6 N
    of tension, so the tensions agree to the integrator's rtol of the largest tension."""
    from tensegrity_core.sim import Simulator

    rtol = yaml.safe_load(scene_path("spine_release").read_text())["integrator"]["rtol"]
    source = BagSource(BAGS / "spine_release")
    assert source.topology.kind == "general" and len(source._times) == 400
    sim = Simulator("spine_release")
    for k in range(1, 401):
        sim.advance(k * 0.01)
        if k % 50 == 1 or k == 400:
            obs, frame = sim.observe(), source.frame_at(k - 1)
            assert frame.t == pytest.approx(obs.t, abs=1e-9) and obs.t == pytest.approx(k * 0.01, abs=1e-12)
            np.testing.assert_allclose(frame.nodes, obs.nodes, rtol=rtol, atol=1e-12)
            np.testing.assert_allclose(frame.member_forces, obs.member_forces, rtol=0,
                                       atol=rtol * np.abs(obs.member_forces).max())


HANG = """
model:
  kind: general
  structure:
    defaults: {EA: 1000.0, type: string, rest_length_ratio: 0.9}
    nodes: {a: [0.0, 0.0, 0.0], b: [1.0, 0.0, 0.0], c: [0.0, 1.0, 0.0], hang: [0.3, 0.3, -1.0]}
    members:
      - {name: s1, nodes: [a, hang], type: actuator}
      - {name: s2, nodes: [b, hang]}
      - {name: s3, nodes: [c, hang]}
    pinned: [a, b, c]
    masses: {hang: 1.0}
  end_effector: hang
initial: {equilibrium: true}
inputs: {s1: {law: commanded}}
effects: [inertia, springs, {damping: {beta: 2.0e-3}}, gravity]
duration: 1.0
"""


def test_a_structure_with_a_free_node_is_placed_from_its_markers(tmp_path):
    """A weight on three strings (docs/scenes.md's example, one string commanded): its free
    node is on no rigid body, so the bag's ``markers`` place the nodes; every frame's nodes
    and end effector are the core's."""
    scene = tmp_path / "hang.yaml"
    scene.write_text(HANG)
    observed = _structure_bag(tmp_path / "hang", str(scene), [[0.9 - 0.002 * k] for k in range(1, 11)],
                              nodes_topic="markers")
    source = BagSource(tmp_path / "hang", scene=str(scene))
    assert len(source._times) == len(observed)
    for k, obs in enumerate(observed):
        frame = source.frame_at(k)
        np.testing.assert_array_equal(frame.nodes, obs.nodes)
        assert (frame.series["p:x"], frame.series["p:y"], frame.series["p:z"]) == tuple(obs.nodes[3])
    assert frame.series["u:s1"] == pytest.approx(0.88, abs=1e-12) and obs.nodes[3][2] != observed[0].nodes[3][2]


def test_a_general_structures_markers_place_every_node():
    """The ``nodes`` marker the simulator publishes for a general structure holds every node
    in order (the view's source of free nodes)."""
    from std_msgs.msg import Header

    from tensegrity_core.sim import Simulator
    from tensegrity_ros.nodes.sim import sender
    from tensegrity_ros.view.structure_frames import StructureMessages

    sim = Simulator("spine_release")
    sim.advance(0.05)
    obs = sim.observe()
    nodes = StructureMessages("spine_release").nodes_of_markers(sender.markers_msg(obs, Header()))
    np.testing.assert_array_equal(nodes, obs.nodes)


class _Frames:
    def __init__(self) -> None:
        self.frames: list = []
        self.reports: list[str] = []
        self.new = threading.Condition()

    def __call__(self, frame) -> None:
        with self.new:
            self.frames.append(frame)
            self.new.notify_all()

    def wait(self, condition, timeout: float = WAIT):
        with self.new:
            assert self.new.wait_for(lambda: any(condition(f) for f in self.frames), timeout), self.reports
            return next(f for f in self.frames if condition(f))


@pytest.mark.ros
def test_a_running_robot_is_drawn_from_its_topics_and_driven_by_the_sliders(cli, ros_context):
    """A real simulator serving the 6-bar (scene six_bar_rest, paused), the view's ROS source
    in this process: it finds the robot from the simulator's scene parameter, its frames give
    each member the length the simulator publishes in ``cable_states`` (read here by the
    test's own subscription), and a slider's rest length reaches the simulator's motor."""
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from tensegrity_msgs.msg import CableStates

    from tensegrity_ros.view.ros_source import RosSource

    sim = cli("node", "sim", "--ros-args", "-p", "scene:=six_bar_rest", "-p", "initial_state:=paused",
              "-p", "paused_publish_rate:=20.0", log_name="sim")
    node = Node("view_robot_test", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(node)
    published: dict[float, CableStates] = {}
    # every state kept until read: this executor spins only once the view has shown the moved
    # frame, which on a loaded machine can be seconds of states later
    node.create_subscription(CableStates, "cable_states",
                             lambda m: published.setdefault(m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, m),
                             100_000)
    source = RosSource("")
    try:
        # this subscription matched before anything moves (the paused simulator republishes at
        # 20 Hz): a state published before it matched would never reach it
        deadline = time.monotonic() + WAIT
        while not published:
            assert time.monotonic() < deadline, "no cable_states from the paused simulator"
            executor.spin_once(timeout_sec=0.1)
        first = source.first_frame(timeout=WAIT)
        assert source.topology.kind == "robot" and "inputs" in source.features
        spec = next(s for s in source.inputs if s.name == "c0_4")
        # the motor's range (six_bar.yaml: [0.45, 1.05] m, closed: the simulator takes its ends)
        assert spec.initial == pytest.approx(0.996) and (spec.low, spec.high) == (0.45, 1.05)
        sink = _Frames()
        source.start(sink, sink.reports.append)
        source.drive({"c0_4": 0.9})
        source.play()
        moved = sink.wait(lambda f: f.run_state == "playing" and f.series["u:c0_4"] == pytest.approx(0.9, abs=1e-9))
        deadline = time.monotonic() + WAIT
        while not any(t == pytest.approx(moved.t, abs=1e-9) for t in published) and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        at = [t for t in published if t == pytest.approx(moved.t, abs=1e-9)]
        assert at, f"no cable_states stamped {moved.t} s (received {min(published, default=None)}..{max(published, default=None)})"
        recorded = published[at[0]]
        np.testing.assert_allclose(_lengths(moved, source.topology), recorded.length, atol=1e-9)
        assert recorded.rest_length[list(recorded.name).index("c0_4")] == pytest.approx(0.9, abs=1e-9)
        assert first.t == 0.0 and len(first.nodes) == 12
        source.pause()
    finally:
        source.stop()
        executor.shutdown()
        node.destroy_node()
    assert sim.popen.poll() is None
