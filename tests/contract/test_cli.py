"""The robot-facing command line as a new user meets it: wrong arguments give one line and a
non-zero exit code (never a traceback), and what the commands print carries a unit with
every measured number.

The unit check reads a printed line as a person does: a number with a decimal point (a
measured value; counts are whole numbers) must have a unit on its line, either after it
(``0.2 s``, ``1185.5 N``) or in the label the line starts with (``final q (... [m] ...) =
[...]``, a numpy array wrapped over several lines being one line).
"""

from __future__ import annotations

import re

import pytest

from tests.forked_cli import run_all

pytestmark = pytest.mark.ros          # one case asks for a simulator over DDS

#: Units a number may carry here (SI and the suite's derived ones).
UNIT = r"(?:s|ms|m|mm|cm|N|Hz|kg|rad|deg|%|m/s|m/s\^2|N/m|N s/m|MiB|KiB|B|x)"
NUMBER = re.compile(r"(?<![\w.\-])(?<!Sect\. )(?<!Eq\. )(?<!Fig\. )[-+]?\d+\.\d+(?:e[-+]?\d+)?")
AFTER = re.compile(r"\s?" + UNIT + r"(?![\w/])")
LABEL = re.compile(r"\[[^\]]*(?:m|s|N|rad|Hz|kg)[^\]]*\]")


def _logical_lines(text: str) -> list[str]:
    """Lines, with a bracket left open (a wrapped numpy array) joined to the lines that close it."""
    out, current, depth = [], "", 0
    for line in text.splitlines():
        current = f"{current} {line}" if depth else line
        depth += line.count("[") - line.count("]")
        if depth <= 0:
            out.append(current)
            current, depth = "", 0
    return out + ([current] if current else [])


def numbers_without_units(text: str) -> list[str]:
    """The lines of ``text`` that print a measured number with no unit."""
    bad = []
    for line in _logical_lines(text):
        if LABEL.search(line.split("=")[0]) and "=" in line:
            continue                                  # "label [unit] = values"
        for match in NUMBER.finditer(line):
            if not AFTER.match(line, match.end()):
                bad.append(line)
                break
    return bad


def test_the_unit_check_finds_a_bare_number_and_accepts_labelled_ones():
    assert numbers_without_units("distance rolled: 0.935 m\npeak tension 1185.5 N\nsimulated 0.2 s: 21 samples") == []
    assert numbers_without_units("final q (centres [m]) = [ 0.33 0.06\n 0.51 ]") == []
    assert numbers_without_units("distance rolled: 0.935") == ["distance rolled: 0.935"]
    assert numbers_without_units("speed 0.5 m/s, rate 2.0") == ["speed 0.5 m/s, rate 2.0"]
    assert numbers_without_units("the paper's fold (Sect. 5.3)") == []           # a reference, not a value


BAD = [   # (arguments, a word the error line must name)
    (["simulate", "no_such_scene"], "no_such_scene"),
    (["up", "--scene", "no_such_scene"], "no_such_scene"),
    (["node", "cables", "--ros-args", "-p", "scene:=class2_at_rest"], "class2_at_rest"),   # not a robot
    (["gait", "six_bar", "roll", "--faces", "-1"], "-1"),
    (["gait", "six_bar", "six_bar_roll", "--timeout", "1"], "simulator"),     # no suite running
    (["bag", "info", "notes.txt"], "mcap"),
    (["play", "text_bag", "--resimulate"], "mcap"),
    (["bag", "repair", "notes.txt"], "is a file"),
]


def test_bad_arguments_give_one_line_and_a_non_zero_exit_code(tmp_path):
    (tmp_path / "notes.txt").write_text("this is not a bag\n")
    (tmp_path / "text_bag").mkdir()
    (tmp_path / "text_bag" / "text_bag_0.mcap").write_text("this is not a bag either\n")
    for done, (args, named) in zip(run_all([a for a, _ in BAD], tmp_path), BAD):
        said = done.stdout + done.stderr
        assert done.returncode != 0, (args, said)
        assert "Traceback" not in said, (args, said)
        lines = [line for line in done.stderr.splitlines() if line.strip()]
        assert len(lines) == 1 and named.lower() in lines[0].lower(), (args, done.stderr)


def test_robot_commands_print_a_unit_with_every_number(tmp_path):
    """(``bag info`` is left out: it prints ``ros2 bag info``'s layout, start and end times as
    dates with the epoch in seconds.)"""
    cases = [["simulate", "six_bar_drop", "--duration", "0.01", "-o", "drop.npz"],
             ["export", "mjcf", "six_bar", "-o", "six_bar.xml"],
             ["scenes"]]
    for done in run_all(cases, tmp_path):
        assert done.returncode == 0, (done.args, done.stderr)
        assert numbers_without_units(done.stdout) == [], done.args
