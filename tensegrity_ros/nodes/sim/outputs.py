"""What tensegrity_sim publishes for its model, and the messages of one publication. No node:
the node creates a publisher per topic of :attr:`Outputs.topics` and publishes what
:meth:`Outputs.messages` returns.

The model says what there is (:class:`~tensegrity_core.sim.model.Interface`, its names):

- class-2 mechanism: ``joint_states`` (rho1, rho2 [m], beta [rad]; effort = applied force
  [N]) and ``end_effector`` every publication, from the cheap joint sample;
  ``mechanism_state`` (every n-th, ``state_rate``) and ``markers`` (``marker_rate``) from a
  full observation, taken only when one of them is due and wanted;
- general structure: ``joint_states`` (one joint per actuated cable: length [m], its rate
  [m/s], tension [N]: a robot's measured ones, :mod:`.joint_sensors`), ``end_effector`` and, with moving rigid bodies, ``body_states`` and
  ``/tf`` (world -> each body's frame, :mod:`.transforms`) every publication; ``cable_states`` (every member) at ``state_rate``; ``markers`` at
  ``marker_rate``; all from one observation per publication, or from the joint sample when
  only ``joint_states`` and ``end_effector`` are wanted (and the scene has no sensor noise,
  which the sample's member values do not carry);
- robot: as a general structure (its rods are its bodies and members of kind "bar", its
  cables members of kind "string", its motor-driven cables the joints), and
  ``imu/<body>`` (sensor_msgs/Imu, one per IMU, frame_id = its body) at ``imu_rate``,
  ``contacts`` (tensegrity_msgs/CapContacts: the caps touching the floor) at
  ``state_rate``; its ``markers`` draw rods, cables coloured by tension, the floor and the
  contacts (:mod:`.robot_messages`).

``events`` and ``/clock`` are the node's (they do not depend on the model's kind).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from geometry_msgs.msg import PointStamped
from numpy.typing import NDArray
from sensor_msgs.msg import Imu, JointState
from std_msgs.msg import Header
from tensegrity_msgs.msg import CableStates, CapContacts, MechanismState, RigidBodyStates
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from tensegrity_core.class2.names import JOINTS
from tensegrity_core.excerpt import excerpt
from tensegrity_ros.nodes.common import ParameterValueError
from tensegrity_ros.nodes.sim import robot_messages, sender, topic_bytes, transforms
from tensegrity_ros.nodes.sim.decimation import Decimation, cap_warnings
from tensegrity_ros.nodes.sim.joint_bytes import JointStateBytes
from tensegrity_ros.nodes.sim.joint_sensors import joint_sensors
from tensegrity_ros.nodes.sim.message_bytes import MessageBytes
from tensegrity_ros.nodes.sim.plant import SimPlant

#: What a publication needs done: the message of each topic (name, message).
Messages = list[tuple[str, object]]
FloatArray = NDArray[np.float64]
#: The topics a joint sample gives (no observation needed).
_JOINTS_ONLY = frozenset({"joint_states", "end_effector"})


def _check_topic(body: str, topic: str) -> None:
    """Refuse an IMU whose body's name makes no ROS topic name (the core takes any name; rclpy
    would raise InvalidTopicNameException as the publisher is made), in one line."""
    from rclpy.exceptions import InvalidTopicNameException
    from rclpy.validate_topic_name import validate_topic_name

    try:
        validate_topic_name(topic)
    except InvalidTopicNameException:
        raise ParameterValueError(
            f"tensegrity_sim: the IMU of {excerpt(body)} cannot publish on {excerpt(topic)}: a ROS topic name holds "
            "letters, digits and '_' in tokens that do not start with a digit; rename the body in the robot's "
            "description") from None


class Outputs:
    """The per-publication topics of one plant's model and their messages."""

    def __init__(self, plant: SimPlant, *, publish_rate: float, state_rate: float, marker_rate: float,
                 imu_rate: float, frame_prefix: str = ""):
        self.plant = plant
        #: Put before each moving body's name to make its frame (/tf child, IMU frame_id).
        self.frame_prefix = frame_prefix
        self.general = plant.interface.command == "rest_length"
        self.robot = plant.model.kind == "robot"
        self._floor = plant.floor()
        #: The IMUs' topics, in the order of their readings.
        self.imu_topics = tuple(f"imu/{name}" for name in plant.names.imu_names)
        for name, topic in zip(plant.names.imu_names, self.imu_topics):
            _check_topic(name, topic)
        if self.general:
            self.topics: dict[str, type] = {"joint_states": JointState, "end_effector": PointStamped,
                                            "cable_states": CableStates, "markers": MarkerArray}
            if plant.names.body_names:
                self.topics |= {"body_states": RigidBodyStates, "/tf": TFMessage}
            slow = {"cable_states": state_rate, "markers": marker_rate}
            if self.robot:
                self.topics |= dict.fromkeys(self.imu_topics, Imu)
                slow |= dict.fromkeys(self.imu_topics, imu_rate)
                if plant.names.cap_names:
                    self.topics["contacts"] = CapContacts
                    slow["contacts"] = state_rate
        else:
            self.topics = {"joint_states": JointState, "end_effector": PointStamped,
                           "mechanism_state": MechanismState, "markers": MarkerArray}
            slow = {"mechanism_state": state_rate, "markers": marker_rate}
        self.decimation = Decimation(publish_rate, slow)
        #: What the node warns of at start: the rates of its topics capped at publish_rate.
        self.cap_warnings = cap_warnings(publish_rate, {"state_rate": state_rate, "marker_rate": marker_rate}
                                         | ({"imu_rate": imu_rate} if self.robot and self.imu_topics else {}))
        #: The topics of every publication.
        self.every_publication = tuple(t for t in self.topics if t not in self.decimation.every)
        #: The joint names of joint_states.
        self.joint_names = tuple(plant.interface.inputs if self.general else JOINTS)
        #: What joint_states report of each joint (a robot's measured lengths and tensions,
        #: :mod:`.joint_sensors`).
        self.sensors = joint_sensors(plant.model, self.joint_names)
        self._joint_bytes: JointStateBytes | None = None
        #: The actuated members (joint_states' joints) as indices into an observation's members.
        self._members = np.asarray(plant.interface.members, dtype=np.intp)
        #: The other topics' templates of serialized bytes, by (topic, frame).
        self._templates: dict[tuple[str, str], MessageBytes] = {}

    def messages(self, hdr: Header, wanted: Callable[[str], bool]) -> Messages:
        """The messages of this publication (counted by the decimation) for the topics
        ``wanted`` (someone subscribes; asked only of the topics due: an rmw graph query
        each); the expensive observation only when needed. joint_states, and a general
        structure's cable_states, body_states, end_effector and IMU readings, are serialized
        bytes (what a publisher publishes as they are: :mod:`.joint_bytes`, :mod:`.topic_bytes`)."""
        due = self.decimation.next()
        want = {t for t in self.every_publication if wanted(t)}
        if due:
            want |= {t for t in due if wanted(t)}
        if not want:
            return []
        out: Messages = []
        plant, interface = self.plant, self.plant.interface
        if self.general and want <= _JOINTS_ONLY and not plant.noisy:
            # the joints alone (a lockstep loop's usual state): the cheap joint sample, of
            # the actuated members only (not the coordinates: a robot's rotation vectors)
            sample = plant.joint_sample(coordinates=False)
            if len(sample.actuated_lengths) == len(interface.inputs):
                if "joint_states" in want:
                    out.append(("joint_states", self._joints(
                        hdr, sample.actuated_lengths, sample.actuated_rates, sample.actuated_forces,
                        lambda: sender.actuated_joint_state_msg(sample, interface, hdr))))
                if "end_effector" in want:
                    out.append(("end_effector", sender.end_effector_msg(sample, hdr)))
                return out
        if self.general:
            obs = plant.observe()
            members = self._members
            frame = hdr.frame_id
            build: dict[str, Callable[[], object]] = {
                     "joint_states": lambda: self._joints(
                         hdr, obs.member_lengths[members], obs.member_rates[members], obs.member_forces[members],
                         lambda: sender.cable_joint_state_msg(obs, interface, hdr)),
                     "end_effector": lambda: self._bytes(
                         "end_effector", frame, lambda: topic_bytes.end_effector_bytes(frame), hdr,
                         {"point": obs.end_effector}, lambda: sender.end_effector_msg(obs, hdr)),
                     "body_states": lambda: self._bytes(
                         "body_states", frame, lambda: topic_bytes.body_states_bytes(obs.body_names, frame), hdr,
                         topic_bytes.body_states_runs(obs), lambda: sender.body_states_msg(obs, hdr)),
                     "/tf": lambda: transforms.tf_msg(obs, hdr, self.frame_prefix),
                     "cable_states": lambda: self._bytes(
                         "cable_states", frame, lambda: topic_bytes.cable_states_bytes(obs, interface, frame), hdr,
                         topic_bytes.cable_states_runs(obs), lambda: sender.cable_states_msg(obs, interface, hdr)),
                     "markers": lambda: (robot_messages.robot_markers_msg(obs, self._floor, hdr) if self.robot
                                         else sender.markers_msg(obs, hdr)),
                     "contacts": lambda: robot_messages.contacts_msg(obs, hdr)}
            for i, topic in enumerate(self.imu_topics):
                def imu(i: int = i, topic: str = topic) -> object:
                    body = self.frame_prefix + obs.imu_names[i]
                    return self._bytes(topic, body, lambda: topic_bytes.imu_bytes(body), hdr,
                                       topic_bytes.imu_runs(obs, i),
                                       lambda: robot_messages.imu_msg(obs, i, Header(stamp=hdr.stamp, frame_id=body)))
                build[topic] = imu
            return [(t, build[t]()) for t in self.topics if t in want]
        if want & {"joint_states", "end_effector"}:
            sample = plant.joint_sample()
            if "joint_states" in want:
                out.append(("joint_states", self._joints(
                    hdr, sample.q, sample.qdot, np.array([sample.applied_forces[0], sample.applied_forces[1], 0.0]),
                    lambda: sender.joint_state_msg(sample, hdr))))
            if "end_effector" in want:
                out.append(("end_effector", sender.end_effector_msg(sample, hdr)))
        if want & {"mechanism_state", "markers"}:
            obs = plant.observe()
            if "mechanism_state" in want:
                out.append(("mechanism_state", sender.mechanism_state_msg(obs, hdr)))
            if "markers" in want:
                out.append(("markers", sender.markers_msg(obs, hdr)))
        return out

    def _joints(self, hdr: Header, position: FloatArray, velocity: FloatArray, effort: FloatArray,
                message: Callable[[], JointState]) -> bytes | JointState:
        """joint_states of this publication as serialized bytes (:mod:`.joint_bytes`: the
        names and frame serialized once), or ``message()`` where those bytes do not check out."""
        cdr = self._joint_bytes
        length, tension = self.sensors.length, self.sensors.tension
        if cdr is None or cdr.frame_id != hdr.frame_id:
            fields = ("position", "velocity") * length.reported + ("effort",) * tension.reported
            cdr = self._joint_bytes = JointStateBytes(self.joint_names, hdr.frame_id, fields=fields)
        if not cdr.ok or len(position) != len(self.joint_names):
            return self._measured(message())
        if self.sensors.everything:
            return cdr.fill(hdr.stamp.sec, hdr.stamp.nanosec, position, velocity, effort)
        return cdr.fill(hdr.stamp.sec, hdr.stamp.nanosec, length.of(position), length.of(velocity),
                        tension.of(effort))

    def _bytes(self, topic: str, frame_id: str, template: Callable[[], MessageBytes], hdr: Header,
               runs: topic_bytes.Runs, message: Callable[[], object]) -> object:
        """``topic``'s message of this publication as serialized bytes (its template, made
        once per frame by ``template()``, filled with ``runs``), or ``message()`` where the
        template does not check out."""
        cdr = self._templates.get((topic, frame_id))
        if cdr is None:
            cdr = self._templates[(topic, frame_id)] = template()
        return cdr.fill(hdr.stamp.sec, hdr.stamp.nanosec, runs) if cdr.ok else message()

    def _measured(self, msg: JointState) -> JointState:
        """``msg`` with the lengths, rates and tensions the robot measures (:mod:`.joint_sensors`)."""
        if not self.sensors.everything:
            length, tension = self.sensors.length, self.sensors.tension
            msg.position = length.of(msg.position).tolist()
            msg.velocity = length.of(msg.velocity).tolist()
            msg.effort = tension.of(msg.effort).tolist()
        return msg
