"""A lockstep controller's CableCommand read from its serialized bytes (nodes/sim/command_bytes.py)
gives what rclpy's deserialization and the full check give: for bytes serialized by rclpy,
and for bytes taken from DDS (which end where the message ends)."""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.ros


def test_a_serialized_cable_command_is_received_as_its_deserialized_message():
    """receive_cable_bytes of a serialized CableCommand gives what receive_cables of rclpy's
    deserialization gives, the same Command or the same error: the 6-bar's whole commands in
    input order (read in place, not deserialized) for random rest lengths, stamps and frame
    names; and commands of any other form (fewer or reordered names, a name changed, reel
    speeds, out of range, NaN, another frame) deserialized and checked in full."""
    import math
    import random

    from rclpy.serialization import serialize_message
    from tensegrity_msgs.msg import CableCommand

    from tensegrity_core.sim import load_scene
    from tensegrity_ros.nodes.actuator_commands import CommandError
    from tensegrity_ros.nodes.sim import receiver
    from tensegrity_ros.nodes.sim.command_bytes import CableCommandBytes
    from tensegrity_ros.nodes.sim.plant import SimPlant

    interface = SimPlant(load_scene("six_bar_drop"), 1_000_000).interface
    names = list(interface.inputs)
    reader = CableCommandBytes(names)
    rng = random.Random(3)
    (lo, hi), n = interface.limits[0], len(names)

    def outcome(receive, what):
        try:
            return receive(what, interface=interface)
        except CommandError as err:
            return str(err)

    def check(msg, *, fast):
        raw = serialize_message(msg)
        assert (reader.read(raw) is not None) == fast, msg
        got = outcome(lambda raw, interface: receiver.receive_cable_bytes(raw, reader, interface=interface), raw)
        assert got == outcome(receiver.receive_cables, msg)
        return got

    def command(names, rest, frame="", **more):
        msg = CableCommand(name=list(names), rest_length=list(rest), **more)
        msg.header.frame_id = frame
        msg.header.stamp.sec, msg.header.stamp.nanosec = rng.randrange(2**31), rng.randrange(10**9)
        return msg

    for frame in ("", "w", "world", "a_longer_frame_name_", "ü"):
        for _ in range(20):
            rest = [rng.uniform(lo, hi) for _ in range(n)]
            got = check(command(names, rest, frame), fast=True)
            assert got.update.values == tuple(rest) and got.update.indices == tuple(range(n))
    rest = [0.5 * (lo + hi)] * n
    other = [names[1], names[0], *names[2:]]
    renamed = [names[0][:-1] + "x", *names[1:]]
    for msg in (command(names[:-1], rest[:-1]), command(other, rest), command(renamed, rest),
                command([], rest), command(names, rest, reel_speed=[math.nan] * n)):
        check(msg, fast=False)
    for bad in (hi + 1.0, math.nan, math.inf):
        assert isinstance(check(command(names, [bad, *rest[1:]]), fast=True), str)   # read, then refused in full


def test_commands_taken_from_dds_are_read_in_place(ros_context):
    """Commands published and taken raw over DDS on loopback (a subscription and a publisher
    of one node, waited on until every command arrived) are read in place with their stamps
    and rest lengths."""
    import time

    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from tensegrity_msgs.msg import CableCommand

    from tensegrity_core.robot.loading import load_robot
    from tensegrity_ros.nodes.sim.command_bytes import CableCommandBytes

    robot = load_robot("six_bar")
    motors = [robot.cables.names[c] for c in robot.motors.cable]
    reader = CableCommandBytes(motors)
    node = rclpy.create_node("command_bytes_probe", context=ros_context)
    got: list[bytes] = []
    node.create_subscription(CableCommand, "command_bytes_probe", got.append, 100, raw=True)
    pub = node.create_publisher(CableCommand, "command_bytes_probe", 100)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    try:
        deadline = time.monotonic() + 60
        while pub.get_subscription_count() < 1:
            assert time.monotonic() < deadline, "the probe's own subscription did not match"
            ex.spin_once(timeout_sec=0.05)
        sent = []
        for k in range(20):
            msg = CableCommand(name=motors, rest_length=[0.7 + 0.001 * k + 0.0001 * i for i in range(len(motors))])
            msg.header.frame_id = "world" if k % 2 else ""
            msg.header.stamp.sec, msg.header.stamp.nanosec = k, 1000 * k
            pub.publish(msg)
            sent.append((k, 1000 * k, tuple(msg.rest_length)))
        while len(got) < len(sent):
            assert time.monotonic() < deadline, f"{len(got)} of {len(sent)} commands arrived"
            ex.spin_once(timeout_sec=0.05)
        assert [reader.read(raw) for raw in got] == sent
    finally:
        ex.shutdown()
        node.destroy_node()
