"""Lockstep: which command the step the simulator waits at runs under. Plain logic, no node.

A command is offered with the time and step the simulator waits at. Stamped with that
time, it is kept for the step until the step takes it; several commands stamped for one
step are merged as if applied in the order they came: a later one sets only the inputs it
names (an empty command changes nothing, a command of every input replaces the whole
command). A copy of one of the commands the last step ran under, arriving again with its
old stamp, is a duplicate (a controller answers a state republished to it again) and is
dropped without a word; any other stamp is refused with the reason
(:func:`~tensegrity_ros.nodes.sim.receiver.check_step`). A reset forgets the commands the
last step ran under, and the kept one too unless the state it answered is republished
unchanged.
"""

from __future__ import annotations

from tensegrity_ros.nodes.actuator_commands import ForceUpdate
from tensegrity_ros.nodes.sim.cable_commands import InputUpdate
from tensegrity_ros.nodes.sim.receiver import Command, check_step


class LockstepGate:
    """The command kept for the waiting step (``pending``: the merge of those offered for it)
    and the commands the last step ran under (``applied``, each as it came)."""

    def __init__(self) -> None:
        self.pending: Command | None = None
        self.applied: tuple[Command, ...] = ()
        self._parts: list[Command] = []          # the commands merged into ``pending``, each once

    def offer(self, command: Command, time_ns: int, step: int) -> bool:
        """Merge ``command`` into the one kept for the step at ``time_ns`` [ns] (step
        ``step``): True; a duplicate of one the last step ran under: False; stamped
        otherwise: :class:`~tensegrity_ros.nodes.actuator_commands.CommandError`."""
        if command.stamp_ns != time_ns and command in self.applied:   # the usual stamp: no comparison
            return False
        check_step(command, time_ns, step)
        kept = self.pending
        if kept is None:
            kept = command
        else:
            update = merge(kept.update, command.update)
            if update is not kept.update:
                kept = command if update is command.update else Command(update, time_ns)
        self.pending = kept
        if command not in self._parts:           # a controller answering a republished state again: once
            self._parts.append(command)
        return True

    def take(self) -> Command | None:
        """The kept command, now the one the step runs under (None: none came yet)."""
        command, self.pending = self.pending, None
        if command is not None:
            self.applied, self._parts = tuple(self._parts), []
        return command

    def reset(self, *, state_changed: bool) -> None:
        """After a reset: a kept command stays only for the very state it answered."""
        self.applied = ()
        if state_changed:
            self.pending, self._parts = None, []


Update = ForceUpdate | InputUpdate


def merge(first: Update, later: Update) -> Update:
    """The update of ``first`` then ``later`` (of one kind): ``first``'s values of the inputs
    ``later`` does not name, then ``later``'s. Applied to any values it gives what applying
    ``first`` and then ``later`` gives."""
    if not later.indices:
        return first
    named = set(later.indices)
    if named.issuperset(first.indices):
        return later
    kept = [(i, v) for i, v in zip(first.indices, _values(first)) if i not in named]
    indices = tuple(i for i, _ in kept) + later.indices
    values = tuple(v for _, v in kept) + _values(later)
    return InputUpdate(indices, values) if isinstance(later, InputUpdate) else ForceUpdate(indices, values)


def _values(update: Update) -> tuple[float, ...]:
    """An update's values (rest lengths [m] or forces [N]), in the order of its indices."""
    return update.values if isinstance(update, InputUpdate) else update.forces
