"""Validation of actuator-force commands (pure function behind the sim node's subscription)."""

from __future__ import annotations

import math

import pytest

from tensegrity_ros.nodes.actuator_commands import CommandError, parse_command


@pytest.mark.parametrize("names, forces, expected", [
    ([], [1.0, 2.0], ((0, 1), (1.0, 2.0))),
    (["f2", "f1"], [1.0, 2.0], ((1, 0), (1.0, 2.0))),
    (["rho1"], [3.0], ((0,), (3.0,))),
    (["Actuator_2", "AB"], [-1.0, 0.5], ((1, 0), (-1.0, 0.5))),
    (["rho 1", "BC"], [0.0, 0.0], ((0, 1), (0.0, 0.0))),
])
def test_accepted_commands(names, forces, expected):
    update = parse_command(names, forces, max_abs_force=100.0)
    assert (update.indices, update.forces) == expected


def test_partial_command_keeps_the_other_actuator():
    assert parse_command(["f2"], [5.0], max_abs_force=10.0).apply([1.0, 2.0]) == [1.0, 5.0]


@pytest.mark.parametrize("names, forces, reason", [
    ([], [1.0], "unnamed command must give 2 forces"),
    ([], [1.0, 2.0, 3.0], "unnamed command must give 2 forces"),
    (["f1", "f2"], [1.0], "2 names but 1 forces"),
    (["f3"], [1.0], "unknown actuator name 'f3'"),
    (["f1", "rho1"], [1.0, 2.0], "named twice"),
    (["f1"], [math.nan], "not finite"),
    (["f2"], [math.inf], "not finite"),
    (["f1"], [-101.0], "exceeds the limit"),
])
def test_rejected_commands_say_why(names, forces, reason):
    with pytest.raises(CommandError, match=reason):
        parse_command(names, forces, max_abs_force=100.0)


def test_a_huge_actuator_name_is_quoted_as_an_excerpt():
    """A 64 KiB name (issue 12) is named by its start and its length, not echoed whole."""
    name = "x" * 65536
    with pytest.raises(CommandError) as err:
        parse_command([name], [1.0], max_abs_force=100.0)
    message = str(err.value)
    assert len(message) < 300 and "65536 characters" in message and "x" * 40 in message
