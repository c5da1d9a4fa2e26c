"""The simulator node's parts without DDS: the sender's stamps, the receiver's lockstep
check, the plant's integer clock, the run-control table of the standard, joint_states as
serialized bytes."""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.ros


def test_stamps_are_exact_integer_nanoseconds():
    from tensegrity_ros.nodes.sim.sender import time_msg
    from tensegrity_ros.rclpy_utils.messages import stamp_ns

    for ns in (0, 1, 999_999_999, 1_000_000_000, 123 * 10**9 + 456, 2**40 + 7):
        msg = time_msg(ns)
        assert 0 <= msg.nanosec < 10**9 and stamp_ns(msg) == ns
    # what a float seconds round trip would lose: 1e9 steps of 1 ns at 2**40 ns
    assert time_msg(2**40 + 7).nanosec == (2**40 + 7) % 10**9


def test_the_plant_clock_is_k_steps_and_a_reset_keeps_or_zeroes_it():
    from tensegrity_core.sim import load_scene
    from tensegrity_core.sim.sampled import step_time
    from tensegrity_ros.nodes.sim.plant import SimPlant

    plant = SimPlant(load_scene("class2_at_rest"), 3_000_000)
    hold = plant.initial_command
    for _ in range(7):
        assert plant.step(hold).fault is None
    assert plant.time_ns == 21_000_000 and plant.sim.t == step_time(7, 3_000_000)
    plant.reset(keep_time=True)
    plant.step(hold)
    assert plant.time_ns == 24_000_000 and plant.sim.t == step_time(1, 3_000_000)
    plant.reset(keep_time=False)
    assert plant.time_ns == 0 and plant.k == 0


def test_a_faulted_plant_holds_the_state_and_the_clock_goes_on():
    from tensegrity_core.sim import load_scene
    from tensegrity_ros.nodes.sim.plant import SimPlant

    plant = SimPlant(load_scene("class2_at_rest"), 10_000_000)
    outcome = None
    for _ in range(300):                 # -3 N on both pushes rho1 + rho2 to 2L (lambda1) in ~1 s
        outcome = plant.step([-3.0, -3.0])
        if outcome.fault:
            break
    assert outcome.fault and "lambda1" in outcome.fault
    assert any(kind == "singular" for _, kind, _ in outcome.events)
    held = plant.joint_sample().q.copy()
    k = plant.k
    assert plant.step([0.0, 0.0]) == type(outcome)((), None)
    assert plant.k == k + 1 and (plant.joint_sample().q == held).all()


def test_a_lockstep_command_must_carry_the_stamp_of_the_state_it_answers():
    from tensegrity_msgs.msg import ActuatorForces

    from tensegrity_ros.nodes.actuator_commands import CommandError
    from tensegrity_ros.nodes.sim.receiver import check_step, receive

    msg = ActuatorForces(name=["f2"], force=[1.5])
    msg.header.stamp.sec, msg.header.stamp.nanosec = 2, 500_000_000
    cmd = receive(msg, max_force=10.0)
    assert cmd.stamp_ns == 2_500_000_000 and cmd.update.apply([0.0, 0.0]) == [0.0, 1.5]
    check_step(cmd, 2_500_000_000, 250)
    with pytest.raises(CommandError, match=r"stamped 2.500000000 s, but the simulator waits at step 251 "
                                           r"\(t = 2.510000000 s\)"):
        check_step(cmd, 2_510_000_000, 251)


def test_every_transition_of_the_standard():
    from simulation_interfaces.msg import Result, SimulationState
    from simulation_interfaces.srv import SetSimulationState

    from tensegrity_ros.nodes.sim.control import PAUSED, PLAYING, STOPPED, transition

    ok, already = Result.RESULT_OK, SetSimulationState.Response.ALREADY_IN_TARGET_STATE
    table = {(STOPPED, PLAYING): (ok, False), (STOPPED, PAUSED): (ok, False), (PLAYING, PAUSED): (ok, False),
             (PAUSED, PLAYING): (ok, False), (PLAYING, STOPPED): (ok, True), (PAUSED, STOPPED): (ok, True)}
    for a in (STOPPED, PLAYING, PAUSED):
        assert transition(a, a).answer.code == already and transition(a, a).state == a
        for b in (STOPPED, PLAYING, PAUSED):
            if a != b:
                t = transition(a, b)
                assert (t.answer.code, t.reset) == table[(a, b)] and t.state == b
        assert transition(a, SimulationState.STATE_QUITTING).answer.code == Result.RESULT_FEATURE_UNSUPPORTED
        for bad in (SimulationState.STATE_NO_WORLD, SimulationState.STATE_LOADING_WORLD, 17, 255):
            t = transition(a, bad)
            assert t.answer.code == SetSimulationState.Response.INCORRECT_TRANSITION and t.state == a


def test_reset_scopes():
    from simulation_interfaces.msg import Result
    from simulation_interfaces.srv import ResetSimulation

    from tensegrity_ros.nodes.sim.control import reset_plan

    r = ResetSimulation.Request
    assert (reset_plan(r.SCOPE_DEFAULT).answer.ok, reset_plan(r.SCOPE_DEFAULT).time) == (True, True)
    assert (reset_plan(r.SCOPE_ALL).answer.ok, reset_plan(r.SCOPE_ALL).time) == (True, True)
    assert (reset_plan(r.SCOPE_STATE).answer.ok, reset_plan(r.SCOPE_STATE).time) == (True, False)
    assert reset_plan(r.SCOPE_STATE | r.SCOPE_TIME).time
    for scope in (r.SCOPE_TIME, r.SCOPE_SPAWNED, r.SCOPE_STATE | r.SCOPE_SPAWNED, 8, 64):
        assert reset_plan(scope).answer.code == Result.RESULT_FEATURE_UNSUPPORTED


@pytest.mark.parametrize("scene", ["six_bar_drop", "table_actuated"])
def test_joint_states_alone_come_from_the_joint_sample_and_equal_the_full_observations(scene):
    """A publication of only joint_states and end_effector (a lockstep loop's) takes the
    cheap joint sample; its messages equal those of a publication with every topic."""
    from tensegrity_core.sim import load_scene
    from tensegrity_ros.nodes.sim import sender
    from tensegrity_ros.nodes.sim.outputs import Outputs
    from tensegrity_ros.nodes.sim.plant import SimPlant

    plant = SimPlant(load_scene(scene), 1_000_000)
    for _ in range(30):
        plant.step(plant.initial_command)
    outputs = Outputs(plant, publish_rate=100.0, state_rate=100.0, marker_rate=100.0, imu_rate=100.0)
    hdr = sender.header(plant.time_ns, "world")
    calls = []
    observe = plant.observe
    plant.observe = lambda: calls.append(1) or observe()
    alone = dict(outputs.messages(hdr, lambda t: t in ("joint_states", "end_effector")))
    assert calls == []                                    # no full observation for them
    every = dict(outputs.messages(hdr, lambda t: True))
    assert calls == [1]
    from geometry_msgs.msg import PointStamped
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState

    joints = deserialize_message(alone["joint_states"], JointState)    # published as serialized bytes
    assert joints == deserialize_message(every["joint_states"], JointState)
    assert alone["end_effector"] == deserialize_message(every["end_effector"], PointStamped)
    assert len(joints.name) == len(plant.interface.inputs) > 0


@pytest.mark.parametrize("n", [1, 3, 24])
@pytest.mark.parametrize("stale", range(1, 8))
def test_a_marked_array_is_found_at_its_place_after_padding_left_from_an_earlier_mark(n, stale):
    """The padding before an aligned float64 array holds what the serializer's buffer held, which
    can be the last bytes of an array marked in an earlier serialization: the marked array is
    still found once, at its own place (a sequence length, 1..7 stale bytes, the array, the
    next sequence length)."""
    import struct

    from tensegrity_ros.nodes.sim import message_bytes

    array = message_bytes._marks(n)
    marked = struct.pack("<I", n) + array[-stale:] + array + struct.pack("<I", n)
    first = 4 + stale
    assert message_bytes._where(marked, array) == (first, first + 8 * n)


@pytest.mark.parametrize("names", [(), ("rho1", "rho2", "beta"), tuple(f"c{i}_{i + 4}" for i in range(24))])
@pytest.mark.parametrize("fields", [("position", "velocity", "effort"), ("position", "velocity"), ("effort",), ()])
def test_joint_states_as_bytes_read_back_as_the_messages_rclpy_builds(names, fields):
    """rclpy's deserializer reads every refill of the serialized joint_states as the message
    rclpy itself builds from the same values (random values and stamps, every byte pattern of
    a float64 that is not NaN; the arrays not kept empty, whatever values are given for
    them); values of another length, a single value among them, are refused."""
    import numpy as np
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState

    from tensegrity_ros.nodes.sim.joint_bytes import JointStateBytes

    cdr = JointStateBytes(names, "lab", fields=fields)
    assert cdr.ok
    rng = np.random.default_rng(7)
    n = len(names)
    for _ in range(50):
        sec, nanosec = int(rng.integers(0, 2**31)), int(rng.integers(0, 10**9))
        values = [rng.integers(0, 2**64, n, dtype=np.uint64).view(np.float64) for _ in range(3)]
        values = [np.where(np.isnan(v), 0.5, v) for v in values]
        kept = {f: v.tolist() if f in fields else [] for f, v in zip(("position", "velocity", "effort"), values)}
        expected = JointState(name=list(names), **kept)
        expected.header.frame_id = "lab"
        expected.header.stamp.sec, expected.header.stamp.nanosec = sec, nanosec
        assert deserialize_message(cdr.fill(sec, nanosec, *values), JointState) == expected
    if n and fields:
        short = [v[1:] if f == fields[0] else v for f, v in zip(("position", "velocity", "effort"), values)]
        with pytest.raises(ValueError, match=f"joint_states of {n} joints, got {n - 1} values"):
            cdr.fill(0, 0, *short)
    if n > 1 and fields:                  # one value is not spread over every joint
        single = [v[:1] if f == fields[-1] else v for f, v in zip(("position", "velocity", "effort"), values)]
        with pytest.raises(ValueError, match=f"joint_states of {n} joints, got 1 values"):
            cdr.fill(0, 0, *single)


def test_joint_states_bytes_are_found_whatever_earlier_serializations_left_in_the_buffer():
    """The padding before an aligned array holds what the serializer's buffer held before: the
    layouts of joint_states of every choice of arrays are found (bytes, not the message
    fallback) after those of other joints and frames, in either order."""
    from tensegrity_ros.nodes.sim.joint_bytes import JointStateBytes

    choices = [("position", "velocity", "effort"), ("position", "velocity"), ("effort",), ()]
    for names, frame in ([f"c{i}" for i in range(24)], "lab"), (["c0_4", *(f"c{i}" for i in range(1, 24))], "world"):
        for fields in (*choices, *reversed(choices)):
            assert JointStateBytes(names, frame, fields=fields).ok, (names[0], frame, fields)


@pytest.mark.parametrize(("lengths", "tensions"), [(["c0_4", "c2_10"], ["c0_4", "c1_7"]), ("none", "all"),
                                                   ("all", "none"), ("none", "none")])
def test_joint_states_report_the_lengths_and_tensions_the_robot_measures(tmp_path, lengths, tensions):
    """A 6-bar whose description measures some cables' lengths and some tensions: joint_states
    (as bytes from the joint sample, and as a message with every topic) carry cable_states'
    length and rate [m, m/s] where the length is measured and its tension [N] where the tension
    is, NaN for the other joints, and an empty array where no joint's cable is measured; every
    motor cable stays a joint."""
    import math
    from pathlib import Path

    import yaml
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState
    from tensegrity_msgs.msg import CableStates

    from tensegrity_core.robot import examples
    from tensegrity_core.sim import load_scene
    from tensegrity_ros.nodes.sim import sender
    from tensegrity_ros.nodes.sim.outputs import Outputs
    from tensegrity_ros.nodes.sim.plant import SimPlant

    robot = yaml.safe_load((Path(examples.__file__).parent / "six_bar.yaml").read_text())
    robot["sensors"] |= {"cable_length": lengths, "cable_tension": tensions}
    (tmp_path / "six_bar_sensed.yaml").write_text(yaml.safe_dump(robot))
    scene = {"name": "sensed", "model": {"kind": "robot", "robot": "six_bar_sensed.yaml"},
             "initial": {"drawn": True},
             "effects": ["inertia", "cables", "motors", "gravity", "contact", "friction", "sensors"], "duration": 1.0}
    (tmp_path / "sensed.yaml").write_text(yaml.safe_dump(scene))
    plant = SimPlant(load_scene(str(tmp_path / "sensed.yaml")), 1_000_000)
    for _ in range(30):
        plant.step(plant.initial_command)
    outputs = Outputs(plant, publish_rate=100.0, state_rate=100.0, marker_rate=100.0, imu_rate=100.0)
    hdr = sender.header(plant.time_ns, "world")
    alone = deserialize_message(dict(outputs.messages(hdr, lambda t: t == "joint_states"))["joint_states"], JointState)
    every = dict(outputs.messages(hdr, lambda t: True))
    every["joint_states"] = deserialize_message(every["joint_states"], JointState)
    cables = deserialize_message(every["cable_states"], CableStates)
    length, rate, tension = (dict(zip(cables.name, a)) for a in (cables.length, cables.length_rate, cables.tension))
    motors = [c["name"] for c in robot["cables"] if c.get("motor")]

    def measured(which, name):
        return which == "all" or (which != "none" and name in which)

    for joints in (alone, every["joint_states"]):
        assert list(joints.name) == motors
        for array, truth, which in ((joints.position, length, lengths), (joints.velocity, rate, lengths),
                                    (joints.effort, tension, tensions)):
            if which == "none":
                assert len(array) == 0
                continue
            assert len(array) == len(motors)
            for name, value in zip(motors, array):
                assert value == truth[name] if measured(which, name) else math.isnan(value), name
    assert any(v != 0.0 for v in rate.values())          # a moving robot: the rates are not all zero


def test_a_part_imports_without_the_node():
    import subprocess
    import sys

    probe = ("import sys; import tensegrity_ros.nodes.sim.cable_commands; "
             "print('tensegrity_ros.nodes.sim.node' in sys.modules, 'rclpy.node' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True, timeout=120)
    assert out.stdout.split() == ["False", "False"]


def test_a_string_going_taut_is_published_under_the_members_name():
    """A weight falls freely on a slack string and pulls it taut after sqrt(2 d / g) (d the
    string's slack, 0.5 m): the event names the member as cable_states does."""
    from tensegrity_core.sim import load_scene
    from tensegrity_ros.nodes.sim import sender
    from tensegrity_ros.nodes.sim.plant import SimPlant

    scene = load_scene({
        "model": {"kind": "general", "structure": {
            "nodes": {"a": [0, 0, 0], "w": [0, 0, -1.0]}, "pinned": ["a"], "masses": {"w": 1.0},
            "members": [{"name": "tether", "nodes": ["a", "w"], "EA": 100.0, "rest_length": 1.5}]}},
        "initial": {"drawn": True}, "effects": ["inertia", "springs", {"gravity": {"vector": [0, 0, -9.81]}}],
        "duration": 1.0})
    plant = SimPlant(scene, 10_000_000)
    events = []
    while not events:
        events = [e for e in plant.step(plant.initial_command).events if e[1] == "taut"]
    msg = sender.event_msg(events[0], plant.offset_ns, "world", plant.names)
    assert (msg.kind, msg.index, msg.name) == ("taut", 0, "tether")
    assert msg.time == pytest.approx((2 * 0.5 / 9.81) ** 0.5, abs=1e-9)
