"""Frames of a general structure or a robot from the simulator's messages: the drawing's nodes
moved by ``body_states`` (or read from ``markers``), tensions and rest lengths from
``cable_states``, cap contacts from ``contacts`` (docs/ros.md).

The messages name members and bodies but carry no topology: which nodes a member joins, where
a node sits on its body. That comes from the scene the suite simulates (its name: the
simulator's ``scene`` parameter, a bag's ``--scene`` or its metadata). A body's frame has its
origin at the mean of its nodes and the world's axes in the scene's drawing, so a node ``i``
on a body at pose ``(p, q)`` is at ``p + R(q) (X_i - C)`` [m], with ``X_i`` its drawn position
and ``C`` the drawn centre of the body's nodes. Nodes on no moving body (a fixed body's, a
pinned one) stay where the scene draws them; a structure with free nodes (joints that are not
on a rigid body) takes every node from the ``markers`` topic's ``nodes`` list instead, which
names every node in the structure's order.

Messages are anything with the ROS fields: a live message or one decoded from a bag.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from tensegrity_core.errors import TensegrityError
from tensegrity_core.sim import load_scene
from tensegrity_ros.view.frame import Frame, Topology
from tensegrity_ros.view.frames import scene_topology

#: The ``markers`` namespace whose SPHERE_LIST holds every node of a general structure.
NODES_MARKER: Final = "nodes"


class TopologyMismatch(TensegrityError):
    """The messages name members or bodies that the scene does not have (a one-line reason)."""


def _floats(values: Any) -> NDArray[np.float64]:
    return np.asarray(list(values), dtype=float)


class StructureMessages:
    """The frames of a suite (or its bag) simulating the general structure or robot ``scene``
    (a shipped scene's name or a scene file); ``topology`` is what the view draws."""

    def __init__(self, scene: str):
        self.scene = load_scene(scene)
        model = self.scene.model
        if model.kind == "class2":
            raise TopologyMismatch(f"scene {self.scene.name!r} is the class-2 mechanism: its states are "
                                   "mechanism_state messages, not cable_states")
        drawn = scene_topology(self.scene)        # the messages carry no energies: no energy plot
        self.topology: Topology = replace(drawn, series_groups=tuple(g for g in drawn.series_groups
                                                                     if not g[1][0].startswith("E:")))
        described = model.robot if model.kind == "robot" else model.structure
        self.drawn = np.asarray(described.nodes, dtype=float).reshape(-1, 3)
        members: dict[str, tuple[int, ...]] = {}
        if model.kind == "robot":
            members = {n: tuple(int(i) for i in ends) for n, ends in zip(model.robot.rods.names, model.robot.rods.ends)}
        members.update({b.name: tuple(b.nodes) for b in described.bodies if not b.fixed})
        #: per moving body: its node indices and their offsets from its centre in the drawing [m]
        self.bodies = {name: (list(idx), self.drawn[list(idx)] - self.drawn[list(idx)].mean(axis=0))
                       for name, idx in members.items()}
        on_body = {i for idx in members.values() for i in idx}
        on_body |= {i for b in described.bodies if b.fixed for i in b.nodes}
        pinned = np.asarray(described.pinned, dtype=bool).reshape(len(self.drawn), -1)
        free = [i for i in range(len(self.drawn)) if i not in on_body and not pinned[i].all()]
        #: nodes come from the ``markers`` (free nodes) or from ``body_states``
        self.nodes_topic = "markers" if free else "body_states"
        #: the plotted rest lengths (a robot's motor cables, a structure's actuators) by member name
        self._rest = [k.partition(":")[2] for _title, keys in self.topology.series_groups for k in keys
                      if k.startswith("u:")]

    # -- checks --------------------------------------------------------------------------
    def check_members(self, names: Any) -> None:
        """:class:`TopologyMismatch` unless ``cable_states`` names the scene's members in order."""
        if tuple(names) != self.topology.member_names:
            extra = sorted(set(names) - set(self.topology.member_names))
            missing = sorted(set(self.topology.member_names) - set(names))
            raise TopologyMismatch(
                f"the states name members the scene {self.scene.name!r} does not have in that order "
                f"(not in the scene: {', '.join(extra[:3]) or 'none'}; missing: {', '.join(missing[:3]) or 'none'}): "
                "give the scene the suite simulated (--scene NAME)")

    def check_bodies(self, names: Any) -> None:
        """:class:`TopologyMismatch` unless every body ``body_states`` names is a moving body of the scene."""
        unknown = [n for n in names if n not in self.bodies]
        if unknown:
            raise TopologyMismatch(f"body_states names bodies the scene {self.scene.name!r} does not have "
                                   f"({', '.join(unknown[:3])}): give the scene the suite simulated (--scene NAME)")

    # -- nodes ---------------------------------------------------------------------------
    def nodes_of_bodies(self, msg: Any) -> NDArray[np.float64]:
        """(n, 3) [m]: the drawing's nodes, each moving body's moved to its pose in ``msg``
        (``tensegrity_msgs/RigidBodyStates``)."""
        nodes = self.drawn.copy()
        names, poses = list(msg.name), list(msg.pose)
        n = min(len(names), len(poses))
        if n == 0:
            return nodes
        # one rotation per moved node, all applied in one call (a call per body cost the
        # view's bag thread a fifth of its time per frame)
        poses = poses[:n]
        placed = [self.bodies[name] for name in names[:n]]
        of_node = np.repeat(np.arange(len(placed)), [len(idx) for idx, _ in placed])
        q = np.array([(p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w) for p in poses])
        c = np.array([(p.position.x, p.position.y, p.position.z) for p in poses])
        offsets = np.vstack([off for _, off in placed])
        nodes[np.concatenate([idx for idx, _ in placed])] = Rotation.from_quat(q[of_node]).apply(offsets) + c[of_node]
        return nodes

    def nodes_of_markers(self, msg: Any) -> NDArray[np.float64] | None:
        """(n, 3) [m] from the ``nodes`` marker of a ``visualization_msgs/MarkerArray``, or
        None if it has none (or not one point per node)."""
        for marker in msg.markers:
            if marker.ns == NODES_MARKER and len(marker.points) == len(self.drawn):
                return np.array([[p.x, p.y, p.z] for p in marker.points], dtype=float)
        return None

    # -- frames --------------------------------------------------------------------------
    def frame(self, t: float, nodes: NDArray[np.float64], states: Any, contacts: Any, run_state: str) -> Frame:
        """The frame at ``t`` [s] of ``nodes`` (n, 3) [m], the latest ``cable_states``
        (``tensegrity_msgs/CableStates``: tensions [N], rest lengths [m]; None before the first)
        and ``contacts`` (``tensegrity_msgs/CapContacts``; None without)."""
        return structure_frame(self.topology, self._rest, t, nodes, states, contacts, run_state)


def structure_frame(topo: Topology, rest_names: Any, t: float, nodes: NDArray[np.float64], states: Any,
                    contacts: Any, run_state: str) -> Frame:
    """The frame at ``t`` [s] of a structure of ``topo``: ``nodes`` (n, 3) [m], the latest
    ``cable_states`` (tensions [N], rest lengths [m] of which the members ``rest_names`` are
    plotted; None before the first) and ``contacts`` (``tensegrity_msgs/CapContacts``; None without)."""
    m = len(topo.member_names)
    tension = _floats(states.tension) if states is not None else np.zeros(m)
    rest = _floats(states.rest_length) if states is not None else np.full(m, np.nan)
    series = {f"T:{n}": float(v) for n, v in zip(topo.member_names, tension)}
    index = {n: i for i, n in enumerate(topo.member_names)}
    series.update({f"u:{n}": float(rest[index[n]]) for n in rest_names})
    found: list[tuple[NDArray[np.float64], float]] = []
    if contacts is not None:
        forces = dict(zip(contacts.name, (float(f) for f in contacts.normal_force)))
        series.update({f"N:{n}": forces.get(n, 0.0) for n in topo.node_names})
        found = [(np.array([p.x, p.y, p.z], dtype=float), float(f))
                 for p, f in zip(contacts.position, contacts.normal_force) if f > 0.0]
    if topo.end_effector is not None:
        series.update(zip(("p:x", "p:y", "p:z"), (float(v) for v in nodes[topo.end_effector])))
    return Frame(t=float(t), nodes=nodes, member_forces=tension, run_state=run_state, contacts=tuple(found),
                 series=series)


def stamp_seconds(msg: Any) -> float:
    """A message's header stamp [s]; a ``MarkerArray``'s is its first marker's (NaN without one)."""
    if hasattr(msg, "markers"):
        if not msg.markers:
            return math.nan
        msg = msg.markers[0]
    return int(msg.header.stamp.sec) + int(msg.header.stamp.nanosec) * 1e-9
