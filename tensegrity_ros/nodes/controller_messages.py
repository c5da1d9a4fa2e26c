"""The class-2 controller's message translations, no node: a joint state to ``(t, q, qdot)``,
a trajectory's start stamp, durations, and what tells two actuator commands apart (so the
controller knows its own commands from another node's)."""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Duration as DurationMsg
from sensor_msgs.msg import JointState
from tensegrity_msgs.msg import ActuatorForces

from tensegrity_core.class2.names import JOINTS
from tensegrity_core.errors import TensegrityError
from tensegrity_ros.rclpy_utils.messages import stamp_to_s


class OldStamp(TensegrityError):
    """A trajectory's start stamp lies in the past."""


def stamp_start(stamp, now: float) -> float | None:
    """The start time of a trajectory: None (now) for a zero stamp, else the stamp [s]."""
    t = stamp_to_s(stamp)
    if t == 0.0:
        return None
    if t < now:
        raise OldStamp(f"header.stamp {t:.6f} s is before the controller's current time {now:.6f} s "
                       "(zero starts the trajectory at once)")
    return t


def parse_joint_state(msg: JointState):
    """``(t, q, qdot)`` of a joint state naming rho1, rho2, beta, or None when unusable."""
    names = list(msg.name)
    try:
        idx = [names.index(n) for n in JOINTS]
        q = [float(msg.position[i]) for i in idx]
        qdot = [float(msg.velocity[i]) for i in idx]
    except (ValueError, IndexError):
        return None
    if not all(math.isfinite(v) for v in q + qdot):
        return None
    return stamp_to_s(msg.header.stamp), np.array(q), np.array(qdot)


def command_key(msg: ActuatorForces) -> tuple:
    """What tells two commands apart: stamp, names and forces."""
    return msg.header.stamp.sec, msg.header.stamp.nanosec, tuple(msg.name), tuple(msg.force)


def duration_msg(seconds: float) -> DurationMsg:
    """A duration message of ``seconds`` [s] (negative: zero), nanoseconds rounded."""
    seconds = max(0.0, seconds)
    sec = math.floor(seconds)
    return DurationMsg(sec=int(sec), nanosec=min(int(round((seconds - sec) * 1e9)), 999_999_999))
