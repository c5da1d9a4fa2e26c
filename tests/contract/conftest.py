"""Fixtures of the contract tests: a suite started as a user starts it, and a plain rclpy client."""

from tests.ros_support import cli  # noqa: F401
