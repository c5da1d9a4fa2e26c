"""Any message of fixed shape as serialized bytes, refilled in place for each publication.

The simulator's joint_states, cable_states, IMU readings and body states keep their names,
kinds, frames and sequence lengths from one publication to the next: only the header's
stamp, runs of float64 (positions, lengths, quaternions, velocities) and runs of bools
(slack) change. Publishing the Python message converts every string and nested message to
C and serializes the whole message each time; :class:`MessageBytes` publishes rclpy's own
serialization of a template with the stamp and the runs written into it.
The layout is not written here: where the stamp and each float run lie is found in rclpy's
serialization of templates with marker values there (:func:`_where`), a bool
run as the one place where all-False and all-True templates read ``0`` and ``1``; the result
is checked once against rclpy's deserializer, and a template that does not check out
leaves :attr:`MessageBytes.ok` False (the caller then publishes messages).
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from rclpy.serialization import deserialize_message, serialize_message

#: Stamp values of non-zero bytes: mark the stamp's bytes.
_MARK_SEC, _MARK_NSEC = 0x1A1A1A1A, 0x1B1B1B1B
_STAMP = struct.Struct("<iI")


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


#: ``build(sec, nanosec, runs)``: the message stamped ``sec``, ``nanosec`` whose runs have
#: the values ``runs`` gives (name -> sequence), zeros or False for a run not given.
Build = Callable[[int, int, Mapping[str, Sequence[Any]]], Any]


def _bool_run(false: bytes, true: bytes, n: int) -> tuple[int, int]:
    """``(first, end)``: the one place where ``false`` holds ``n`` zero bytes and ``true``
    ``n`` one bytes, or ``(0, 0)`` (none, or several)."""
    zeros, ones = bytes(n), b"\x01" * n
    found = [i for i in range(len(true) - n + 1) if true[i:i + n] == ones and false[i:i + n] == zeros]
    return (found[0], found[0] + n) if len(found) == 1 and len(true) == len(false) else (0, 0)


class MessageBytes:
    """The serialized messages of ``build`` (of type ``msg_type``) with the float64 runs
    ``floats`` and the bool runs ``bools`` (name -> length each)."""

    def __init__(self, msg_type: type, build: Build, floats: Mapping[str, int], bools: Mapping[str, int] | None = None):
        self.msg_type = msg_type
        self.build = build
        self.floats, self.bools = dict(floats), dict(bools or {})
        self._buffer = bytearray(serialize_message(build(0, 0, {})))
        self._stamp = _where(serialize_message(build(_MARK_SEC, _MARK_NSEC, {})), _STAMP.pack(_MARK_SEC, _MARK_NSEC))
        places: dict[str, tuple[int, int]] = {}
        for name, n in self.floats.items():
            mark = _marks(n)
            places[name] = _where(serialize_message(build(0, 0, {name: np.frombuffer(mark, "<f8").tolist()})), mark)
        for name, n in self.bools.items():
            places[name] = _bool_run(serialize_message(build(0, 0, {name: [False] * n})),
                                     serialize_message(build(0, 0, {name: [True] * n})), n)
        sizes = {**{k: 8 * n for k, n in self.floats.items()}, **self.bools}
        self.ok = self._stamp[1] > 0 and all(not n or e - b == n for (b, e), n in
                                             ((places[k], sizes[k]) for k in sizes))
        #: Per run: its name and the values of the buffer it fills (written in place).
        self._views: list[tuple[str, NDArray[Any]]] = []
        if self.ok:
            self._views = [(k, np.frombuffer(self._buffer, "<f8", count=n, offset=places[k][0]))
                           for k, n in self.floats.items()]
            self._views += [(k, np.frombuffer(self._buffer, np.bool_, count=n, offset=places[k][0]))
                            for k, n in self.bools.items()]
            rng = np.random.default_rng(0)       # checked once against rclpy's own reading
            values = {**{k: rng.uniform(-1.0, 1.0, n) for k, n in self.floats.items()},
                      **{k: rng.random(n) < 0.5 for k, n in self.bools.items()}}
            got = deserialize_message(self.fill(1_234_567_890, 987_654_321, values), msg_type)
            self.ok = got == build(1_234_567_890, 987_654_321, {k: v.tolist() for k, v in values.items()})

    def fill(self, sec: int, nanosec: int, runs: Mapping[str, Any]) -> bytes:
        """The message stamped ``sec``, ``nanosec`` with every run's values (name -> as many
        float64 or bools as the run has)."""
        buf = self._buffer
        _STAMP.pack_into(buf, self._stamp[0], sec, nanosec)
        for name, view in self._views:
            values = runs[name]
            if len(values) != len(view):      # an assignment would broadcast a single value
                raise ValueError(f"run {name} of {len(view)} values, got {len(values)}")
            view[:] = values
        return bytes(buf)
