"""A running general structure or robot over ROS 2: its state topics in, cable commands out.

Subscribes, on the view's node, to the simulator's ``cable_states``
(``tensegrity_msgs/CableStates``), ``contacts`` (``tensegrity_msgs/CapContacts``, robots
with a floor) and the topic that places the nodes, ``body_states``
(``tensegrity_msgs/RigidBodyStates``) or, for a structure with free nodes, ``markers``
(:mod:`.structure_frames`); a frame goes out for every message of that topic, with the
latest tensions and contacts. The page's sliders set the rest lengths [m] of the motors that
take rest-length commands, published as ``cable_commands`` (``tensegrity_msgs/CableCommand``,
by cable name) at the caller's rate.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from tensegrity_ros.view.frame import Frame
from tensegrity_ros.view.inputs import InputSpec, command_input
from tensegrity_ros.view.structure_frames import StructureMessages, TopologyMismatch, stamp_seconds


class StructureLink:
    """The topics of ``structure`` on ``node``; ``sink`` takes each frame, ``run_state()`` names
    the simulator's run state; ``error`` holds a mismatch between the messages and the scene."""

    def __init__(self, node: Any, structure: StructureMessages, sink: Callable[[Frame], None],
                 run_state: Callable[[], str]):
        from rclpy.qos import QoSProfile
        from tensegrity_msgs.msg import CableCommand, CableStates, CapContacts, RigidBodyStates
        from visualization_msgs.msg import MarkerArray

        from tensegrity_core.sim import compile_scene

        self.structure = structure
        self.interface = compile_scene(structure.scene).interface
        self._sink = sink
        self._run_state = run_state
        self._lock = threading.Lock()
        self._cables: Any = None
        self._contacts: Any = None
        self.error: TopologyMismatch | None = None
        qos = QoSProfile(depth=10)
        node.create_subscription(CableStates, "cable_states", self._on_cables, qos)
        if structure.topology.floor and structure.topology.kind == "robot":
            node.create_subscription(CapContacts, "contacts", self._on_contacts, qos)
        if structure.nodes_topic == "body_states":
            node.create_subscription(RigidBodyStates, "body_states", self._on_bodies, qos)
        else:
            node.create_subscription(MarkerArray, "markers", self._on_markers, qos)
        self.commands = node.create_publisher(CableCommand, "cable_commands", QoSProfile(depth=10))
        self.CableCommand = CableCommand
        self.clock = node.get_clock()

    def _on_cables(self, msg: Any) -> None:
        with self._lock:
            if self._cables is None:
                try:
                    self.structure.check_members(msg.name)
                except TopologyMismatch as err:
                    self.error = err
            self._cables = msg

    def _on_contacts(self, msg: Any) -> None:
        with self._lock:
            self._contacts = msg

    def _on_bodies(self, msg: Any) -> None:
        try:
            nodes = self.structure.nodes_of_bodies(msg)
        except KeyError:
            try:
                self.structure.check_bodies(msg.name)
            except TopologyMismatch as err:
                self.error = err
            return
        self._emit(stamp_seconds(msg), nodes)

    def _on_markers(self, msg: Any) -> None:
        nodes = self.structure.nodes_of_markers(msg)
        if nodes is not None:
            self._emit(stamp_seconds(msg), nodes)

    def _emit(self, t: float, nodes: Any) -> None:
        with self._lock:
            cables, contacts = self._cables, self._contacts
        if cables is None or self.error is not None:      # tensions first: no frame without them
            return
        self._sink(self.structure.frame(t, nodes, cables, contacts, self._run_state()))

    def inputs(self) -> tuple[InputSpec, ...]:
        """One slider per motor (or actuated member) that takes rest-length commands: its
        limits the motor's range, or ``REST_LENGTH_SPAN`` of its rest length either way
        without one (:func:`.inputs.command_input`); starting at the rest length of the latest
        ``cable_states``."""
        itf = self.interface
        modes = itf.modes or ("rest_length",) * len(itf.inputs)
        with self._lock:
            rest = list(self._cables.rest_length) if self._cables is not None else []
        out = []
        for name, commanded, (lo, hi), member, mode in zip(itf.inputs, itf.commanded, itf.limits, itf.members, modes):
            if not commanded or mode != "rest_length" or member < 0 or member >= len(rest):
                continue
            out.append(command_input(name, float(rest[member]), (lo, hi)))
        return tuple(out)

    def publish(self, values: dict[str, float]) -> None:
        """Command the rest lengths ``values`` [m] by cable name."""
        msg = self.CableCommand(name=list(values), rest_length=[float(v) for v in values.values()])
        msg.header.stamp = self.clock.now().to_msg()
        self.commands.publish(msg)
