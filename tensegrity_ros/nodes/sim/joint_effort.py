"""Which joints of ``joint_states`` report an effort: the cable tensions a robot measures.

A robot's description lists the cables whose tension it measures (``sensors.cable_tension``,
docs/structures.md); ``joint_states`` reports what the robot measures, as a ros2_control
robot's joint_state_broadcaster does from its state interfaces, while ``cable_states`` stays
the simulator's ground truth (every member's tension). sensor_msgs/JointState holds each
array either full (one value per joint) or empty, so:

- every joint's cable measured (and every model that is not a robot): effort = tension [N];
- none measured (the 3-bar's ``cable_tension: none``): effort empty;
- some: effort full, NaN for the joints whose cable is not measured (joint_state_broadcaster's
  value for a joint without that state interface).

Plain logic, no node.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.sim.model import Model


@dataclass(frozen=True)
class JointEffort:
    """Per joint (joint order), whether its effort is measured."""

    measured: tuple[bool, ...]

    @property
    def reported(self) -> bool:
        """Whether joint_states carries an effort array at all."""
        return any(self.measured) or not self.measured

    def of(self, tensions: ArrayLike) -> NDArray[np.float64]:
        """The effort array of one joint_states from every joint's tension [N]: as they are,
        empty, or NaN where not measured (module docstring)."""
        values = np.asarray(tensions, dtype=np.float64)
        if all(self.measured):
            return values
        if not any(self.measured):
            return np.zeros(0)
        return np.where(self.measured, values, np.nan)


def joint_effort(model: Model[Any, Any], joint_names: Sequence[str]) -> JointEffort:
    """The measured efforts of ``joint_names`` (a robot's motor cables) in ``model``'s
    description; every joint of a model that is not a robot."""
    robot = getattr(model, "robot", None) if model.kind == "robot" else None
    if robot is None:
        return JointEffort((True,) * len(joint_names))
    measured = {robot.cables.names[i] for i in robot.sensors.cable_tension}
    return JointEffort(tuple(name in measured for name in joint_names))
