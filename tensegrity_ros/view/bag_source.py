"""Frames from a recorded bag: a timeline to play, pause, scrub and play faster or slower.

Reads the bag's own data only (no suite, no ROS at run time): the ``MechanismState``
messages of the class-2 simulator, decoded by ``mcap-ros2-support`` from the schema stored
in the bag. Messages stay encoded until shown (a long bag costs its size in memory, not a
decoded copy); the timeline's time is the messages' header stamps [s] from the first. The
strings' colour scale is the largest tension of the bag (of up to ``SCALE_SAMPLES`` states
spread over it), so a state has the same colours however the timeline reached it.
"""

from __future__ import annotations

import bisect
import os
import threading
import time
from collections.abc import Callable
from typing import Any, Final

import numpy as np
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory

from tensegrity_ros.bag.errors import BagError
from tensegrity_ros.bag.reader import BagReader
from tensegrity_ros.view.frame import Frame
from tensegrity_ros.view.frames import class2_topology, frame_of_mechanism_state
from tensegrity_ros.view.inputs import InputSpec
from tensegrity_ros.view.source import Report, Sink

#: The message types the view draws, and the topic names it looks for them on.
STATE_TYPE: Final = "tensegrity_msgs/msg/MechanismState"
#: Timeline ticks per second of wall time while playing.
TICK_HZ: Final = 60.0
#: States decoded at most to find the bag's largest string tension (spread over the bag).
SCALE_SAMPLES: Final = 500


def _ignore(_text: str) -> None:
    """A report nobody reads (before :meth:`BagSource.start`)."""


class BagSource:
    """The timeline of the mechanism states in the bag at ``path`` (folder or .mcap)."""

    inputs: tuple[InputSpec, ...] = ()

    def __init__(self, path: str | os.PathLike[str]):
        reader = BagReader(path)
        topics = [t.name for t in reader.topics() if t.type in (STATE_TYPE, "tensegrity_msgs/MechanismState")]
        if not topics:
            raise BagError(f"bag {path} has no {STATE_TYPE} topic to draw (record the simulator's "
                           "mechanism_state: `tensegrity record`)")
        self.topic = topics[0]
        encoding, text = reader.definitions()[next(t.type for t in reader.topics() if t.name == self.topic)]
        schema = Schema(id=1, name=STATE_TYPE, encoding=encoding, data=text.encode())
        decode = DecoderFactory().decoder_for("cdr", schema)
        if decode is None:
            raise BagError(f"bag {path}: cannot decode {self.topic} (schema encoding {encoding!r})")
        self._decode: Callable[[bytes], Any] = decode
        self._data: list[bytes] = []
        self._times: list[float] = []
        for m in reader.messages([self.topic]):
            msg = self._decode(m.data)
            self._data.append(m.data)
            self._times.append(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)
        if not self._data:
            raise BagError(f"bag {path}: {self.topic} has no messages")
        order = sorted(range(len(self._times)), key=self._times.__getitem__)   # by stamp, as a timeline
        self._data = [self._data[i] for i in order]
        self._times = [self._times[i] for i in order]
        self.t0 = self._times[0]
        self.duration = self._times[-1] - self.t0
        self.topology = class2_topology()
        strings = self.topology.of_kind("string")
        every = max(1, len(self._data) // SCALE_SAMPLES)
        self.tension_scale = max(float(np.max(np.asarray(self._decode(d).member_forces)[strings], initial=0.0))
                                 for d in [*self._data[::every], self._data[-1]])
        self.label = f"bag {os.fspath(path)}: {self.topic}, {len(self._data)} states over {self.duration:.3f} s"
        self.features = frozenset({"run", "timeline"})
        self._lock = threading.Lock()
        self._playhead = 0.0
        self._rate = 1.0
        self._playing = False
        self._shown = -1
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._report: Report = _ignore

    def frame_at(self, index: int) -> Frame:
        return frame_of_mechanism_state(self._decode(self._data[index]), "recorded")

    def first_frame(self, timeout: float = 0.0) -> Frame:
        return self.frame_at(0)

    def index_at(self, t: float) -> int:
        """The last state at or before ``t`` [s] from the start (the first one before it)."""
        return max(0, bisect.bisect_right(self._times, self.t0 + t) - 1)

    def start(self, sink: Sink, report: Report) -> None:
        self._report = report
        self._thread = threading.Thread(target=self._run, args=(sink,), name="view_bag", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join()

    def _run(self, sink: Sink) -> None:
        last = time.monotonic()
        while not self._stop.is_set():
            now = time.monotonic()
            with self._lock:
                if self._playing:
                    self._playhead = min(self.duration, self._playhead + (now - last) * self._rate)
                    if self._playhead >= self.duration:
                        self._playing = False
                        self._report(f"end of the bag ({self.duration:.3f} s)")
                index = self.index_at(self._playhead)
                changed, self._shown = index != self._shown, index
            last = now
            if changed:
                sink(self.frame_at(index))
            self._wake.wait(1.0 / TICK_HZ)
            self._wake.clear()

    def play(self) -> None:
        with self._lock:
            if self._playhead >= self.duration:
                self._playhead = 0.0
            self._playing = True
        self._report(f"playing at {self._rate:g} x real time")
        self._wake.set()

    def pause(self) -> None:
        with self._lock:
            self._playing = False
        self._report(f"paused at {self._playhead:.3f} s")
        self._wake.set()

    def seek(self, t: float) -> None:
        with self._lock:
            self._playhead = min(max(0.0, float(t)), self.duration)
        self._wake.set()

    def set_rate(self, rate: float) -> None:
        with self._lock:
            self._rate = float(rate)
        self._report(f"rate {rate:g} x real time")

    def step(self, steps: int) -> None:
        self._report("a bag has no steps: scrub the timeline")

    def drive(self, values: dict[str, float] | None) -> None:
        self._report("a bag's inputs are recorded: nothing to drive")

    def move(self, x: float, y: float, duration: float) -> None:
        self._report("a bag is a recording: nothing to move")

