"""``bag plot``: joint positions and the end effector against time, as a PNG.

Messages are decoded without ROS, by ``mcap-ros2-support`` from the ``ros2msg`` schemas
stored in the bag. Every ``sensor_msgs/msg/JointState`` topic gives one line per joint
(position: m for the actuators, rad for angles, as the publisher sends them); every
``geometry_msgs/msg/PointStamped`` topic gives x, y, z [m]. Time is the log (receive) time
in seconds from the bag's first message.
"""

from __future__ import annotations

import math
import os
from collections import defaultdict
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory

from tensegrity_ros.bag.errors import BagError, decoded
from tensegrity_ros.bag.reader import BagReader

#: Most lines whose legend fits inside a plot; more go beside it, at most LEGEND_ROWS a column.
LEGEND_INSIDE, LEGEND_ROWS = 8, 14

JOINT_STATE = "sensor_msgs/msg/JointState"
POINT_STAMPED = "geometry_msgs/msg/PointStamped"


def decoded_messages(reader: BagReader, topics: list[str]) -> Iterator[tuple[str, int, Any]]:
    """(topic, log_time_ns, decoded object) of ``topics``, decoded by mcap-ros2-support."""
    factory = DecoderFactory()
    schemas = {name: Schema(id=i + 1, name=name, encoding=enc, data=text.encode("utf-8"))
               for i, (name, (enc, text)) in enumerate(sorted(reader.definitions().items()))}
    decoders: dict[str, Callable[[bytes], Any]] = {}
    for m in reader.messages(topics):
        if m.type not in decoders:
            decoder = factory.decoder_for("cdr", schemas.get(m.type))
            if decoder is None:
                raise BagError(f"topic {m.topic}: no ros2msg schema for {m.type!r} in the bag")
            decoders[m.type] = decoder
        yield m.topic, m.log_time_ns, decoded(decoders[m.type], m.data,
                                              f"bag {reader.folder}: the message of {m.topic} logged at "
                                              f"{m.log_time_ns} ns")


def plot_bag(bag: str | os.PathLike[str], out: str | os.PathLike[str]) -> Path:
    """Write the plot of ``bag`` to ``out`` (PNG); return its path."""
    import matplotlib.pyplot as plt

    fig = bag_figure(bag)
    out = Path(out)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def bag_figure(bag: str | os.PathLike[str]) -> Any:
    """The matplotlib figure of ``bag``'s joint positions and end effector (module note)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    reader = BagReader(bag)
    joint_topics = [t.name for t in reader.topics() if t.type == JOINT_STATE]
    point_topics = [t.name for t in reader.topics() if t.type == POINT_STAMPED]
    if not joint_topics and not point_topics:
        raise BagError(f"bag {reader.folder} has no {JOINT_STATE} or {POINT_STAMPED} topic to plot")
    start = reader.start_ns or 0
    joints: defaultdict[str, tuple[list[float], list[float]]] = defaultdict(lambda: ([], []))
    points: defaultdict[str, tuple[list[float], list[float], list[float], list[float]]] = defaultdict(
        lambda: ([], [], [], []))
    for topic, t_ns, msg in decoded_messages(reader, joint_topics + point_topics):
        t = (t_ns - start) / 1e9
        if topic in joint_topics:
            for name, pos in zip(msg.name, msg.position):
                times, values = joints[f"{topic}: {name}"]
                times.append(t)
                values.append(pos)
        else:
            for column, value in zip(points[topic], (t, msg.point.x, msg.point.y, msg.point.z)):
                column.append(value)

    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(9, 6.5))
    for label, (times, positions) in joints.items():
        axes[0].plot(times, positions, label=label)
    axes[0].set_ylabel("joint position [m or rad]")
    axes[0].set_title(f"{reader.folder.name}: joint positions")
    for topic, (times, x, y, z) in points.items():
        for values, axis in ((x, "x"), (y, "y"), (z, "z")):
            axes[1].plot(times, values, label=f"{topic} {axis}")
    axes[1].set_ylabel("end effector [m]")
    axes[1].set_title("end effector")
    axes[1].set_xlabel("time since first message [s]")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        if len(ax.lines) > LEGEND_INSIDE:   # a robot's 24 cables: beside the plot, in columns
            ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0,
                      ncol=math.ceil(len(ax.lines) / LEGEND_ROWS))
        elif ax.lines:
            ax.legend(fontsize=8, loc="best")
        else:
            ax.text(0.5, 0.5, "no data", ha="center", va="center", transform=ax.transAxes)
    fig.tight_layout()
    return fig
