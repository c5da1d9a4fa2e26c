"""The README's commands and the command line agree: every ``./run ...`` or
``tensegrity ...`` line of the README's code blocks parses with the ``tensegrity`` parser,
options and arguments included; every one in inline code (``tensegrity export mjcf``) names a
command (``./run setup``, ``test`` and ``bench`` are the set-up script's own words); and every
command of the parser is shown in a code block at least once."""

from __future__ import annotations

import argparse
import contextlib
import io
import re
import shlex
from pathlib import Path

from tensegrity_ros.cli import build_parser

README = Path(__file__).resolve().parents[1] / "README.md"
#: Words ``./run`` handles itself instead of passing them to ``tensegrity`` (see ``run``).
RUN_WORDS = frozenset({"setup", "test", "bench"})
#: A command in a line of code: ``./run ...``, ``tensegrity ...``, ``venv/bin/tensegrity ...``.
COMMAND = re.compile(r"(?:^|\s)(\./run|(?:[\w.]+/)*bin/tensegrity|tensegrity)\s+([a-z][^`#]*)")


def code_lines(markdown: str, *, inline: bool) -> list[str]:
    """The lines of the code blocks of a Markdown text (a line holding several commands
    separated by ``/`` split into them), or with ``inline`` its inline code spans."""
    lines, fence = [], False
    for line in markdown.splitlines():
        if line.startswith("```"):
            fence = not fence
        elif fence and not inline:
            lines += line.split("   /   ")
        elif not fence and inline:
            lines += re.findall(r"`([^`]+)`", line)
    return lines


def readme_commands(markdown: str, *, inline: bool = False) -> list[list[str]]:
    """Each command the README shows in its code blocks (or ``inline`` code), as its
    arguments after ``./run`` or ``tensegrity``."""
    return [shlex.split(m[2]) for line in code_lines(markdown, inline=inline) if (m := COMMAND.search(line))]


def command_paths(parser: argparse.ArgumentParser, prefix: tuple[str, ...] = ()) -> set[tuple[str, ...]]:
    """Every command of ``parser`` that takes no further subcommand, as its words."""
    paths = set()
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                paths |= command_paths(sub, (*prefix, name)) or {(*prefix, name)}
    return paths


def parses(argv: list[str]) -> str:
    """``""`` when ``tensegrity argv`` parses, else argparse's message."""
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            build_parser().parse_args(argv)
    except SystemExit as stop:
        return "" if stop.code == 0 else err.getvalue().strip().splitlines()[-1]
    return ""


def test_the_readme_parser_finds_commands():
    text = ("Run `./run fk 0.7 0.7` or `tensegrity_core`.\n```bash\n"
            "./run record -o b   /   ./run play b --rate 2   # comment\nvenv/bin/tensegrity ik 1 2\n```\n")
    assert readme_commands(text) == [["record", "-o", "b"], ["play", "b", "--rate", "2"], ["ik", "1", "2"]]
    assert readme_commands(text, inline=True) == [["fk", "0.7", "0.7"]]
    assert parses(["fk", "0.7"]) and not parses(["fk", "0.7", "0.7"])
    assert command_paths(build_parser()) >= {("fk",), ("export", "mjcf"), ("bag", "info")}


def test_every_readme_command_parses():
    bad = [f"{' '.join(argv)}: {problem}" for argv in readme_commands(README.read_text())
           if argv[0] not in RUN_WORDS and (problem := parses(argv))]
    assert not bad, "\n".join(bad)


def names_a_command(argv: list[str], paths: set[tuple[str, ...]]) -> bool:
    """Whether ``argv`` starts with a command's words: its first word is a command, and a
    word after a command that has subcommands is one of them."""
    prefixes = {path[:n] for path in paths for n in range(1, len(path) + 1)}
    words: tuple[str, ...] = ()
    for word in argv:
        if (*words, word) in prefixes:
            words = (*words, word)
        elif words in paths:
            break                                   # the command's own arguments follow
        else:
            return False
    return words in paths


def test_every_inline_command_names_a_command():
    paths = command_paths(build_parser())
    assert names_a_command(["export", "mjcf"], paths) and names_a_command(["fk", "0.7"], paths)
    assert not names_a_command(["export", "mjfc"], paths) and not names_a_command(["bag"], paths)
    bad = [" ".join(argv) for argv in readme_commands(README.read_text(), inline=True)
           if argv[0] not in RUN_WORDS and not names_a_command(argv, paths)]
    assert not bad, "\n".join(bad)


def test_every_command_is_in_the_readme():
    shown = {tuple(argv[:n]) for argv in readme_commands(README.read_text()) for n in range(1, len(argv) + 1)}
    missing = sorted(" ".join(path) for path in command_paths(build_parser()) - shown)
    assert not missing, f"commands the README's examples do not show: {', '.join(missing)}"
