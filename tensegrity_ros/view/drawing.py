"""The 3D scene of one structure in a viser server: created once from a :class:`Topology`,
moved by :meth:`StructureDrawing.show` for every :class:`Frame`.

Bars and actuators are cylinders (one batched mesh of instances: a frame is one message
for all of them); strings are lines coloured by tension (:mod:`.colors`), slack ones thin and
grey; nodes are points; rigid bodies translucent hulls of their nodes; fold-limit or floor
contacts red points; the end effector's path a green trail; the floor a grid at z = 0.
Sizes scale with the structure's extent at its first frame.
"""

from __future__ import annotations

from collections import deque
from typing import Any, Final

import numpy as np
import trimesh
from scipy.spatial import ConvexHull, QhullError

from tensegrity_ros.view import colors
from tensegrity_ros.view.frame import Frame, Topology
from tensegrity_ros.view.geometry import segment_poses

#: Points kept on the end effector's trail (at the view's frame rate: ~20 s at 30 fps).
TRAIL_POINTS: Final = 600
_NO_SEGMENT: Final = np.zeros((1, 2, 3), dtype=np.float32)


def _hull_faces(points: np.ndarray) -> np.ndarray:
    """Triangles (k, 3) over ``points``: their convex hull, or a fan where they are coplanar."""
    try:
        return np.asarray(ConvexHull(points).simplices, dtype=np.uint32)
    except (QhullError, ValueError):
        n = len(points)
        return np.array([(0, i, i + 1) for i in range(1, n - 1)], dtype=np.uint32)


class StructureDrawing:
    """The drawn structure (see the module docstring); ``scene`` is a viser ``SceneApi``;
    ``tension_scale`` [N] the top of the strings' colour scale if known (it still grows with
    a larger tension)."""

    def __init__(self, scene: Any, topology: Topology, first: Frame, *, tension_scale: float = 0.0):
        self.scene = scene
        self.topology = topology
        self.scale = colors.TensionScale(max(tension_scale, 1e-6))
        extent = float(np.ptp(first.nodes, axis=0).max()) if len(first.nodes) else 1.0
        self.size = max(extent, 1e-3)
        self.radius = 0.012 * self.size
        self.cylinders = topology.of_kind("bar", "actuator")
        self.strings = topology.of_kind("string")
        kinds = [topology.member_kinds[i] for i in self.cylinders]
        self._cylinder_colors = np.array([colors.ACTUATOR if k == "actuator" else colors.BAR for k in kinds],
                                         dtype=np.uint8).reshape(-1, 3)
        self._trail: deque[np.ndarray] = deque(maxlen=TRAIL_POINTS)
        self._make(first)

    def _make(self, first: Frame) -> None:
        sc = self.scene
        if self.topology.floor:
            sc.add_grid("/floor", width=4 * self.size, height=4 * self.size, plane="xy",
                        cell_size=self.size / 10, section_size=self.size / 2)
        if len(self.cylinders):
            mesh = trimesh.creation.cylinder(radius=1.0, height=1.0, sections=16)
            pos, wxyz, scales = self._cylinder_poses(first.nodes)
            self.bars = sc.add_batched_meshes_simple(
                "/structure/bars", vertices=mesh.vertices, faces=mesh.faces, batched_wxyzs=wxyz,
                batched_positions=pos, batched_scales=scales, batched_colors=self._cylinder_colors,
                lod="off", cast_shadow=False, receive_shadow=False)
        thick = 0.6 * self.radius
        self.taut = sc.add_line_segments("/structure/strings", _NO_SEGMENT, colors.SLACK, thickness=thick)
        self.slack = sc.add_line_segments("/structure/slack", _NO_SEGMENT, colors.SLACK, thickness=thick / 3)
        self.nodes = sc.add_point_cloud("/structure/nodes", first.nodes.astype(np.float32), colors.NODE,
                                        point_size=2.2 * self.radius, point_shape="circle")
        self.contacts = sc.add_point_cloud("/structure/contacts", np.zeros((1, 3), np.float32), colors.CONTACT,
                                           point_size=5 * self.radius, point_shape="circle", visible=False)
        self.bodies = []
        for name, idx in self.topology.bodies:
            faces = _hull_faces(first.nodes[list(idx)])
            handle = sc.add_mesh_simple(f"/structure/bodies/{name}", first.nodes[list(idx)].astype(np.float32),
                                        faces, color=colors.BODY, opacity=0.35, side="double",
                                        cast_shadow=False, receive_shadow=False)
            self.bodies.append((handle, list(idx)))
        self.path = sc.add_line_segments("/structure/path", _NO_SEGMENT, colors.PATH, thickness=self.radius / 3,
                                         visible=False)
        self.show(first)

    def _cylinder_poses(self, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        ends = self.topology.members[self.cylinders]
        mid, wxyz, lengths = segment_poses(nodes[ends[:, 0]], nodes[ends[:, 1]])
        scales = np.stack([np.full(len(lengths), self.radius), np.full(len(lengths), self.radius), lengths], axis=1)
        return mid, wxyz, scales

    def show(self, frame: Frame) -> None:
        """Move the drawing to ``frame`` (call with the server's ``atomic()`` held to update
        all parts in one message batch)."""
        nodes = frame.nodes
        if len(self.cylinders):
            pos, wxyz, scales = self._cylinder_poses(nodes)
            self.bars.batched_positions = pos
            self.bars.batched_wxyzs = wxyz
            self.bars.batched_scales = scales
        if len(self.strings):
            ends = self.topology.members[self.strings]
            tension = frame.member_forces[self.strings]
            scale = self.scale.update(tension)
            segments = np.stack([nodes[ends[:, 0]], nodes[ends[:, 1]]], axis=1).astype(np.float32)
            rgb = colors.tension_colors(tension, scale)
            taut = tension > 0.0
            self._set_lines(self.taut, segments[taut], rgb[taut])
            self._set_lines(self.slack, segments[~taut], rgb[~taut])
        self.nodes.points = nodes.astype(np.float32)
        if frame.contacts:
            self.contacts.points = np.array([p for p, _ in frame.contacts], dtype=np.float32)
        self.contacts.visible = bool(frame.contacts)
        for handle, idx in self.bodies:
            handle.vertices = nodes[idx].astype(np.float32)
        if self.topology.end_effector is not None:
            self._trail.append(nodes[self.topology.end_effector].astype(np.float32))
            if len(self._trail) > 1:
                trail = np.asarray(self._trail)
                self.path.points = np.stack([trail[:-1], trail[1:]], axis=1)
                self.path.visible = True

    def legend(self) -> str:
        """The legend's HTML for what this drawing shows, with the tension scale so far."""
        topo = self.topology
        return colors.legend_html(self.scale.value, cylinders=bool(len(self.cylinders)), strings=bool(len(self.strings)),
                                  bodies=bool(topo.bodies), contacts=True, path=topo.end_effector is not None)

    def clear_trail(self) -> None:
        """Forget the end effector's path (after a reset or a jump on a bag's timeline)."""
        self._trail.clear()
        self.path.visible = False

    @staticmethod
    def _set_lines(handle: Any, segments: np.ndarray, rgb: np.ndarray) -> None:
        if len(segments):
            handle.points = segments
            handle.colors = np.repeat(rgb[:, None, :], 2, axis=1)
        handle.visible = bool(len(segments))
