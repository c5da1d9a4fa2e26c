"""Fixtures of the view's tests (shared ROS fixtures live in tests/ros_support.py)."""

from tests.ros_support import cli, ros_context  # noqa: F401
