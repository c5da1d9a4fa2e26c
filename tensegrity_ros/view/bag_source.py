"""Frames from a recorded bag: a timeline to play, pause, scrub and play faster or slower.

Reads the bag's own data only (no suite, no ROS at run time), decoded by ``mcap-ros2-support``
from the schemas stored in the bag: the class-2 simulator's ``MechanismState`` messages, or a
general structure's or robot's ``body_states`` (or ``markers``), ``cable_states`` and
``contacts`` (:mod:`.structure_frames`), whose topology comes from the scene the suite
simulated: ``scene`` (``tensegrity view BAG --scene NAME``) or, without it, the bag's metadata
(``custom_data: {scene: NAME}``, as ``ros2 bag record --custom-data scene=NAME`` writes), or,
when the metadata names none or cannot be read, a robot's own ``markers`` (:mod:`.marker_robot`).
Messages stay encoded until shown (a long bag costs its size in memory, not a decoded copy);
the timeline's time is the header stamps [s] of the messages that place the nodes, from the
first; each frame takes the latest tensions and contacts stamped at or before it. The
strings' colour scale is the largest tension of the bag (of up to ``SCALE_SAMPLES`` states
spread over it), so a state has the same colours however the timeline reached it.
"""

from __future__ import annotations

import bisect
import math
import os
import struct
import threading
import time
from collections.abc import Callable
from typing import Any, Final

import numpy as np
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory

from tensegrity_core.errors import TensegrityError
from tensegrity_ros.bag.errors import BagError, decoded
from tensegrity_ros.bag.reader import BagReader
from tensegrity_ros.bag.scene import recorded_scene
from tensegrity_ros.view.frame import Frame, Topology
from tensegrity_ros.view.frames import class2_topology, frame_of_mechanism_state
from tensegrity_ros.view.inputs import InputSpec
from tensegrity_ros.view.marker_robot import MarkerRobot, NotDrawable
from tensegrity_ros.view.pacing import Pacer
from tensegrity_ros.view.source import Report, Sink
from tensegrity_ros.view.structure_frames import StructureMessages, stamp_seconds

#: The message types the view draws.
STATE_TYPE: Final = "tensegrity_msgs/msg/MechanismState"
CABLES_TYPE: Final = "tensegrity_msgs/msg/CableStates"
BODIES_TYPE: Final = "tensegrity_msgs/msg/RigidBodyStates"
CONTACTS_TYPE: Final = "tensegrity_msgs/msg/CapContacts"
MARKERS_TYPE: Final = "visualization_msgs/msg/MarkerArray"
#: States decoded at most to find the bag's largest string tension (spread over the bag).
SCALE_SAMPLES: Final = 500


def _ignore(_text: str) -> None:
    """A report nobody reads (before :meth:`BagSource.start`)."""


def _type_name(name: str) -> str:
    """``pkg/msg/Name`` of a stored type name (``pkg/Name`` in older bags)."""
    pkg, _, rest = name.partition("/")
    return name if rest.startswith("msg/") else f"{pkg}/msg/{rest}"


def _header_first(definition: str) -> bool:
    """Whether a ``ros2msg`` definition's first field is ``std_msgs/Header header``."""
    for line in definition.splitlines():
        field = line.split("#", 1)[0].split()
        if field:
            return field == ["std_msgs/Header", "header"]
    return False


def _stamps(encoding: str, definition: str, decode: Callable[[bytes], Any]) -> Callable[[bytes], float]:
    """A message's header stamp [s], as :func:`~.structure_frames.stamp_seconds` gives it.
    For a type whose first field is its header, a plain-CDR message's stamp is read from its
    first bytes (the 4-byte encapsulation, then ``int32 sec``, ``uint32 nanosec``) without
    decoding the message: decoding every message in Python was half the CPU of opening a
    robot's bag (0.45 s for the 6-bar's roll). Others are decoded."""
    def decoded(data: bytes) -> float:
        return stamp_seconds(decode(data))

    if encoding != "ros2msg" or not _header_first(definition):
        return decoded

    def read(data: bytes) -> float:
        kind = data[:2]
        if kind not in (b"\x00\x00", b"\x00\x01") or len(data) < 12:   # CDR_BE, CDR_LE; else decoded
            return decoded(data)
        sec, nanosec = struct.unpack_from("<iI" if kind == b"\x00\x01" else ">iI", data, 4)
        return int(sec) + int(nanosec) * 1e-9

    return read


class _Topic:
    """One topic's messages, encoded, sorted by header stamp, with a decoder."""

    def __init__(self, reader: BagReader, path: object, topic: str, type_name: str):
        definitions = {_type_name(k): v for k, v in reader.definitions().items()}
        encoding, text = definitions[type_name]
        decode = DecoderFactory().decoder_for("cdr", Schema(id=1, name=type_name, encoding=encoding,
                                                            data=text.encode()))
        if decode is None:
            raise BagError(f"bag {path}: cannot decode {topic} (schema encoding {encoding!r})")
        self.name = topic
        self._path = path
        self._decode = decode
        stamp = _stamps(encoding, text, decode)
        pairs = [(self._guarded(stamp, m.data, f"message {i} (in the bag's order)"), m.data)
                 for i, m in enumerate(reader.messages([topic]))]
        pairs = sorted((p for p in pairs if math.isfinite(p[0])), key=lambda p: p[0])   # stamped ones
        self.times = [t for t, _ in pairs]
        self.data = [d for _, d in pairs]

    def at(self, index: int) -> Any:
        """The ``index``-th message (in stamp order), decoded; a BagError if it cannot be."""
        return self._guarded(self._decode, self.data[index], f"the message stamped {self.times[index]:.9f} s "
                             f"({index + 1} of {len(self.data)})")

    def _guarded(self, read: Callable[[bytes], Any], data: bytes, which: str) -> Any:
        """``read(data)``, or a one-line BagError naming the message (``which``)."""
        return decoded(read, data, f"bag {self._path}: {which} on {self.name}")

    def latest(self, t: float) -> Any:
        """The last message stamped at or before ``t`` [s] (the first if none is), or None if empty."""
        if not self.data:
            return None
        return self.at(max(0, bisect.bisect_right(self.times, t) - 1))


class BagSource:
    """The timeline of the states in the bag at ``path`` (folder or .mcap); ``scene`` names the
    scene a general structure's or robot's bag was recorded from (see the module docstring)."""

    inputs: tuple[InputSpec, ...] = ()

    def __init__(self, path: str | os.PathLike[str], scene: str | None = None, *, fps: float = 60.0):
        #: the timeline's ticks while playing, one frame each at most: ``fps`` a second, the
        #: view's frame rate (a state decoded between two the view sends would only be dropped)
        self.pacer = Pacer(1.0 / fps)
        reader = BagReader(path)
        types = {t.name: _type_name(t.type) for t in reader.topics()}
        of_type = {kind: [n for n, k in types.items() if k == kind] for kind in set(types.values())}
        self._structure: StructureMessages | MarkerRobot | None = None
        self._cables: _Topic | None = None
        self._contacts: _Topic | None = None
        self._read: dict[str, _Topic] = {}
        if of_type.get(STATE_TYPE):
            self._nodes = _Topic(reader, path, of_type[STATE_TYPE][0], STATE_TYPE)
            self.topology: Topology = class2_topology()
        elif of_type.get(CABLES_TYPE):
            self._structure = self._described(reader, path, of_type, scene)
            self._nodes = self._structure_topics(reader, path, of_type, self._structure)
            self.topology = self._structure.topology
        else:
            raise BagError(f"bag {path} has no {STATE_TYPE} or {CABLES_TYPE} topic to draw (record the simulator's "
                           "states: `tensegrity record`)")
        self.topic = self._nodes.name
        self._times = self._nodes.times
        if not self._times:
            raise BagError(f"bag {path}: {self.topic} has no messages")
        self.t0 = self._times[0]
        self.duration = self._times[-1] - self.t0
        self.tension_scale = self._largest_tension()
        self.label = f"bag {os.fspath(path)}: {self.topic}, {len(self._times)} states over {self.duration:.3f} s"
        if isinstance(self._structure, MarkerRobot):
            self.label += f"; {self._structure.label}"
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

    def _topic(self, reader: BagReader, path: object, name: str, type_name: str) -> _Topic:
        """The topic ``name`` of the bag, read once."""
        if name not in self._read:
            self._read[name] = _Topic(reader, path, name, type_name)
        return self._read[name]

    def _described(self, reader: BagReader, path: object, of_type: dict[str, list[str]],
                   scene: str | None) -> StructureMessages | MarkerRobot:
        """What draws a structure's bag: ``scene``, else the scene its metadata names, else
        the robot its own markers draw (:mod:`.marker_robot`); else a one-line BagError
        saying what is missing."""
        cables = of_type[CABLES_TYPE][0]
        unread = ""
        if not scene:
            try:
                _ = reader.custom_data         # checked here: a malformed one refuses nothing
            except TensegrityError as err:     # the messages may still draw the robot
                unread = f" (its custom_data cannot be read: {err})"
            else:
                scene = recorded_scene(reader, path)
        if scene:
            try:
                return StructureMessages(scene)
            except TensegrityError as err:
                raise BagError(f"bag {path}: scene {scene}: {err}") from None
        space = cables.rpartition("/")[0]
        markers = next((n for n in of_type.get(MARKERS_TYPE, []) if n.rpartition("/")[0] == space), None)
        why = "it has no markers topic beside it"
        if markers is not None:
            topic, names = self._topic(reader, path, markers, MARKERS_TYPE), self._topic(reader, path, cables, CABLES_TYPE)
            why = "its markers topic is empty" if not topic.data or not names.data else ""
            if not why:
                try:
                    return MarkerRobot(topic.at(0), names.at(0).name)
                except NotDrawable as err:
                    why = str(err)
        raise BagError(f"bag {path} holds a general structure's or robot's states ({cables}) but not which "
                       f"structure{unread}, and {why}: name the scene it was recorded from with --scene NAME "
                       "(`tensegrity scenes`)")

    def _structure_topics(self, reader: BagReader, path: object, of_type: dict[str, list[str]],
                          structure: StructureMessages | MarkerRobot) -> _Topic:
        """The topics of a general structure or robot, checked against its scene; the topic
        that places the nodes."""
        cables = of_type[CABLES_TYPE][0]
        space = cables.rpartition("/")[0]
        drawn = repr(structure.scene.name) if isinstance(structure, StructureMessages) else "the robot"

        def beside(kind: str) -> str | None:      # the topic of this type in the same namespace
            return next((n for n in of_type.get(kind, []) if n.rpartition("/")[0] == space), None)

        self._cables = self._topic(reader, path, cables, CABLES_TYPE)
        contacts = beside(CONTACTS_TYPE)
        self._contacts = self._topic(reader, path, contacts, CONTACTS_TYPE) if contacts else None
        kind = BODIES_TYPE if structure.nodes_topic == "body_states" else MARKERS_TYPE
        topic = beside(kind)
        if topic is None:
            raise BagError(f"bag {path} has no {structure.nodes_topic} topic beside {cables}: the nodes of "
                           f"{drawn} come from it")
        nodes = self._topic(reader, path, topic, kind)
        try:
            if self._cables.data:
                structure.check_members(self._cables.at(0).name)
            if kind == BODIES_TYPE and nodes.data:
                structure.check_bodies(nodes.at(0).name)
        except TensegrityError as err:
            raise BagError(f"bag {path}: {err}") from None
        if kind == MARKERS_TYPE:      # only the marker arrays with every node place them
            keep = [i for i in range(len(nodes.data)) if structure.nodes_of_markers(nodes.at(i)) is not None]
            nodes.times = [nodes.times[i] for i in keep]
            nodes.data = [nodes.data[i] for i in keep]
        return nodes

    def _largest_tension(self) -> float:
        """The largest string tension [N] of up to ``SCALE_SAMPLES`` states spread over the bag."""
        strings = self.topology.of_kind("string")
        source = self._cables if self._structure is not None else self._nodes
        if source is None or not source.data:
            return 0.0
        field = "tension" if self._structure is not None else "member_forces"
        every = max(1, len(source.data) // SCALE_SAMPLES)
        return max(float(np.max(np.asarray(getattr(source.at(i), field))[strings], initial=0.0))
                   for i in [*range(0, len(source.data), every), len(source.data) - 1])

    def frame_at(self, index: int) -> Frame:
        """The ``index``-th state of the timeline."""
        msg = self._nodes.at(index)
        if self._structure is None:
            return frame_of_mechanism_state(msg, "recorded")
        t = self._times[index]
        structure = self._structure
        placed = (structure.nodes_of_bodies(msg) if isinstance(structure, StructureMessages)
                  and structure.nodes_topic == "body_states" else structure.nodes_of_markers(msg))
        assert placed is not None          # only marker arrays with every node are on the timeline
        cables = self._cables.latest(t) if self._cables is not None else None
        contacts = self._contacts.latest(t) if self._contacts is not None else None
        return self._structure.frame(t, placed, cables, contacts, "recorded")

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
        """Tick on the pacer's grid (the time a frame takes to decode is within the period)."""
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
                try:
                    frame = self.frame_at(index)
                except BagError as err:       # a damaged message: said, and the last frame stays shown
                    self._report(f"error: {err}")
                else:
                    sink(frame)
            self._wake.wait(max(0.0, self.pacer.tick(now) - time.monotonic()))
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

