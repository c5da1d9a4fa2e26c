"""tensegrity_sim on a robot over real DDS: the 6-bar (``six_bar_drop``: every motor cable
commanded) publishes one joint per motor cable, every member's state, its rods' frames, one
IMU per rod and its contacts; rest-length commands drive its motors (tension and reel-speed
motors take their own fields), in lockstep equal to the core's sampled-data run to the last
bit; bad commands are refused and change nothing.

Oracles: the robot description's drawing, stiffnesses, rest lengths and masses (lengths,
Hooke's law and each rod's cable forces computed here: at t = 0 the robot hangs 5 cm above the
floor at rest, so each IMU reads its rod's cable forces over its mass and no rotation), and
the core's :func:`~tensegrity_core.sim.sampled.run_sampled` of the same gait.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from tests.ros.test_sim_general import Watcher

pytestmark = pytest.mark.ros

STEP_NS = 1_000_000
LIFT = 0.05             # six_bar_drop's initial lift [m]


@pytest.fixture
def robot(cli, ros_context):
    """Start `tensegrity node sim` on six_bar_drop with extra parameters; yields (proc, watcher)."""
    watchers = []

    def start(*params: str, scene: str = "six_bar_drop"):
        args = ["node", "sim", "--ros-args", "-p", f"scene:={scene}", "-p", f"step_size:={STEP_NS / 1e9}",
                "-p", "publish_rate:=100.0", "-p", "state_rate:=100.0", "-p", "marker_rate:=100.0",
                "-p", "imu_rate:=100.0"]
        for p in params:
            args += ["-p", p]
        proc = cli(*args, log_name="sim")
        proc.wait_for("publishing at")
        from sensor_msgs.msg import Imu
        from tensegrity_msgs.msg import CapContacts

        watcher = Watcher(ros_context, (("contacts", CapContacts), *((f"imu/rod{i}", Imu) for i in range(6))))
        watchers.append(watcher)
        return proc, watcher

    yield start
    for w in watchers:
        w.close()


def test_the_six_bar_at_rest_in_the_air_publishes_its_drawing_hookes_law_and_its_imus_and_refuses_bad_commands(robot):
    """One paused simulator: its states at rest, then bad robot commands (refused, nothing
    changed: still paused at t = 0, the drawn rest lengths)."""
    from tensegrity_core.robot.loading import load_robot

    proc, ros = robot("initial_state:=paused", "paused_publish_rate:=20.0", "imu_rate:=500.0")
    proc.wait_for("parameter imu_rate = 500 Hz is above publish_rate = 100 Hz: its topics go out with every "
                  "publication, at 100 Hz")           # capped, as at 100 Hz: said at start
    joints, cables, bodies, contacts, markers = ros.at(0, "joint_states", "cable_states", "body_states", "contacts",
                                                       "markers")
    r = load_robot("six_bar")
    nodes = r.nodes + [0.0, 0.0, LIFT]
    motor = [r.cables.names[c] for c in r.motors.cable]
    assert list(joints.name) == motor
    assert list(cables.name) == list(r.rods.names + r.cables.names)
    assert list(cables.kind) == ["bar"] * 6 + ["string"] * len(r.cables)
    assert list(cables.actuated) == [False] * 6 + [m >= 0 for m in r.cables.motor]
    h = nodes[r.cables.ends[:, 1]] - nodes[r.cables.ends[:, 0]]
    length = np.linalg.norm(h, axis=1)
    tension = np.maximum(0.0, r.cables.stiffness * (length - r.cables.rest_length))      # Hooke, at rest
    np.testing.assert_allclose(cables.length[6:], length, rtol=1e-12)
    np.testing.assert_array_equal(cables.rest_length[6:], r.cables.rest_length)
    np.testing.assert_allclose(cables.tension[6:], tension, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(cables.length_rate, 0.0, atol=1e-12)
    np.testing.assert_array_equal(cables.slack[6:], length < r.cables.rest_length)
    index = {n: i for i, n in enumerate(r.cables.names)}
    np.testing.assert_array_equal(joints.position, [cables.length[6 + index[m]] for m in motor])
    np.testing.assert_array_equal(joints.effort, [cables.tension[6 + index[m]] for m in motor])
    # the rods' frames: origin at the midpoint, the drawing's axes, at rest
    assert list(bodies.name) == list(r.rods.names)
    mid = nodes[r.rods.ends].mean(axis=1)
    np.testing.assert_allclose([[p.position.x, p.position.y, p.position.z] for p in bodies.pose], mid, atol=1e-12)
    np.testing.assert_allclose([[p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w]
                                for p in bodies.pose], [[0, 0, 0, 1]] * 6, atol=1e-12)
    # each IMU: specific force = (cable forces on the rod's caps) / its mass (gravity cancels:
    # a = F/m + g, the IMU reads a - g); no rotation yet
    pull = np.zeros((len(nodes), 3))
    for (a, b), t, u in zip(r.cables.ends, tension, h / length[:, None]):
        pull[a] += t * u
        pull[b] -= t * u
    for k, name in enumerate(r.rods.names):
        imu, = ros.at(0, f"imu/{name}")
        assert imu.header.frame_id == name
        expected = pull[r.rods.ends[k]].sum(axis=0) / r.rods.mass[k]
        a = imu.linear_acceleration
        np.testing.assert_allclose([a.x, a.y, a.z], expected, atol=1e-9 * max(1.0, np.abs(expected).max()))
        w, q = imu.angular_velocity, imu.orientation
        assert (w.x, w.y, w.z) == (0.0, 0.0, 0.0) and (q.x, q.y, q.z, q.w) == (0.0, 0.0, 0.0, 1.0)
        assert list(imu.orientation_covariance) == [0.0] * 9          # exact readings
    assert list(contacts.name) == []                                  # 5 cm up: nothing touches
    assert [m.ns for m in markers.markers] == ["rods", "cables", "floor", "contacts"]
    assert len(markers.markers[1].points) == 2 * len(r.cables)
    _bad_robot_commands_are_refused_and_change_nothing(proc, ros)


def wave(t: float, n: int) -> list[float]:
    """Rest lengths [m] of the 6-bar's n motor cables at ``t`` [s]: a wave around 0.75 m
    (inside the motors' range 0.45 .. 1.05 m)."""
    return [0.75 + 0.1 * math.sin(2 * math.pi * (t / 0.05 - i / n)) for i in range(n)]


def test_a_lockstep_run_of_a_gait_equals_the_cores_sampled_data_run_bit_for_bit(robot):
    from tensegrity_core.robot.loading import load_robot
    from tensegrity_core.sim.sampled import run_sampled
    from tensegrity_ros.apps.sim_client import SimClient

    r = load_robot("six_bar")
    motor = tuple(r.cables.names[c] for c in r.motors.cable)
    proc, ros = robot("lockstep:=true", "initial_state:=paused", "paused_publish_rate:=0.0",
                      "lockstep_timeout:=30.0")
    import rclpy

    steps = 60
    client = SimClient(rclpy, "robot_lockstep_client", context=ros.executor.context, cables=motor)
    try:
        client.wait_for_services(30)
        client.set_law(lambda s: wave(s.t, len(motor)), until_ns=steps * STEP_NS)
        client.step(steps)
        client.wait_joint(steps * STEP_NS)
        effectors = [ros.at(k * STEP_NS, "end_effector")[0].point for k in range(steps + 1)]
        bodies = ros.at(steps * STEP_NS, "body_states")[0]
    finally:
        client.close()
    run = run_sampled("six_bar_drop", lambda s: wave(s.t, len(motor)), step_ns=STEP_NS, steps=steps)
    assert run.success and len(run.samples) == steps + 1
    np.testing.assert_array_equal([[p.x, p.y, p.z] for p in effectors], [s.end_effector for s in run.samples])
    # the rods' centres are the first coordinates of each rod's six (centre, rotation vector)
    centres = run.samples[-1].q.reshape(-1, 6)[:, :3]
    np.testing.assert_array_equal([[p.position.x, p.position.y, p.position.z] for p in bodies.pose], centres)
    assert effectors[0].z - effectors[-1].z > 1e-3                 # it falls: 17.6 mm in 60 ms for its centre
    log = proc.stderr()
    assert "rejected" not in log and "no command for step" not in log


def _bad_robot_commands_are_refused_and_change_nothing(proc, ros):
    start, = ros.at(0, "cable_states")
    from tensegrity_msgs.msg import ActuatorForces

    forces = ros.node.create_publisher(ActuatorForces, "actuator_forces", 10)
    cases = [
        (lambda: ros.send(["c9_9"], [0.8]), "unknown cable name 'c9_9' (actuated cables: c0_4, c0_7"),
        (lambda: ros.send(["c0_4"], [float("nan")]), "rest length of c0_4 is not finite"),
        (lambda: ros.send(["c0_4"], [1.2]), "rest length of c0_4 = 1.2 m is outside its range (0.45, 1.05) m"),
        (lambda: ros.send(["c0_4"], [0.8], tension=[500.0]), "no named cable's motor takes tensions (leave tension empty)"),
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
    assert {tuple(m.rest_length) for m in ros.got["cable_states"].values()} == {tuple(start.rest_length)}
    assert set(ros.got["cable_states"]) == {0}                 # paused: nothing stepped


def test_tension_and_reel_speed_motors_take_their_commands_over_ros_exactly_as_the_core(robot, tmp_path):
    """A scene with c0_4's motor in tension mode and c0_7's in reel-speed mode: one
    CableCommand gives each its own field (NaN in the other), a rest length for a tension
    motor and a reel speed over the slew limit are refused in one line each; the states
    stepped under the command equal the core's, and the reel moves c0_7's rest length at the
    commanded speed (Delta l0 = v dt per 1 ms step, inside its range)."""
    import yaml

    from tensegrity_core.sim import Simulator
    from tensegrity_core.sim.sampled import step_time
    from tensegrity_ros.apps.sim_client import SimClient
    from tensegrity_ros.rclpy_utils.matching import wait_for_matches

    reel = -0.2                                  # m/s: reels in, inside the 6-bar's 0.5 m/s limit
    scene = tmp_path / "six_bar_modes.yaml"
    scene.write_text(yaml.safe_dump({
        "name": "six_bar_modes", "model": {"kind": "robot", "robot": "six_bar"},
        "initial": {"drawn": True, "lift": LIFT}, "duration": 3.0,
        "effects": ["inertia", "cables", {"motors": {"modes": {"c0_4": "tension", "c0_7": "reel_speed"}}},
                    "gravity", "contact", "friction", "sensors"]}))
    proc, ros = robot("initial_state:=paused", "paused_publish_rate:=20.0", scene=str(scene))
    import rclpy

    start, = ros.at(0, "cable_states")
    c04, c07 = list(start.name).index("c0_4"), list(start.name).index("c0_7")
    client = SimClient(rclpy, "robot_modes_client", context=ros.executor.context)
    nan = math.nan
    try:
        client.wait_for_services(30)
        assert wait_for_matches([ros.pub], 1, 30)
        deadline = time.monotonic() + 30
        for send, reason in ((lambda: ros.send(["c0_4"], [0.8]), "no named cable's motor takes rest lengths"),
                             (lambda: ros.send(["c0_7"], [], reel_speed=[0.6]),
                              "reel speed of c0_7 = 0.6 m/s is outside its range (-0.5, 0.5) m/s")):
            while reason not in proc.stderr():   # a reason of its own each: shown at once (refusals.py)
                assert time.monotonic() < deadline, proc.stderr()[-2000:]
                send()
                ros.spin(0.2)
        ros.send(["c0_4", "c0_7"], [], tension=[300.0, nan], reel_speed=[nan, reel])
        states = [start]
        while states[-1].rest_length[c04] == start.rest_length[c04]:
            assert time.monotonic() < deadline + 30, "the command never acted"
            client.step(1)
            states += ros.at(len(states) * STEP_NS, "cable_states")
        client.step(50)
        states += [ros.at(k * STEP_NS, "cable_states")[0] for k in range(len(states), len(states) + 50)]
    finally:
        client.close()
    k0, n = len(states) - 51, len(states) - 1
    sim = Simulator(str(scene))
    held = list(sim.command)
    inputs = sim.interface.inputs
    assert sim.interface.modes[inputs.index("c0_4")] == "tension"
    assert sim.interface.modes[inputs.index("c0_7")] == "reel_speed"
    for k in range(n):
        command = list(held)
        if k >= k0 - 1:
            command[inputs.index("c0_4")], command[inputs.index("c0_7")] = 300.0, reel
        sim.set_command(command)
        sim.advance(step_time(k + 1, STEP_NS))
    obs = sim.observe()
    np.testing.assert_array_equal(states[n].tension, obs.member_forces)
    assert states[n].rest_length[c04] < start.rest_length[c04] - 1e-3     # it reels in towards 300 N
    # the reel: every step from the command's first on moves c0_7's rest length by v dt
    moved = np.diff([s.rest_length[c07] for s in states[k0 - 1:]])
    np.testing.assert_allclose(moved, reel * STEP_NS / 1e9, rtol=1e-9)
