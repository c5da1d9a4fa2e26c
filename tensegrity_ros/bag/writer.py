"""Write a rosbag2 bag folder with MCAP storage, using the ``mcap`` library's writer.

A bag folder ``DIR`` holds ``DIR_0.mcap`` and ``metadata.yaml``. The MCAP file has profile
``ros2``; one schema per message type (name ``pkg/msg/Name``, encoding ``ros2msg``, the
full definition from :mod:`.msgdefs`); one channel per topic (message encoding ``cdr``,
metadata ``offered_qos_profiles`` in rosbag2's YAML form and ``topic_type_hash``); each
message with its log time (receive time) and publish time in nanoseconds since the epoch.
Closing adds a ``rosbag2`` metadata record (``serialized_metadata``) as rosbag2 Jazzy does,
the summary section, and ``metadata.yaml``. A bag with ``custom_data`` also gets, right after
the MCAP header, a metadata record ``tensegrity_custom_data`` (:data:`CUSTOM_DATA_RECORD`, the
same keys and values) written to the operating system before any message: a recorder
killed before it closed leaves no ``metadata.yaml`` and no ``rosbag2`` record, and this is
where :func:`tensegrity_ros.bag.repair.repair_bag` finds the custom_data again.

Durability: messages are grouped in chunks that are closed when they reach ``chunk_size``
bytes or when :meth:`BagWriter.maybe_flush` finds the oldest message of the open chunk
``flush_interval`` seconds old (default :data:`DEFAULT_FLUSH_INTERVAL`). "Flushed" means
what a reader of the file after a crash can use: the MCAP writer closes the chunk (writes
the complete, CRC-checked chunk record and its message indexes) and the file buffer is
written to the operating system (``write``, no ``fsync``: it survives the process being
killed, not a power cut). Messages of a chunk not yet closed exist only in this process's
memory. So a recorder killed with SIGKILL loses at most the last ``flush_interval`` s
(plus what its subscriptions had received but it had not taken yet), and
:func:`tensegrity_ros.bag.repair.repair_bag` recovers every closed chunk. A shorter
interval loses less and makes more, smaller chunks (compressed a little less well).
"""

from __future__ import annotations

import os
import time
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import yaml
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter

from tensegrity_ros.bag.errors import BagError
from tensegrity_ros.bag.metadata import BagMetadata, FileInfo, TopicInfo, write_metadata
from tensegrity_ros.bag.msgdefs import full_definition
from tensegrity_ros.bag.qos import dump_profiles

DEFAULT_CHUNK_SIZE = 768 * 1024   # bytes; rosbag2's MCAP default
DEFAULT_FLUSH_INTERVAL = 0.1      # seconds (a SIGKILL loses at most about this; 1 s lost ~0.45 s)
#: Name of the MCAP metadata record holding ``custom_data`` from the start of the file.
CUSTOM_DATA_RECORD = "tensegrity_custom_data"
COMPRESSIONS = {"none": CompressionType.NONE, "zstd": CompressionType.ZSTD,
                "lz4": CompressionType.LZ4}


def _library_id() -> str:
    def ver(dist: str) -> str:
        try:
            return version(dist)
        except PackageNotFoundError:
            return "unknown"
    return f"tensegrity-ros {ver('tensegrity-ros')}; mcap {ver('mcap')}"


def mcap_file_name(folder: Path) -> str:
    """rosbag2's name of the first storage file of bag folder ``folder``."""
    return f"{folder.name}_0.mcap"


class BagWriter:
    """Write one bag folder. Use as a context manager or call :meth:`close`.

    ``folder`` must not exist yet (like rosbag2, a bag is never overwritten). The storage
    file is ``<folder name>_0.mcap`` unless ``file_name`` says otherwise.
    ``compression`` is the MCAP chunk compression: ``"zstd"`` (default), ``"lz4"``, ``"none"``.
    ``custom_data``: the metadata's ``custom_data`` (as ``ros2 bag record --custom-data``), e.g.
    ``{"scene": "six_bar_rest"}``, the scene the run simulated (``tensegrity view BAG`` draws it).
    """

    def __init__(self, folder: str | os.PathLike[str], *, chunk_size: int = DEFAULT_CHUNK_SIZE,
                 compression: str = "zstd", flush_interval: float = DEFAULT_FLUSH_INTERVAL,
                 file_name: str | None = None, custom_data: dict[str, str] | None = None):
        if not isinstance(chunk_size, int) or chunk_size < 1024:
            raise BagError(f"chunk_size must be an integer >= 1024 bytes, got {chunk_size!r}")
        if compression not in COMPRESSIONS:
            raise BagError(f"compression must be one of {sorted(COMPRESSIONS)}, got {compression!r}")
        if not flush_interval > 0:
            raise BagError(f"flush_interval must be > 0 s, got {flush_interval!r}")
        self.folder = Path(folder)
        if self.folder.exists():
            raise BagError(f"{self.folder} exists already; a bag is never overwritten")
        try:
            self.folder.mkdir(parents=True)
        except OSError as err:
            raise BagError(f"cannot create bag folder {self.folder}: {err.strerror}") from None
        self.path = self.folder / (file_name or mcap_file_name(self.folder))
        self._stream = open(self.path, "wb")
        # mcap has no type information
        self._mcap: Any = McapWriter(self._stream, chunk_size=chunk_size, compression=COMPRESSIONS[compression])
        self._mcap.start(profile="ros2", library=_library_id())
        self.custom_data = dict(custom_data) if custom_data else None
        if self.custom_data:      # survives a kill (see the module docstring)
            self._mcap.add_metadata(CUSTOM_DATA_RECORD, self.custom_data)
        self._stream.flush()      # killed before its first chunk, it is still an MCAP file
        self._flush_interval = flush_interval
        self._unflushed_since: float | None = None
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self.topics: dict[str, TopicInfo] = {}
        self._start: int | None = None         # first and last log time [ns]
        self._end: int | None = None
        self._closed = False

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def add_topic(self, topic: TopicInfo, definition: str | None = None,
                  encoding: str = "ros2msg") -> None:
        """Register a topic (schema once per type, one channel per topic).

        ``definition`` is the full schema text in ``encoding``; by default the ``ros2msg``
        text built from the installed .msg files.
        """
        if topic.name in self.topics:
            raise BagError(f"topic {topic.name} is already in bag {self.folder}")
        if topic.type not in self._schemas:
            if definition is None:
                definition, encoding = full_definition(topic.type), "ros2msg"
            self._schemas[topic.type] = self._mcap.register_schema(
                name=topic.type, encoding=encoding, data=definition.encode("utf-8"))
        self._channels[topic.name] = self._mcap.register_channel(
            topic=topic.name,
            message_encoding=topic.serialization_format,
            schema_id=self._schemas[topic.type],
            metadata={"offered_qos_profiles": dump_profiles(topic.offered_qos_profiles),
                      "topic_type_hash": topic.type_description_hash},
        )
        self.topics[topic.name] = TopicInfo(
            name=topic.name, type=topic.type, serialization_format=topic.serialization_format,
            offered_qos_profiles=list(topic.offered_qos_profiles),
            type_description_hash=topic.type_description_hash, message_count=0)

    def write(self, topic: str, data: bytes, log_time_ns: int, publish_time_ns: int | None = None,
              sequence: int = 0) -> None:
        """Append one serialized (CDR) message of a registered topic."""
        channel = self._channels.get(topic)
        if channel is None:
            raise BagError(f"topic {topic} was not added to bag {self.folder}")
        log_time_ns = int(log_time_ns)
        self._mcap.add_message(
            channel_id=channel, log_time=log_time_ns, data=bytes(data),
            publish_time=log_time_ns if publish_time_ns is None else int(publish_time_ns),
            sequence=int(sequence) & 0xFFFFFFFF)
        self.topics[topic].message_count += 1
        self._start = log_time_ns if self._start is None else min(self._start, log_time_ns)
        self._end = log_time_ns if self._end is None else max(self._end, log_time_ns)
        if self._unflushed_since is None:
            self._unflushed_since = time.monotonic()

    def flush(self) -> None:
        """Close the open chunk (if it has messages) and hand everything to the OS."""
        self._mcap.flush()
        self._stream.flush()
        self._unflushed_since = None

    def maybe_flush(self) -> bool:
        """:meth:`flush` if the oldest unflushed message is ``flush_interval`` s old."""
        if (self._unflushed_since is not None
                and time.monotonic() - self._unflushed_since >= self._flush_interval):
            self.flush()
            return True
        return False

    def metadata(self) -> BagMetadata:
        """The bag's metadata as of now."""
        count = sum(t.message_count for t in self.topics.values())
        start = self._start or 0
        duration = self._end - self._start if self._start is not None and self._end is not None else 0
        return BagMetadata(
            topics=[TopicInfo(**vars(t)) for t in self.topics.values()],
            files=[FileInfo(self.path.name, start, duration, count)],
            starting_time_ns=start, duration_ns=duration, message_count=count, custom_data=self.custom_data)

    def close(self) -> BagMetadata:
        """Finish the MCAP file (summary, footer) and write ``metadata.yaml``. Idempotent."""
        meta = self.metadata()
        if self._closed:
            return meta
        self._closed = True
        info = meta.to_dict()["rosbag2_bagfile_information"]
        self._mcap.add_metadata("rosbag2", {"serialized_metadata": yaml.safe_dump(
            info, default_flow_style=False, sort_keys=False)})
        self._mcap.finish()
        self._stream.flush()
        os.fsync(self._stream.fileno())
        self._stream.close()
        write_metadata(self.folder, meta)
        return meta
