"""Rigid bodies drawn as hulls of their nodes, moved by their poses: a hull's vertices are sent
to the page once, in the body's frame, and each frame moves it by one pose per body.

Bodies of the same shape (congruent node sets, node for node: a spine's vertebrae) share one
mesh drawn once per body (:class:`HullGroup`: one instanced draw, two small updates a frame
for all of them). A body's frame: origin at the mean of its nodes, axes those of the group's
first body as first drawn. A body's pose in a frame is the rigid motion that carries the
group's template onto its nodes (:func:`.geometry.rigid_poses`; exact for a rigid body, whose
nodes keep their distances).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull, QhullError
from scipy.spatial.transform import Rotation

from tensegrity_ros.view.geometry import rigid_poses

#: Two bodies share a mesh when one's nodes lie within this fraction of the structure's
#: extent of the other's moved onto them (far below a pixel).
SAME_SHAPE: Final = 1e-6


@dataclass(frozen=True, eq=False)
class HullGroup:
    """Bodies of one shape: ``template`` (k, 3) [m] their nodes in the body frame (centred at
    their mean), ``faces`` (f, 3) the template's hull, ``nodes`` (b, k) each body's node
    indices in the template's order."""

    template: NDArray[np.float64]
    faces: NDArray[np.uint32]
    nodes: NDArray[np.int64]

    def poses(self, positions: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Each body's position (b, 3) [m] and orientation ``(w, x, y, z)`` (b, 4) for the
        structure's node ``positions`` (n, 3) [m]."""
        return rigid_poses(self.template, positions[self.nodes])


def hull_faces(points: NDArray[np.float64]) -> NDArray[np.uint32]:
    """Triangles (f, 3) over ``points``: their convex hull, or a fan where they are coplanar."""
    try:
        return np.asarray(ConvexHull(points).simplices, dtype=np.uint32)
    except (QhullError, ValueError):
        n = len(points)
        return np.array([(0, i, i + 1) for i in range(1, n - 1)], dtype=np.uint32).reshape(-1, 3)


def hull_groups(bodies: Sequence[Sequence[int]], positions: NDArray[np.float64], size: float) -> list[HullGroup]:
    """The bodies (node indices each, 3 or more) grouped by shape at the node ``positions``
    (n, 3) [m] of a structure of extent ``size`` [m] (the module docstring), in order of their
    first body."""
    groups: list[tuple[NDArray[np.float64], list[Sequence[int]]]] = []
    for body in bodies:
        points = positions[list(body)]
        for template, members in groups:
            if len(template) == len(points):
                centre, wxyz = rigid_poses(template, points[None])
                moved = centre[0] + Rotation.from_quat(wxyz[0], scalar_first=True).apply(template)
                if np.abs(moved - points).max() <= SAME_SHAPE * size:
                    members.append(body)
                    break
        else:
            groups.append((points - points.mean(axis=0), [body]))
    return [HullGroup(template, hull_faces(template), np.array(members, dtype=np.int64).reshape(len(members), -1))
            for template, members in groups]
