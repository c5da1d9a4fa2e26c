"""`tensegrity up` brings the suite up in a namespace and Ctrl-C stops every node (issue 6)."""

from __future__ import annotations

import re
import signal
import subprocess
import time
from collections import Counter
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros


def _children(pid: int) -> set[int]:
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True)
    return {int(p) for p in out.stdout.split()}


def _alive(pid: int) -> bool:
    return subprocess.run(["ps", "-p", str(pid)], capture_output=True).returncode == 0


def test_up_starts_every_node_and_ctrl_c_stops_them_and_a_second_up_there_is_refused(cli, ros_context, tmp_path):
    """`up` starts every node; a second `up` in the same namespace, which would publish the
    same topics, exits 1 with one line that names the domain and the running nodes, and the
    first runs on; Ctrl-C then stops every node of the first."""
    import os

    import rclpy

    up = cli("up", "--namespace", "/suite_test", "--record", str(tmp_path / "bag"), log_name="up")
    node = rclpy.create_node("up_probe", context=ros_context)
    expected_services = {"/suite_test/solve_ik", "/suite_test/find_form", "/suite_test/reset",
                         "/suite_test/move_end_effector/_action/send_goal",
                         "/suite_test/follow_actuator_trajectory/_action/send_goal"}
    deadline = time.monotonic() + 60
    while True:
        services = {name for name, _ in node.get_service_names_and_types()}
        topics = {name for name, _ in node.get_topic_names_and_types()}
        if expected_services <= services and "/suite_test/joint_states" in topics:
            break
        assert time.monotonic() < deadline, (services, topics)
        time.sleep(0.2)
    children = _children(up.popen.pid)
    assert len(children) == 5          # sim, ik, controller, formfind, recorder
    # with --record the simulator's clock starts only once the recorder subscribed (and its
    # matches held): a joint state seen here has been sent to the recorder too
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState

    from tensegrity_ros.rclpy_utils.raw_take import take_all

    sub = node.create_subscription(JointState, "/suite_test/joint_states", lambda *_: None, QoSProfile(depth=10),
                                   raw=True)
    while not take_all(sub):
        assert time.monotonic() < deadline + 60, up.stderr()
        time.sleep(0.05)
    second = cli("up", "--namespace", "/suite_test", "--no-formfind", "--no-controller", log_name="up_second")
    assert second.popen.wait(60) == 1, second.stderr()
    domain = os.environ.get("ROS_DOMAIN_ID", "0")
    [line] = second.stderr().strip().splitlines()       # one line, no child started
    # the names its graph showed by the first look that found one: some of the first's nodes
    found = re.fullmatch(rf"error: the suite is already running in ROS domain {domain} in namespace /suite_test "
                         r"\(([^()]+)\): stop it first, or start this one in "
                         r"another namespace \(--namespace /robot2\) or domain \(ROS_DOMAIN_ID\)", line)
    assert found, line
    names = found[1].split(", ")
    assert names == sorted(set(names)) and set(names) <= {f"/suite_test/tensegrity_{n}" for n in
                                                          ("sim", "ik", "controller", "formfind", "recorder")}, line
    assert up.popen.poll() is None                      # the running suite is left alone
    assert _children(up.popen.pid) == children
    up.popen.send_signal(signal.SIGINT)
    assert up.popen.wait(60) == 0, up.stderr()
    out = up.popen.stdout.read()
    assert not any(_alive(pid) for pid in children)
    # the recorder is stopped only once every publisher has exited (their last lines are out
    # by then), so it takes the simulator's last messages: every message the simulator counts
    # as published is in the bag (read by the mcap package)
    handover = out.index("[launch] sim, ik, controller, formfind exited; stopping record\n")
    published = re.search(r"\[sim\] .*published: (.*?); rejected", out)
    assert published and published.start() < handover, out
    assert out.index("[record] recorded ") > handover, out
    counts = {("" if t.startswith("/") else "/suite_test/") + t: int(n)
              for t, n in (item.rsplit(" ", 1) for item in published.group(1).split(", "))}
    from mcap.reader import make_reader

    (mcap_file,) = (tmp_path / "bag").glob("*.mcap")
    with open(mcap_file, "rb") as f:
        in_bag = Counter(channel.topic for _, channel, _ in make_reader(f).iter_messages())
    assert counts["/suite_test/joint_states"] > 0, out
    # the simulator's located events too (a stop on the singular set), whether or not this run had any
    assert "recording /suite_test/events [tensegrity_msgs/msg/SimulationEvent]" in out, out
    assert {t: in_bag[t] for t, n in counts.items() if n} == {t: n for t, n in counts.items() if n}, out
    # the recorder was stopped cleanly too: its bag is complete
    from tensegrity_ros.bag.reader import BagReader

    reader = BagReader(tmp_path / "bag")
    assert not reader.recovered
    assert any(t.name == "/suite_test/joint_states" and t.message_count > 0 for t in reader.topics())
    # ... from t = 0: the clock waited for the recorder's own subscriptions (the controller's on
    # joint_states does not count for the recorder)
    from rclpy.serialization import deserialize_message

    stamps = [deserialize_message(m.data, JointState).header.stamp for m in reader.messages()
              if m.topic == "/suite_test/joint_states"]
    assert min((s.sec, s.nanosec) for s in stamps) == (0, 0), stamps[:3]
    node.destroy_node()


def test_up_on_a_general_structure_starts_its_nodes_and_records_its_topics(cli, ros_context, tmp_path):
    """Issue 30: `up --scene` of a general structure starts the simulator, the cable controller
    and form-finding (no IK, no class-2 controller), and records cable and body states."""
    import rclpy

    up = cli("up", "--scene", "table_actuated", "--namespace", "/general_up", "--record", str(tmp_path / "bag"),
             log_name="up")
    node = rclpy.create_node("up_general_probe", context=ros_context)
    deadline = time.monotonic() + 90
    want = {"/general_up/cable_states", "/general_up/body_states", "/general_up/joint_states"}
    while not want <= {name for name, _ in node.get_topic_names_and_types()} \
            or "/general_up/tensegrity_cable_controller/follow_joint_trajectory/_action/send_goal" not in \
            {name for name, _ in node.get_service_names_and_types()}:
        assert time.monotonic() < deadline, up.stderr()
        time.sleep(0.2)
    assert len(_children(up.popen.pid)) == 4         # sim, cables, formfind, recorder
    services = {name for name, _ in node.get_service_names_and_types()}
    assert "/general_up/solve_ik" not in services and "/general_up/move_end_effector/_action/send_goal" not in services
    # once the recorder subscribes to a topic, every message after it is recorded: wait until
    # it subscribes to each, then until a few messages of each have gone out (seen here)
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState
    from tensegrity_msgs.msg import CableStates, RigidBodyStates

    from tensegrity_ros.rclpy_utils.raw_take import take_all

    kinds = {"/general_up/cable_states": CableStates, "/general_up/body_states": RigidBodyStates,
             "/general_up/joint_states": JointState}
    while not all(any(i.node_name == "tensegrity_recorder" for i in node.get_subscriptions_info_by_topic(t))
                  for t in want):
        assert time.monotonic() < deadline, up.stderr()
        time.sleep(0.05)
    subs = {t: node.create_subscription(kinds[t], t, lambda *_: None, QoSProfile(depth=100), raw=True)
            for t in want}
    seen = dict.fromkeys(want, 0)
    while min(seen.values()) < 5:
        assert time.monotonic() < deadline + 60, (seen, up.stderr())
        for t, sub in subs.items():
            seen[t] += len(take_all(sub))
        time.sleep(0.05)
    up.popen.send_signal(signal.SIGINT)
    assert up.popen.wait(60) == 0, up.stderr()
    from tensegrity_ros.bag.reader import BagReader

    counts = {t.name: t.message_count for t in BagReader(tmp_path / "bag").topics()}
    assert all(counts.get(t, 0) > 0 for t in want), counts
    node.destroy_node()
    # the recorder stored the scene in the bag (read back by the mcap package: rosbag2's
    # metadata record, and metadata.yaml), so `tensegrity view BAG` needs no --scene
    import yaml
    from mcap.reader import make_reader

    with open(tmp_path / "bag" / "bag_0.mcap", "rb") as f:
        records = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    assert yaml.safe_load(records["rosbag2"]["serialized_metadata"])["custom_data"] == {"scene": "table_actuated"}
    info = yaml.safe_load((tmp_path / "bag" / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["custom_data"] == {"scene": "table_actuated"}
    from tensegrity_ros.view.bag_source import BagSource

    assert BagSource(tmp_path / "bag").topic == "/general_up/body_states"


def test_up_on_a_robot_records_every_topic_its_simulator_publishes(cli, ros_context, tmp_path):
    """`up --scene ROBOT --record`: the simulator starts its clock once the recorder subscribes
    to every output topic, so the recorder must take the robot's own ones too (each
    ``imu/<rod>``, ``contacts``); a bag then holds every topic the simulator published."""
    import rclpy
    import yaml
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import Imu

    from tensegrity_core.robot import examples
    from tensegrity_ros.rclpy_utils.raw_take import take_all

    description = yaml.safe_load((Path(examples.__file__).parent / "six_bar.yaml").read_text())
    rods = [rod["name"] for rod in description["rods"]]           # imu: all (one IMU per rod)
    want = {f"/robot_up/{t}" for t in ("joint_states", "cable_states", "body_states", "contacts",
                                       *(f"imu/{r}" for r in rods))}
    up = cli("up", "--scene", "six_bar_rest", "--namespace", "/robot_up", "--record", str(tmp_path / "bag"),
             log_name="up")
    node = rclpy.create_node("up_robot_probe", context=ros_context)
    deadline = time.monotonic() + 120
    while not all(any(i.node_name == "tensegrity_recorder" for i in node.get_subscriptions_info_by_topic(t))
                  for t in want):
        assert up.popen.poll() is None and time.monotonic() < deadline, up.stderr()[-3000:]
        time.sleep(0.1)
    # the recorder took every output topic, so the clock runs: a few IMU states go out
    imu = node.create_subscription(Imu, f"/robot_up/imu/{rods[-1]}", lambda *_: None, QoSProfile(depth=100),
                                   raw=True)
    seen = 0
    while seen < 5:
        assert up.popen.poll() is None and time.monotonic() < deadline + 60, up.stderr()[-3000:]
        seen += len(take_all(imu))
        time.sleep(0.05)
    node.destroy_node()
    up.popen.send_signal(signal.SIGINT)
    assert up.popen.wait(60) == 0, up.stderr()[-3000:]
    from mcap.reader import make_reader

    counts: dict[str, int] = {}
    with open(tmp_path / "bag" / "bag_0.mcap", "rb") as f:
        for _, channel, _ in make_reader(f).iter_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
    assert all(counts.get(t, 0) > 0 for t in want), counts


def test_the_suite_nodes_of_a_namespace_are_told_apart_from_other_namespaces_and_nodes():
    from tensegrity_ros.apps.suite_presence import suite_nodes_in

    graph = [("tensegrity_sim", "/"), ("tensegrity_sim", "/robot2"), ("tensegrity_ik", "/"), ("talker", "/"),
             ("tensegrity_sim", "/")]
    assert suite_nodes_in(graph, "/") == ["/tensegrity_ik", "/tensegrity_sim"]
    assert suite_nodes_in(graph, "/robot2") == ["/robot2/tensegrity_sim"]
    assert suite_nodes_in(graph, "/robot3") == []


def test_suite_nodes_without_a_claim_are_found_in_the_graph_and_the_claim_is_left_free(ros_context):
    """A suite node started by hand (no `up`, so no claim): the look finds it in the graph,
    names it, and takes no claim; where nothing runs, the claim is taken and a second look
    meets it at once. The long look only bounds the wait: it ends as the node shows."""
    import rclpy

    from tensegrity_ros.apps.suite_claim import SuiteClaim, claim
    from tensegrity_ros.apps.suite_presence import running_suite

    node = rclpy.create_node("tensegrity_formfind", namespace="/by_hand", context=ros_context)
    try:
        presence = running_suite(["--ros-args", "-r", "__ns:=/by_hand"], ["sim", "ik"], look_s=120.0)
    finally:
        node.destroy_node()
    assert presence.found == ["/by_hand/tensegrity_formfind"] and presence.claim is None, presence
    free = claim(presence.domain, "/by_hand", [])
    assert isinstance(free, SuiteClaim)
    free.release()

    empty = running_suite(["--ros-args", "-r", "__ns:=/nobody_here"], ["sim", "formfind"], look_s=0.5)
    assert empty.found == [] and empty.namespace == "/nobody_here" and empty.claim is not None, empty
    try:
        again = running_suite(["--ros-args", "-r", "__ns:=/nobody_here"], ["sim"], look_s=0.5)
        assert again.found == ["/nobody_here/tensegrity_formfind", "/nobody_here/tensegrity_sim"], again
    finally:
        empty.claim.release()
