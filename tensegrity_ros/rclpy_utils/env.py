"""Process environment for anything that creates a ROS context.

These machines may send traffic only to loopback: DDS discovery stays on localhost unless
the user explicitly chose another range (``ROS_AUTOMATIC_DISCOVERY_RANGE``). Call
:func:`ensure_ros_environment` before ``import rclpy``; :func:`require_rclpy` does both
and turns a missing ROS installation into a clear message.
"""

from __future__ import annotations

import os

DEFAULT_DISCOVERY_RANGE = "LOCALHOST"


class RosUnavailableError(RuntimeError):
    """rclpy or the tensegrity_msgs interfaces cannot be imported."""


def ensure_ros_environment() -> None:
    """Default ``ROS_AUTOMATIC_DISCOVERY_RANGE`` to LOCALHOST (a user's value wins)."""
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", DEFAULT_DISCOVERY_RANGE)


def require_rclpy():
    """Import and return rclpy after setting the environment, or raise a clear error."""
    ensure_ros_environment()
    try:
        import rclpy
        import tensegrity_msgs.msg  # noqa: F401  (built from msgs_spec/ by ./run setup)
    except ImportError as err:
        raise RosUnavailableError(
            f"ROS 2 is not available in this environment ({err}). Run `./run setup` "
            "(installs the ROS 2 Jazzy wheels and builds tensegrity_msgs), or "
            "`pip install 'tensegrity-ros[ros]'` and build msgs_spec/."
        ) from err
    return rclpy
