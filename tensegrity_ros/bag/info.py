"""``bag info``: what a bag holds (like ``ros2 bag info``), from the storage itself.

Counts, start and end are read from the MCAP files (their summary, or the recovery scan of a
damaged file), not copied from ``metadata.yaml``; a metadata file that disagrees with the
storage is reported, since ``bag repair`` regenerates it.
"""

from __future__ import annotations

import os
from datetime import UTC, datetime
from typing import Any

from tensegrity_ros.bag.reader import BagReader
from tensegrity_ros.bag.scene import unread_custom_data


def bag_info(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Summary of the bag at ``path`` as plain data (times in ns since the epoch, size in bytes)."""
    reader = BagReader(path)
    topics = reader.topics()
    start, end = reader.start_ns, reader.end_ns
    meta = reader.metadata
    notes = []
    if reader.recovered:
        notes.append("storage was not closed properly; content shown is what the recovery "
                     "scan found (run `tensegrity bag repair`)")
    if meta is None:
        notes.append("metadata.yaml is missing (run `tensegrity bag repair`)")
    else:
        meta_counts = {t.name: t.message_count for t in meta.topics}
        if meta_counts != {t.name: t.message_count for t in topics}:
            notes.append("metadata.yaml counts differ from the storage (run `tensegrity bag repair`)")
    unread = unread_custom_data(reader, path)
    if unread:
        notes.append(unread)
    return {
        "path": str(reader.folder),
        "files": [p.name for p in reader.files],
        "size_bytes": reader.size_bytes,
        "storage_identifier": "mcap",
        "ros_distro": meta.ros_distro if meta else "",
        "start_ns": start,
        "end_ns": end,
        "duration_s": (end - start) / 1e9 if start is not None and end is not None else 0.0,
        "message_count": sum(t.message_count for t in topics),
        "topics": [
            {
                "name": t.name,
                "type": t.type,
                "count": t.message_count,
                "serialization_format": t.serialization_format,
                "offered_qos_profiles": t.offered_qos_profiles,
            }
            for t in topics
        ],
        "recovered": reader.recovered,
        "damage": reader.damage,
        "notes": notes,
    }


def _size(n: int) -> str:
    if n < 1024:
        return f"{n} B"
    size = n / 1024
    for unit in ("KiB", "MiB"):
        if size < 1024:
            return f"{size:.1f} {unit}"
        size /= 1024
    return f"{size:.1f} GiB"


def _stamp(ns: int | None) -> str:
    if ns is None:
        return "-"
    dt = datetime.fromtimestamp(ns / 1e9, tz=UTC)
    return f"{dt:%b %d %Y %H:%M:%S}.{(ns // 1_000_000) % 1000:03d} UTC ({ns / 1e9:.9f})"


def format_info(info: dict[str, Any]) -> str:
    """Human-readable text of :func:`bag_info` (layout of ``ros2 bag info``)."""
    lines = [
        f"Files:             {', '.join(info['files'])}",
        f"Bag size:          {_size(info['size_bytes'])}",
        f"Storage id:        {info['storage_identifier']}",
        f"ROS Distro:        {info['ros_distro'] or '-'}",
        f"Duration:          {info['duration_s']:.9f}s",
        f"Start:             {_stamp(info['start_ns'])}",
        f"End:               {_stamp(info['end_ns'])}",
        f"Messages:          {info['message_count']}",
    ]
    width = max([len(t["name"]) for t in info["topics"]] + [1])
    twidth = max([len(t["type"]) for t in info["topics"]] + [1])
    for i, t in enumerate(info["topics"]):
        label = "Topic information: " if i == 0 else " " * 19
        lines.append(f"{label}Topic: {t['name']:{width}} | Type: {t['type']:{twidth}} | "
                     f"Count: {t['count']} | Serialization Format: {t['serialization_format']}")
    if not info["topics"]:
        lines.append("Topic information: (none)")
    for note in info["notes"]:
        lines.append(f"Note: {note}")
    return "\n".join(lines)
