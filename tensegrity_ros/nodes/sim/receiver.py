"""The simulator's command receiver: a command message checked once, handed on as plain values.

Two command messages, one per kind of input (the model's
:class:`~tensegrity_core.sim.model.Interface` says which the scene takes): actuator forces
(``ActuatorForces``, the class-2 mechanism: :func:`receive`) and rest lengths of actuated
cables (``CableCommand``, general structures: :func:`receive_cables`, or
:func:`receive_cable_bytes` of the serialized message). Each validates names
and values and returns a :class:`Command`; a message of the other kind is refused with a
reason naming the right one. The plant never sees a message. In lockstep mode
:func:`check_step` also requires the command's stamp to be the simulation time of the step
the simulator waits at (integer nanoseconds, compared exactly).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from rclpy.serialization import deserialize_message
from tensegrity_msgs.msg import CableCommand

from tensegrity_core.sim.model import Interface
from tensegrity_ros.nodes.actuator_commands import CommandError, ForceUpdate, parse_command
from tensegrity_ros.nodes.sim.cable_commands import InputUpdate, every_input, listed, parse_cable_command
from tensegrity_ros.nodes.sim.command_bytes import CableCommandBytes
from tensegrity_ros.nodes.sim.sender import NS_PER_S
from tensegrity_ros.rclpy_utils.messages import stamp_ns


@dataclass(frozen=True)
class Command:
    """A valid command: which inputs it sets (forces [N], tension positive, or rest lengths
    [m]) and its stamp [ns on the simulation clock]."""

    update: ForceUpdate | InputUpdate
    stamp_ns: int


def receive(msg: Any, *, max_force: float, interface: Interface | None = None) -> Command:
    """The :class:`Command` of an ``ActuatorForces`` message, or :class:`CommandError` saying
    why not (also when the scene's inputs are not actuator forces)."""
    if interface is not None and interface.command != "force":
        if not interface.inputs:
            raise CommandError("this scene has no actuators: it takes no commands")
        raise CommandError(f"this scene's inputs are rest lengths of its actuated cables ({listed(interface.inputs)}), "
                           "not actuator forces: send tensegrity_msgs/CableCommand on cable_commands")
    update = parse_command(list(msg.name), list(msg.force), max_abs_force=max_force)
    return Command(update, stamp_ns(msg.header.stamp))


def receive_cables(msg: Any, *, interface: Interface) -> Command:
    """The :class:`Command` of a ``CableCommand`` message, or :class:`CommandError` saying why not."""
    update = parse_cable_command(list(msg.name), msg.rest_length, msg.reel_speed, msg.tension, interface)
    return Command(update, stamp_ns(msg.header.stamp))


def receive_cable_bytes(raw: bytes, reader: CableCommandBytes, *, interface: Interface) -> Command:
    """:func:`receive_cables` of a serialized ``CableCommand``: a command of every input in
    input order with rest lengths in range is read in place (:mod:`.command_bytes`), any other
    is deserialized and checked in full (the same :class:`Command`, or the same error)."""
    read = reader.read(raw)
    if read is not None:
        sec, nanosec, values = read
        update = every_input(values, interface)
        if update is not None:
            return Command(update, sec * NS_PER_S + nanosec)
    return receive_cables(deserialize_message(raw, CableCommand), interface=interface)


def check_step(command: Command, expected_ns: int, step: int) -> None:
    """Lockstep: the command must be stamped with the time ``expected_ns`` of the state it
    answers (step ``step``); otherwise :class:`CommandError` naming both times."""
    if command.stamp_ns != expected_ns:
        raise CommandError(
            f"command stamped {command.stamp_ns / NS_PER_S:.9f} s, but the simulator waits at step {step} "
            f"(t = {expected_ns / NS_PER_S:.9f} s): a lockstep command must carry the stamp of the "
            "joint state it answers")
