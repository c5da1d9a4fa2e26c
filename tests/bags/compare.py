"""Open bags with the independent readers and turn messages into comparable plain data.

``read_with_mcap_ros2`` decodes with mcap-ros2-support (schemas from the file);
``read_with_rosbags`` reads the bag folder with rosbags' rosbag2 reader and decodes with a
typestore built from the definitions stored in the bag (not from our .msg lookup).
``plain`` maps rclpy, mcap-ros2-support and rosbags message objects onto the same nested
dicts/lists of Python scalars, so equality means equal content.
"""

from __future__ import annotations

import array
import dataclasses
from collections import defaultdict
from pathlib import Path

import numpy as np


def plain(obj):
    if hasattr(obj, "get_fields_and_field_types"):              # rclpy message
        return {k: plain(getattr(obj, k)) for k in obj.get_fields_and_field_types()}
    if dataclasses.is_dataclass(obj):                            # rosbags message
        # rosbags lists constants (upper case; ROS 2 fields are lower case) and __msgtype__
        return {f.name: plain(getattr(obj, f.name)) for f in dataclasses.fields(obj)
                if not f.name.startswith("__") and not f.name.isupper()}
    if hasattr(obj, "_type") and hasattr(obj, "__slots__"):      # mcap-ros2-support message
        return {k: plain(getattr(obj, k)) for k in obj.__slots__}
    if isinstance(obj, (bytes, bytearray)):
        return list(obj)
    if isinstance(obj, (list, tuple, array.array, np.ndarray)):
        return [plain(v) for v in obj]
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def read_with_mcap_ros2(folder: Path) -> dict[str, list]:
    """{topic: [(log_time, publish_time, plain message), ...]} in file order per topic."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    out = defaultdict(list)
    for path in sorted(Path(folder).glob("*.mcap")):
        with open(path, "rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            assert reader.get_header().profile == "ros2"
            for schema, channel, message, decoded in reader.iter_decoded_messages():
                assert schema.encoding == "ros2msg" and channel.message_encoding == "cdr"
                out[channel.topic].append((message.log_time, message.publish_time, plain(decoded)))
    return dict(out)


def read_with_rosbags(folder: Path) -> dict[str, list]:
    """{topic: [(log_time, plain message), ...]} via rosbags' rosbag2 reader."""
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.EMPTY)
    out = defaultdict(list)
    with Reader(folder) as reader:
        for conn in reader.connections:
            store.register(get_types_from_msg(conn.msgdef.data, conn.msgtype))
        for conn, timestamp, raw in reader.messages():
            out[conn.topic].append((timestamp, plain(store.deserialize_cdr(raw, conn.msgtype))))
    return dict(out)
