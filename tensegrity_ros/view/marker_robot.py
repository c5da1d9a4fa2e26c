"""A robot drawn from its own ``markers``, for a bag that does not say which scene it was
recorded from (no ``custom_data``, or one that cannot be read) and no ``--scene``.

The simulator's robot markers (``tensegrity_ros/nodes/sim/robot_messages.py``) draw every rod
(namespace ``rods``) and every cable (``cables``) as one segment of a ``LINE_LIST``, from one
cap centre to the other, in member order: the order ``cable_states`` names them, rods
first. So the caps are the distinct end points of the first such message, the members the
pairs of caps their segments join, and every later message places the caps (each cap at
the first point that named it). A ``floor`` marker means the robot has a floor (z = 0).

What the markers do not say, and the drawing therefore leaves out: the caps' names (caps
are named ``cap 1``, ``cap 2``, ... in the order they first appear) and radii, the rods'
radius (both drawn at sizes of the robot's extent), which cables are motor-driven (no
rest-length plot) and each cap's normal force by name (contacts are still drawn, from the
``contacts`` topic's positions). The timeline is the ``markers`` topic's, usually recorded
less often than ``body_states``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.errors import TensegrityError
from tensegrity_ros.view.frame import Frame, Topology
from tensegrity_ros.view.structure_frames import structure_frame

#: The ``markers`` namespaces of a robot's rods and cables (member order within each).
RODS: Final = "rods"
CABLES: Final = "cables"
FLOOR: Final = "floor"


class NotDrawable(TensegrityError):
    """The markers do not draw a robot (a one-line reason)."""


def _segments(msg: Any, ns: str) -> NDArray[np.float64] | None:
    """(k, 2, 3) [m]: the segments of the ``LINE_LIST`` marker ``ns`` of ``msg``, None without one."""
    for marker in msg.markers:
        if marker.ns == ns and len(marker.points) % 2 == 0:
            return np.array([[p.x, p.y, p.z] for p in marker.points], dtype=float).reshape(-1, 2, 3)
    return None


class MarkerRobot:
    """The robot the ``MarkerArray`` ``first`` draws, its members named ``member_names``
    (``cable_states``' names: rods, then cables); :class:`NotDrawable` if it draws none."""

    nodes_topic: Final = "markers"

    def __init__(self, first: Any, member_names: Sequence[str]):
        rods, cables = _segments(first, RODS), _segments(first, CABLES)
        if rods is None or cables is None:
            raise NotDrawable("its markers draw no robot (no 'rods' and 'cables' line lists)")
        names = tuple(member_names)
        if len(names) != len(rods) + len(cables):
            raise NotDrawable(f"its markers draw {len(rods)} rods and {len(cables)} cables, its cable_states "
                              f"name {len(names)} members")
        points = np.vstack([rods.reshape(-1, 3), cables.reshape(-1, 3)])
        #: per point of the rods' then the cables' segments: its cap
        self.cap_of_point = np.zeros(len(points), dtype=np.int64)
        firsts: list[int] = []                                      # per cap: the first point naming it
        for k, p in enumerate(points):
            same = [c for c, i in enumerate(firsts) if np.array_equal(points[i], p)]
            if not same:
                firsts.append(k)
            self.cap_of_point[k] = same[0] if same else len(firsts) - 1
        self.first_points = np.array(firsts, dtype=np.int64)
        self.n_points = len(points)
        n_rods = len(rods)
        members = self.cap_of_point.reshape(-1, 2)
        caps = tuple(f"cap {i + 1}" for i in range(len(firsts)))
        groups = [("cable tensions [N]", tuple(f"T:{n}" for n in names[n_rods:]))]
        if n_rods:
            groups.append(("rod forces [N]", tuple(f"T:{n}" for n in names[:n_rods])))
        self.topology = Topology(kind="robot", node_names=caps, member_names=names, members=members,
                                 member_kinds=("bar",) * n_rods + ("string",) * len(cables),
                                 floor=any(m.ns == FLOOR for m in first.markers), series_groups=tuple(groups))
        self.label = "drawn from its markers"

    def check_members(self, names: Any) -> None:
        """:class:`NotDrawable` unless ``cable_states`` names the members the markers draw."""
        if tuple(names) != self.topology.member_names:
            raise NotDrawable("its cable_states name other members than its markers draw")

    def check_bodies(self, names: Any) -> None:
        """Nothing to check: the caps come from the markers."""

    def nodes_of_markers(self, msg: Any) -> NDArray[np.float64] | None:
        """(n, 3) [m]: the caps where ``msg`` draws them, None if it draws another robot."""
        rods, cables = _segments(msg, RODS), _segments(msg, CABLES)
        if rods is None or cables is None:
            return None
        points = np.vstack([rods.reshape(-1, 3), cables.reshape(-1, 3)])
        if len(points) != self.n_points:
            return None
        return points[self.first_points]

    def frame(self, t: float, nodes: NDArray[np.float64], states: Any, contacts: Any, run_state: str) -> Frame:
        """The frame at ``t`` [s] (as :meth:`.StructureMessages.frame`)."""
        return structure_frame(self.topology, (), t, nodes, states, contacts, run_state)
