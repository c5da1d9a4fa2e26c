"""Frames from what the suite produces: the core's observations and ``MechanismState`` messages.

The class-2 mechanism's topology is the core's (:data:`tensegrity_core.class2.geometry.MEMBERS`:
its struts are bars, its springs strings, AB and BC actuators); a general structure's is
its scene's structure (members, kinds, rigid bodies). A series key is ``"<group>:<name>"``;
the part after the colon is the name shown in a plot's legend.
"""

from __future__ import annotations

from typing import Any, Final

import numpy as np

from tensegrity_core.class2.geometry import MEMBERS, NODE_NAMES
from tensegrity_ros.view.frame import Frame, Topology

#: Class-2 member kinds (the paper's words) as the view's kinds.
CLASS2_KINDS: Final = {"strut": "bar", "spring": "string", "actuator": "actuator"}
#: The class-2 actuators' node pairs, in actuator order (AB, BC): where a fold-limit contact acts.
CLASS2_ACTUATOR_NODES: Final = tuple(m.nodes for m in MEMBERS if m.kind == "actuator")


def class2_topology() -> Topology:
    """The class-2 mechanism: nodes A..F, members 1_AB..10_CE, node D's path drawn."""
    labels = tuple(m.label for m in MEMBERS)
    return Topology(
        kind="class2", node_names=NODE_NAMES, member_names=labels,
        members=np.array([m.nodes for m in MEMBERS]), member_kinds=tuple(CLASS2_KINDS[m.kind] for m in MEMBERS),
        end_effector=NODE_NAMES.index("D"),
        series_groups=(("actuator lengths [m]", ("q:rho1", "q:rho2")), ("strut angle beta [rad]", ("q:beta",)),
                       ("actuator forces [N]", ("f:f1", "f:f2")),
                       ("member forces [N]", tuple(f"T:{name}" for name in labels))))


def general_topology(structure: Any, end_effector: int | None, *, floor: bool) -> Topology:
    """A general structure (:class:`tensegrity_core.general.structure.Structure`); ``floor``:
    draw the plane z = 0 (scenes under gravity)."""
    names = tuple(structure.member_names)
    actuators = tuple(n for n, k in zip(names, structure.member_kinds) if k == "actuator")
    groups: list[tuple[str, tuple[str, ...]]] = []
    if end_effector is not None:
        node = structure.node_names[end_effector]
        groups.append((f"node {node} [m]", ("p:x", "p:y", "p:z")))
    groups.append(("member forces [N]", tuple(f"T:{n}" for n in names)))
    if actuators:
        groups.append(("actuator rest lengths [m]", tuple(f"u:{n}" for n in actuators)))
    groups.append(("energy [J]", ("E:potential", "E:kinetic")))
    return Topology(kind="general", node_names=tuple(structure.node_names), member_names=names,
                    members=np.asarray(structure.members), member_kinds=tuple(structure.member_kinds),
                    bodies=tuple((b.name, tuple(b.nodes)) for b in structure.bodies),
                    end_effector=end_effector, floor=floor, series_groups=tuple(groups))


def robot_topology(robot: Any) -> Topology:
    """A robot (:class:`tensegrity_core.robot.description.Robot`): its rods as bars drawn at
    their radius, end caps as nodes at the caps' radius, cables as strings, the floor. Plotted:
    cable tensions [N], the motor-driven cables' rest lengths [m], the caps' normal forces [N]
    (with a floor), the rods' axial forces [N], energies [J]."""
    rods, cables = tuple(robot.rods.names), tuple(robot.cables.names)
    members = np.vstack([np.asarray(robot.rods.ends).reshape(-1, 2), np.asarray(robot.cables.ends).reshape(-1, 2)])
    caps = tuple(robot.node_names)
    groups = [("cable tensions [N]", tuple(f"T:{n}" for n in cables)),
              ("motor rest lengths [m]", tuple(f"u:{cables[i]}" for i in robot.motors.cable))]
    if robot.floor is not None:
        groups.append(("cap normal forces [N]", tuple(f"N:{n}" for n in caps)))
    if rods:
        groups.append(("rod forces [N]", tuple(f"T:{n}" for n in rods)))
    groups.append(("energy [J]", ("E:potential", "E:kinetic")))
    return Topology(kind="robot", node_names=caps, member_names=rods + cables, members=members,
                    member_kinds=("bar",) * len(rods) + ("string",) * len(cables),
                    bodies=tuple((b.name, tuple(b.nodes)) for b in robot.bodies), floor=robot.floor is not None,
                    bar_radius=float(np.max(robot.rods.radius, initial=0.0)),
                    node_radius=float(np.max(robot.rods.cap_radius, initial=0.0)),
                    series_groups=tuple(groups))


def scene_topology(scene: Any) -> Topology:
    """The topology of a loaded scene (:class:`tensegrity_core.sim.scene.Scene`)."""
    if scene.model.kind == "class2":
        return class2_topology()
    if scene.model.kind == "robot":
        return robot_topology(scene.model.robot)
    return general_topology(scene.model.structure, scene.model.end_effector, floor="gravity" in scene.effects)


def _points(values: Any) -> np.ndarray:
    """(n, 3) [m] of ``geometry_msgs/Point``-like objects or an (n, 2|3) array (z = 0 if 2-D)."""
    if len(values) and hasattr(values[0], "x"):
        return np.array([[p.x, p.y, p.z] for p in values], dtype=float)
    a = np.asarray(values, dtype=float).reshape(len(values), -1)
    return np.hstack([a, np.zeros((len(a), 3 - a.shape[1]))]) if a.shape[1] < 3 else a[:, :3]


def class2_frame(t: float, q: Any, forces: Any, nodes: Any, member_forces: Any, contact_forces: Any,
                 run_state: str) -> Frame:
    """A class-2 frame: ``q = (rho1, rho2, beta)`` [m, m, rad], applied actuator ``forces``
    (f1, f2) [N], the six ``nodes``, the ten ``member_forces`` [N] and the fold limit's
    ``contact_forces`` (on AB, BC) [N, >= 0]; a positive contact force is drawn at the
    actuator's folded end."""
    p = _points(nodes)
    contacts = tuple((0.5 * (p[i] + p[j]), float(f))
                     for (i, j), f in zip(CLASS2_ACTUATOR_NODES, list(contact_forces)[:2]) if float(f) > 0.0)
    tension = np.asarray(member_forces, dtype=float)
    series = {"q:rho1": float(q[0]), "q:rho2": float(q[1]), "q:beta": float(q[2]),
              "f:f1": float(forces[0]), "f:f2": float(forces[1])}
    series.update({f"T:{m.label}": float(v) for m, v in zip(MEMBERS, tension)})
    return Frame(t=float(t), nodes=p, member_forces=tension, run_state=run_state, contacts=contacts, series=series)


def robot_frame(t: float, nodes: Any, member_forces: Any, rest_lengths: Any, cap_forces: Any, topology: Topology,
                run_state: str, *, energies: tuple[float, float] | None = None) -> Frame:
    """A robot's frame: cap centres ``nodes`` (n, 3) [m], ``member_forces`` [N] (rods then
    cables), the motor-driven cables' ``rest_lengths`` [m] (motor order) and each cap's floor normal force
    ``cap_forces`` [N] in node order (> 0: in contact, drawn at the cap); energies [J] when known."""
    p = _points(nodes)
    tension = np.asarray(member_forces, dtype=float)
    normal = np.asarray(cap_forces, dtype=float)
    motors = [k for _title, keys in topology.series_groups for k in keys if k.startswith("u:")]
    series = {f"T:{n}": float(v) for n, v in zip(topology.member_names, tension)}
    series.update({k: float(v) for k, v in zip(motors, rest_lengths)})
    series.update({f"N:{n}": float(v) for n, v in zip(topology.node_names, normal)})
    if energies is not None:
        series.update({"E:potential": float(energies[0]), "E:kinetic": float(energies[1])})
    contacts = tuple((p[i], float(f)) for i, f in enumerate(normal) if f > 0.0)
    return Frame(t=float(t), nodes=p, member_forces=tension, run_state=run_state, contacts=contacts, series=series)


def frame_of_mechanism_state(msg: Any, run_state: str) -> Frame:
    """A frame of a ``tensegrity_msgs/MechanismState`` (a ROS message or a message decoded
    from a bag: anything with its fields); ``t`` is the header stamp [s]."""
    stamp = msg.header.stamp
    t = int(stamp.sec) + int(stamp.nanosec) * 1e-9
    return class2_frame(t, list(msg.q), list(msg.actuator_force), msg.nodes, list(msg.member_forces),
                        list(msg.contact_force), run_state)


def _by_node(obs: Any, topology: Topology) -> np.ndarray:
    """A robot's cap normal forces [N] in node order (the core gives them in its caps' order,
    ``obs.cap_names``, which is the rods' ends, not the nodes'); none without a floor."""
    if not len(obs.cap_names):
        return np.zeros(0)
    normal = np.zeros(len(topology.node_names))
    normal[[topology.node_names.index(c) for c in obs.cap_names]] = np.asarray(obs.contact_forces, dtype=float)
    return normal


def frame_of_observation(obs: Any, topology: Topology, run_state: str) -> Frame:
    """A frame of a core :class:`~tensegrity_core.sim.simulator.Observation` of a scene of
    ``topology``."""
    if topology.kind == "class2":
        return class2_frame(obs.t, obs.q, obs.applied_forces, obs.nodes, obs.member_forces, obs.contact_forces,
                            run_state)
    nodes = _points(obs.nodes)
    tension = np.asarray(obs.member_forces, dtype=float)
    series = {f"T:{n}": float(v) for n, v in zip(topology.member_names, tension)}
    if topology.kind == "robot":
        return robot_frame(obs.t, nodes, tension, obs.applied_forces, _by_node(obs, topology), topology, run_state,
                           energies=(obs.potential_energy, obs.kinetic_energy))
    if topology.end_effector is not None:
        series.update(zip(("p:x", "p:y", "p:z"), (float(v) for v in nodes[topology.end_effector])))
    actuators = [n for n, k in zip(topology.member_names, topology.member_kinds) if k == "actuator"]
    series.update({f"u:{n}": float(v) for n, v in zip(actuators, obs.applied_forces)})
    series.update({"E:potential": float(obs.potential_energy), "E:kinetic": float(obs.kinetic_energy)})
    return Frame(t=float(obs.t), nodes=nodes, member_forces=tension, run_state=run_state, series=series)
