"""What the ROS commands share: a short-lived client's rclpy and node, how long it gives DDS
discovery, and the checks of what a user hands to ROS (``--ros-args``, names, namespaces),
refused in one line before any node exists."""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterable, Iterator
from types import ModuleType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rclpy.node import Node


def client_node(name: str, ros_args: list[str]) -> tuple[ModuleType, Node]:
    """rclpy initialised for a short-lived client command, and its node.

    rclpy's signal handling is off (``SignalHandlerOptions.NO``): its SIGTERM handler shuts
    the context down under the command, whose next rclpy call then raises
    ``ExternalShutdownException`` (a traceback, exit code 1). Instead SIGTERM is Ctrl-C here:
    both raise ``KeyboardInterrupt`` in the main thread, the one thread a client command
    runs rclpy on, which each command turns into its clean end. Every wait of a client
    command is a loop of short waits (at most 0.1 s), so the interrupt is taken at once."""
    import signal

    from tensegrity_ros.rclpy_utils.env import require_rclpy

    rclpy = require_rclpy()
    from rclpy.signals import SignalHandlerOptions

    from tensegrity_ros.rclpy_utils.parameter_guard import guard_parameter_services

    signal.signal(signal.SIGTERM, signal.default_int_handler)
    rclpy.init(args=["tensegrity", *ros_args], signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node(name)
    guard_parameter_services(node)
    return rclpy, node


#: Seconds a client gives the graph to show a publisher or subscriber it looks for (DDS
#: discovery on loopback takes a few hundred ms; more on a loaded machine).
DISCOVERY_S = 2.0

#: What each ROS argument rcl could not parse should look like.
_ROS_ARG_FORMS = {"parameter override rule": "-p NAME:=VALUE", "remap rule": "-r FROM:=TO (a namespace: __ns:=/robot1)",
                  "params file": "--params-file FILE, a readable ROS parameter YAML file",
                  "log level": "--log-level LEVEL (debug, info, warn, error, fatal)"}


def check_ros_args(ros_args: list[str]) -> None:
    """Refuse ``--ros-args ...`` that rcl cannot parse with one line (a CliError, exit 2), before
    any node or child process starts; rclpy.init would raise RCLError (a traceback), and every
    child of ``tensegrity up`` would. No arguments: nothing to check."""
    if not ros_args:
        return
    from tensegrity_ros.rclpy_utils.env import require_rclpy

    require_rclpy()
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    from rclpy.utilities import remove_ros_args

    from tensegrity_core.excerpt import clip
    from tensegrity_ros.cli._common import CliError

    try:
        with _c_stderr_discarded():          # rcl's own warning would be a second line
            remove_ros_args(["tensegrity", *ros_args])
    except _rclpy.UnknownROSArgsError as err:
        unknown = str(err).strip("[]").replace("'", "")
        raise CliError(clip(f"unknown ROS arguments: {unknown} (known: -p NAME:=VALUE, -r FROM:=TO, "
                            "--params-file FILE, --log-level LEVEL, ...)")) from None
    except _rclpy.RCLInvalidROSArgsError as err:
        what = str(err).removeprefix("Failed to parse ROS arguments: ").partition(". Error:")[0]
        form = next((f for kind, f in _ROS_ARG_FORMS.items() if kind in what), None)
        raise CliError(clip(f"bad ROS argument: {what[:1].lower()}{what[1:]}" + (f" (expected {form})" if form else "")
                            )) from None


@contextlib.contextmanager
def _c_stderr_discarded() -> Iterator[None]:
    """File descriptor 2 goes to /dev/null for the block (what C libraries print there)."""
    sys.stderr.flush()
    saved = os.dup(2)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)


def check_ros_name(name: str, option: str, *, namespace: bool = False) -> None:
    """Refuse a topic, service or action name (or, with ``namespace``, a namespace) that ROS
    would not take, with one line (a CliError, exit 2) before any node is created."""
    from tensegrity_ros.rclpy_utils.env import require_rclpy

    require_rclpy()
    from rclpy.exceptions import NameValidationException
    from rclpy.validate_namespace import validate_namespace
    from rclpy.validate_topic_name import validate_topic_name

    from tensegrity_core.excerpt import excerpt
    from tensegrity_ros.cli._common import CliError

    try:
        if namespace:
            validate_namespace(name if name.startswith("/") else "/" + name)
        else:
            validate_topic_name(name)
    except NameValidationException as err:
        why = str(err).splitlines()[0].partition(": ")[2].rstrip(":")
        raise CliError(f"{option} {excerpt(name)} is not a valid ROS {'namespace' if namespace else 'name'}: {why}"
                       ) from None


def namespace_hint(name: str, graph_names: Iterable[str]) -> str:
    """``"; found /robot1/solve_ik: add --ros-args -r __ns:=/robot1"`` when the relative
    ``name`` a client looked for is in the graph only under another namespace (the suite was
    started with ``tensegrity up --namespace``), else ``""``. ``graph_names`` are fully
    qualified service or action names."""
    if name.startswith(("/", "~")):              # absolute or private: a namespace does not move it
        return ""
    found = sorted(n for n in set(graph_names) if n.endswith("/" + name) and n != "/" + name)
    if not found:
        return ""
    more = f" (and {len(found) - 1} more)" if len(found) > 1 else ""
    return f"; found {found[0]}{more}: add --ros-args -r __ns:={found[0][:-len(name) - 1]}"
