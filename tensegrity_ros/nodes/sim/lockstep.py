"""Lockstep: which command the step the simulator waits at runs under. Plain logic, no node.

A command is offered with the time and step the simulator waits at. Stamped with that
time, it is kept for the step (a later one with the same stamp replaces it) until the step
takes it. The command the last step ran under, arriving again with its old stamp, is a
duplicate (a controller answers a state republished to it again) and is dropped without a
word; any other stamp is refused with the reason
(:func:`~tensegrity_ros.nodes.sim.receiver.check_step`). A reset forgets the command the
last step ran under, and the kept one too unless the state it answered is republished
unchanged.
"""

from __future__ import annotations

from tensegrity_ros.nodes.sim.receiver import Command, check_step


class LockstepGate:
    """The command kept for the waiting step (``pending``) and the one the last step ran under
    (``applied``)."""

    def __init__(self) -> None:
        self.pending: Command | None = None
        self.applied: Command | None = None

    def offer(self, command: Command, time_ns: int, step: int) -> bool:
        """Keep ``command`` for the step at ``time_ns`` [ns] (step ``step``): True; a
        duplicate of the last step's: False; stamped otherwise:
        :class:`~tensegrity_ros.nodes.actuator_commands.CommandError`."""
        if command.stamp_ns != time_ns and command == self.applied:   # the usual stamp: no comparison
            return False
        check_step(command, time_ns, step)
        self.pending = command
        return True

    def take(self) -> Command | None:
        """The kept command, now the one the step runs under (None: none came yet)."""
        command, self.pending = self.pending, None
        if command is not None:
            self.applied = command
        return command

    def reset(self, *, state_changed: bool) -> None:
        """After a reset: a kept command stays only for the very state it answered."""
        self.applied = None
        if state_changed:
            self.pending = None
