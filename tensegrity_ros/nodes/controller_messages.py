"""The controller's translations between messages and the core's values (no node, no DDS).

- the result codes of the two actions for the core's goal outcomes and planning errors, and a
  goal's end with them (:func:`finish`);
- a joint state to ``(t [s], q, qdot)`` (rho1, rho2 [m], beta [rad] and their rates), a
  trajectory's start stamp to a time [s] (and the warning for one far ahead), seconds to a
  ``builtin_interfaces/Duration``;
- the feedback of a goal: at its takeover and at every tick.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, TypeAlias

import numpy as np
from builtin_interfaces.msg import Duration as DurationMsg
from geometry_msgs.msg import Point
from numpy.typing import NDArray
from sensor_msgs.msg import JointState
from tensegrity_msgs.action import FollowActuatorTrajectory, MoveEndEffector
from trajectory_msgs.msg import JointTrajectoryPoint

from tensegrity_core.class2 import end_effector_of
from tensegrity_core.class2.control import PlanningError
from tensegrity_core.class2.control import goals as G
from tensegrity_core.class2.control.errors import INVALID_JOINTS, OUTSIDE_WORKSPACE, SINGULAR_PATH
from tensegrity_core.class2.control.law import Tick
from tensegrity_core.class2.names import ACTUATED_JOINTS, JOINTS
from tensegrity_core.errors import TensegrityError
from tensegrity_ros.rclpy_utils.messages import stamp_to_s

FloatArray: TypeAlias = NDArray[np.float64]
#: ``(t, q, qdot)`` of a joint state: time [s], ``(rho1 [m], rho2 [m], beta [rad])`` and their rates.
JointSample: TypeAlias = tuple[float, FloatArray, FloatArray]
#: A goal of the controller.
Goal: TypeAlias = G.MoveGoal | G.TrajectoryGoal

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
    """A trajectory ended before the controller's current time."""


def given(value: float) -> float | None:
    """0 means "not given" in the MoveEndEffector goal; anything else is checked by the planner."""
    return None if value == 0.0 else value


def stamp_start(stamp: Any, now: float, times: Sequence[float]) -> float | None:
    """The start time of a trajectory whose points come ``times`` [s] after it: None (now)
    for a zero stamp, else the stamp [s]. As joint_trajectory_controller (its
    ``validate_trajectory_msg``), a start in the past is joined where the trajectory is at
    ``now``, and only a trajectory that ended before ``now`` is refused (:class:`OldStampError`)."""
    t = stamp_to_s(stamp)
    if t == 0.0:
        return None
    end = t + max(times, default=0.0)
    if end < now:
        raise OldStampError(f"the trajectory started at header.stamp {t:.6f} s ended at {end:.6f} s, before the "
                            f"controller's current time {now:.6f} s (zero starts the trajectory at once)")
    return t


def far_start_warning(start: float | None, now: float, horizon: float) -> str | None:
    """What to say of a trajectory that starts more than ``horizon`` seconds of simulation
    time after ``now`` (it waits for its stamp, as joint_trajectory_controller's goals do):
    such a stamp is most likely wall-clock time from a client without use_sim_time. None
    for a start within the horizon or at once."""
    if start is None or start - now <= horizon:
        return None
    return (f"a trajectory starts at {start:.6f} s, {start - now:.3g} s after the simulation's time {now:.6f} s, "
            "and waits until then: is its trajectory.header.stamp wall-clock time (a client without "
            "use_sim_time)? A zero stamp starts it at once")


def parse_joint_state(msg: JointState) -> JointSample | None:
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


def finish(handle: Any, result: Any, outcome: G.Outcome) -> Any:
    """Fill ``result`` (an action's result message) from ``outcome`` and end the goal of
    ``handle`` (rclpy's ServerGoalHandle) as the outcome says; returns ``result``."""
    result.error_code = OUTCOME_CODES[outcome.code]
    result.error_string = outcome.message
    if outcome.succeeded:
        handle.succeed()
    elif outcome.code == G.CANCELED:
        handle.canceled()
    else:
        handle.abort()
    return result


def duration_msg(seconds: float) -> DurationMsg:
    """A duration message of ``seconds`` [s] (negative: zero), nanoseconds rounded."""
    seconds = max(0.0, seconds)
    sec = math.floor(seconds)
    return DurationMsg(sec=int(sec), nanosec=min(int(round((seconds - sec) * 1e9)), 999_999_999))


def start_feedback(goal: Goal, header: Any, latest: JointSample, L: float) -> Any:
    """The feedback of ``goal`` when it has just taken over: the last measured state
    ``latest`` (its message's ``header``) against the reference at that time, before any
    tick under the goal (``L``: strut length [m]). A client that steps a paused simulator
    waits for it: from then on every step is the goal's."""
    t, q, qdot = latest
    desired = goal.reference.sample(t - goal.t_start)
    d = np.array(end_effector_of(q, L))
    if isinstance(goal, G.MoveGoal):
        fb = MoveEndEffector.Feedback(header=header, phase=goal.phase)
        target = goal.reference.target
        fb.end_effector = Point(x=float(d[0]), y=float(d[1]))
        fb.desired = Point(x=float(desired.end_effector[0]), y=float(desired.end_effector[1]))
        fb.tracking_error = float(math.hypot(*(d - desired.end_effector)))
        fb.distance_to_target = float(math.hypot(d[0] - target[0], d[1] - target[1]))
        fb.time_from_start = 0.0
        return fb
    fb = FollowActuatorTrajectory.Feedback(header=header, joint_names=list(ACTUATED_JOINTS))
    when = duration_msg(max(0.0, t - goal.t_start))     # > 0: a trajectory started in the past, joined
    fb.desired = JointTrajectoryPoint(positions=[float(v) for v in desired.q[:2]],
                                      velocities=[float(v) for v in desired.qdot[:2]], time_from_start=when)
    fb.actual = JointTrajectoryPoint(positions=[float(v) for v in q[:2]],
                                     velocities=[float(v) for v in qdot[:2]], time_from_start=when)
    fb.error = JointTrajectoryPoint(positions=[float(desired.q[k] - q[k]) for k in (0, 1)],
                                    velocities=[float(desired.qdot[k] - qdot[k]) for k in (0, 1)],
                                    time_from_start=when)
    return fb


def feedback(goal: Goal, header: Any, tick: Tick, q: FloatArray, qdot: FloatArray) -> Any:
    """The feedback of ``goal`` at a tick of the law on the joint state ``(q, qdot)`` (its
    message's ``header``)."""
    if isinstance(goal, G.MoveGoal):
        fb = MoveEndEffector.Feedback(header=header, phase=goal.phase)
        fb.end_effector = Point(x=float(tick.end_effector[0]), y=float(tick.end_effector[1]))
        fb.desired = Point(x=float(tick.desired.end_effector[0]), y=float(tick.desired.end_effector[1]))
        fb.tracking_error = float(math.hypot(*(tick.end_effector - tick.desired.end_effector)))
        fb.distance_to_target = float(goal.distance)
        fb.time_from_start = float(tick.tau)
        return fb
    fb = FollowActuatorTrajectory.Feedback(header=header, joint_names=list(ACTUATED_JOINTS))
    when = duration_msg(tick.tau)
    fb.desired = JointTrajectoryPoint(positions=[float(v) for v in tick.desired.q[:2]],
                                      velocities=[float(v) for v in tick.desired.qdot[:2]], time_from_start=when)
    fb.actual = JointTrajectoryPoint(positions=[float(v) for v in q[:2]],
                                     velocities=[float(v) for v in qdot[:2]], time_from_start=when)
    # control_msgs' sign (joint_trajectory_controller's feedback): desired - actual, as the goal's
    fb.error = JointTrajectoryPoint(positions=[float(v) for v in goal.error],
                                    velocities=[float(v) for v in goal.rate_error], time_from_start=when)
    return fb


def joint_tolerances(items: Sequence[Any], default: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """``((pos1, pos2), (vel1, vel2))`` from JointTolerance messages (0: default, < 0: off)."""
    pos, vel = [default, default], [0.0, 0.0]
    for item in items:
        if item.name not in ACTUATED_JOINTS:
            raise PlanningError(f"tolerance for unknown joint {item.name!r}; the joints are rho1, rho2",
                                code=INVALID_JOINTS)
        for values, v, d in ((pos, item.position, default), (vel, item.velocity, 0.0)):
            if not math.isfinite(v):
                raise PlanningError(f"tolerance of {item.name} must be finite, got {v!r}")
            values[ACTUATED_JOINTS.index(item.name)] = d if v == 0.0 else (v if v > 0.0 else 0.0)
    return (pos[0], pos[1]), (vel[0], vel[1])
