"""Timed trajectories of a model's commanded inputs with joint_trajectory_controller's
semantics: checking, interpolation, and the path and goal tolerances of a goal. No ROS.

The joints are a model's inputs that take commands (general structures: actuated cables,
whose positions are rest lengths [m]; see :class:`~tensegrity_core.sim.model.Interface`).
A trajectory names some of them, each once, and gives points with ``time_from_start`` [s]
(>= 0, strictly increasing), positions (one per named joint, inside each input's range) and
optionally velocities and accelerations (every point or none); the last point's velocities
are 0 (joint_trajectory_controller's default, ``allow_nonzero_velocity_at_trajectory_end:
false``: after it the trajectory holds its positions at rest). Interpolation as in
ros2_controllers' joint_trajectory_controller: positions only -> linear, with velocities ->
cubic Hermite, with accelerations too -> quintic (``scipy.interpolate.BPoly.from_derivatives``,
which is exactly that family). Unless the first point is at 0 the first segment starts at
time 0 from ``start`` (the joints' commands when the goal starts) at rest. After the last
point the trajectory holds it.

:class:`GoalMonitor` checks a running goal as joint_trajectory_controller does: until the
last point's time each joint must stay within its path tolerance of the desired position
(and rate, where given); after it, the goal succeeds once every joint is within its goal
tolerance, and fails when that has not happened ``goal_time`` seconds after the end (``inf``:
it waits as long as it takes, as joint_trajectory_controller with a goal time of 0).

Tolerance values as control_msgs' JointTolerance gives them (:func:`tolerance`): > 0 the
bound, 0 the default, < 0 "erased" (not checked; for the goal time: no limit).

What a goal may hold that single-DOF joints cannot follow is refused
(:func:`unsupported_reason`): a multi-DOF trajectory, the component tolerances (bounds on the
x, y, z, translation or rotation of a multi-DOF joint: a cable has none of them, so a bound
given there could never be checked; joint_trajectory_controller, whose joints are
single-DOF too, accepts them and checks nothing, which would report success against bounds
never applied) and efforts.

A robot's motors trail their commands by their lag and slew limit (the 3-bar's lag of 1 s
needs 6.5 s to close the 0.07 m its crawl ends with to 0.1 mm), so a default goal time meant
for the command's own delay runs out before they arrive. :func:`motors_settle_time` bounds
the time its slowest motor among a goal's joints needs to come within the goal tolerance of
a rest length commanded from anywhere in its range (no gap can be wider): the time the
default goal time adds for a robot's motors.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Final

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.errors import TensegrityError
from tensegrity_core.excerpt import excerpt

if TYPE_CHECKING:       # a name for annotations: the model module brings the integrators (scipy.integrate)
    from tensegrity_core.sim.model import Interface

FloatArray = NDArray[np.float64]

#: The largest last-point velocity taken for 0 [m/s]: joint_trajectory_controller's (float epsilon).
END_VELOCITY_EPS: Final = float(np.finfo(np.float32).eps)
#: What a trajectory may hold (input from outside is bounded).
MAX_POINTS: Final = 100_000
MAX_DURATION: Final = 24 * 3600.0

#: Outcome codes, as control_msgs/FollowJointTrajectory's result.
SUCCESSFUL: Final = 0
INVALID_GOAL: Final = -1
INVALID_JOINTS: Final = -2
OLD_HEADER_TIMESTAMP: Final = -3
PATH_TOLERANCE_VIOLATED: Final = -4
GOAL_TOLERANCE_VIOLATED: Final = -5


class TrajectoryError(TensegrityError):
    """A trajectory that cannot be followed; ``code`` says which check failed (INVALID_GOAL,
    INVALID_JOINTS)."""

    def __init__(self, message: str, code: int = INVALID_GOAL):
        super().__init__(message)
        self.code = code


@dataclass(frozen=True)
class Sample:
    """The trajectory at one time: positions, velocities, accelerations of its joints."""

    positions: FloatArray
    velocities: FloatArray
    accelerations: FloatArray


class JointTrajectory:
    """A checked trajectory of some of a model's inputs (build it with :func:`plan_trajectory`).

    ``names`` the joints in the trajectory's order, ``inputs`` their input indices, ``duration``
    the last point's time [s]."""

    def __init__(self, names: tuple[str, ...], inputs: tuple[int, ...], knots: FloatArray, values: FloatArray):
        self.names = names
        self.inputs = inputs
        # imported here: what imports this module for its checks (a node's start) does not
        # pay for scipy.interpolate (~0.7 s of CPU with scipy.special and scipy.optimize)
        from scipy.interpolate import BPoly

        self.duration = float(knots[-1])
        self._poly = BPoly.from_derivatives(knots, values)
        self._rate = self._poly.derivative(1)
        self._accel = self._poly.derivative(2)
        self._last = values[-1, 0].copy()

    def sample(self, tau: float) -> Sample:
        """The trajectory ``tau`` seconds after its start (before 0: the start; after the end:
        the last point, at rest)."""
        n = len(self.names)
        if tau >= self.duration:
            return Sample(self._last.copy(), np.zeros(n), np.zeros(n))
        tau = max(tau, 0.0)
        return Sample(np.asarray(self._poly(tau), dtype=float), np.asarray(self._rate(tau), dtype=float),
                      np.asarray(self._accel(tau), dtype=float))

    def command(self, tau: float, held: Sequence[float]) -> list[float]:
        """A whole command (one value per input, input order): ``held`` with the trajectory's
        joints at their positions ``tau`` seconds after the start."""
        out = [float(v) for v in held]
        for i, v in zip(self.inputs, self.sample(tau).positions):
            out[i] = float(v)
        return out


def _rows(name: str, value: Sequence[Sequence[float]], n: int, width: int) -> FloatArray | None:
    """``value`` as an (n, width) finite array, or None when no point gives it."""
    if len(value) == 0 or all(len(row) == 0 for row in value):
        return None
    if len(value) != n:
        raise TrajectoryError(f"{name}: {len(value)} rows for {n} points (give all points or none)")
    for i, row in enumerate(value):
        if len(row) != width:
            raise TrajectoryError(f"point {i}: {len(row)} {name} for the {width} joints")
    arr = np.array([[float(v) for v in row] for row in value])
    if not np.all(np.isfinite(arr)):
        i, j = np.argwhere(~np.isfinite(arr))[0]
        raise TrajectoryError(f"point {i}: {name}[{j}] is not finite ({float(arr[i, j])!r})")
    return arr


def plan_trajectory(names: Sequence[str], times: Sequence[float], positions: Sequence[Sequence[float]],
                    velocities: Sequence[Sequence[float]] = (), accelerations: Sequence[Sequence[float]] = (), *,
                    interface: Interface, start: Sequence[float]) -> JointTrajectory:
    """The :class:`JointTrajectory` of the given points (see the module docstring), or
    :class:`TrajectoryError`. ``start``: the current command of every input (input order)."""
    names = [str(n) for n in names]
    takes = [n for n, c in zip(interface.inputs, interface.commanded) if c]
    if not takes:
        raise TrajectoryError("this scene has no inputs that take commands", code=INVALID_JOINTS)
    if not names:
        raise TrajectoryError("the trajectory names no joints", code=INVALID_JOINTS)
    modes = dict(zip(interface.inputs, interface.modes))
    for name in names:
        if name not in takes:
            raise TrajectoryError(f"unknown joint {excerpt(name)}; the joints are {', '.join(takes)}",
                                  code=INVALID_JOINTS)
        if modes.get(name, "rest_length") != "rest_length":
            raise TrajectoryError(f"joint {name}'s motor takes a {modes[name].replace('_', ' ')}, not a rest length: "
                                  "trajectories drive rest-length motors (send its command on cable_commands)",
                                  code=INVALID_JOINTS)
    if len(set(names)) != len(names):
        raise TrajectoryError(f"a joint is named twice in {excerpt(names)}", code=INVALID_JOINTS)
    inputs = tuple(interface.inputs.index(name) for name in names)
    n = len(times)
    if n == 0:
        raise TrajectoryError("the trajectory has no points")
    if n > MAX_POINTS:
        raise TrajectoryError(f"the trajectory has {n} points; at most {MAX_POINTS} are accepted")
    t = np.array([float(v) for v in times])
    if not np.all(np.isfinite(t)) or t[0] < 0.0:
        raise TrajectoryError(f"time_from_start must be finite and >= 0, got {excerpt(list(t[:3]))} s")
    if np.any(np.diff(t) <= 0.0):
        i = int(np.argmax(np.diff(t) <= 0.0)) + 1
        raise TrajectoryError(f"time_from_start must increase strictly: point {i} at {t[i]:g} s does not "
                              f"follow point {i - 1} at {t[i - 1]:g} s")
    if t[-1] > MAX_DURATION:
        raise TrajectoryError(f"the trajectory lasts {t[-1]:g} s; at most {MAX_DURATION:g} s are accepted")
    p = _rows("positions", positions, n, len(names))
    if p is None:
        raise TrajectoryError("every point needs positions")
    v = _rows("velocities", velocities, n, len(names))
    a = _rows("accelerations", accelerations, n, len(names))
    if a is not None and v is None:
        raise TrajectoryError("accelerations need velocities too")
    if v is not None and np.any(np.abs(v[-1]) > END_VELOCITY_EPS):
        j = int(np.argmax(np.abs(v[-1]) > END_VELOCITY_EPS))
        raise TrajectoryError(f"the last point's velocity of {names[j]} is {v[-1, j]:g} {interface.unit}/s: a "
                              "trajectory must end at rest (its last point then holds)")
    for j, i in enumerate(inputs):
        lo, hi = interface.limits[i]
        bad = np.flatnonzero(~((p[:, j] > lo) & (p[:, j] < hi)))
        if bad.size:
            raise TrajectoryError(f"point {int(bad[0])}: position of {names[j]} = {p[bad[0], j]:g} "
                                  f"{interface.unit} is outside its range {interface.range_text(i)} {interface.unit}")
    derivs = [p] + [x for x in (v, a) if x is not None]
    if t[0] > 0.0:
        s0 = np.array([float(start[i]) for i in inputs])
        t = np.concatenate([[0.0], t])
        derivs = [np.vstack([s0 if k == 0 else np.zeros(len(names)), d]) for k, d in enumerate(derivs)]
    if len(t) == 1:                      # one point at time 0: hold it
        t = np.array([0.0, 1e-9])
        derivs = [np.vstack([d, d]) for d in derivs[:1]]
    return JointTrajectory(tuple(names), inputs, t, np.stack(derivs, 1))


@dataclass(frozen=True)
class Tolerances:
    """Per joint of a trajectory (its order): ``path_position`` [m] and ``path_velocity``
    [m/s] while it runs, ``goal_position`` and ``goal_velocity`` at its end (``inf``: not
    checked), and ``goal_time`` [s] after the end to meet the goal tolerances (``inf``: no limit)."""

    path_position: tuple[float, ...]
    path_velocity: tuple[float, ...]
    goal_position: tuple[float, ...]
    goal_velocity: tuple[float, ...]
    goal_time: float


@dataclass(frozen=True)
class Outcome:
    """How a goal ended: ``code`` (SUCCESSFUL or the check that failed) and why."""

    code: int
    message: str

    @property
    def succeeded(self) -> bool:
        return self.code == SUCCESSFUL


class GoalMonitor:
    """The path and goal checks of one running trajectory (see the module docstring)."""

    def __init__(self, trajectory: JointTrajectory, tolerances: Tolerances, unit: str = "m"):
        self.trajectory = trajectory
        self.tolerances = tolerances
        self.unit = unit

    def check(self, tau: float, positions: Sequence[float], velocities: Sequence[float] | None = None
              ) -> Outcome | None:
        """The outcome at ``tau`` seconds after the start given the joints' actual positions
        (and rates, if measured), or None while the goal runs on. The errors its message names are
        desired - actual, control_msgs' sign (the ``error`` of FollowJointTrajectory's feedback
        and of joint_trajectory_controller's state), so a message and the feedback of the same
        moment agree."""
        tr, tol = self.trajectory, self.tolerances
        desired = tr.sample(tau)
        pos_err = desired.positions - np.asarray(positions, dtype=float)
        vel_err = None if velocities is None else desired.velocities - np.asarray(velocities, dtype=float)
        if tau <= tr.duration:
            bad = _violation(tr.names, pos_err, vel_err, tol.path_position, tol.path_velocity, self.unit)
            if bad:
                return Outcome(PATH_TOLERANCE_VIOLATED, f"at {tau:.6g} s from the start: {bad} exceeds the path "
                                                        "tolerance")
            if tau < tr.duration:
                return None
        bad = _violation(tr.names, pos_err, vel_err, tol.goal_position, tol.goal_velocity, self.unit)
        if not bad:
            return Outcome(SUCCESSFUL, f"within the goal tolerance {tau - tr.duration:.6g} s after the end")
        if tau - tr.duration > tol.goal_time:
            return Outcome(GOAL_TOLERANCE_VIOLATED, f"{bad} exceeds the goal tolerance {tol.goal_time:g} s after the "
                                                    "end (goal_time_tolerance)")
        return None


def _violation(names: Sequence[str], pos_err: FloatArray, vel_err: FloatArray | None, pos_tol: Sequence[float],
               vel_tol: Sequence[float], unit: str) -> str:
    """The first tolerance exceeded, as ``"<joint>: position error <e> <unit> (tolerance <t>)"``
    (``e`` = desired - actual), or ``""``."""
    for j, name in enumerate(names):
        if abs(pos_err[j]) > pos_tol[j]:
            return f"{name}: position error {pos_err[j]:.3g} {unit} (tolerance {pos_tol[j]:g} {unit})"
        if vel_err is not None and abs(vel_err[j]) > vel_tol[j]:
            return f"{name}: velocity error {vel_err[j]:.3g} {unit}/s (tolerance {vel_tol[j]:g} {unit}/s)"
    return ""


def unsupported_reason(*, multi_dof: bool, component_tolerances: tuple[int, int], effort: bool) -> str | None:
    """Why a goal cannot be followed by single-DOF joints that take positions, or None: it
    has a multi-DOF trajectory, component tolerances (how many path and goal component
    tolerances it gives), or points with effort."""
    if multi_dof:
        return "multi_dof_trajectory is not supported: cables are single-DOF joints"
    for key, count in zip(("component_path_tolerance", "component_goal_tolerance"), component_tolerances):
        if count:
            return (f"{key} ({count} given) is not supported: it bounds components (x, y, z, translation, rotation) "
                    f"of multi-DOF joints, and cables are single-DOF joints: give {key.removeprefix('component_')}")
    if effort:
        return "points with effort are not accepted: the cables take rest lengths"
    return None


def tolerance(value: float, default: float) -> float:
    """A JointTolerance value (or a goal time [s]) as a bound: > 0 itself, 0 the default, < 0
    not checked (inf; control_msgs' -1, "erased")."""
    if not math.isfinite(value):
        raise TrajectoryError(f"a tolerance must be finite, got {value!r}")
    return default if value == 0.0 else (value if value > 0.0 else math.inf)


def motors_settle_time(scene: Any, joints: Sequence[str], tolerance: float) -> float:
    """s the slowest rest-length motor of ``joints`` in the scene ``scene`` needs to come within
    ``tolerance`` [m] (> 0) of a rest length commanded from anywhere in its range
    (:func:`tensegrity_core.robot.motor.settling_time`; the scene's ``motors`` lag and slew limit
    replacing the description's); 0 for a scene without robot motors (ideal actuators) or
    without the ``motors`` effect (ideal motors)."""
    from tensegrity_core.robot.motor import settling_time
    from tensegrity_core.sim.scene import RobotModelSpec

    fx = scene.effects.get("motors")
    if fx is None or not isinstance(scene.model, RobotModelSpec):
        return 0.0
    robot = scene.model.robot
    wanted = [j for j, c in enumerate(robot.motors.cable) if robot.cables.names[c] in set(joints)]
    if not wanted:
        return 0.0
    tau = robot.motors.tau[wanted] if fx.tau is None else np.full(len(wanted), fx.tau)
    speed = robot.motors.max_speed[wanted] if fx.max_speed is None else np.full(len(wanted), fx.max_speed)
    width = robot.motors.range[wanted, 1] - robot.motors.range[wanted, 0]
    return float(np.max(settling_time(width, tolerance, tau, speed)))
