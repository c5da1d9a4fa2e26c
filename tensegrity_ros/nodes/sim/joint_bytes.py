"""joint_states as serialized bytes, refilled in place for each publication.

A simulator's joint_states keep their joint names (a robot's motor cables, the class-2
joints) and their frame from one publication to the next: only the stamp and the float
arrays it carries change. Publishing the Python message converts every name to C and serializes
the whole message each time, ~20 us of the ~120 us of CPU a 6-bar lockstep step costs the
node (measured in one process between two core steps, load ~15: a joint_states publication
44 us, the same bytes published raw 24 us). :class:`JointStateBytes` publishes the bytes
instead (a :class:`.message_bytes.MessageBytes` whose runs are the arrays kept); a template
that does not check out (another RMW's encoding) leaves :attr:`JointStateBytes.ok` False and
the caller publishes messages.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray
from sensor_msgs.msg import JointState
from std_msgs.msg import Header

from tensegrity_ros.nodes.sim.message_bytes import MessageBytes

_FIELDS = ("position", "velocity", "effort")


def _message(names: Sequence[str], frame_id: str, sec: int = 0, nanosec: int = 0,
             arrays: Mapping[str, Sequence[float]] | None = None, fields: Sequence[str] = _FIELDS) -> JointState:
    """A JointState as rclpy builds it (arrays not given: zeros; not in ``fields``: empty)."""
    n = len(names)
    given = arrays or {}
    msg = JointState(name=list(names), **{f: given.get(f, [0.0] * n) for f in fields})
    msg.header = Header(frame_id=frame_id)
    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
    return msg


class JointStateBytes:
    """The serialized JointState of the joints ``names`` in frame ``frame_id`` with the
    arrays ``fields`` (of position, velocity, effort; the others empty)."""

    def __init__(self, names: Sequence[str], frame_id: str, *, fields: Sequence[str] = _FIELDS):
        self.names = tuple(names)
        self.frame_id = frame_id
        self.fields = tuple(f for f in _FIELDS if f in fields)
        self._bytes = MessageBytes(
            JointState, lambda sec, nanosec, runs: _message(self.names, frame_id, sec, nanosec, runs, self.fields),
            {f: len(self.names) for f in self.fields})
        self.ok = self._bytes.ok

    def fill(self, sec: int, nanosec: int, position: NDArray[np.float64], velocity: NDArray[np.float64],
             effort: NDArray[np.float64]) -> bytes:
        """The message stamped ``sec``, ``nanosec`` with these positions, velocities and
        efforts (one float64 per joint each, joint order; the arrays not kept are ignored)."""
        given = {"position": position, "velocity": velocity, "effort": effort}
        n = len(self.names)
        for f in self.fields:
            if len(given[f]) != n:          # an assignment would broadcast a single value
                raise ValueError(f"joint_states of {n} joints, got {len(given[f])} values")
        return self._bytes.fill(sec, nanosec, given)
