"""What every short-lived ROS client command shares: its rclpy and node, and how long it
gives DDS discovery."""

from __future__ import annotations

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
