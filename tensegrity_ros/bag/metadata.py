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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from tensegrity_ros.bag.errors import BagError
from tensegrity_ros.bag.qos import parse_profiles

METADATA_FILE = "metadata.yaml"
FORMAT_VERSION = 9
ROS_DISTRO = "jazzy"


@dataclass
class TopicInfo:
    """One recorded topic: name, type (``pkg/msg/Name``), QoS offered by its publishers."""

    name: str
    type: str
    serialization_format: str = "cdr"
    offered_qos_profiles: list[dict] = field(default_factory=list)
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
    def from_dict(cls, data: Any, source: str = "metadata") -> "BagMetadata":
        try:
            info = data["rosbag2_bagfile_information"]
            version = int(info["version"])
            topics = []
            for entry in info.get("topics_with_message_count") or []:
                tm = entry["topic_metadata"]
                topics.append(TopicInfo(
                    name=tm["name"],
                    type=tm["type"],
                    serialization_format=tm.get("serialization_format", "cdr"),
                    offered_qos_profiles=parse_profiles(tm.get("offered_qos_profiles")),
                    type_description_hash=tm.get("type_description_hash") or "",
                    message_count=int(entry.get("message_count", 0)),
                ))
            paths = list(info.get("relative_file_paths") or [])
            files = [
                FileInfo(
                    path=f["path"],
                    starting_time_ns=int(f["starting_time"]["nanoseconds_since_epoch"]),
                    duration_ns=int(f["duration"]["nanoseconds"]),
                    message_count=int(f["message_count"]),
                )
                for f in info.get("files") or []
            ]
            if not files:  # version < 5 lists only the paths
                files = [FileInfo(p, 0, 0, 0) for p in paths]
            return cls(
                topics=topics,
                files=files,
                starting_time_ns=int(info["starting_time"]["nanoseconds_since_epoch"]),
                duration_ns=int(info["duration"]["nanoseconds"]),
                message_count=int(info["message_count"]),
                storage_identifier=info.get("storage_identifier", ""),
                compression_format=info.get("compression_format") or "",
                compression_mode=info.get("compression_mode") or "",
                custom_data=info.get("custom_data") or None,
                ros_distro=info.get("ros_distro") or "",
                version=version,
            )
        except (KeyError, TypeError, ValueError) as err:
            raise BagError(f"{source} is not rosbag2 metadata ({type(err).__name__}: {err})") from None


def read_metadata(folder: str | os.PathLike) -> BagMetadata:
    """Read ``<folder>/metadata.yaml``; :class:`BagError` if missing or malformed."""
    path = Path(folder) / METADATA_FILE
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise BagError(f"{path} does not exist") from None
    except yaml.YAMLError as err:
        raise BagError(f"{path} is not valid YAML: {err}") from None
    return BagMetadata.from_dict(data, str(path))


def write_metadata(folder: str | os.PathLike, meta: BagMetadata) -> Path:
    """Write ``<folder>/metadata.yaml`` atomically (temporary file, then rename)."""
    path = Path(folder) / METADATA_FILE
    tmp = path.with_suffix(".yaml.tmp")
    tmp.write_text(
        yaml.safe_dump(meta.to_dict(), default_flow_style=False, sort_keys=False),
        encoding="utf-8",
    )
    os.replace(tmp, path)
    return path
