"""What a robot's simulator publishes, read as a roboticist reads it: the 6-bar of
``six_bar_rest`` (standing on a face, motors holding) on a free-running simulator.

Expectations come from the ROS 2 message conventions and issues 29-30, and are computed here
from the robot's description file read with PyYAML (not from the suite's code):

- ``joint_states``: one joint per motor cable of ``six_bar.yaml``; position = the cable's
  length [m] = the distance of its two caps, each at its rod's pose applied to the drawn
  offset from the rod's centre (``body_states``, docs/ros.md); velocity = d(length)/dt
  [m/s] from the rods' twists; effort = tension [N] >= 0, the cable law of the description
  (stiffness 4000 N/m, damping 50 N s/m, tension-only).
- ``cable_states``: slack iff tension 0; rods are bars, cables strings, strings never push.
- ``imu/<rod>`` (sensor_msgs/Imu): frame_id = the rod, a unit quaternion equal to the rod's
  pose, covariances per sensor_msgs (all zeros = unknown; element 0 = -1 only for a quantity
  not provided), at rest the specific force -g in the rod frame (+9.81 m/s^2 along world up
  expressed in the rod frame) and no rotation; stamps on the simulation clock.
- ``/tf`` (tf2_msgs/TFMessage, what tf2 listeners and RViz read): world (body_states'
  frame_id) -> each rod's frame (the IMUs' frame_ids), stamped as body_states, equal to its
  poses; the rod's drawn axis, rotated, is the line of its two caps now: caps placed by the
  transforms reproduce every cable's length (cable_states) and every contact's position.
- ``/clock`` advances; every state is stamped with a time the clock published.
- ``contacts``: only the caps that touch (their centre one cap radius above the floor within
  1 mm, issue 29's penetration bound), normal forces >= 0 that carry the robot's weight at
  rest (6 rods x 5 kg: a rod's ``mass`` includes its caps, docs/structures.md), friction
  within mu_static x normal.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from tensegrity_core.robot import examples
from tests.contract.client import Client, stamp_ns, start_sim

pytestmark = pytest.mark.ros

G = 9.81                                   # m/s^2 (9.80665 is within the tolerances below)


@pytest.fixture(scope="module")
def robot():
    """The 6-bar's description, as a user reads it."""
    from pathlib import Path

    return yaml.safe_load((Path(examples.__file__).parent / "six_bar.yaml").read_text())


@pytest.fixture(scope="module")
def suite(tmp_path_factory, robot):
    from rclpy.qos import QoSProfile
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import Imu, JointState
    from tensegrity_msgs.msg import CableStates, CapContacts, RigidBodyStates
    from tf2_msgs.msg import TFMessage

    # as fast as the machine allows, publishing every 50 ms of simulated time (1 ms steps): the
    # robot rocks on its face for about 10 s of simulation before it is at rest
    sim = start_sim(tmp_path_factory.mktemp("robot_topics"), "six_bar_rest", "real_time_factor:=0.0",
                    "publish_rate:=20.0", "step_size:=0.001", "marker_rate:=0.0")
    client = Client("robot_topics_client")
    try:
        client.listen(Clock, "/clock", QoSProfile(depth=1000))
        for msg_type, topic in ((JointState, "joint_states"), (CableStates, "cable_states"),
                                (RigidBodyStates, "body_states"), (CapContacts, "contacts")):
            client.listen(msg_type, topic, QoSProfile(depth=1000))
        for rod in robot["rods"]:
            client.listen(Imu, f"imu/{rod['name']}", QoSProfile(depth=1000))
        # as tf2's TransformListener subscribes (reliable, volatile, keep last 100)
        client.listen(TFMessage, "/tf", QoSProfile(depth=100))
        yield client, sim
    finally:
        client.close()
        sim.stop()


def _by_stamp(client, topic):
    return client.stamped[topic]


def _at_rest(client, robot) -> int | None:
    """The stamp [ns] of a state of the robot at rest (every rod's speed < 1 mm/s and rotation
    < 0.01 rad/s) that joint_states, cable_states, contacts and every rod's IMU have, or None
    (every rod's as the description names them: an IMU subscription that matched later than the
    others has received nothing yet)."""
    bodies = client.received["body_states"][-8:]          # the latest states (each later one is as good)
    topics = ["joint_states", "cable_states", "contacts"] + [f"imu/{rod['name']}" for rod in robot["rods"]]
    for msg in reversed(bodies):
        stamp = stamp_ns(msg.header.stamp)
        if all(stamp in client.stamped[t] for t in topics) and all(
                np.hypot(np.hypot(t.linear.x, t.linear.y), t.linear.z) < 1e-3
                and np.hypot(np.hypot(t.angular.x, t.angular.y), t.angular.z) < 1e-2 for t in msg.twist):
            return stamp
    return None


def _rotation(q):
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat([q.x, q.y, q.z, q.w])


def _caps(robot, bodies):
    """Each cap's position [m] and velocity [m/s] from the rods' poses and twists (world frame)."""
    nodes = {n: np.array(p, dtype=float) for n, p in robot["nodes"].items()}
    poses = dict(zip(bodies.name, zip(bodies.pose, bodies.twist)))
    out = {}
    for rod in robot["rods"]:
        pose, twist = poses[rod["name"]]
        centre_drawn = (nodes[rod["nodes"][0]] + nodes[rod["nodes"][1]]) / 2
        centre = np.array([pose.position.x, pose.position.y, pose.position.z])
        v = np.array([twist.linear.x, twist.linear.y, twist.linear.z])
        w = np.array([twist.angular.x, twist.angular.y, twist.angular.z])
        for n in rod["nodes"]:
            r = _rotation(pose.orientation).apply(nodes[n] - centre_drawn)
            out[n] = (centre + r, v + np.cross(w, r))
    return out


def test_joint_states_are_the_motor_cables_length_rate_and_tension(suite, robot):
    client, _ = suite
    stamp = client.wait(lambda: _at_rest(client, robot), "the robot at rest in every topic")
    joints = _by_stamp(client, "joint_states")[stamp]
    bodies = _by_stamp(client, "body_states")[stamp]
    states = _by_stamp(client, "cable_states")[stamp]
    motors = [c["name"] for c in robot["cables"] if c.get("motor")]
    assert sorted(joints.name) == sorted(motors)
    assert len(joints.position) == len(joints.velocity) == len(joints.effort) == len(motors)
    caps = _caps(robot, bodies)
    ends = {c["name"]: c["nodes"] for c in robot["cables"]}
    rest = dict(zip(states.name, states.rest_length))
    k, c = robot["cable_defaults"]["stiffness"], robot["cable_defaults"]["damping"]
    for name, length, rate, tension in zip(joints.name, joints.position, joints.velocity, joints.effort):
        (pa, va), (pb, vb) = caps[ends[name][0]], caps[ends[name][1]]
        d = pa - pb
        assert length == pytest.approx(np.linalg.norm(d), abs=1e-9), name
        assert rate == pytest.approx(d @ (va - vb) / np.linalg.norm(d), abs=1e-6), name
        expected = max(0.0, k * (length - rest[name]) + c * rate) if length > rest[name] else 0.0
        assert tension >= 0.0
        assert tension == pytest.approx(expected, rel=1e-9, abs=1e-6), name


def test_cable_states_name_every_member_and_slack_means_no_tension(suite, robot):
    client, _ = suite
    stamp = client.wait(lambda: _at_rest(client, robot), "the robot at rest in every topic")
    states = _by_stamp(client, "cable_states")[stamp]
    rods = [r["name"] for r in robot["rods"]]
    cables = [c["name"] for c in robot["cables"]]
    assert sorted(states.name) == sorted(rods + cables)
    joints = _by_stamp(client, "joint_states")[stamp]
    lengths = dict(zip(joints.name, joints.position))
    for name, kind, length, tension, slack in zip(states.name, states.kind, states.length, states.tension,
                                                  states.slack):
        assert kind == ("bar" if name in rods else "string"), name
        if name in cables:
            assert tension >= 0.0, name
            assert slack == (tension == 0.0), name
            assert length == lengths[name]
    msgs = client.received["cable_states"]
    assert all(m.slack[i] == (m.tension[i] == 0.0) for m in msgs for i, n in enumerate(m.name) if n in cables)


def test_each_rod_imu_reads_as_sensor_msgs_imu_says_at_rest(suite, robot):
    client, _ = suite
    stamp = client.wait(lambda: _at_rest(client, robot), "the robot at rest in every topic")
    bodies = _by_stamp(client, "body_states")[stamp]
    poses = dict(zip(bodies.name, bodies.pose))
    for rod in (r["name"] for r in robot["rods"]):
        imu = _by_stamp(client, f"imu/{rod}")[stamp]
        assert imu.header.frame_id == rod
        q = imu.orientation
        assert np.hypot(np.hypot(q.x, q.y), np.hypot(q.z, q.w)) == pytest.approx(1.0, abs=1e-9)
        body = _rotation(poses[rod].orientation).as_matrix()
        assert np.allclose(_rotation(q).as_matrix(), body, atol=1e-9), rod    # the rod's frame
        for cov in (imu.orientation_covariance, imu.angular_velocity_covariance,
                    imu.linear_acceleration_covariance):
            assert len(cov) == 9
            # every quantity is provided: element 0 is not -1; exact readings: zeros (unknown) or >= 0
            assert cov[0] != -1.0 and all(np.isfinite(cov)) and min(cov[0], cov[4], cov[8]) >= 0.0
        up_in_rod = _rotation(q).inv().apply([0.0, 0.0, G])
        a = imu.linear_acceleration
        assert np.allclose([a.x, a.y, a.z], up_in_rod, atol=0.05), (rod, a, up_in_rod)
        w = imu.angular_velocity
        assert np.allclose([w.x, w.y, w.z], 0.0, atol=1e-2), rod


def test_every_state_is_stamped_on_the_simulation_clock(suite, robot):
    client, _ = suite
    client.wait_count("/clock", 20)
    clock = [stamp_ns(m.clock) for m in client.received["/clock"]]
    assert all(b > a for a, b in zip(clock, clock[1:])), "the clock went back or stood while playing"
    assert clock[-1] < 3600 * 10**9              # simulation time from 0, not the wall clock
    # the clock's step: a reader more than its history (1000 ticks) behind on a loaded machine
    # loses ticks, so a state is on the clock when it lies on the ticks' grid, heard or not
    step = math.gcd(*(b - a for a, b in zip(clock, clock[1:])))
    for topic in ("joint_states", "cable_states", "contacts", f"imu/{robot['rods'][0]['name']}"):
        stamps = [s for s in _by_stamp(client, topic) if clock[0] <= s <= clock[-1]]
        assert stamps and all((s - clock[0]) % step == 0 for s in stamps), (topic, step)


def test_contacts_are_the_caps_on_the_floor_and_carry_the_weight(suite, robot):
    client, _ = suite
    stamp = client.wait(lambda: _at_rest(client, robot), "the robot at rest in every topic")
    contacts = _by_stamp(client, "contacts")[stamp]
    caps = _caps(robot, _by_stamp(client, "body_states")[stamp])
    radius = {n: r["cap_radius"] for r in robot["rods"] for n in r["nodes"]}
    touching = set(contacts.name)
    assert len(touching) == 3                     # standing on a face
    for name, point, normal, friction in zip(contacts.name, contacts.position, contacts.normal_force,
                                             contacts.friction_force):
        assert normal >= 0.0
        assert point.z == pytest.approx(caps[name][0][2], abs=1e-9)
        assert 0.0 <= radius[name] - point.z < 1e-3, name       # touching, less than 1 mm into the floor
        assert np.hypot(friction.x, friction.y) <= robot["floor"]["mu_static"] * normal + 1e-9
        assert friction.z == 0.0
    for name, (p, _) in caps.items():
        if name not in touching:
            assert p[2] > radius[name], name                   # every other cap is off the floor
    mass = sum(r["mass"] for r in robot["rods"])          # each rod's whole mass, caps included
    assert sum(contacts.normal_force) == pytest.approx(mass * G, rel=5e-3)


def test_the_simulator_offers_events_and_markers(suite):
    client, _ = suite
    topics = client.topics_of("tensegrity_sim")
    assert topics["/events"] == ["tensegrity_msgs/msg/SimulationEvent"]
    assert topics["/markers"] == ["visualization_msgs/msg/MarkerArray"]
    assert topics["/body_states"] == ["tensegrity_msgs/msg/RigidBodyStates"]     # the rods' poses


def test_a_node_with_use_sim_time_follows_the_simulation_clock(suite):
    """rclpy's own TimeSource subscribes to /clock (best effort, depth 1) when use_sim_time is set."""
    import rclpy
    from rclpy.parameter import Parameter

    client, _ = suite
    node = rclpy.create_node("sim_time_user", context=client.context,
                             parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, True)])
    try:
        client.add_node(node)
        client.wait_until(lambda: node.get_clock().now().nanoseconds > 0, "the node's clock to start")
        latest = max(client.stamped_copy("joint_states"))
        client.wait_until(lambda: node.get_clock().now().nanoseconds >= latest, "the node's clock to pass a state")
        assert node.get_clock().now().nanoseconds < latest + 3600 * 10**9       # simulation time, not wall time
    finally:
        client.drop_node(node)


def _tf_at(client, stamp):
    """world -> frame transforms of the /tf message stamped ``stamp`` [ns] (None if none arrived)."""
    for msg in reversed(client.received["/tf"]):
        if msg.transforms and stamp_ns(msg.transforms[0].header.stamp) == stamp:
            return msg
    return None


def test_tf_gives_every_rod_frame_the_imus_name(suite, robot):
    client, _ = suite
    stamp = client.wait(lambda: (s := _at_rest(client, robot)) is not None and _tf_at(client, s) is not None and s,
                        "the robot at rest in every topic and /tf")
    tf = _tf_at(client, stamp)
    bodies = _by_stamp(client, "body_states")[stamp]
    rods = [r["name"] for r in robot["rods"]]
    assert sorted(t.child_frame_id for t in tf.transforms) == sorted(rods)
    imu_frames = {client.received[f"imu/{rod}"][-1].header.frame_id for rod in rods}
    assert imu_frames == set(rods)                                    # the frames tf2 must resolve
    poses = dict(zip(bodies.name, bodies.pose))
    for t in tf.transforms:
        assert t.header.frame_id == bodies.header.frame_id != ""     # the world frame of body_states
        assert stamp_ns(t.header.stamp) == stamp
        pose = poses[t.child_frame_id]
        r, q = t.transform.translation, t.transform.rotation
        assert (r.x, r.y, r.z) == (pose.position.x, pose.position.y, pose.position.z)
        assert _rotation(q).approx_equal(_rotation(pose.orientation), atol=1e-12)
        imu = _by_stamp(client, f"imu/{t.child_frame_id}")[stamp]
        assert _rotation(q).approx_equal(_rotation(imu.orientation), atol=1e-9)   # body -> world, both


def test_tf_places_the_caps_where_the_cables_and_contacts_say(suite, robot):
    client, _ = suite
    stamp = client.wait(lambda: (s := _at_rest(client, robot)) is not None and _tf_at(client, s) is not None and s,
                        "the robot at rest in every topic and /tf")
    tf = {t.child_frame_id: t.transform for t in _tf_at(client, stamp).transforms}
    nodes = {n: np.array(p, dtype=float) for n, p in robot["nodes"].items()}
    caps = {}
    for rod in robot["rods"]:
        a, b = (nodes[n] for n in rod["nodes"])
        t = tf[rod["name"]]
        rotation, origin = _rotation(t.rotation), np.array([t.translation.x, t.translation.y, t.translation.z])
        for n in rod["nodes"]:                  # the rod's frame has the world's axes in the drawing
            caps[n] = origin + rotation.apply(nodes[n] - (a + b) / 2)
    # every cable's length and every contact fix each rod's axis (the line of its caps) and centre
    states = _by_stamp(client, "cable_states")[stamp]
    length = dict(zip(states.name, states.length))
    for cable in robot["cables"]:
        i, j = cable["nodes"]
        assert np.linalg.norm(caps[i] - caps[j]) == pytest.approx(length[cable["name"]], abs=1e-9), cable["name"]
    contacts = _by_stamp(client, "contacts")[stamp]
    for name, p in zip(contacts.name, contacts.position):
        np.testing.assert_allclose(caps[name], [p.x, p.y, p.z], atol=1e-9)
