"""Is a recording of a lockstep run complete? The stamps a bag holds against the stamps the
run published.

A lockstep run publishes its state once per step, stamped with the simulation time, and
its controller answers each state with a command stamped like it; so the stamps of a
topic say exactly which messages of the run a bag holds, whatever the order or the
repeats (a paused simulator republishes a state with its stamp). Stamps are integer
nanoseconds: a message's ``header.stamp``, or ``clock`` of a ``rosgraph_msgs/Clock``.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path

from rclpy.serialization import deserialize_message

from tensegrity_ros.bag.reader import BagReader
from tensegrity_ros.bag.recorder import message_class
from tensegrity_ros.rclpy_utils.messages import stamp_ns

NS_PER_S = 1_000_000_000


def _stamp_ns(msg: object) -> int:
    """A message's stamp [ns]: a ``Clock``'s time, else its header's stamp."""
    return stamp_ns(msg.clock if hasattr(msg, "clock") else msg.header.stamp)  # type: ignore[attr-defined]


def bag_stamps(folder: str | Path, topics: Iterable[str]) -> dict[str, set[int]]:
    """The distinct stamps [ns] of each of ``topics`` (absolute names) in the bag."""
    reader = BagReader(folder)
    wanted = set(topics)
    classes = {t.name: message_class(t.type) for t in reader.topics() if t.name in wanted}
    out: dict[str, set[int]] = {t: set() for t in wanted}
    for m in reader.messages(list(classes)):
        out[m.topic].add(_stamp_ns(deserialize_message(m.data, classes[m.topic])))
    return out


def missing_stamps(folder: str | Path, expected: Mapping[str, Iterable[int]]) -> dict[str, list[int]]:
    """For each topic of ``expected`` (absolute name -> the stamps [ns] the run published),
    the stamps the bag lacks, sorted; a complete bag gives empty lists."""
    held = bag_stamps(folder, expected)
    return {topic: sorted(set(stamps) - held[topic]) for topic, stamps in expected.items()}


def completeness_line(folder: str | Path, expected: Mapping[str, Iterable[int]]) -> tuple[bool, str]:
    """``(complete, one line)``: every expected message in the bag, or what is missing per topic."""
    wanted = {t: sorted(set(s)) for t, s in expected.items()}
    missing = missing_stamps(folder, wanted)
    steps = max((len(s) for s in wanted.values()), default=0)
    if not any(missing.values()):
        return True, f"complete: every message of the run on {', '.join(expected)} ({steps} stamps)"
    lost = ", ".join(f"{t} {len(m)} of {len(wanted[t])} (first at t = {m[0] / NS_PER_S:.3f} s)"
                     for t, m in missing.items() if m)
    return False, f"INCOMPLETE: missing {lost}"
