"""``metadata.yaml`` of a bag folder, in the rosbag2 format Jazzy writes (version 9).

Layout (times in nanoseconds since the Unix epoch, durations in nanoseconds)::

    rosbag2_bagfile_information:
      version: 9
      storage_identifier: mcap
      duration: {nanoseconds: ...}
      starting_time: {nanoseconds_since_epoch: ...}
      message_count: N
      topics_with_message_count:
        - topic_metadata: {name, type, serialization_format: cdr,
                           offered_qos_profiles: [<profile>, ...], type_description_hash}
          message_count: n
      compression_format: ""      # rosbag2 file/message compression; MCAP chunk
      compression_mode: ""        # compression is a storage setting and is not listed here
      relative_file_paths: [<bag>_0.mcap]
      files: [{path, starting_time, duration, message_count}]
      custom_data: ~
      ros_distro: jazzy

Version 8 and older files (QoS profiles as a YAML string with enum integers) are read too.
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from tensegrity_core.excerpt import excerpt
from tensegrity_ros.bag.errors import BagError
from tensegrity_ros.bag.qos import parse_profiles
from tensegrity_ros.bag.untrusted import MAX_YAML_BYTES, load_bag_yaml, path_inside, read_bounded

METADATA_FILE = "metadata.yaml"
FORMAT_VERSION = 9
ROS_DISTRO = "jazzy"
#: Longest string field accepted in metadata (topic and type names, file paths) [characters].
MAX_TEXT = 4096


@dataclass
class TopicInfo:
    """One recorded topic: name, type (``pkg/msg/Name``), QoS offered by its publishers."""

    name: str
    type: str
    serialization_format: str = "cdr"
    offered_qos_profiles: list[dict[str, Any]] = field(default_factory=list)
    type_description_hash: str = ""
    message_count: int = 0


@dataclass
class FileInfo:
    """One storage file of the bag (path relative to the bag folder)."""

    path: str
    starting_time_ns: int
    duration_ns: int
    message_count: int


@dataclass
class BagMetadata:
    """Everything ``metadata.yaml`` holds."""

    topics: list[TopicInfo]
    files: list[FileInfo]
    starting_time_ns: int = 0
    duration_ns: int = 0
    message_count: int = 0
    storage_identifier: str = "mcap"
    compression_format: str = ""
    compression_mode: str = ""
    custom_data: dict[str, str] | None = None
    ros_distro: str = ROS_DISTRO
    version: int = FORMAT_VERSION

    @property
    def relative_file_paths(self) -> list[str]:
        return [f.path for f in self.files]

    def to_dict(self) -> dict[str, Any]:
        return {"rosbag2_bagfile_information": {
            "version": self.version,
            "storage_identifier": self.storage_identifier,
            "duration": {"nanoseconds": int(self.duration_ns)},
            "starting_time": {"nanoseconds_since_epoch": int(self.starting_time_ns)},
            "message_count": int(self.message_count),
            "topics_with_message_count": [
                {
                    "topic_metadata": {
                        "name": t.name,
                        "type": t.type,
                        "serialization_format": t.serialization_format,
                        "offered_qos_profiles": list(t.offered_qos_profiles),
                        "type_description_hash": t.type_description_hash,
                    },
                    "message_count": int(t.message_count),
                }
                for t in self.topics
            ],
            "compression_format": self.compression_format,
            "compression_mode": self.compression_mode,
            "relative_file_paths": self.relative_file_paths,
            "files": [
                {
                    "path": f.path,
                    "starting_time": {"nanoseconds_since_epoch": int(f.starting_time_ns)},
                    "duration": {"nanoseconds": int(f.duration_ns)},
                    "message_count": int(f.message_count),
                }
                for f in self.files
            ],
            "custom_data": self.custom_data or None,
            "ros_distro": self.ros_distro,
        }}

    @classmethod
    def from_dict(cls, data: Any, source: str = "metadata") -> BagMetadata:
        """Metadata from the parsed YAML ``data``; :class:`BagError` naming the first field
        that is missing or of the wrong type (the data comes from a bag: every field is
        checked, and values are quoted only as excerpts)."""
        f = _Fields(source)
        info = f.mapping(f.mapping(data, "the document").get("rosbag2_bagfile_information"),
                         "rosbag2_bagfile_information")
        version = f.integer(info, "version")
        topics = []
        for entry in f.sequence(info, "topics_with_message_count"):
            entry = f.mapping(entry, "topics_with_message_count entry")
            tm = f.mapping(entry.get("topic_metadata"), "topic_metadata")
            try:
                profiles = parse_profiles(tm.get("offered_qos_profiles"))
            except BagError as err:
                raise BagError(f"{source}: {err}") from None
            topics.append(TopicInfo(
                name=f.text(tm, "name"),
                type=f.text(tm, "type"),
                serialization_format=f.text(tm, "serialization_format", "cdr"),
                offered_qos_profiles=profiles,
                type_description_hash=f.text(tm, "type_description_hash", ""),
                message_count=f.integer(entry, "message_count", 0),
            ))
        paths = [f.text({"relative_file_paths": p}, "relative_file_paths")
                 for p in f.sequence(info, "relative_file_paths")]
        files = []
        for entry in f.sequence(info, "files"):
            entry = f.mapping(entry, "files entry")
            files.append(FileInfo(
                path=f.text(entry, "path"),
                starting_time_ns=f.integer(f.mapping(entry.get("starting_time"), "starting_time"),
                                           "nanoseconds_since_epoch"),
                duration_ns=f.integer(f.mapping(entry.get("duration"), "duration"), "nanoseconds"),
                message_count=f.integer(entry, "message_count"),
            ))
        if not files:  # version < 5 lists only the paths
            files = [FileInfo(p, 0, 0, 0) for p in paths]
        custom = info.get("custom_data") or None
        if custom is not None:
            custom = {f.text({"custom_data key": k}, "custom_data key"): f.text(custom, k)
                      for k in f.mapping(custom, "custom_data")}
        return cls(
            topics=topics,
            files=files,
            starting_time_ns=f.integer(f.mapping(info.get("starting_time"), "starting_time"),
                                       "nanoseconds_since_epoch"),
            duration_ns=f.integer(f.mapping(info.get("duration"), "duration"), "nanoseconds"),
            message_count=f.integer(info, "message_count"),
            storage_identifier=f.text(info, "storage_identifier", ""),
            compression_format=f.text(info, "compression_format", ""),
            compression_mode=f.text(info, "compression_mode", ""),
            custom_data=custom,
            ros_distro=f.text(info, "ros_distro", ""),
            version=version,
        )


class _Fields:
    """Typed access to the fields of untrusted metadata; errors name ``source`` and the field."""

    def __init__(self, source: str):
        self.source = source

    def _fail(self, what: str, wanted: str, value: Any) -> BagError:
        return BagError(f"{self.source} is not rosbag2 metadata: {what} must be {wanted}, "
                        f"got {excerpt(value)}")

    def mapping(self, value: Any, what: str) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self._fail(what, "a mapping", value)
        return value

    def sequence(self, info: dict[str, Any], key: str) -> list[Any]:
        value = info.get(key)
        if value is None:
            return []
        if not isinstance(value, list):
            raise self._fail(key, "a list", value)
        return value

    def text(self, d: dict[str, Any], key: str, default: str | None = None) -> str:
        value = d.get(key, default)
        if value is None and default is not None:
            return default
        if not isinstance(value, str):
            raise self._fail(key, "a string", value)
        if len(value) > MAX_TEXT:
            raise self._fail(key, f"at most {MAX_TEXT} characters", value)
        return value

    def integer(self, d: dict[str, Any], key: str, default: int | None = None) -> int:
        value = d.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise self._fail(key, "an integer", value)
        if not -2**63 <= value < 2**64:
            raise self._fail(key, "a 64-bit integer", value)
        return value


def read_metadata(folder: str | os.PathLike[str]) -> BagMetadata:
    """Read ``<folder>/metadata.yaml``; :class:`BagError` if missing, outside the folder
    (a symbolic link out), too large or malformed."""
    path = path_inside(folder, METADATA_FILE, "metadata file")
    data = read_bounded(path, MAX_YAML_BYTES, "metadata file")
    return BagMetadata.from_dict(load_bag_yaml(data, str(path)), str(path))


def write_metadata(folder: str | os.PathLike[str], meta: BagMetadata) -> Path:
    """Write ``<folder>/metadata.yaml`` atomically: a new temporary file in the folder (a
    fresh name, never an existing file or link), then a rename over the old one (which
    replaces a link rather than writing through it)."""
    folder = Path(folder)
    path = folder / METADATA_FILE
    fd, tmp = tempfile.mkstemp(prefix=".metadata-", suffix=".yaml.tmp", dir=folder)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(yaml.safe_dump(meta.to_dict(), default_flow_style=False, sort_keys=False))
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
