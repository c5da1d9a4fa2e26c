"""The messages of a robot's own topics: pure functions from an observation to messages.

Like :mod:`.sender`, nothing here holds state or touches a node. Each function takes a
:class:`~tensegrity_core.sim.simulator.Observation` of a robot scene (its IMU and cap
readings, :class:`~tensegrity_core.sim.model.Observed`) and a header; units SI, forces
tension positive.
"""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import Pose, Quaternion, Vector3
from sensor_msgs.msg import Imu
from std_msgs.msg import ColorRGBA, Header
from tensegrity_msgs.msg import CapContacts
from visualization_msgs.msg import Marker, MarkerArray

from tensegrity_core.sim.simulator import Observation
from tensegrity_ros.nodes.sim.sender import Coordinates, force_color, point

#: Line widths of the robot's markers [m]: rods, cables.
ROD_WIDTH, CABLE_WIDTH = 0.03, 0.008
#: Side of the floor's marker [m] and its thickness [m].
FLOOR_SIZE, FLOOR_THICKNESS = 10.0, 0.002
#: Diameter of a contact's marker [m].
CONTACT_SIZE = 0.04


def _vector(v: Coordinates) -> Vector3:
    return Vector3(x=float(v[0]), y=float(v[1]), z=float(v[2]))


def _quaternion(q: Coordinates) -> Quaternion:
    return Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3]))


def imu_msg(obs: Observation, i: int, hdr: Header) -> Imu:
    """IMU ``i`` of the observation (``hdr.frame_id``: the body it is fixed to) as a real
    strapdown IMU reports it, in its body's frame: orientation (body -> world), angular
    velocity [rad/s] and linear acceleration = specific force [m/s^2] (acceleration minus
    gravity: +9.81 up at rest). The readings are exact (the core's IMUs are noise-free), so
    the covariances are 0, which sensor_msgs/Imu reads as "unknown"; every quantity is
    provided, so no element 0 is -1."""
    return Imu(header=hdr, orientation=_quaternion(obs.imu_orientation[i]),
               angular_velocity=_vector(obs.imu_angular_velocity[i]),
               linear_acceleration=_vector(obs.imu_specific_force[i]))


def contacts_msg(obs: Observation, hdr: Header) -> CapContacts:
    """The caps touching the floor: centre [m], normal force [N], friction force [N], slipping."""
    m = CapContacts(header=hdr)
    for c in np.flatnonzero(obs.cap_contact):
        m.name.append(obs.cap_names[c])
        m.position.append(point(obs.nodes[obs.node_names.index(obs.cap_names[c])]))
        m.normal_force.append(float(obs.contact_forces[c]))
        m.friction_force.append(_vector(obs.friction_forces[c]))
        m.slipping.append(bool(obs.cap_slipping[c]))
    return m


def robot_markers_msg(obs: Observation, floor: tuple[np.ndarray, np.ndarray] | None, hdr: Header) -> MarkerArray:
    """Rods (grey-blue thick lines, compression blue), cables coloured by tension (red, relative
    to the largest cable tension of this observation; grey when slack), the floor (a thin grey
    plate through ``floor = (point, unit normal)`` [m], when the robot has one) and the caps
    in contact (green spheres)."""
    rods = [i for i, k in enumerate(obs.member_kinds) if k == "bar"]
    cables = [i for i, k in enumerate(obs.member_kinds) if k != "bar"]
    out: list[Marker] = []
    for ns, members, width in (("rods", rods, ROD_WIDTH), ("cables", cables, CABLE_WIDTH)):
        m = Marker(header=hdr, ns=ns, id=len(out), type=Marker.LINE_LIST, action=Marker.ADD)
        m.scale.x = width
        m.pose.orientation.w = 1.0
        scale = max([1e-9] + [abs(float(obs.member_forces[i])) for i in members])
        for i in members:
            colour = force_color(float(obs.member_forces[i]), scale)
            for n in obs.member_nodes[i]:
                m.points.append(point(obs.nodes[n]))
                m.colors.append(colour)
        out.append(m)
    if floor is not None:
        p, normal = floor
        plate = Marker(header=hdr, ns="floor", id=len(out), type=Marker.CUBE, action=Marker.ADD)
        plate.pose = Pose(position=point(np.asarray(p) - 0.5 * FLOOR_THICKNESS * np.asarray(normal)),
                          orientation=_quaternion(_z_to(normal)))
        plate.scale.x = plate.scale.y = FLOOR_SIZE
        plate.scale.z = FLOOR_THICKNESS
        plate.color = ColorRGBA(r=0.5, g=0.5, b=0.5, a=0.5)
        out.append(plate)
    touching = Marker(header=hdr, ns="contacts", id=len(out), type=Marker.SPHERE_LIST, action=Marker.ADD)
    touching.scale.x = touching.scale.y = touching.scale.z = CONTACT_SIZE
    touching.pose.orientation.w = 1.0
    touching.color = ColorRGBA(r=0.1, g=0.8, b=0.2, a=1.0)
    touching.points = [point(obs.nodes[obs.node_names.index(obs.cap_names[c])])
                       for c in np.flatnonzero(obs.cap_contact)]
    out.append(touching)
    return MarkerArray(markers=out)


def _z_to(normal: Coordinates) -> np.ndarray:
    """The quaternion ``(x, y, z, w)`` of the shortest rotation taking +z to the unit ``normal``."""
    n = np.asarray(normal, dtype=float)
    q = np.array([-n[1], n[0], 0.0, 1.0 + n[2]])     # half-way quaternion of (0, 0, 1) and n
    norm = np.linalg.norm(q)
    return q / norm if norm > 1e-12 else np.array([1.0, 0.0, 0.0, 0.0])
