"""Refusal warnings throttled per reason (:mod:`tensegrity_ros.nodes.refusals`), without ROS."""

from __future__ import annotations

from tensegrity_ros.nodes.actuator_commands import CommandError, parse_command
from tensegrity_ros.nodes.refusals import ReasonThrottle, reason_of


def _refusal(names, forces) -> CommandError:
    try:
        parse_command(names, forces, max_abs_force=10.0)
    except CommandError as err:
        return err
    raise AssertionError("the command was accepted")


def test_a_new_reason_is_shown_at_once_and_the_same_one_once_a_period():
    throttle = ReasonThrottle(1.0)
    assert throttle.admit("a", 0.0)
    assert throttle.admit("b", 0.01)               # another reason within the period
    assert not throttle.admit("a", 0.99)           # the same reason within its period
    assert throttle.admit("a", 1.0)                # a period after its last admission
    assert not throttle.admit("b", 1.0)            # b's period started at 0.01 s
    assert throttle.admit("b", 1.01)


def test_a_reason_is_the_raise_site_not_the_values_it_quotes():
    over_a, over_b = _refusal(["f1"], [11.0]), _refusal(["f2"], [-1e9])
    unknown = _refusal(["f9"], [1.0])
    assert str(over_a) != str(over_b) and reason_of(over_a) == reason_of(over_b)
    assert reason_of(unknown) != reason_of(over_a)
