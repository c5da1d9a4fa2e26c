"""The lockstep gate without a node: the command a step runs under when several come for it
(merged as applied in order), duplicates of the last step's commands, other stamps, resets."""

from __future__ import annotations

import functools

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_ros.nodes.actuator_commands import CommandError, ForceUpdate
from tensegrity_ros.nodes.sim.cable_commands import InputUpdate
from tensegrity_ros.nodes.sim.lockstep import LockstepGate
from tensegrity_ros.nodes.sim.receiver import Command

pytestmark = pytest.mark.ros

T = 20_000_000        # the time the simulator waits at [ns] (step 2 of 10 ms steps)


def test_the_gate_keeps_the_command_of_the_waited_step_drops_a_repeat_and_refuses_other_stamps():
    gate = LockstepGate()
    a = Command(ForceUpdate((0, 1), (0.5, 0.5)), 0)
    assert gate.take() is None
    assert gate.offer(a, 0, 0) and gate.take() == a and gate.pending is None
    assert gate.offer(a, 10, 1) is False                      # the last step's answer again: dropped
    with pytest.raises(CommandError, match="stamped 0.000000000 s, but the simulator waits at step 1"):
        gate.offer(Command(ForceUpdate((0,), (0.7,)), 0), 10, 1)
    b = Command(ForceUpdate((0,), (0.7,)), 10)
    assert gate.offer(b, 10, 1) and gate.pending == b
    gate.reset(state_changed=False)                           # the very state again: b still answers it
    assert gate.pending == b and gate.applied == ()
    gate.reset(state_changed=True)
    assert gate.pending is None


def test_commands_for_one_step_merge_a_later_one_setting_only_what_it_names():
    gate = LockstepGate()
    client = Command(InputUpdate((1,), (0.85,)), T)                  # one cable of three
    controller = Command(InputUpdate((), ()), T)                     # idle: no change
    assert gate.offer(client, T, 2) and gate.offer(controller, T, 2)
    assert gate.pending == client                                    # the empty answer changed nothing
    other = Command(InputUpdate((2, 1), (0.7, 0.8)), T)
    assert gate.offer(other, T, 2)
    assert gate.pending.update.apply([0.9, 0.9, 0.9]) == [0.9, 0.8, 0.7]
    every = Command(InputUpdate((0, 1, 2), (0.6, 0.6, 0.6)), T)
    assert gate.offer(every, T, 2) and gate.pending == every         # every input: the whole command
    with pytest.raises(CommandError, match="waits at step 2"):
        gate.offer(Command(InputUpdate((0,), (0.5,)), T + 10), T, 2)  # stamped for a later step
    assert gate.pending == every                                     # the refusal changed nothing
    assert gate.take() == every and gate.take() is None              # taken once
    assert gate.applied == (client, controller, other, every)
    for copy in gate.applied:                                        # any of them answered again: dropped
        assert gate.offer(copy, T + 10, 3) is False
    with pytest.raises(CommandError, match="waits at step 3"):
        gate.offer(Command(InputUpdate((0,), (0.5,)), T), T + 10, 3)  # for the last step, but none of its
    assert gate.offer(every, T, 2)        # at the same step still (a reset to the state it answered): kept again


def test_full_actuator_forces_for_one_step_the_last_wins():
    gate = LockstepGate()
    first, second = Command(ForceUpdate((0, 1), (0.5, 0.5)), T), Command(ForceUpdate((1, 0), (0.25, 1.5)), T)
    assert gate.offer(first, T, 2) and gate.offer(second, T, 2)
    assert gate.take() == second
    assert second.update.apply([0.0, 0.0]) == [1.5, 0.25]


def test_a_controller_answering_a_republished_state_again_is_kept_once():
    gate = LockstepGate()
    idle = Command(InputUpdate((), ()), T)
    for _ in range(100):
        assert gate.offer(idle, T, 2)
    assert gate.take() == idle and gate.applied == (idle,)


def _commands(n: int, kind: type):
    """A command of ``kind`` naming a subset of ``n`` inputs (empty: no change), any order."""
    return st.lists(st.integers(0, n - 1), unique=True, max_size=n).flatmap(
        lambda indices: st.lists(st.floats(0.05, 5.0), min_size=len(indices), max_size=len(indices)).map(
            lambda values: Command(kind(tuple(indices), tuple(values)), T)))


@st.composite
def _interleaved(draw):
    """Several clients' commands for one step, each client's in its order, interleaved anyhow;
    the values the inputs held before [m or N]."""
    kind, n = draw(st.sampled_from([(InputUpdate, 1), (InputUpdate, 3), (InputUpdate, 24), (ForceUpdate, 2)]))
    clients = draw(st.lists(st.lists(_commands(n, kind), max_size=4), min_size=1, max_size=3))
    turns = draw(st.permutations([c for c, commands in enumerate(clients) for _ in commands]))
    queues = [list(commands) for commands in clients]
    order = [queues[c].pop(0) for c in turns]
    held = draw(st.lists(st.floats(0.05, 5.0), min_size=n, max_size=n))
    return order, held


@given(_interleaved())
def test_any_interleaving_of_partial_commands_gives_what_applying_them_in_order_gives(case):
    order, held = case
    gate = LockstepGate()
    for command in order:
        assert gate.offer(command, T, 2)
    taken = gate.take()
    expected = functools.reduce(lambda values, command: command.update.apply(values), order, held)
    if not order:
        assert taken is None
        return
    assert taken.stamp_ns == T
    assert taken.update.apply(held) == expected
    assert set(gate.applied) == set(order) and len(gate.applied) == len(set(order))
    for command in order:                       # each answered again after the step: dropped
        assert gate.offer(command, T + 10, 3) is False
