"""Read rosbag2 MCAP bags: complete ones through their index, damaged ones by a linear scan.

:class:`BagReader` accepts a bag folder (with or without ``metadata.yaml``) or a single
``.mcap`` file. The storage files are those listed in ``metadata.yaml``, else every
``*.mcap`` in the folder. A file whose summary section cannot be read (a recording that
was killed) is scanned record by record from the start; the scan keeps every record up to
the first one that is truncated or fails its CRC, so every chunk that was completely
written is recovered, and :attr:`BagReader.recovered` is set. The bag's ``custom_data``
(:attr:`BagReader.custom_data`) is ``metadata.yaml``'s, else the storage's own (a killed
recording has no ``metadata.yaml``); a malformed one refuses nothing but itself (reading it
raises :class:`BagError`), the messages are read all the same.

Messages come out in log-time (receive-time) order, ties in file order, so the order per
topic is the order of reception.

A bag is data from elsewhere: every file it names is resolved inside its folder
(:mod:`.untrusted`), records are at most ``MAX_RECORD_BYTES`` and chunks decompress to at
most ``MAX_CHUNK_BYTES`` (a few kilobytes of zstd can claim gigabytes), and whatever the
``mcap`` library raises on a malformed file becomes a :class:`BagError` naming the file.
"""

from __future__ import annotations

import dataclasses
import heapq
import io
import os
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

import lz4.frame
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.reader import make_reader
from mcap.records import Channel, Chunk, ChunkIndex, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader, breakup_chunk

from tensegrity_core.excerpt import clip, excerpt
from tensegrity_ros.bag.errors import BagError
from tensegrity_ros.bag.metadata import METADATA_FILE, BagMetadata, FileInfo, MetadataReader, TopicInfo, read_metadata
from tensegrity_ros.bag.qos import parse_profiles
from tensegrity_ros.bag.untrusted import load_bag_yaml, open_regular, path_inside
from tensegrity_ros.bag.writer import CUSTOM_DATA_RECORD

#: Largest MCAP record read from a bag [bytes] (a chunk of rosbag2's default is 768 KiB).
MAX_RECORD_BYTES = 256 * 1024 * 1024
#: Largest decompressed chunk [bytes].
MAX_CHUNK_BYTES = 256 * 1024 * 1024


@dataclass(frozen=True)
class BagMessage:
    """One stored message: CDR bytes and times in nanoseconds since the epoch."""

    topic: str
    type: str
    data: bytes
    log_time_ns: int
    publish_time_ns: int
    sequence: int


@dataclass
class _FileContent:
    path: Path
    schemas: dict[int, Schema]
    channels: dict[int, Channel]
    counts: dict[int, int]
    start_ns: int | None
    end_ns: int | None
    recovered: bool
    messages: list[Message] | None  # kept only for scanned (damaged) files
    damage: str = ""
    chunk_indexes: list[ChunkIndex] = dataclasses.field(default_factory=list)  # complete files
    records: dict[str, dict[str, str]] = dataclasses.field(default_factory=dict)  # metadata records by name


def _chunk_records(chunk: Chunk, path: Path) -> list[Any]:
    """The records of ``chunk``, decompressed to at most ``MAX_CHUNK_BYTES`` (zstd frames
    carry their own content size, which ``zstandard.decompress`` trusts over any limit)."""
    if chunk.compression == "zstd":
        with zstandard.ZstdDecompressor().stream_reader(io.BytesIO(chunk.data)) as stream:
            data = stream.read(MAX_CHUNK_BYTES + 1)
    elif chunk.compression == "lz4":
        data = lz4.frame.LZ4FrameDecompressor().decompress(chunk.data, max_length=MAX_CHUNK_BYTES + 1)
    elif chunk.compression == "":
        data = chunk.data
    else:
        raise BagError(f"{path}: chunk compression {excerpt(chunk.compression)} is not "
                       "supported (zstd, lz4 or none)")
    if len(data) > MAX_CHUNK_BYTES:
        raise BagError(f"{path}: a chunk decompresses to more than {MAX_CHUNK_BYTES} bytes")
    if len(data) != chunk.uncompressed_size:
        raise BagError(f"{path}: a chunk decompresses to {len(data)} bytes, its header says "
                       f"{chunk.uncompressed_size}")
    return breakup_chunk(dataclasses.replace(chunk, compression="", data=data), validate_crc=True)


def _scan(path: Path) -> _FileContent:
    """Linear scan of a possibly truncated file; stops at the first damaged record.
    :class:`BagError` if not even the MCAP header can be read (not an MCAP file)."""
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    messages: list[Message] = []
    records: dict[str, dict[str, str]] = {}
    damage = ""
    header = False
    with open_regular(path, "storage file") as f:
        try:
            for record in StreamReader(f, emit_chunks=True, validate_crcs=True,
                                       record_size_limit=MAX_RECORD_BYTES).records:
                header = header or isinstance(record, Header)
                for r in _chunk_records(record, path) if isinstance(record, Chunk) else [record]:
                    if isinstance(r, Schema):
                        schemas[r.id] = r
                    elif isinstance(r, Channel):
                        channels[r.id] = r
                    elif isinstance(r, Message):
                        messages.append(r)
                    elif isinstance(r, Metadata):
                        records[r.name] = dict(r.metadata)
        except Exception as err:  # truncation, CRC, torn compressed chunk: many error types
            damage = clip(f"{type(err).__name__}: {err}" if str(err) else type(err).__name__, 200)
    if not header:
        raise BagError(f"storage file {path} is not an MCAP file ({damage or 'no header'})")
    # Messages of a torn chunk are never kept (the chunk is read whole before breakup).
    messages.sort(key=lambda m: m.log_time)
    counts: dict[int, int] = {}
    for m in messages:
        counts[m.channel_id] = counts.get(m.channel_id, 0) + 1
    return _FileContent(
        path=path, schemas=schemas, channels=channels, counts=counts,
        start_ns=messages[0].log_time if messages else None,
        end_ns=messages[-1].log_time if messages else None,
        recovered=True, messages=messages, damage=damage, records=records)


def _open(path: Path) -> _FileContent:
    with open_regular(path, "storage file") as f:
        try:
            mcap = make_reader(f)
            summary = mcap.get_summary()
            if summary is not None:
                size = os.fstat(f.fileno()).st_size
                for ci in summary.chunk_indexes:
                    _check_index(ci, size)
                records = {m.name: dict(m.metadata) for m in mcap.iter_metadata()}
        except Exception:  # no footer, torn or implausible summary: fall back to the scan
            summary = None
    if summary is None or summary.statistics is None:
        return _scan(path)
    stats = summary.statistics
    has_messages = stats.message_count > 0
    return _FileContent(
        path=path, schemas=dict(summary.schemas), channels=dict(summary.channels),
        counts=dict(stats.channel_message_counts),
        start_ns=stats.message_start_time if has_messages else None,
        end_ns=stats.message_end_time if has_messages else None,
        recovered=False, messages=None, chunk_indexes=list(summary.chunk_indexes), records=records)


def _check_index(ci: ChunkIndex, file_size: int) -> None:
    if not (0 < ci.chunk_length <= MAX_RECORD_BYTES + 9
            and ci.chunk_start_offset + ci.chunk_length <= file_size
            and ci.uncompressed_size <= MAX_CHUNK_BYTES):
        raise ValueError("chunk index outside the file or over the size limits")


def _read_indexed_chunk(f: BinaryIO, ci: ChunkIndex, path: Path) -> list[Any]:
    """The records of the chunk that index ``ci`` points to (a complete file's read path)."""
    f.seek(ci.chunk_start_offset)
    raw = f.read(ci.chunk_length)
    stream = ReadDataStream(io.BytesIO(raw))
    if len(raw) != ci.chunk_length or stream.read1() != Opcode.CHUNK or \
            stream.read8() != ci.chunk_length - 9:
        raise BagError(f"{path}: the summary's chunk index does not point to a chunk")
    return _chunk_records(Chunk.read(stream), path)


class BagReader:
    """Read a bag folder or an ``.mcap`` file (see the module docstring)."""

    def __init__(self, path: str | os.PathLike[str]):
        path = Path(path)
        if not path.exists():
            raise BagError(f"bag {path} does not exist")
        self.metadata: BagMetadata | None = None
        if not path.is_dir():
            self.folder = path.parent
            files = [path]
        else:
            self.folder = path
            if os.path.lexists(path / METADATA_FILE):
                self.metadata = read_metadata(path)
                if self.metadata.storage_identifier not in ("mcap", ""):
                    raise BagError(f"bag {path} uses storage "
                                   f"{excerpt(self.metadata.storage_identifier)}; only 'mcap' "
                                   "is supported")
                files = [path_inside(path, p, "storage file")
                         for p in self.metadata.relative_file_paths]
                if len({f.resolve() for f in files}) != len(files):
                    raise BagError(f"{path / METADATA_FILE} lists a storage file twice")
            else:
                files = [path_inside(path, p.name, "storage file") for p in sorted(path.glob("*.mcap"))]
            if not files:
                raise BagError(f"bag {path} has no .mcap storage file")
        self._files = [_open(f) for f in files]
        self.files = [c.path for c in self._files]

    @property
    def recovered(self) -> bool:
        """True if a storage file had no valid summary and was read by the recovery scan."""
        return any(c.recovered for c in self._files)

    @property
    def damage(self) -> list[str]:
        """Where the recovery scan stopped, per damaged file ("" for intact files)."""
        return [f"{c.path.name}: {c.damage}" for c in self._files if c.damage]

    @property
    def custom_data(self) -> dict[str, str] | None:
        """The bag's ``custom_data``: ``metadata.yaml``'s when the folder has one, else the
        first storage file's record written at the start of a recording
        (:data:`~tensegrity_ros.bag.writer.CUSTOM_DATA_RECORD`), else the ``custom_data`` in its
        ``rosbag2`` record (written when a recording closes, by rosbag2 too); checked as
        ``metadata.yaml``'s are. :class:`BagError` (one line naming the file and the field) when
        the one that counts is malformed: the messages are still read."""
        if self.metadata is not None:
            if self.metadata.custom_data_error:
                raise BagError(self.metadata.custom_data_error)
            return self.metadata.custom_data
        for content in self._files:
            source = f"{content.path} (metadata record)"
            if CUSTOM_DATA_RECORD in content.records:
                return MetadataReader(source).custom_data({"custom_data": content.records[CUSTOM_DATA_RECORD]}, ())
            serialized = content.records.get("rosbag2", {}).get("serialized_metadata")
            if serialized is not None:
                info = load_bag_yaml(serialized, f"{content.path}: rosbag2's serialized_metadata")
                return MetadataReader(source).custom_data(info if isinstance(info, dict) else {}, ())
        return None

    @property
    def start_ns(self) -> int | None:
        starts = [c.start_ns for c in self._files if c.start_ns is not None]
        return min(starts) if starts else None

    @property
    def end_ns(self) -> int | None:
        ends = [c.end_ns for c in self._files if c.end_ns is not None]
        return max(ends) if ends else None

    @property
    def size_bytes(self) -> int:
        return sum(p.stat().st_size for p in self.files)

    def file_infos(self) -> list[FileInfo]:
        """Per storage file: name, first log time, duration, message count (as found)."""
        out = []
        for c in self._files:
            start = c.start_ns or 0
            duration = c.end_ns - c.start_ns if c.start_ns is not None and c.end_ns is not None else 0
            out.append(FileInfo(c.path.name, start, duration, sum(c.counts.values())))
        return out

    def _meta_topic(self, name: str) -> TopicInfo | None:
        if self.metadata is None:
            return None
        return next((t for t in self.metadata.topics if t.name == name), None)

    def topics(self) -> list[TopicInfo]:
        """Topics with their message counts as found in the storage, in channel order."""
        out: dict[str, TopicInfo] = {}
        for content in self._files:
            for cid, ch in content.channels.items():
                schema = content.schemas.get(ch.schema_id)
                meta = self._meta_topic(ch.topic)
                if ch.topic not in out:
                    qos_text = ch.metadata.get("offered_qos_profiles")
                    out[ch.topic] = TopicInfo(
                        name=ch.topic,
                        type=schema.name if schema else (meta.type if meta else ""),
                        serialization_format=ch.message_encoding,
                        offered_qos_profiles=(parse_profiles(qos_text) if qos_text is not None
                                              else (meta.offered_qos_profiles if meta else [])),
                        type_description_hash=ch.metadata.get(
                            "topic_type_hash", meta.type_description_hash if meta else ""),
                        message_count=0)
                out[ch.topic].message_count += content.counts.get(cid, 0)
        return list(out.values())

    def definitions(self) -> dict[str, tuple[str, str]]:
        """Message type -> (schema encoding, schema text) as stored."""
        out = {}
        for c in self._files:
            for s in c.schemas.values():
                try:
                    out[s.name] = (s.encoding, s.data.decode("utf-8"))
                except UnicodeDecodeError:
                    raise BagError(f"{c.path}: the schema of {excerpt(s.name)} is not UTF-8 "
                                   "text") from None
        return out

    def _iter_file(self, content: _FileContent, topics: set[str] | None,
                   start_ns: int | None) -> Iterator[BagMessage]:
        def make(channel: Channel, m: Message) -> BagMessage:
            schema = content.schemas.get(channel.schema_id)
            return BagMessage(channel.topic, schema.name if schema else "", bytes(m.data),
                              m.log_time, m.publish_time, m.sequence)

        if content.messages is not None:
            for m in content.messages:
                ch = content.channels.get(m.channel_id)
                if ch is None or (topics is not None and ch.topic not in topics):
                    continue
                if start_ns is not None and m.log_time < start_ns:
                    continue
                yield make(ch, m)
            return
        try:
            yield from self._iter_indexed(content, topics, start_ns, make)
        except BagError:
            raise
        except Exception as err:  # a malformed chunk of a file with a valid summary
            raise BagError(f"storage file {content.path} is damaged: "
                           f"{clip(f'{type(err).__name__}: {err}', 200)}") from None

    @staticmethod
    def _iter_indexed(content: _FileContent, topics: set[str] | None, start_ns: int | None,
                      make: Callable[[Channel, Message], BagMessage]) -> Iterator[BagMessage]:
        """Messages of a complete file in log-time order (ties in file order), read chunk by
        chunk through the summary's chunk index: chunks are taken in order of their first
        log time, and a message is yielded once no chunk still to be read can hold an
        earlier one."""
        wanted = {cid for cid, ch in content.channels.items()
                  if topics is None or ch.topic in topics}
        chunks = sorted((ci for ci in content.chunk_indexes
                         if (start_ns is None or ci.message_end_time >= start_ns)
                         and (not ci.message_index_offsets
                              or wanted & set(ci.message_index_offsets))),
                        key=lambda ci: (ci.message_start_time, ci.chunk_start_offset))
        pending: list[Any] = []
        with open_regular(content.path, "storage file") as f:
            for ci in chunks:
                while pending and pending[0][0] < ci.message_start_time:
                    yield heapq.heappop(pending)[3]
                for k, r in enumerate(_read_indexed_chunk(f, ci, content.path)):
                    if (isinstance(r, Message) and r.channel_id in wanted
                            and (start_ns is None or r.log_time >= start_ns)):
                        heapq.heappush(pending, (r.log_time, ci.chunk_start_offset, k,
                                                 make(content.channels[r.channel_id], r)))
            while pending:
                yield heapq.heappop(pending)[3]

    def messages(self, topics: Iterable[str] | None = None,
                 start_ns: int | None = None) -> Iterator[BagMessage]:
        """Messages in log-time order; only ``topics`` if given; from ``start_ns`` on."""
        wanted = None if topics is None else set(topics)
        streams = [self._iter_file(c, wanted, start_ns) for c in self._files]
        if len(streams) == 1:
            yield from streams[0]
        else:
            yield from heapq.merge(*streams, key=lambda m: m.log_time_ns)
