"""Read rosbag2 MCAP bags: complete ones through their index, damaged ones by a linear scan.

:class:`BagReader` accepts a bag folder (with or without ``metadata.yaml``) or a single
``.mcap`` file. The storage files are those listed in ``metadata.yaml``, else every
``*.mcap`` in the folder. A file whose summary section cannot be read (a recording that
was killed) is scanned record by record from the start; the scan keeps every record up to
the first one that is truncated or fails its CRC, so every chunk that was completely
written is recovered, and :attr:`BagReader.recovered` is set.

Messages come out in log-time (receive-time) order, ties in file order, so the order per
topic is the order of reception.
"""

from __future__ import annotations

import heapq
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Iterator

from mcap.reader import make_reader
from mcap.records import Channel, Message, Schema
from mcap.stream_reader import StreamReader

from tensegrity_ros.bag.errors import BagError
from tensegrity_ros.bag.metadata import (METADATA_FILE, BagMetadata, FileInfo, TopicInfo,
                                         read_metadata)
from tensegrity_ros.bag.qos import parse_profiles


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


def _scan(path: Path) -> _FileContent:
    """Linear scan of a possibly truncated file; stops at the first damaged record."""
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    messages: list[Message] = []
    damage = ""
    with open(path, "rb") as f:
        try:
            for record in StreamReader(f, validate_crcs=True).records:
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels[record.id] = record
                elif isinstance(record, Message):
                    messages.append(record)
        except Exception as err:  # truncation, CRC, torn compressed chunk: many error types
            damage = f"{type(err).__name__}: {err}" if str(err) else type(err).__name__
    # Messages of a torn chunk are never yielded (the chunk is read whole before breakup).
    messages.sort(key=lambda m: m.log_time)
    counts: dict[int, int] = {}
    for m in messages:
        counts[m.channel_id] = counts.get(m.channel_id, 0) + 1
    return _FileContent(
        path=path, schemas=schemas, channels=channels, counts=counts,
        start_ns=messages[0].log_time if messages else None,
        end_ns=messages[-1].log_time if messages else None,
        recovered=True, messages=messages, damage=damage)


def _open(path: Path) -> _FileContent:
    try:
        with open(path, "rb") as f:
            summary = make_reader(f).get_summary()
    except FileNotFoundError:
        raise BagError(f"storage file {path} does not exist") from None
    except Exception:  # no footer, torn summary: fall back to the scan
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
        recovered=False, messages=None)


class BagReader:
    """Read a bag folder or an ``.mcap`` file (see the module docstring)."""

    def __init__(self, path: str | os.PathLike):
        path = Path(path)
        if not path.exists():
            raise BagError(f"bag {path} does not exist")
        self.metadata: BagMetadata | None = None
        if path.is_file():
            self.folder = path.parent
            files = [path]
        else:
            self.folder = path
            if (path / METADATA_FILE).is_file():
                self.metadata = read_metadata(path)
                if self.metadata.storage_identifier not in ("mcap", ""):
                    raise BagError(f"bag {path} uses storage {self.metadata.storage_identifier!r};"
                                   " only 'mcap' is supported")
                files = [path / p for p in self.metadata.relative_file_paths]
            else:
                files = sorted(path.glob("*.mcap"))
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
            duration = (c.end_ns - c.start_ns) if c.start_ns is not None else 0
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
        return {s.name: (s.encoding, s.data.decode("utf-8"))
                for c in self._files for s in c.schemas.values()}

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
        with open(content.path, "rb") as f:
            reader = make_reader(f)
            for _schema, ch, m in reader.iter_messages(
                    topics=None if topics is None else sorted(topics),
                    starting_at=start_ns, log_time_order=True):
                yield make(ch, m)

    def messages(self, topics: Iterable[str] | None = None,
                 start_ns: int | None = None) -> Iterator[BagMessage]:
        """Messages in log-time order; only ``topics`` if given; from ``start_ns`` on."""
        wanted = None if topics is None else set(topics)
        streams = [self._iter_file(c, wanted, start_ns) for c in self._files]
        if len(streams) == 1:
            yield from streams[0]
        else:
            yield from heapq.merge(*streams, key=lambda m: m.log_time_ns)
