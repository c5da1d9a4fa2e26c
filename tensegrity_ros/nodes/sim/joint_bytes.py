"""joint_states as serialized bytes, refilled in place for each publication.

A simulator's joint_states keep their joint names (a robot's motor cables, the class-2
joints) and their frame from one publication to the next: only the stamp and the three
float arrays change. Publishing the Python message converts every name to C and serializes
the whole message each time, ~20 us of the ~120 us of CPU a 6-bar lockstep step costs the
node (measured in one process between two core steps, load ~15: a joint_states publication
44 us, the same bytes published raw 24 us). :class:`JointStateBytes` publishes the bytes
instead: rclpy's own serialization of a template, with the stamp and the arrays written
into it. The layout is not written here: where the stamp and each array lie is found in
rclpy's serialization of templates with marker values in that field, and the result is
checked once against rclpy's deserializer; a template that does not check out (another
RMW's encoding) leaves :attr:`JointStateBytes.ok` False and the caller publishes messages.
"""

from __future__ import annotations

import struct
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Header

#: A float64 of eight distinct bytes (a finite number): an array of it marks that array's
#: bytes. Distinct, so the marked run cannot also be found a few bytes earlier: the padding
#: before an aligned array holds whatever the serializer's buffer held, which may be the tail
#: of an earlier marked serialization (an array of eight equal bytes was then found twice,
#: overlapping, and the template refused: 1 of ~10 CI runs).
_MARK = float(np.frombuffer(bytes(range(0x50, 0x58)), dtype="<f8")[0])
#: Stamp values of distinct non-zero bytes: mark the stamp's bytes.
_MARK_SEC, _MARK_NSEC = 0x14131211, 0x18171615
_FIELDS = ("position", "velocity", "effort")
_STAMP = struct.Struct("<iI")


def _message(names: Sequence[str], frame_id: str, sec: int = 0, nanosec: int = 0,
             arrays: Mapping[str, Sequence[float]] | None = None, fields: Sequence[str] = _FIELDS) -> JointState:
    """A JointState as rclpy builds it (arrays not given: zeros; not in ``fields``: empty)."""
    n = len(names)
    given = arrays or {}
    msg = JointState(name=list(names), **{f: given.get(f, [0.0] * n) for f in fields})
    msg.header = Header(frame_id=frame_id)
    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
    return msg


def _where(marked: bytes, mark: bytes) -> tuple[int, int]:
    """``(first, end)``: the one place ``mark`` lies in ``marked``, or ``(0, 0)`` (none, or
    several). Searched rather than diffed: the padding bytes before an aligned field are
    whatever the serializer left there, so two serializations differ there too (and may end
    with bytes of a mark, which is why a mark's bytes are distinct)."""
    first = marked.find(mark)
    if first < 0 or marked.find(mark, first + 1) >= 0:
        return 0, 0
    return first, first + len(mark)


class JointStateBytes:
    """The serialized JointState of the joints ``names`` in frame ``frame_id`` (``effort``
    False: its effort array empty)."""

    def __init__(self, names: Sequence[str], frame_id: str, *, effort: bool = True):
        self.names = tuple(names)
        self.frame_id = frame_id
        n = len(self.names)
        fields = _FIELDS if effort else _FIELDS[:2]
        template = serialize_message(_message(self.names, frame_id, fields=fields))
        self._buffer = bytearray(template)
        self._stamp = _where(serialize_message(_message(self.names, frame_id, _MARK_SEC, _MARK_NSEC, fields=fields)),
                             _STAMP.pack(_MARK_SEC, _MARK_NSEC))
        self._arrays = [_where(serialize_message(_message(self.names, frame_id, arrays={f: [_MARK] * n}, fields=fields)),
                               struct.pack(f"<{n}d", *[_MARK] * n)) for f in fields]
        self.ok = self._stamp[1] > 0 and (n == 0 or all(e - b == 8 * n for b, e in self._arrays))
        if self.ok:                          # checked once against rclpy's own reading
            values = [np.arange(n, dtype=float) + k + 0.25 for k in range(3)]
            got = deserialize_message(self.fill(1_234_567_890, 987_654_321, *values), JointState)
            self.ok = got == _message(self.names, frame_id, 1_234_567_890, 987_654_321,
                                      {f: v.tolist() for f, v in zip(fields, values)}, fields)

    def fill(self, sec: int, nanosec: int, position: NDArray[np.float64], velocity: NDArray[np.float64],
             effort: NDArray[np.float64]) -> bytes:
        """The message stamped ``sec``, ``nanosec`` with these positions, velocities and
        efforts (one float64 per joint each, joint order; efforts ignored without an effort array)."""
        buf = self._buffer
        _STAMP.pack_into(buf, self._stamp[0], sec, nanosec)
        for (b, e), values in zip(self._arrays, (position, velocity, effort)):
            data = np.ascontiguousarray(values, dtype="<f8").tobytes()
            if len(data) != e - b:            # a slice assignment of another length would move the rest
                raise ValueError(f"joint_states of {len(self.names)} joints, got {len(data) // 8} values")
            buf[b:e] = data
        return bytes(buf)
