"""tensegrity_sim on a general structure over real DDS: the actuated tensegrity table
(``table_actuated``) publishes one joint per actuated cable, every member's state and the top
body's frame; cable commands (rest lengths) drive it, free-running and in lockstep; bad
cable commands are refused and change nothing.

Oracles: the structure file's drawing, EA and rest lengths with the published body pose
(the members' lengths and Hooke's law computed here), the top body's force and moment
balance at the form-found start, and the core simulator stepped in this process with the
same commands (equal to the last bit).
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

pytestmark = pytest.mark.ros

STEP_NS = 10_000_000
CABLES = ("long1", "long2", "long3")
G = 9.80665


class Watcher:
    """A node in the test process keeping the simulator's latest outputs by stamp."""

    def __init__(self, ctx, extra: tuple[tuple[str, type], ...] = ()):
        import rclpy
        from geometry_msgs.msg import PointStamped
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import QoSProfile
        from sensor_msgs.msg import JointState
        from tensegrity_msgs.msg import CableCommand, CableStates, RigidBodyStates
        from visualization_msgs.msg import MarkerArray

        self.node = rclpy.create_node("general_watcher", context=ctx)
        self.got: dict[str, dict[int, object]] = {}
        self.count: dict[str, int] = {}
        qos = QoSProfile(depth=1000)
        for topic, kind in (("joint_states", JointState), ("cable_states", CableStates),
                            ("body_states", RigidBodyStates), ("end_effector", PointStamped),
                            ("markers", MarkerArray), *extra):
            self.got[topic], self.count[topic] = {}, 0
            self.node.create_subscription(kind, topic, lambda m, t=topic: self._keep(t, m), qos)
        self.pub = self.node.create_publisher(CableCommand, "cable_commands", 10)
        self.CableCommand = CableCommand
        self.executor = SingleThreadedExecutor(context=ctx)
        self.executor.add_node(self.node)

    def _keep(self, topic, msg) -> None:
        header = msg.markers[0].header if topic == "markers" else msg.header
        self.got[topic][header.stamp.sec * 10**9 + header.stamp.nanosec] = msg
        self.count[topic] += 1

    def spin_until(self, cond, timeout: float = 60.0) -> None:
        end = time.monotonic() + timeout
        while not cond():
            assert time.monotonic() < end, "condition not met in time"
            self.executor.spin_once(timeout_sec=0.01)

    def spin(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.01)

    def at(self, stamp_ns: int, *topics: str) -> list:
        self.spin_until(lambda: all(stamp_ns in self.got[t] for t in topics))
        return [self.got[t][stamp_ns] for t in topics]

    def send(self, names, rest_lengths, **extra) -> None:
        self.pub.publish(self.CableCommand(name=list(names), rest_length=list(rest_lengths), **extra))

    def close(self) -> None:
        self.node.destroy_node()


@pytest.fixture
def table(cli, ros_context):
    """Start `tensegrity node sim` on table_actuated with extra parameters; yields (proc, watcher)."""
    watchers = []

    def start(*params: str, scene: str = "table_actuated"):
        args = ["node", "sim", "--ros-args", "-p", f"scene:={scene}", "-p", f"step_size:={STEP_NS / 1e9}",
                "-p", "publish_rate:=100.0", "-p", "state_rate:=100.0", "-p", "marker_rate:=100.0"]
        for p in params:
            args += ["-p", p]
        proc = cli(*args, log_name="sim")
        proc.wait_for("publishing at")
        watcher = Watcher(ros_context)
        watchers.append(watcher)
        return proc, watcher

    yield start
    for w in watchers:
        w.close()


def _structure():
    from tensegrity_core.general import structure_from_file
    from tensegrity_core.sim import scene_path

    return structure_from_file(scene_path("table_actuated").parent / "structures" / "table_actuated.yaml")


def _rotation(q) -> np.ndarray:
    x, y, z, w = q.x, q.y, q.z, q.w
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _nodes(structure, body_pose) -> np.ndarray:
    """Node positions: the fixed bottom as drawn, the top placed by its published pose."""
    nodes = structure.nodes.copy()
    top = list(structure.bodies[1].nodes)
    drawn = structure.nodes[top]
    R = _rotation(body_pose.orientation)
    p = body_pose.position
    nodes[top] = np.array([p.x, p.y, p.z]) + (drawn - drawn.mean(axis=0)) @ R.T
    return nodes


def test_a_paused_table_agrees_with_its_structure_refuses_bad_cable_commands_and_steps_a_good_one_as_the_core(table):
    """One paused simulator, in this order (each part leaves the state the next starts
    from: paused at t = 0, the drawn rest lengths): its states at rest, bad cable commands
    (refused, nothing changed), a good one stepped as the core steps it."""
    proc, ros = table("initial_state:=paused", "paused_publish_rate:=20.0")
    _joint_states_cable_states_and_the_body_frame_agree_with_the_structure_at_rest(ros)
    _bad_cable_commands_are_refused_and_change_nothing(proc, ros)
    _a_cable_command_drives_the_rest_length_exactly_as_the_core(proc, ros)


def _joint_states_cable_states_and_the_body_frame_agree_with_the_structure_at_rest(ros):
    joints, cables, bodies, ee, markers = ros.at(0, "joint_states", "cable_states", "body_states", "end_effector",
                                                 "markers")
    s = _structure()
    assert list(joints.name) == list(CABLES) and list(bodies.name) == ["top"]
    assert list(cables.name) == list(s.member_names) and list(cables.kind) == list(s.member_kinds)
    assert list(cables.actuated) == [True, True, True, False]
    nodes = _nodes(s, bodies.pose[0])
    h = nodes[s.members[:, 1]] - nodes[s.members[:, 0]]
    lengths = np.linalg.norm(h, axis=1)
    np.testing.assert_allclose(cables.length, lengths, rtol=1e-12)
    np.testing.assert_array_equal(cables.rest_length, s.rest_lengths)          # the drawn 0.9, 0.3 m
    tension = s.EA * (lengths - s.rest_lengths) / s.rest_lengths                 # Hooke, all taut
    np.testing.assert_allclose(cables.tension, tension, rtol=1e-9)
    assert not any(cables.slack) and min(tension) > 0
    np.testing.assert_array_equal(joints.position, np.array(cables.length)[:3])
    np.testing.assert_array_equal(joints.effort, np.array(cables.tension)[:3])
    np.testing.assert_allclose(joints.velocity, 0.0, atol=1e-12)                 # at rest
    c1 = nodes[s.node_names.index("c1")]
    np.testing.assert_allclose([ee.point.x, ee.point.y, ee.point.z], c1, rtol=1e-12)
    # the top body at rest: its members' forces and its weight balance, as forces and moments
    top = set(s.bodies[1].nodes)
    centre = np.array([bodies.pose[0].position.x, bodies.pose[0].position.y, bodies.pose[0].position.z])
    force, moment = np.array([0.0, 0.0, -2.0 * G]), np.zeros(3)        # the weight acts at the centre
    for (a, b), t, u in zip(s.members, tension, h / lengths[:, None]):
        for node, pull in ((a, t * u), (b, -t * u)):
            if node in top:
                force += pull
                moment += np.cross(nodes[node] - centre, pull)
    assert np.linalg.norm(force) < 1e-7 * max(tension) and np.linalg.norm(moment) < 1e-7 * max(tension)
    assert len(markers.markers[0].points) == 2 * len(s.member_names)


def _a_cable_command_drives_the_rest_length_exactly_as_the_core(proc, ros):
    """A command sent while paused (free-running) holds from the step that follows its
    arrival; the states stepped under it equal the core's under the same commands."""
    import rclpy

    from tensegrity_core.sim import Simulator
    from tensegrity_core.sim.sampled import step_time
    from tensegrity_ros.apps.sim_client import SimClient
    from tensegrity_ros.rclpy_utils.matching import wait_for_matches

    since = len(proc.stderr())
    start, = ros.at(0, "cable_states")
    client = SimClient(rclpy, "general_test_client", context=ros.executor.context, cables=CABLES)
    try:
        client.wait_for_services(30)
        assert wait_for_matches([ros.pub], 1, 30)
        ros.send(["long1"], [0.85])
        # one step at a time until a state shows the command (it may arrive at any step),
        # then 20 more under it
        states = [start]
        deadline = time.monotonic() + 60
        while states[-1].rest_length[0] != 0.85:
            assert time.monotonic() < deadline, "the cable command never acted"
            client.step(1)
            states += ros.at(len(states) * STEP_NS, "cable_states")
        client.step(20)
        states += [ros.at(k * STEP_NS, "cable_states")[0] for k in range(len(states), len(states) + 20)]
    finally:
        client.close()
    # the state at t_k shows the rest lengths it was stepped under: the command's from step k0 - 1
    k0, n = len(states) - 21, len(states) - 1
    assert all(list(m.rest_length) == [0.9, 0.9, 0.9, 0.3] for m in states[:k0])
    assert all(list(m.rest_length) == [0.85, 0.9, 0.9, 0.3] for m in states[k0:])
    sim = Simulator("table_actuated")
    for k in range(n):
        sim.set_command([0.85 if k >= k0 - 1 else 0.9, 0.9, 0.9])
        sim.advance(step_time(k + 1, STEP_NS))
    obs = sim.observe()
    np.testing.assert_array_equal(states[n].length, obs.member_lengths)
    np.testing.assert_array_equal(states[n].tension, obs.member_forces)
    assert states[n].length[0] < start.length[0] - 1e-4          # the shorter rest length pulled c1 down
    assert "rejected" not in proc.stderr()[since:]


def gait(sample) -> list[float]:
    """Rest lengths [m] of long1..3 at the sample's time: a wave around the table."""
    return [0.9 + 0.03 * math.sin(2 * math.pi * (sample.t / 0.4 - i / 3)) for i in range(3)]


def test_a_lockstep_run_under_cable_commands_equals_the_core_run_bit_for_bit(table):
    from tensegrity_core.sim import Simulator
    from tensegrity_core.sim.sampled import step_time
    from tensegrity_core.sim.simulator import JointSample
    from tensegrity_ros.apps.sim_client import SimClient

    proc, ros = table("lockstep:=true", "initial_state:=paused", "paused_publish_rate:=0.0",
                      "lockstep_timeout:=30.0")
    import rclpy

    steps = 40
    client = SimClient(rclpy, "general_lockstep_client", context=ros.executor.context, cables=CABLES)
    try:
        client.wait_for_services(30)
        client.set_law(gait, until_ns=steps * STEP_NS)
        client.step(steps)
        client.wait_joint(steps * STEP_NS)
        table_ = {j.stamp_ns: j for j in client.take_joints()}
    finally:
        client.close()
    sim = Simulator("table_actuated")
    expected = [sim.observe()]
    for k in range(steps):
        sim.set_command(gait(JointSample(step_time(k, STEP_NS), np.zeros(0), np.zeros(0), np.zeros(0),
                                         np.zeros(3), False)))
        sim.advance(step_time(k + 1, STEP_NS))
        expected.append(sim.observe())
    ros_lengths = np.array([table_[k * STEP_NS].position for k in range(steps + 1)])
    np.testing.assert_array_equal(ros_lengths, np.array([o.member_lengths[:3] for o in expected]))
    np.testing.assert_array_equal(np.array([table_[k * STEP_NS].effort for k in range(steps + 1)]),
                                  np.array([o.member_forces[:3] for o in expected]))
    assert np.ptp(ros_lengths[:, 0]) > 1e-3                     # the gait moved the table
    log = proc.stderr()
    assert "rejected" not in log and "no command for step" not in log


def _bad_cable_commands_are_refused_and_change_nothing(proc, ros):
    ros.at(0, "cable_states")
    from tensegrity_msgs.msg import ActuatorForces

    forces = ros.node.create_publisher(ActuatorForces, "actuator_forces", 10)
    cases = [
        (lambda: ros.send(["long9"], [0.8]), "unknown cable name 'long9' (actuated cables: long1, long2, long3)"),
        (lambda: ros.send(["long1"], [float("nan")]), "rest length of long1 is not finite"),
        (lambda: ros.send(["long2"], [-0.1]), "rest length of long2 = -0.1 m is outside its range (0, inf) m"),
        (lambda: ros.send([], [0.8, 0.8]), "unnamed command must give 3 rest lengths"),
        (lambda: ros.send(["long1", "long1"], [0.8, 0.8]), "cable long1 named twice"),
        (lambda: ros.send(["long1"], [0.8], reel_speed=[0.1]), "reel_speed commands are not taken"),
        (lambda: forces.publish(ActuatorForces(name=["f1"], force=[1.0])),
         "not actuator forces: send tensegrity_msgs/CableCommand on cable_commands"),
    ]
    for send, reason in cases:
        # warnings are throttled per reason (tensegrity_ros/nodes/refusals.py): each case's
        # refusal is a reason of its own, shown at once; resent until it is seen
        deadline = time.monotonic() + 30
        while reason not in proc.stderr():
            assert time.monotonic() < deadline, (reason, proc.stderr()[-2000:])
            send()
            ros.spin(0.2)
    n = ros.count["cable_states"]
    ros.spin(0.5)
    assert ros.count["cable_states"] > n                       # alive: still republishing
    assert {tuple(m.rest_length) for m in ros.got["cable_states"].values()} == {(0.9, 0.9, 0.9, 0.3)}
    assert set(ros.got["cable_states"]) == {0}                 # paused: nothing stepped


def test_a_cable_command_to_the_class2_mechanism_names_the_right_message(table):
    proc, ros = table(scene="class2_at_rest")
    deadline = time.monotonic() + 30
    while "send tensegrity_msgs/ActuatorForces on actuator_forces" not in proc.stderr():
        assert time.monotonic() < deadline, proc.stderr()[-2000:]
        ros.send(["long1"], [0.8])
        ros.spin(0.2)
    assert "rejected cable command: this scene's inputs are actuator forces (f1, f2)" in proc.stderr()
