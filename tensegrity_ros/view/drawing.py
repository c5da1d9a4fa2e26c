"""The 3D scene of one structure in a viser server: created once from a :class:`Topology`,
moved by :meth:`StructureDrawing.show` for every :class:`Frame`.

Bars and actuators are cylinders (one batched mesh of instances: a frame is one message
for all of them); strings are lines coloured by tension (:mod:`.colors`), slack ones thin and
grey; nodes are points; rigid bodies translucent hulls of their nodes, each sent once and moved by
the body's pose (:mod:`.hulls`); fold-limit or floor
contacts red points; the end effector's path a green trail; the floor a grid at z = 0.
Lines (strings, the trail, the floor's grid) have a width in screen pixels; other sizes scale with the
structure's extent at its first frame, except a robot's rods and end
caps, drawn at their radii (a rod with its caps: a capsule). A floor contact also shows its
normal force as a red vertical line up from the cap (unlit, as the strings: a lit cylinder
standing upright is shaded nearly black under the view's lights), its height ``CONTACT_HEIGHT``
times the structure's extent for the largest normal force seen so far.
"""

from __future__ import annotations

from collections import deque
from typing import Any, Final

import numpy as np

from tensegrity_ros.view import colors
from tensegrity_ros.view.frame import Frame, Topology
from tensegrity_ros.view.geometry import grid_lines, segment_poses, unit_cylinder
from tensegrity_ros.view.hulls import hull_groups

#: Points kept on the end effector's trail (at the view's frame rate: ~20 s at 30 fps).
TRAIL_POINTS: Final = 600
#: Height of the largest floor normal force's line, as a fraction of the structure's extent.
CONTACT_HEIGHT: Final = 0.5
#: The floor's grid: its width as a multiple of the structure's extent, cells across it, a
#: section line every this many cells.
GRID_WIDTH: Final = 4.0
GRID_CELLS: Final = 20
GRID_SECTION: Final = 5
#: Width of a taut string's line and of a slack one [screen pixels].
STRING_PX: Final = 3.0
SLACK_PX: Final = 1.0
#: Width [screen px] of a floor contact's normal-force line.
NORMAL_PX: Final = 4.0
_NO_SEGMENT: Final = np.zeros((1, 2, 3), dtype=np.float32)


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
        self.radius = topology.bar_radius or 0.012 * self.size
        self.node_size = 2 * topology.node_radius or 2.2 * self.radius
        self.force_scale = colors.TensionScale(1e-6)     # the largest floor normal force so far [N]
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
            # lines, not viser's grid (a plane whose shader draws the lines at every pixel it
            # covers: on software WebGL it halved the frame rate of a 1280 x 720 page)
            lines, section = grid_lines(0.5 * GRID_WIDTH * self.size, GRID_CELLS, GRID_SECTION)
            rgb = np.where(section[:, None], colors.GRID_SECTION, colors.GRID_CELL).astype(np.uint8)
            sc.add_line_segments("/floor", lines, np.repeat(rgb[:, None, :], 2, axis=1), thickness=SLACK_PX,
                                 thickness_units="screen")
        vertices, faces = unit_cylinder(16)
        if len(self.cylinders):
            pos, wxyz, scales = self._cylinder_poses(first.nodes)
            self.bars = sc.add_batched_meshes_simple(
                "/structure/bars", vertices=vertices, faces=faces, batched_wxyzs=wxyz,
                batched_positions=pos, batched_scales=scales, batched_colors=self._cylinder_colors,
                lod="off", cast_shadow=False, receive_shadow=False)
        # strings in screen pixels: a line of world width is drawn twice (an antialiasing
        # fringe over its core), which cost a page on software WebGL about a third of its frames
        self.taut = sc.add_line_segments("/structure/strings", _NO_SEGMENT, colors.SLACK,
                                         thickness=STRING_PX, thickness_units="screen")
        self.slack = sc.add_line_segments("/structure/slack", _NO_SEGMENT, colors.SLACK,
                                          thickness=SLACK_PX, thickness_units="screen")
        self.nodes = sc.add_point_cloud("/structure/nodes", first.nodes.astype(np.float32), colors.NODE,
                                        point_size=self.node_size, point_shape="circle")
        self.contacts = sc.add_point_cloud("/structure/contacts", np.zeros((1, 3), np.float32), colors.CONTACT,
                                           point_size=max(5 * self.radius, 1.2 * self.node_size),
                                           point_shape="circle", visible=False)
        if self.topology.floor:
            self.normals = sc.add_line_segments("/structure/normal_forces", _NO_SEGMENT, colors.CONTACT,
                                                thickness=NORMAL_PX, thickness_units="screen", visible=False)
        # bodies of three nodes or more (a rod's two nodes span no hull: its cylinder draws
        # it) as hulls sent once in their body frames and moved by their poses: no vertices
        # re-sent a frame, one instanced mesh per shape (docs/design/view.md)
        self._hulls = hull_groups([idx for _, idx in self.topology.bodies if len(idx) >= 3], first.nodes, self.size)
        self.bodies = []
        for i, group in enumerate(self._hulls):
            pos, wxyz = group.poses(first.nodes)
            self.bodies.append(sc.add_batched_meshes_simple(
                f"/structure/bodies/{i}", vertices=group.template.astype(np.float32), faces=group.faces,
                batched_wxyzs=wxyz, batched_positions=pos, batched_colors=colors.BODY, opacity=0.35, side="double",
                lod="off", cast_shadow=False, receive_shadow=False))
        self.path = sc.add_line_segments("/structure/path", _NO_SEGMENT, colors.PATH, thickness=SLACK_PX * 2,
                                         thickness_units="screen", visible=False)
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
        if self.topology.floor:
            self._show_normals(frame.contacts)
        for group, handle in zip(self._hulls, self.bodies):
            handle.batched_positions, handle.batched_wxyzs = group.poses(nodes)
        if self.topology.end_effector is not None:
            self._trail.append(nodes[self.topology.end_effector].astype(np.float32))
            if len(self._trail) > 1:
                trail = np.asarray(self._trail)
                self.path.points = np.stack([trail[:-1], trail[1:]], axis=1)
                self.path.visible = True

    def _show_normals(self, contacts: tuple[tuple[np.ndarray, float], ...]) -> None:
        """Each floor contact's normal force as a vertical red line up from the top of its cap."""
        if contacts:
            forces = np.array([f for _, f in contacts])
            scale = self.force_scale.update(forces)
            base = np.array([p for p, _ in contacts], dtype=float)
            base[:, 2] += 0.5 * self.node_size          # from the top of the cap, not hidden in it
            top = base.copy()
            top[:, 2] += CONTACT_HEIGHT * self.size * forces / scale
            self.normals.points = np.stack([base, top], axis=1).astype(np.float32)
        self.normals.visible = bool(contacts)

    def legend(self) -> str:
        """The legend's HTML for what this drawing shows, with the tension scale so far."""
        topo = self.topology
        return colors.legend_html(self.scale.value, bars=self._bar_label(), actuators=bool(len(topo.of_kind("actuator"))),
                                  strings=bool(len(self.strings)),
                                  bodies=bool(topo.bodies), contacts=True, path=topo.end_effector is not None,
                                  normal_force=(CONTACT_HEIGHT * self.size, self.force_scale.value) if topo.floor else None)

    def _bar_label(self) -> str:
        """The legend's words for the bars ("" without any)."""
        if not len(self.topology.of_kind("bar")):
            return ""
        return "rod (cylinder), end caps (spheres)" if self.topology.kind == "robot" else "bar (cylinder)"

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
