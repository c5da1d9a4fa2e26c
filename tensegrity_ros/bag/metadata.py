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

``custom_data`` is free-form data of the recorder's (the recorded scene, ...), not what the
bag's messages need: one that is malformed leaves the rest of the file readable, and
:attr:`BagMetadata.custom_data_error` says why it could not be read.
"""

from __future__ import annotations

import os
import secrets
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

import yaml

from tensegrity_core.schema import KeyPath, Reader, SchemaError, described, excerpt
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
    #: Why the file's ``custom_data`` could not be read ("" when it could or there is none);
    #: ``custom_data`` is then None.
    custom_data_error: str = ""

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
        """Metadata from the parsed YAML ``data`` (``source`` names it in messages), checked
        field by field by :class:`MetadataReader`: a :class:`MetadataError` names the first
        field that is missing, unknown or of the wrong type, with its key path and line."""
        return MetadataReader(source).metadata(data)


class MetadataError(SchemaError, BagError):
    """``metadata.yaml`` is not rosbag2 metadata: the field (key path), its line and the file."""


#: The fields of each part of the metadata this reader knows (rosbag2 versions up to
#: :data:`FORMAT_VERSION`), and those of them that must be there.
INFO_FIELDS: Final = ("version", "storage_identifier", "duration", "starting_time", "message_count",
                      "topics_with_message_count", "compression_format", "compression_mode",
                      "relative_file_paths", "files", "custom_data", "ros_distro")
INFO_REQUIRED: Final = ("version", "duration", "starting_time", "message_count")
TOPIC_ENTRY_FIELDS: Final = ("topic_metadata", "message_count")
TOPIC_FIELDS: Final = ("name", "type", "serialization_format", "offered_qos_profiles", "type_description_hash")
FILE_FIELDS: Final = ("path", "starting_time", "duration", "message_count")


class MetadataReader(Reader):
    """The schema of ``metadata.yaml`` (see the module's docstring) on the one
    :class:`~tensegrity_core.schema.Reader`. The data comes from a bag: every field is
    checked, values are quoted only as excerpts, and strings are at most :data:`MAX_TEXT`
    characters. Fields of a newer rosbag2 version than :data:`FORMAT_VERSION` that this
    reader does not know are passed over; in a version it knows, an unknown field is an
    error that names it."""

    def __init__(self, source: str) -> None:
        super().__init__(MetadataError, source)
        self.known = True           # whether this reader knows the file's version's fields

    def metadata(self, data: Any) -> BagMetadata:
        top = self.mapping(data, ())
        self.fields(top, (), ("rosbag2_bagfile_information",), ("rosbag2_bagfile_information",))
        root: KeyPath = ("rosbag2_bagfile_information",)
        info = self.mapping(top["rosbag2_bagfile_information"], root, top, "rosbag2_bagfile_information")
        version = self.integer(info, "version", root, lo=1)
        self.known = version <= FORMAT_VERSION
        self.fields(info, root, INFO_FIELDS, INFO_REQUIRED)
        topic_list = self.optional_list(info, "topics_with_message_count", root)
        topics = [self.topic(entry, root + ("topics_with_message_count", i), topic_list, i)
                  for i, entry in enumerate(topic_list)]
        paths_at = root + ("relative_file_paths",)
        paths = self.optional_list(info, "relative_file_paths", root)
        for i, p in enumerate(paths):
            self.text_value(p, paths_at + (i,), paths, i)
        files_at = root + ("files",)
        file_list = self.optional_list(info, "files", root)
        files = [self.storage_file(entry, files_at + (i,), file_list, i) for i, entry in enumerate(file_list)]
        if not files:  # version < 5 lists only the paths
            files = [FileInfo(p, 0, 0, 0) for p in paths]
        try:
            custom, custom_error = self.custom_data(info, root), ""
        except MetadataError as err:     # the recorder's data: the messages are still readable
            custom, custom_error = None, str(err)
        return BagMetadata(
            topics=topics,
            files=files,
            starting_time_ns=self.nanoseconds(info, "starting_time", "nanoseconds_since_epoch", root),
            duration_ns=self.nanoseconds(info, "duration", "nanoseconds", root, lo=0),
            message_count=self.count(info, "message_count", root),
            storage_identifier=self.text(info, "storage_identifier", root, ""),
            compression_format=self.text(info, "compression_format", root, ""),
            compression_mode=self.text(info, "compression_mode", root, ""),
            custom_data=custom,
            ros_distro=self.text(info, "ros_distro", root, ""),
            version=version,
            custom_data_error=custom_error,
        )

    def topic(self, value: Any, path: KeyPath, container: Any, key: int) -> TopicInfo:
        entry = self.mapping(value, path, container, key)
        self.fields(entry, path, TOPIC_ENTRY_FIELDS, ("topic_metadata",))
        at = path + ("topic_metadata",)
        tm = self.mapping(entry["topic_metadata"], at, entry, "topic_metadata")
        self.fields(tm, at, TOPIC_FIELDS, ("name", "type"))
        try:
            profiles = parse_profiles(tm.get("offered_qos_profiles"))
        except BagError as err:
            raise self.error(str(err), at + ("offered_qos_profiles",), tm, "offered_qos_profiles") from None
        return TopicInfo(
            name=self.text(tm, "name", at),
            type=self.text(tm, "type", at),
            serialization_format=self.text(tm, "serialization_format", at, "cdr"),
            offered_qos_profiles=profiles,
            type_description_hash=self.text(tm, "type_description_hash", at, ""),
            message_count=self.count(entry, "message_count", path, default=0),
        )

    def storage_file(self, value: Any, path: KeyPath, container: Any, key: int) -> FileInfo:
        entry = self.mapping(value, path, container, key)
        self.fields(entry, path, FILE_FIELDS, FILE_FIELDS)
        return FileInfo(
            path=self.text(entry, "path", path),
            starting_time_ns=self.nanoseconds(entry, "starting_time", "nanoseconds_since_epoch", path),
            duration_ns=self.nanoseconds(entry, "duration", "nanoseconds", path, lo=0),
            message_count=self.count(entry, "message_count", path),
        )

    def custom_data(self, info: dict[Any, Any], path: KeyPath) -> dict[str, str] | None:
        if info.get("custom_data") is None:
            return None
        at = path + ("custom_data",)
        custom = self.mapping(info["custom_data"], at, info, "custom_data")
        for k in custom:
            self.text_value(k, at + (k,), custom, k)
        return {k: self.text(custom, k, at) for k in custom} or None

    # -- fields ----------------------------------------------------------------------------
    def fields(self, d: dict[Any, Any], path: KeyPath, allowed: tuple[str, ...],
               required: tuple[str, ...] = ()) -> None:
        """Every field of ``required`` is in ``d``; in a version this reader knows, every
        field of ``d`` is one of ``allowed`` (an unknown one is named with the closest)."""
        self.keys(d, path, allowed if self.known else tuple(d), required)

    def optional_list(self, d: dict[Any, Any], key: str, path: KeyPath) -> list[Any]:
        """``d[key]`` as a list; ``[]`` when absent or null."""
        return [] if d.get(key) is None else self.sequence(d[key], path + (key,), d, key)

    def text(self, d: dict[Any, Any], key: Any, path: KeyPath, default: str | None = None) -> str:
        """``d[key]`` as a string of at most :data:`MAX_TEXT` characters, ``default`` when
        absent or null (required when ``default`` is None)."""
        if d.get(key) is None and default is not None:
            return default
        value = self.string(d, key, path)
        return self.text_value(value, path + (key,), d, key)

    def text_value(self, value: Any, path: KeyPath, container: Any, key: Any) -> str:
        if not isinstance(value, str):
            raise self.error(f"must be a string, got {described(value)}", path, container, key)
        if len(value) > MAX_TEXT:
            raise self.error(f"must be at most {MAX_TEXT} characters, got {excerpt(value)}", path, container, key)
        return value

    def count(self, d: dict[Any, Any], key: str, path: KeyPath, default: int | None = None) -> int:
        """``d[key]``: a count (a 64-bit unsigned integer)."""
        return self.int64(d, key, path, default=default, lo=0)

    def nanoseconds(self, d: dict[Any, Any], key: str, field: str, path: KeyPath, lo: int | None = None) -> int:
        """``d[key][field]``: a time or duration [ns], 64-bit."""
        at = path + (key,)
        inner = self.mapping(d[key], at, d, key)
        if field not in inner:
            raise self.error(f"missing required key {field!r}", at, inner)
        return self.int64(inner, field, at, lo=lo)

    def int64(self, d: dict[Any, Any], key: str, path: KeyPath, *, default: int | None = None,
              lo: int | None = None) -> int:
        value = self.integer(d, key, path, default=default, lo=lo)
        if not -2**63 <= value < 2**64:
            raise self.error(f"must fit in 64 bits, got {excerpt(value)}", path + (key,), d, key)
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
    replaces a link rather than writing through it). The file gets the permissions of any
    file the user creates (``0o666`` less the umask, as the storage file and rosbag2's
    ``metadata.yaml``), not a temporary file's owner-only ones."""
    folder = Path(folder)
    path = folder / METADATA_FILE
    tmp = folder / f".metadata-{secrets.token_hex(8)}.yaml.tmp"
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o666)   # the umask applies
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(yaml.safe_dump(meta.to_dict(), default_flow_style=False, sort_keys=False))
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
