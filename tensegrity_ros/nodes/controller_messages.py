"""The controller's translations between messages and the core's values (no node, no DDS).

- the result codes of the two actions for the core's goal outcomes and planning errors;
- a joint state to ``(t [s], q, qdot)`` (rho1, rho2 [m], beta [rad] and their rates), a
  trajectory's start stamp to a time [s], seconds to a ``builtin_interfaces/Duration``;
- what tells two actuator commands apart.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from builtin_interfaces.msg import Duration as DurationMsg
from numpy.typing import NDArray
from sensor_msgs.msg import JointState
from tensegrity_msgs.action import FollowActuatorTrajectory, MoveEndEffector
from tensegrity_msgs.msg import ActuatorForces

from tensegrity_core.class2.control import goals as G
from tensegrity_core.class2.control.errors import INVALID_JOINTS, OUTSIDE_WORKSPACE, SINGULAR_PATH
from tensegrity_core.class2.names import JOINTS
from tensegrity_core.errors import TensegrityError
from tensegrity_ros.rclpy_utils.messages import stamp_to_s

_MOVE = MoveEndEffector.Result
_FOLLOW = FollowActuatorTrajectory.Result
#: Outcome codes of the core's goals -> result codes (the same numbers in both actions).
OUTCOME_CODES = {G.SUCCEEDED: 0, G.PATH_TOLERANCE_VIOLATED: _FOLLOW.PATH_TOLERANCE_VIOLATED,
                 G.GOAL_TOLERANCE_VIOLATED: _FOLLOW.GOAL_TOLERANCE_VIOLATED,
                 G.SIMULATOR_STOPPED: _FOLLOW.SIMULATOR_STOPPED, G.SINGULAR_STATE: _FOLLOW.SINGULAR_STATE,
                 G.PREEMPTED: _FOLLOW.PREEMPTED, G.CANCELED: _FOLLOW.CANCELED}
MOVE_PLANNING_CODES = {OUTSIDE_WORKSPACE: _MOVE.OUTSIDE_WORKSPACE, SINGULAR_PATH: _MOVE.SINGULAR_PATH}
FOLLOW_PLANNING_CODES = {INVALID_JOINTS: _FOLLOW.INVALID_JOINTS}


class OldStampError(TensegrityError):
    """A trajectory's start stamp lies in the past."""


def given(value: float) -> float | None:
    """0 means "not given" in the MoveEndEffector goal; anything else is checked by the planner."""
    return None if value == 0.0 else value


def stamp_start(stamp: Any, now: float) -> float | None:
    """The start time of a trajectory: None (now) for a zero stamp, else the stamp [s]."""
    t = stamp_to_s(stamp)
    if t == 0.0:
        return None
    if t < now:
        raise OldStampError(f"header.stamp {t:.6f} s is before the controller's current time {now:.6f} s "
                        "(zero starts the trajectory at once)")
    return t


def parse_joint_state(msg: JointState) -> tuple[float, NDArray[np.float64], NDArray[np.float64]] | None:
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


def command_key(msg: ActuatorForces) -> tuple[int, int, tuple[str, ...], tuple[float, ...]]:
    """What tells two commands apart: stamp, names and forces."""
    return msg.header.stamp.sec, msg.header.stamp.nanosec, tuple(msg.name), tuple(msg.force)


def duration_msg(seconds: float) -> DurationMsg:
    """A duration message of ``seconds`` [s] (negative: zero), nanoseconds rounded."""
    seconds = max(0.0, seconds)
    sec = math.floor(seconds)
    return DurationMsg(sec=int(sec), nanosec=min(int(round((seconds - sec) * 1e9)), 999_999_999))
