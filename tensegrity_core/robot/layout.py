"""The coordinates of a robot: which nodes move with which rigid body, which are free.

A robot's rods are rigid bodies of their two end caps; its description's other rigid
bodies are bodies of their nodes; every other node is free (on its unpinned axes) or
fixed. :func:`robot_layout` numbers them as the dynamics do (the rods first);
:func:`bodies_layout` numbers the description's own bodies alone, as the statics and the
MJCF export see them (a rod there is a bar or a capsule body of its own).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from tensegrity_core.general.dofs import DofLayout
from tensegrity_core.general.structure import RigidBody
from tensegrity_core.robot.description import Robot


class _Bodies:
    """What :class:`~tensegrity_core.general.dofs.DofLayout` reads of a robot: its nodes and
    the rigid bodies given (the rods among them, two nodes each, or not)."""

    def __init__(self, robot: Robot, bodies: Sequence[RigidBody]):
        self.n_nodes = robot.n_nodes
        self.node_names = robot.node_names
        self.nodes = np.asarray(robot.nodes, dtype=float)
        self.pinned = np.asarray(robot.pinned, dtype=bool)
        self.members = np.asarray(robot.cables.ends, dtype=np.int64)
        self.bodies = tuple(bodies)
        self.layout = DofLayout(self)


def robot_layout(robot: Robot) -> DofLayout:
    """The coordinates of a robot: per rod and per moving rigid body its centre and rotation
    vector, the free coordinates of the other nodes (numbering of :class:`DofLayout`; the
    rods come first, in the description's order, then its other bodies)."""
    rods = [RigidBody(name, (int(a), int(b)), float(m)) for name, (a, b), m in
            zip(robot.rods.names, robot.rods.ends.tolist(), robot.rods.mass.tolist())]
    return _Bodies(robot, rods + list(robot.bodies)).layout


def bodies_layout(robot: Robot) -> DofLayout:
    """The layout of the description's own rigid bodies alone (rods not among them: their
    caps are free nodes here)."""
    return _Bodies(robot, robot.bodies).layout
