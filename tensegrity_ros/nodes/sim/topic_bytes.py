"""The simulator's fixed-shape topics of a general structure or robot as serialized bytes
(:class:`.message_bytes.MessageBytes`): per topic, the template (what stays: names, kinds,
frames) and the runs of one observation (what changes). Each equals, read back, the message
of :mod:`.sender` or :mod:`.robot_messages` for the same observation and header.

- ``cable_states``: runs ``length``, ``length_rate``, ``rest_length``, ``tension`` [m, m/s,
  m, N] and ``slack``, one per member;
- ``imu/<body>``: ``orientation`` (x, y, z, w), ``angular_velocity`` [rad/s],
  ``linear_acceleration`` [m/s^2] (covariances 0: exact readings);
- ``body_states``: ``pose`` (per body x, y, z [m], then the quaternion x, y, z, w) and
  ``twist`` (per body linear [m/s], then angular [rad/s] velocity);
- ``end_effector``: ``point`` (x, y, z [m]).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, PointStamped, Pose, Quaternion, Twist, Vector3
from sensor_msgs.msg import Imu
from std_msgs.msg import Header
from tensegrity_msgs.msg import CableStates, RigidBodyStates

from tensegrity_core.sim.model import Interface
from tensegrity_core.sim.simulator import Observation
from tensegrity_ros.nodes.sim.message_bytes import MessageBytes

Runs = Mapping[str, Any]
_CABLE_FLOATS = ("length", "length_rate", "rest_length", "tension")


def _header(sec: int, nanosec: int, frame_id: str) -> Header:
    return Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id=frame_id)


def _floats(runs: Runs, name: str, n: int) -> list[float]:
    return [float(v) for v in runs.get(name, (0.0,) * n)]


def cable_states_bytes(obs: Observation, interface: Interface, frame_id: str) -> MessageBytes:
    """cable_states of the observation's members (their names and kinds, ``interface``'s actuated ones)."""
    names, kinds = [str(s) for s in obs.member_names], [str(s) for s in obs.member_kinds]
    actuated_members = set(interface.members)
    actuated = [i in actuated_members for i in range(len(names))]
    n = len(names)

    def build(sec: int, nanosec: int, runs: Runs) -> CableStates:
        m = CableStates(header=_header(sec, nanosec, frame_id), name=names, kind=kinds, actuated=actuated)
        for f in _CABLE_FLOATS:
            setattr(m, f, _floats(runs, f, n))
        m.slack = [bool(s) for s in runs.get("slack", (False,) * n)]
        return m

    return MessageBytes(CableStates, build, dict.fromkeys(_CABLE_FLOATS, n), {"slack": n})


def cable_states_runs(obs: Observation) -> Runs:
    return {"length": obs.member_lengths, "length_rate": obs.member_rates, "rest_length": obs.member_rest_lengths,
            "tension": obs.member_forces, "slack": obs.member_slack}


def imu_bytes(frame_id: str) -> MessageBytes:
    """An IMU's readings in the frame ``frame_id`` (its body's)."""
    def build(sec: int, nanosec: int, runs: Runs) -> Imu:
        q, w, a = (_floats(runs, k, n) for k, n in (("orientation", 4), ("angular_velocity", 3),
                                                    ("linear_acceleration", 3)))
        return Imu(header=_header(sec, nanosec, frame_id), orientation=Quaternion(x=q[0], y=q[1], z=q[2], w=q[3]),
                   angular_velocity=Vector3(x=w[0], y=w[1], z=w[2]),
                   linear_acceleration=Vector3(x=a[0], y=a[1], z=a[2]))

    return MessageBytes(Imu, build, {"orientation": 4, "angular_velocity": 3, "linear_acceleration": 3})


def imu_runs(obs: Observation, i: int) -> Runs:
    return {"orientation": obs.imu_orientation[i], "angular_velocity": obs.imu_angular_velocity[i],
            "linear_acceleration": obs.imu_specific_force[i]}


def body_states_bytes(names: Sequence[str], frame_id: str) -> MessageBytes:
    """body_states of the bodies ``names``."""
    n = len(names)

    def build(sec: int, nanosec: int, runs: Runs) -> RigidBodyStates:
        p, t = _floats(runs, "pose", 7 * n), _floats(runs, "twist", 6 * n)
        m = RigidBodyStates(header=_header(sec, nanosec, frame_id), name=list(names))
        m.pose = [Pose(position=Point(x=p[7 * b], y=p[7 * b + 1], z=p[7 * b + 2]),
                       orientation=Quaternion(x=p[7 * b + 3], y=p[7 * b + 4], z=p[7 * b + 5], w=p[7 * b + 6]))
                  for b in range(n)]
        m.twist = [Twist(linear=Vector3(x=t[6 * b], y=t[6 * b + 1], z=t[6 * b + 2]),
                         angular=Vector3(x=t[6 * b + 3], y=t[6 * b + 4], z=t[6 * b + 5])) for b in range(n)]
        return m

    return MessageBytes(RigidBodyStates, build, {"pose": 7 * n, "twist": 6 * n})


def body_states_runs(obs: Observation) -> Runs:
    return {"pose": np.concatenate([obs.body_positions, obs.body_orientations], axis=1).ravel(),
            "twist": np.concatenate([obs.body_velocities, obs.body_angular_velocities], axis=1).ravel()}


def end_effector_bytes(frame_id: str) -> MessageBytes:
    def build(sec: int, nanosec: int, runs: Runs) -> PointStamped:
        x = _floats(runs, "point", 3)
        return PointStamped(header=_header(sec, nanosec, frame_id), point=Point(x=x[0], y=x[1], z=x[2]))

    return MessageBytes(PointStamped, build, {"point": 3})
