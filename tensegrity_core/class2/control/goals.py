"""Supervising a running goal: tolerances, settling, and how the goal ends.

A goal wraps the :class:`~tensegrity_core.class2.control.Reference` the controller tracks.
Each controller tick hands it the measured state; it answers with the feedback of the tick
and, once the goal is over, an :class:`Outcome`. The ROS actions translate both into
messages; nothing here knows about ROS.

- :class:`MoveGoal` (MoveEndEffector): ``moving`` until the reference's end, then
  ``settling``; succeeds once ``|D - target| <= tolerance`` has held for ``settle_window``
  seconds, fails (``goal_tolerance_violated``) ``settle_timeout`` seconds after the end.
- :class:`TrajectoryGoal` (FollowActuatorTrajectory, control_msgs' semantics): while the
  trajectory runs every joint must stay within its path tolerance (position, and velocity
  where one is given); after its end, within ``goal_time_tolerance`` seconds, every joint
  must come within its goal tolerance.

Tolerances: a value > 0 is checked, ``<= 0`` (or ``inf``) is not.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.control.law import Tick
from tensegrity_core.class2.control.reference import Reference

#: Default time [s] after an actuator trajectory's last point for the lengths to come within
#: their goal tolerance. Actuator trajectories are quasi-static (beta, which no actuator
#: drives, lags its equilibrium while the lengths move): the lengths settle within 0.1 mm
#: about 5 s after the last point (docs/control.md), so 6 s.
GOAL_TIME_TOLERANCE: Final = 6.0

SUCCEEDED: Final = "succeeded"
PATH_TOLERANCE_VIOLATED: Final = "path_tolerance_violated"
GOAL_TOLERANCE_VIOLATED: Final = "goal_tolerance_violated"
SIMULATOR_STOPPED: Final = "simulator_stopped"
SINGULAR_STATE: Final = "singular_state"
PREEMPTED: Final = "preempted"
CANCELED: Final = "canceled"


@dataclass(frozen=True)
class Outcome:
    """How a goal ended: ``code`` one of the constants above, a message for people."""

    code: str
    message: str

    @property
    def succeeded(self) -> bool:
        return self.code == SUCCEEDED


def _checked(tol: ArrayLike) -> NDArray[np.float64]:
    t = np.asarray(tol, dtype=np.float64)
    return np.where(t > 0.0, t, math.inf)


@dataclass
class _Goal:
    reference: Reference
    t_start: float
    max_force: float = 0.0
    outcome: Outcome | None = None

    def tau(self, t: float) -> float:
        return t - self.t_start

    def end(self, outcome: Outcome) -> Outcome:
        """End the goal (the first outcome wins)."""
        if self.outcome is None:
            self.outcome = outcome
        return self.outcome

    def _forces(self, tick: Tick) -> None:
        self.max_force = max(self.max_force, float(np.max(np.abs(tick.forces))))


@dataclass
class MoveGoal(_Goal):
    """An end-effector move; ``tolerance`` [m], ``settle_timeout``, ``settle_window`` [s]."""

    tolerance: float = 1e-4
    settle_timeout: float = 5.0
    settle_window: float = 0.2
    phase: str = "moving"
    distance: float = math.nan
    settling_time: float = math.nan
    _within_since: float | None = None

    def step(self, t: float, tick: Tick) -> Outcome | None:
        """Supervise the tick at ``t`` [s]; the outcome once the goal is over."""
        if self.outcome is not None:
            return self.outcome
        self._forces(tick)
        target = self.reference.target
        self.distance = math.hypot(tick.end_effector[0] - target[0], tick.end_effector[1] - target[1])
        late = self.tau(t) - self.reference.duration
        if late < 0.0:
            return None
        self.phase = "settling"
        if self.distance <= self.tolerance:
            if self._within_since is None:
                self._within_since = t
            if t - self._within_since >= self.settle_window - 1e-9:
                self.settling_time = max(0.0, self._within_since - self.t_start - self.reference.duration)
                return self.end(Outcome(SUCCEEDED, f"D within {self.distance * 1e3:.4g} mm of the target "
                                                   f"{self.settling_time:.3g} s after the move"))
        else:
            self._within_since = None
        if late > self.settle_timeout:
            return self.end(Outcome(GOAL_TOLERANCE_VIOLATED,
                                    f"D still {self.distance * 1e3:.4g} mm from the target {self.settle_timeout:g} s "
                                    f"after the move (tolerance {self.tolerance * 1e3:g} mm)"))
        return None


@dataclass
class TrajectoryGoal(_Goal):
    """An actuator trajectory; tolerances per joint (rho1, rho2) [m, m/s], ``goal_time`` [s]."""

    path_position: tuple[float, float] = (0.0, 0.0)
    path_velocity: tuple[float, float] = (0.0, 0.0)
    goal_position: tuple[float, float] = (1e-4, 1e-4)
    goal_velocity: tuple[float, float] = (0.0, 0.0)
    goal_time: float = GOAL_TIME_TOLERANCE
    error: NDArray[np.float64] = field(default_factory=lambda: np.zeros(2))
    rate_error: NDArray[np.float64] = field(default_factory=lambda: np.zeros(2))

    def step(self, t: float, q: Sequence[float] | NDArray[np.float64], qdot: Sequence[float] | NDArray[np.float64],
             tick: Tick) -> Outcome | None:
        if self.outcome is not None:
            return self.outcome
        self._forces(tick)
        # desired - actual: control_msgs' sign (FollowJointTrajectory's feedback ``error``)
        self.error = tick.desired.q[:2] - np.asarray(q[:2], dtype=float)
        self.rate_error = tick.desired.qdot[:2] - np.asarray(qdot[:2], dtype=float)
        late = self.tau(t) - self.reference.duration
        if late < 0.0:
            for name, err, tol in (("position", self.error, _checked(self.path_position)),
                                   ("velocity", self.rate_error, _checked(self.path_velocity))):
                bad = np.abs(err) > tol
                if np.any(bad):
                    j = int(np.argmax(bad))
                    return self.end(Outcome(PATH_TOLERANCE_VIOLATED,
                                            f"rho{j + 1} {name} error {err[j]:.4g} exceeds the path tolerance "
                                            f"{tol[j]:g} at t = {self.tau(t):.3f} s of the trajectory"))
            return None
        final = self.reference.final().q[:2]
        err = np.asarray(q[:2], dtype=float) - final
        rate = np.asarray(qdot[:2], dtype=float)
        pos_tol, vel_tol = _checked(self.goal_position), _checked(self.goal_velocity)
        if np.all(np.abs(err) <= pos_tol) and np.all(np.abs(rate) <= vel_tol):
            return self.end(Outcome(SUCCEEDED, f"at the last point within ({abs(err[0]):.3g}, {abs(err[1]):.3g}) m "
                                               f"{late:.3g} s after its time"))
        if late > self.goal_time:
            j = int(np.argmax(np.abs(err) / pos_tol)) if np.any(np.isfinite(pos_tol)) else 0
            return self.end(Outcome(GOAL_TOLERANCE_VIOLATED,
                                    f"rho{j + 1} still {err[j]:.4g} m from the last point {self.goal_time:g} s after "
                                    f"its time (goal tolerance {pos_tol[j]:g} m)"))
        return None
