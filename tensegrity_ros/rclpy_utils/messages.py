"""Message-type helpers that the missing ``rosidl_runtime_py`` would otherwise provide."""

from __future__ import annotations

import array
import importlib
import math
from typing import Any

import numpy as np

from tensegrity_core.excerpt import excerpt


def message_class(type_name: str) -> Any:
    """The Python class of a ROS interface type such as ``sensor_msgs/msg/JointState``.

    Accepts ``pkg/msg/Name``, ``pkg/Name`` (message assumed) and ``pkg/srv/Name``.
    Raises ``ValueError`` naming the type when it cannot be imported.
    """
    parts = type_name.strip("/").split("/")
    if len(parts) == 2:
        parts = [parts[0], "msg", parts[1]]
    if (len(parts) != 3 or parts[1] not in {"msg", "srv", "action"}
            or not parts[0].isidentifier() or not parts[2].isidentifier()):
        raise ValueError(f"not a ROS interface type name: {excerpt(type_name)} (expected pkg/msg/Name)")
    pkg, kind, name = parts
    try:
        return getattr(importlib.import_module(f"{pkg}.{kind}"), name)
    except (ImportError, AttributeError) as err:
        raise ValueError(f"interface type {excerpt(type_name)} is not installed ({excerpt(str(err))})") from None


def message_to_dict(msg: Any) -> Any:
    """A plain-Python (YAML/JSON-friendly) copy of a message, recursively."""
    if hasattr(msg, "get_fields_and_field_types"):
        return {f: message_to_dict(getattr(msg, f)) for f in msg.get_fields_and_field_types()}
    if isinstance(msg, (np.ndarray, array.array)):
        return msg.tolist()
    if isinstance(msg, (list, tuple)):
        return [message_to_dict(v) for v in msg]
    if isinstance(msg, (bytes, bytearray)):
        return list(msg)
    return msg


#: Nanoseconds in a second.
NS_PER_S = 1_000_000_000


def stamp_ns(stamp: Any) -> int:
    """A ``builtin_interfaces/Time`` (or ``Duration``) as integer nanoseconds, exact (no float
    in between): ``sec * 1e9 + nanosec``, as ``rclpy.time.Time.from_msg`` reads it. A
    ``Duration``'s ``sec`` may be negative (-0.5 s is ``sec=-1, nanosec=500000000``); a
    ``nanosec`` of 1e9 or more, which no ROS client sends, adds whole seconds."""
    return int(stamp.sec) * NS_PER_S + int(stamp.nanosec)


def stamp_to_s(stamp: Any) -> float:
    """A ``builtin_interfaces/Time`` as seconds."""
    return float(stamp.sec + 1e-9 * stamp.nanosec)


def duration_to_s(duration: Any) -> float:
    """A ``builtin_interfaces/Duration`` as seconds (its ``sec`` may be negative)."""
    return float(duration.sec + 1e-9 * duration.nanosec)


def duration_msg(seconds: float) -> Any:
    """A ``builtin_interfaces/Duration`` of ``seconds`` (a negative one is 0), to the nanosecond."""
    from builtin_interfaces.msg import Duration

    sec = math.floor(max(0.0, seconds))
    return Duration(sec=int(sec), nanosec=min(int(round((max(0.0, seconds) - sec) * 1e9)), 999_999_999))
