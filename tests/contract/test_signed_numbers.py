"""Every number a command takes is read as a value when it is negative, in any form ``float``
reads (``-1e-12``, ``-.5``, ``-2.5E3``), after an option (``--f -1e3``) as after ``=``
(``--f=-1e3``) and as a positional: argparse's default reads ``-1e3`` as an unknown option.

Parsing only (no command runs, no ROS): the whole file costs about 0.5 s.
"""

from __future__ import annotations

import argparse

import pytest

from tensegrity_ros.cli import build_parser

SIGNED = ("-1e-12", "-.5", "-2.5E3", "-7")


def _commands(parser: argparse.ArgumentParser, words: tuple[str, ...] = ()):
    """(command words, its parser) for every (sub)command that takes no further command."""
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield words, parser
    for sub in subs:
        for name, child in sub.choices.items():
            yield from _commands(child, words + (name,))


def _numbers(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    return [a for a in parser._actions if a.type in (float, int)]


def _filler(action: argparse.Action) -> list[str]:
    """Values that parse for a required positional that is not under test."""
    n = action.nargs if isinstance(action.nargs, int) else 1
    if action.choices:
        return [str(next(iter(action.choices)))] * n
    return ["0"] * n if action.type in (float, int) else ["x"] * n


PARSER = build_parser()                                 # built once: parsing does not change it
LEAVES = dict(_commands(PARSER))
CASES = [(words, action.dest) for words, parser in LEAVES.items() for action in _numbers(parser)]


def test_the_walk_finds_the_commands_with_signed_numbers():
    found = {(" ".join(w), d) for w, d in CASES}
    assert {("stiffness", "f"), ("stiffness", "sweep"), ("ik", "x"), ("move", "y"), ("send-forces", "forces"),
            ("call-ik", "x"), ("gait", "heading")} <= found


@pytest.mark.parametrize("words, dest", CASES, ids=[f"{' '.join(w)}:{d}" for w, d in CASES])
def test_a_negative_number_is_read_as_a_value(words, dest):
    """The parser gives each form back (the command then accepts or refuses it with its own
    one-line reason): it never calls it an option."""
    parser = LEAVES[words]
    action = next(a for a in parser._actions if a.dest == dest)
    for value in SIGNED if action.type is float else ("-7",):    # a whole-number argument reads those only
        _check(words, parser, action, value)


def _check(words: tuple[str, ...], parser: argparse.ArgumentParser, action: argparse.Action, value: str) -> None:
    given = [value] * (action.nargs if isinstance(action.nargs, int) else 1)
    argv = list(words)
    for other in parser._actions:                      # the positionals, in their order
        if other.option_strings:
            continue
        if other is action:
            argv += given
        elif other.nargs not in ("?", "*"):
            argv += _filler(other)
    for other in parser._actions:                      # the required options
        if other.option_strings and other.required and other is not action:
            argv += [other.option_strings[-1], *_filler(other)]
    if action.option_strings:
        argv += [action.option_strings[-1], *given]
    got = getattr(PARSER.parse_args(argv), action.dest)
    assert (got if isinstance(got, list) else [got]) == [action.type(value)] * len(given)
