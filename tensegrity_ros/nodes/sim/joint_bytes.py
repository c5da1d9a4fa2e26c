"""joint_states as serialized bytes, refilled in place for each publication.

A simulator's joint_states keep their joint names (a robot's motor cables, the class-2
joints) and their frame from one publication to the next: only the stamp and the float
arrays it carries change. Publishing the Python message converts every name to C and serializes
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

#: Stamp values of non-zero bytes: mark the stamp's bytes.
_MARK_SEC, _MARK_NSEC = 0x1A1A1A1A, 0x1B1B1B1B
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


def _marks(n: int) -> bytes:
    """The bytes that mark an array of ``n`` float64: 1, 2, ..., 251, 1, 2, ... (no float of
    them is NaN: no byte is 0xff). No run of them shorter than 251 bytes repeats, so they
    cannot be found again shifted by a few bytes: the padding before an aligned array holds
    whatever the serializer's buffer held, such as the marks of the serialization before (a
    mark of equal bytes was then found twice, one to seven bytes apart, and the layout lost)."""
    return bytes(j % 251 + 1 for j in range(8 * n))


def _where(marked: bytes, mark: bytes) -> tuple[int, int]:
    """``(first, end)``: the one place ``mark`` lies in ``marked``, or ``(0, 0)`` (none, or
    several). Searched rather than diffed: the padding bytes before an aligned field are
    whatever the serializer left there, so two serializations differ there too."""
    first = marked.find(mark)
    if first < 0 or marked.find(mark, first + 1) >= 0:
        return 0, 0
    return first, first + len(mark)


class JointStateBytes:
    """The serialized JointState of the joints ``names`` in frame ``frame_id`` with the
    arrays ``fields`` (of position, velocity, effort; the others empty)."""

    def __init__(self, names: Sequence[str], frame_id: str, *, fields: Sequence[str] = _FIELDS):
        self.names = tuple(names)
        self.frame_id = frame_id
        self.fields = tuple(f for f in _FIELDS if f in fields)
        n = len(self.names)
        template = serialize_message(_message(self.names, frame_id, fields=self.fields))
        self._buffer = bytearray(template)
        self._stamp = _where(serialize_message(_message(self.names, frame_id, _MARK_SEC, _MARK_NSEC,
                                                        fields=self.fields)),
                             _STAMP.pack(_MARK_SEC, _MARK_NSEC))
        #: Per array kept: its index in (position, velocity, effort) and where its bytes lie.
        mark = _marks(n)
        values = np.frombuffer(mark, dtype="<f8").tolist()
        self._arrays: list[tuple[int, int, int]] = []
        for f in self.fields:
            marked = serialize_message(_message(self.names, frame_id, arrays={f: values}, fields=self.fields))
            self._arrays.append((_FIELDS.index(f), *_where(marked, mark)))
        self.ok = self._stamp[1] > 0 and (n == 0 or all(e - b == 8 * n for _, b, e in self._arrays))
        #: Per array kept: its index and the float64s of the buffer it fills (written in place).
        self._views = [(i, np.frombuffer(self._buffer, dtype="<f8", count=n, offset=b))
                       for i, b, _ in self._arrays] if self.ok else []
        if self.ok:                          # checked once against rclpy's own reading
            values = [np.arange(n, dtype=float) + k + 0.25 for k in range(3)]
            got = deserialize_message(self.fill(1_234_567_890, 987_654_321, *values), JointState)
            self.ok = got == _message(self.names, frame_id, 1_234_567_890, 987_654_321,
                                      {f: values[i].tolist() for i, f in enumerate(_FIELDS)}, self.fields)

    def fill(self, sec: int, nanosec: int, position: NDArray[np.float64], velocity: NDArray[np.float64],
             effort: NDArray[np.float64]) -> bytes:
        """The message stamped ``sec``, ``nanosec`` with these positions, velocities and
        efforts (one float64 per joint each, joint order; the arrays not kept are ignored)."""
        buf = self._buffer
        _STAMP.pack_into(buf, self._stamp[0], sec, nanosec)
        given = (position, velocity, effort)
        for i, view in self._views:
            values = given[i]
            if len(values) != len(view):      # an assignment would broadcast a single value
                raise ValueError(f"joint_states of {len(self.names)} joints, got {len(values)} values")
            view[:] = values
        return bytes(buf)
