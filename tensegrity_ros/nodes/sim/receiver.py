"""The simulator's command receiver: an ``ActuatorForces`` message checked once, handed on
as plain values.

:func:`receive` validates names and forces (:func:`~tensegrity_ros.nodes.actuator_commands.parse_command`)
and returns a :class:`Command`; the plant never sees a message. In lockstep mode
:func:`check_step` also requires the command's stamp to be the simulation time of the
step the simulator waits at (integer nanoseconds, compared exactly).
"""

from __future__ import annotations

from dataclasses import dataclass

from tensegrity_ros.nodes.actuator_commands import CommandError, ForceUpdate, parse_command
from tensegrity_ros.nodes.sim.sender import NS_PER_S, stamp_ns


@dataclass(frozen=True)
class Command:
    """A valid actuator command: which forces it sets [N] (tension positive) and its stamp
    [ns on the simulation clock]."""

    update: ForceUpdate
    stamp_ns: int


def receive(msg, *, max_force: float) -> Command:
    """The :class:`Command` of an ``ActuatorForces`` message, or :class:`CommandError` saying why not."""
    update = parse_command(list(msg.name), list(msg.force), max_abs_force=max_force)
    return Command(update, stamp_ns(msg.header.stamp))


def check_step(command: Command, expected_ns: int, step: int) -> None:
    """Lockstep: the command must be stamped with the time ``expected_ns`` of the state it
    answers (step ``step``); otherwise :class:`CommandError` naming both times."""
    if command.stamp_ns != expected_ns:
        raise CommandError(
            f"command stamped {command.stamp_ns / NS_PER_S:.9f} s, but the simulator waits at step {step} "
            f"(t = {expected_ns / NS_PER_S:.9f} s): a lockstep command must carry the stamp of the "
            "joint state it answers")
