"""A lockstep controller's CableCommand read from its serialized bytes, without building the message.

A controller answering every state of a robot names every actuated cable in input order and
gives rest lengths only (as ``joint_states`` names them; the cable controller and the gait
do). Each such command has the same bytes but for the stamp and the rest lengths, so where
they lie is fixed by the length of the frame name. Building the Python message of a 6-bar
command (24 names) costs rclpy ~40 us and checking it ~10 us; reading the stamp and the 24
values from their places, after comparing the fixed bytes in one C call, ~3 us.

:class:`CableCommandBytes` reads such a command and returns ``None`` for anything else (other
names or order, reel speeds or tensions, another encoding): the caller then deserializes the
message and checks it as usual, so every error message stays the full check's. The layout
is not written here: it is found by walking rclpy's serialization of a template (XCDR1:
each field aligned to its size, counted from the byte after the 4-byte encapsulation header)
and checked once per frame-name length against rclpy's deserializer. The padding bytes
before an aligned field hold whatever the sender's buffer held, so they are never compared.
"""

from __future__ import annotations

import operator
import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from rclpy.serialization import deserialize_message, serialize_message
from tensegrity_msgs.msg import CableCommand

_U32 = struct.Struct("<I")
_STAMP = struct.Struct("<iI")
_HEADER = 4                        # the encapsulation header; alignment counts from its end


def _align(offset: int, size: int) -> int:
    return _HEADER + -(-(offset - _HEADER) // size) * size


@dataclass(frozen=True)
class _Layout:
    """Where a command of one frame-name length keeps its parts: ``fixed(raw)`` is every byte
    that must equal ``expected`` (the representation, counts, the names; not the stamp, the frame
    name, the values or any padding), ``values`` the rest lengths' format and offset."""

    size: int                      # bytes of the message (rclpy's serialize_message adds a few after them)
    fixed: Callable[[bytes], tuple[bytes, ...]]
    expected: tuple[bytes, ...]
    values: struct.Struct
    values_at: int


def _layout(raw: bytes, n: int) -> _Layout:
    """The layout of ``raw``, rclpy's serialization of a command of ``n`` names and ``n`` rest
    lengths (no reel speeds, no tensions): the fields walked in the message's order."""
    spans: list[tuple[int, int]] = [(0, 2)]            # the representation (not its options: padding)
    offset = _HEADER + _STAMP.size                       # header.stamp: sec, nanosec
    (length,) = _U32.unpack_from(raw, offset)          # header.frame_id: length (with its NUL), chars
    offset += _U32.size + length
    offset = _align(offset, 4)
    spans.append((offset, offset + 4))                 # name: count, then each (length, chars)
    offset += 4
    for _ in range(n):
        offset = _align(offset, 4)
        (length,) = _U32.unpack_from(raw, offset)
        spans.append((offset, offset + 4 + length))
        offset += 4 + length
    offset = _align(offset, 4)
    spans.append((offset, offset + 4))                 # rest_length: count, then float64s aligned to 8
    values_at = _align(offset + 4, 8)
    offset = values_at + 8 * n
    for _ in ("reel_speed", "tension"):                # empty: a count of 0
        offset = _align(offset, 4)
        spans.append((offset, offset + 4))
        offset += 4
    fixed = operator.itemgetter(*(slice(b, e) for b, e in spans))
    return _Layout(offset, fixed, fixed(raw), struct.Struct(f"<{n}d"), values_at)


class CableCommandBytes:
    """Reads the commands that name every one of ``names`` (the scene's inputs) in order with
    rest lengths only (module docstring)."""

    def __init__(self, names: Sequence[str]):
        self.names = tuple(names)
        self._layouts: dict[int, _Layout | None] = {}    # per frame-name length; None: not readable

    def read(self, raw: bytes) -> tuple[int, int, tuple[float, ...]] | None:
        """``(sec, nanosec, rest lengths [m])`` of the serialized command ``raw``, or None: not
        of that form (or not readable here), deserialize it."""
        if len(raw) < _HEADER + _STAMP.size + _U32.size or not self.names:
            return None
        (frame_length,) = _U32.unpack_from(raw, _HEADER + _STAMP.size)
        layout = self._layouts.get(frame_length, ...)
        if layout is ...:
            layout = self._layouts[frame_length] = self._checked_layout(frame_length)
        if layout is None or len(raw) < layout.size or layout.fixed(raw) != layout.expected:
            return None
        sec, nanosec = _STAMP.unpack_from(raw, _HEADER)
        return sec, nanosec, layout.values.unpack_from(raw, layout.values_at)

    def _checked_layout(self, frame_length: int) -> _Layout | None:
        """The layout for frame names of ``frame_length`` bytes with their NUL, found in a
        template and checked against rclpy's reading of other values; None where it does not
        check out (another encoding) or for an implausible length."""
        if not 1 <= frame_length <= 4096:
            return None
        n = len(self.names)
        frame = "f" * (frame_length - 1)
        try:
            layout = _layout(serialize_message(_command(self.names, frame, 0, 0, [0.0] * n)), n)
            values = [0.25 + k for k in range(n)]
            raw = serialize_message(_command(self.names, frame, 1_234_567_890, 987_654_321, values))
            if len(raw) < layout.size or layout.fixed(raw) != layout.expected:
                return None
            got = deserialize_message(raw, CableCommand)
        except (struct.error, ValueError):
            return None
        read = (*_STAMP.unpack_from(raw, _HEADER), layout.values.unpack_from(raw, layout.values_at))
        ok = (list(got.name) == list(self.names) and read[2] == tuple(got.rest_length) == tuple(values)
              and read[:2] == (got.header.stamp.sec, got.header.stamp.nanosec) == (1_234_567_890, 987_654_321))
        return layout if ok else None


def _command(names: Sequence[str], frame: str, sec: int, nanosec: int, values: Sequence[float]) -> CableCommand:
    msg = CableCommand(name=list(names), rest_length=list(values))
    msg.header.frame_id = frame
    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
    return msg
