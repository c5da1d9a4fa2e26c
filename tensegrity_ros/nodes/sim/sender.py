"""The simulator's sender: small pure functions from the core's samples to messages.

Nothing here holds state or touches a node; each function takes plain values (a
:class:`~tensegrity_core.sim.simulator.JointSample` or
:class:`~tensegrity_core.sim.simulator.Observation`, the model's
:class:`~tensegrity_core.sim.model.Interface`, a header, times in integer nanoseconds) and
returns a message. Units SI; forces tension positive.
"""

from __future__ import annotations

import array
from collections.abc import Sequence

import numpy as np
from builtin_interfaces.msg import Time as TimeMsg
from geometry_msgs.msg import Point, PointStamped, Pose, Quaternion, Twist, Vector3
from numpy.typing import NDArray
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState
from std_msgs.msg import ColorRGBA, Header
from tensegrity_msgs.msg import CableStates, MechanismState, RigidBodyStates, SimulationEvent
from visualization_msgs.msg import Marker, MarkerArray

from tensegrity_core.class2.names import JOINTS
from tensegrity_core.events import EventKind, LoggedEvent
from tensegrity_core.sim.model import Interface, Names
from tensegrity_core.sim.simulator import JointSample, Observation

NS_PER_S = 1_000_000_000
#: Names of what an event's index refers to, per kind (the core's event kinds).
EVENT_SUBJECTS: dict[EventKind, tuple[str, ...]] = {"fold": ("rho1", "rho2"), "release": ("rho1", "rho2"),
                  "singular": ("lambda1", "lambda2")}
#: A point or vector [m]: three coordinates (x, y, z).
Coordinates = Sequence[float] | NDArray[np.float64]


def time_msg(ns: int) -> TimeMsg:
    """A stamp of ``ns`` nanoseconds on the simulation clock (exact: no float in between)."""
    sec, nanosec = divmod(int(ns), NS_PER_S)
    return TimeMsg(sec=sec, nanosec=nanosec)


def header(ns: int, frame_id: str) -> Header:
    return Header(stamp=time_msg(ns), frame_id=frame_id)


def restamp(hdr: Header, ns: int) -> Header:
    """``hdr`` stamped ``ns`` nanoseconds, in place (a header reused by every publication,
    whose messages are all published before the next)."""
    hdr.stamp.sec, hdr.stamp.nanosec = divmod(int(ns), NS_PER_S)
    return hdr


def clock_msg(ns: int) -> ClockMsg:
    return ClockMsg(clock=time_msg(ns))


def point(p: Coordinates) -> Point:
    return Point(x=float(p[0]), y=float(p[1]), z=float(p[2]))


def _doubles(values: Sequence[float] | NDArray[np.float64]) -> array.array[float]:
    """A float64 sequence field's value (``array('d')`` takes rclpy's fast path: a list is
    checked element by element on assignment), filled from the values' bytes at once."""
    return array.array("d", np.ascontiguousarray(values, dtype=np.float64).tobytes())


def joint_state_msg(sample: JointSample, hdr: Header) -> JointState:
    """Joints rho1, rho2 [m], beta [rad]: position, velocity, effort = applied force [N] (0 for beta)."""
    msg = JointState(header=hdr, name=list(JOINTS))
    msg.position = _doubles(sample.q)
    msg.velocity = _doubles(sample.qdot)
    msg.effort = _doubles((sample.applied_forces[0], sample.applied_forces[1], 0.0))
    return msg


def cable_joint_state_msg(obs: Observation, interface: Interface, hdr: Header) -> JointState:
    """One joint per actuated cable (the scene's inputs, in input order): position = its
    length [m], velocity = d(length)/dt [m/s], effort = its tension [N] (positive pulling)."""
    members = list(interface.members)
    msg = JointState(header=hdr, name=list(interface.inputs))
    msg.position = _doubles(obs.member_lengths[members])
    msg.velocity = _doubles(obs.member_rates[members])
    msg.effort = _doubles(obs.member_forces[members])
    return msg


def actuated_joint_state_msg(sample: JointSample, interface: Interface, hdr: Header) -> JointState:
    """The joints of :func:`cable_joint_state_msg` from a joint sample (its ``actuated_*``)."""
    msg = JointState(header=hdr, name=list(interface.inputs))
    msg.position = _doubles(sample.actuated_lengths)
    msg.velocity = _doubles(sample.actuated_rates)
    msg.effort = _doubles(sample.actuated_forces)
    return msg


def cable_states_msg(obs: Observation, interface: Interface, hdr: Header) -> CableStates:
    """Every member: kind, actuated, length [m], its rate [m/s], rest length [m], tension [N], slack."""
    actuated = set(interface.members)
    m = CableStates(header=hdr, name=list(obs.member_names), kind=list(obs.member_kinds))
    m.actuated = [i in actuated for i in range(len(obs.member_names))]
    m.length = _doubles(obs.member_lengths)
    m.length_rate = _doubles(obs.member_rates)
    m.rest_length = _doubles(obs.member_rest_lengths)
    m.tension = _doubles(obs.member_forces)
    m.slack = [bool(s) for s in obs.member_slack]
    return m


def body_states_msg(obs: Observation, hdr: Header) -> RigidBodyStates:
    """Each moving rigid body's frame: pose and twist (velocity of its origin, angular velocity)."""
    m = RigidBodyStates(header=hdr, name=list(obs.body_names))
    for p, q, v, w in zip(obs.body_positions, obs.body_orientations, obs.body_velocities,
                          obs.body_angular_velocities):
        m.pose.append(Pose(position=point(p), orientation=Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]),
                                                                     w=float(q[3]))))
        m.twist.append(Twist(linear=Vector3(x=float(v[0]), y=float(v[1]), z=float(v[2])),
                             angular=Vector3(x=float(w[0]), y=float(w[1]), z=float(w[2]))))
    return m


def end_effector_msg(sample: JointSample | Observation, hdr: Header) -> PointStamped:
    return PointStamped(header=hdr, point=point(sample.end_effector))


def mechanism_state_msg(obs: Observation, hdr: Header) -> MechanismState:
    """The full state; ``contact_active[i]``: the fold limit pushes on actuator i (its
    contact force [N] is > 0)."""
    m = MechanismState(header=hdr)
    m.q = [float(v) for v in obs.q]
    m.qdot = [float(v) for v in obs.qdot]
    m.actuator_force = [float(v) for v in obs.applied_forces]
    m.node_names = list(obs.node_names)
    m.nodes = [point(p) for p in obs.nodes]
    m.member_names = list(obs.member_names)
    m.member_lengths = [float(v) for v in obs.member_lengths]
    m.member_forces = [float(v) for v in obs.member_forces]
    m.end_effector = point(obs.end_effector)
    m.potential_energy = float(obs.potential_energy)
    m.kinetic_energy = float(obs.kinetic_energy)
    m.folded = bool(obs.folded)
    contact = [float(v) for v in obs.contact_forces][:2]
    contact += [0.0] * (2 - len(contact))
    m.contact_force = contact
    m.contact_active = [f > 0.0 for f in contact]
    return m


def force_color(t: float, scale: float) -> ColorRGBA:
    """Red for tension, blue for compression, grey near zero; saturates at ``scale`` [N]."""
    a = max(-1.0, min(1.0, t / scale)) if scale > 0 else 0.0
    if a >= 0:
        return ColorRGBA(r=0.6 + 0.4 * a, g=0.6 - 0.5 * a, b=0.6 - 0.5 * a, a=1.0)
    return ColorRGBA(r=0.6 + 0.5 * a, g=0.6 + 0.5 * a, b=0.6 - 0.4 * a, a=1.0)


def markers_msg(obs: Observation, hdr: Header) -> MarkerArray:
    """Members as lines coloured by force (tension red, compression blue, relative to the
    largest |force| of this observation), nodes as spheres."""
    scale = max(1e-9, max(abs(float(t)) for t in obs.member_forces))
    members = Marker(header=hdr, ns="members", id=0, type=Marker.LINE_LIST, action=Marker.ADD)
    members.scale.x = 0.02
    members.pose.orientation.w = 1.0
    for (i, j), t in zip(obs.member_nodes, obs.member_forces):
        for n in (i, j):
            members.points.append(point(obs.nodes[n]))
            members.colors.append(force_color(float(t), scale))
    nodes = Marker(header=hdr, ns="nodes", id=1, type=Marker.SPHERE_LIST, action=Marker.ADD)
    nodes.scale.x = nodes.scale.y = nodes.scale.z = 0.05
    nodes.pose.orientation.w = 1.0
    nodes.color = ColorRGBA(r=0.9, g=0.9, b=0.9, a=1.0)
    nodes.points = [point(p) for p in obs.nodes]
    return MarkerArray(markers=[members, nodes])


def event_msg(event: LoggedEvent, offset_ns: int, frame_id: str, names: Names) -> SimulationEvent:
    """One located event ``(t [s] on the core's clock, kind, index)`` of a model with ``names``;
    the simulation clock reads ``offset_ns`` when the core's clock reads 0. A string's ``slack``
    or ``taut`` event is named by its member (the order of ``cable_states``)."""
    t, kind, index = event
    subjects = names.member_names if kind in ("slack", "taut") else EVENT_SUBJECTS.get(kind, ())
    ns = offset_ns + round(t * NS_PER_S)
    return SimulationEvent(header=header(ns, frame_id), time=offset_ns / NS_PER_S + float(t), kind=str(kind),
                           index=int(index), name=subjects[index] if 0 <= index < len(subjects) else "")
