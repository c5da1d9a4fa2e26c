"""Which values of ``joint_states`` a robot measures: its cables' lengths and tensions.

A robot's description lists the cables whose length and whose tension it measures
(``sensors.cable_length``, ``sensors.cable_tension``, docs/structures.md); ``joint_states``
reports what the robot measures, as a ros2_control robot's joint_state_broadcaster reports
its state interfaces, while ``cable_states`` stays the simulator's ground truth (every
member's length, rate and tension). A joint is a motor cable, so every motor cable is a
joint (the joints a command names), measured or not:

- position = length [m] and velocity = its rate [m/s] where the cable's length is measured
  (an encoder on the reel gives both); effort = tension [N] where its tension is;
- per array, sensor_msgs/JointState holds it full (one value per joint) or empty: every
  joint's cable measured (and every model that is not a robot): the values; none measured
  (the 3-bar's ``cable_tension: none``): empty; some: full, NaN for the joints whose cable
  is not measured (joint_state_broadcaster's value for a joint without that state
  interface).

Plain logic, no node.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.sim.model import Model


@dataclass(frozen=True)
class Measured:
    """Per joint (joint order), whether one quantity of it is measured."""

    measured: tuple[bool, ...]

    @property
    def reported(self) -> bool:
        """Whether joint_states carries this quantity's array at all."""
        return any(self.measured) or not self.measured

    def of(self, values: ArrayLike) -> NDArray[np.float64]:
        """This quantity's array in one joint_states from every joint's value: as they
        are, empty, or NaN where not measured (module docstring)."""
        out = np.asarray(values, dtype=np.float64)
        if all(self.measured):
            return out
        if not any(self.measured):
            return np.zeros(0)
        return np.where(self.measured, out, np.nan)


@dataclass(frozen=True)
class JointSensors:
    """What a model's joint_states report: ``length`` (position and velocity) and
    ``tension`` (effort)."""

    length: Measured
    tension: Measured

    @cached_property
    def everything(self) -> bool:
        """Every quantity of every joint measured (joint_states carries the values as they are;
        asked at every publication, computed once)."""
        return all(self.length.measured) and all(self.tension.measured)


def joint_sensors(model: Model[Any, Any], joint_names: Sequence[str]) -> JointSensors:
    """What the description of ``model`` (a robot) measures of ``joint_names`` (its motor
    cables); everything for a model that is not a robot."""
    robot = getattr(model, "robot", None) if model.kind == "robot" else None
    if robot is None:
        every = Measured((True,) * len(joint_names))
        return JointSensors(every, every)

    def of(cables: Sequence[int]) -> Measured:
        names = {robot.cables.names[i] for i in cables}
        return Measured(tuple(name in names for name in joint_names))

    return JointSensors(of(robot.sensors.cable_length), of(robot.sensors.cable_tension))
