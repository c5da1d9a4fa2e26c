"""The ``tensegrity`` command line.

Subcommands live in modules named ``cmd_*.py`` in this package. Each defines
``register(subparsers)``, which adds its subcommands with ``set_defaults(func=...)``;
a handler returns the process exit code. Handlers import heavy modules (numpy, scipy,
rclpy) inside their bodies so that ``tensegrity --help`` stays fast and so that the core
commands work in an environment without the ROS wheels.

Long-running ROS commands (``node``, ``up``, ``record``, ``play``) set
``stop_signals=True``: for them SIGINT and SIGTERM are stop requests
(:mod:`tensegrity_ros.rclpy_utils.stop_signals`) from the first line of :func:`main` until the process
has exited, and a clean stop exits with code 0; run as the program (:func:`run`) their
process then ends without the interpreter's finalization, where ROS processes abort
(:mod:`tensegrity_ros.rclpy_utils.process_exit`). Every other command gets Python's default
again once parsed (Ctrl-C raises ``KeyboardInterrupt``: exit code 130). When one of them
returns, the process is about to exit: its objects are frozen out of the garbage
collector (``gc.freeze``), so that the interpreter's last collection at exit does not
walk them all (:func:`main`).
"""

from __future__ import annotations

import argparse
import difflib
import gc
import importlib
import os
import pkgutil
import re
import sys
from collections.abc import Iterable
from types import ModuleType
from typing import Any

from tensegrity_core.errors import interrupted
from tensegrity_ros.cli._common import CliError, fail
from tensegrity_ros.rclpy_utils import stop_signals

# DDS stays on loopback unless the user set another range (shared/ros2-jazzy-from-pypi.md).
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("MPLBACKEND", "Agg")


def _command_modules() -> list[ModuleType]:
    pkg = sys.modules[__name__]
    names = sorted(m.name for m in pkgutil.iter_modules(pkg.__path__) if m.name.startswith("cmd_"))
    mods = [importlib.import_module(f"{__name__}.{n}") for n in names]
    return sorted(mods, key=lambda m: getattr(m, "ORDER", 100))


#: What a value that is a negative number looks like on the command line: a minus, then a
#: digit or a point and a digit (``-1``, ``-.5``, ``-1e-12``, ``-2.5E3``). argparse's own
#: pattern (``-\d+`` or ``-\d*\.\d+``, Python 3.11) misses exponents, so it read ``--f -1e3`` as
#: an unknown option ``-1e3``; this is the pattern later Pythons use (CPython gh-123945).
#: None of our options looks like a number, so such a word is always a value.
NEGATIVE_NUMBER = re.compile(r"-\.?\d")


class SignedNumberParser(argparse.ArgumentParser):
    """A parser that reads every negative number as a value (:data:`NEGATIVE_NUMBER`).
    argparse offers no public hook for this: it keeps the pattern in the attribute its
    ``__init__`` sets, replaced here; its subparsers are of the same class."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER


class CommandParser(SignedNumberParser):
    """The parser of one subcommand: an argument it does not know is refused with *its*
    usage and the closest option it has (``tensegrity fk 0.7 0.7 --jsn``: "unrecognized
    arguments: --jsn (did you mean --json?)"), where argparse would hand the leftovers up
    to the top-level parser and print the top-level usage."""

    def parse_known_args(self, args: Iterable[str] | None = None,
                         namespace: Any = None) -> tuple[Any, list[str]]:
        namespace, extras = super().parse_known_args(args, namespace)
        if extras:
            options = [o for action in self._actions for o in action.option_strings]
            hints = [f"{word} (did you mean {close[0]}?)" if word.startswith("-") and (
                close := difflib.get_close_matches(word.partition("=")[0], options, n=1)) else word
                for word in extras]
            self.error(f"unrecognized arguments: {' '.join(hints)}")
        return namespace, extras


def build_parser() -> argparse.ArgumentParser:
    parser = SignedNumberParser(
        prog="tensegrity",
        description="Simulate, analyse and drive tensegrity mechanisms "
        "(numerical core + ROS 2 Jazzy node suite).",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=CommandParser)
    for mod in _command_modules():
        mod.register(sub)
    return parser


def run() -> None:
    """The ``tensegrity`` program (the console script and ``python -m tensegrity_ros.cli``):
    :func:`main`, and a long-running ROS command's process then ends without the
    interpreter's finalization (:mod:`tensegrity_ros.rclpy_utils.process_exit`)."""
    sys.exit(main(exit_after=True))


def main(argv: list[str] | None = None, *, exit_after: bool = False) -> int:
    """Run the command ``argv`` (default: the process's arguments); its exit code. With
    ``exit_after`` a long-running ROS command (``node``, ``up``, ``record``, ``play``) ends
    the process once it has returned, instead of returning."""
    # Held from the first line: a signal during start-up (imports, argument parsing) ends
    # the process at once with code 0, never with a traceback or killed mid-import.
    stop_signals.install()
    keep = False
    try:
        if argv is None:
            argv = sys.argv[1:]
        # Let `--ros-args ...` through to rclpy untouched (remapping, namespaces, parameters).
        ros_args: list[str] = []
        if "--ros-args" in argv:
            i = argv.index("--ros-args")
            argv, ros_args = argv[:i], argv[i:]
        parser = build_parser()
        args = parser.parse_args(argv)
        args.ros_args = ros_args
        if not getattr(args, "func", None):
            parser.print_help()
            return 0 if not argv else 2
        keep = bool(getattr(args, "stop_signals", False))  # kept until the process exits
        if not keep:
            stop_signals.release()    # Python's defaults again: Ctrl-C raises KeyboardInterrupt
        code = _run(args)
        if keep and exit_after:
            from tensegrity_ros.rclpy_utils.process_exit import end_process

            end_process(code)
        return code
    finally:
        if not keep:
            stop_signals.release()
        else:
            # The command has closed what it opened (nodes, ROS context, bag) and the process
            # exits next. Its interpreter's final garbage collection would walk every object
            # of numpy, scipy and rclpy: 0.1-0.3 s of CPU per process, about 1 CPU-s for `up`
            # and its five children, which under load made a stop of `up` take over 2 s.
            # Frozen objects are still released by reference counting at exit, and atexit
            # handlers (logging, multiprocessing, weakref.finalize) still run; only a
            # finalizer of cyclic garbage is skipped, which Python does not promise at exit.
            gc.freeze()


def _run(args: argparse.Namespace) -> int:
    from tensegrity_ros.rclpy_utils.env import RosUnavailableError

    try:
        if args.ros_args:
            from tensegrity_ros.cli.ros_clients import check_ros_args

            check_ros_args(args.ros_args)
        return int(args.func(args) or 0)
    except CliError as err:
        if interrupted(err):           # a Ctrl-C that a library turned into an error
            return 130
        return fail(str(err), err.code)
    except RosUnavailableError as err:
        return fail(str(err), 3)
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:            # output piped into `head` and the like
        sys.stdout = open(os.devnull, "w")
        return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
