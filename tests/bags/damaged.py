"""Bags with one message damaged, for the readers' refusals."""

from __future__ import annotations

from pathlib import Path


def damaged_copy(source: Path, folder: Path, topic: str, index: int, keep: int) -> None:
    """A copy of the bag ``source`` (with the suite's writer) whose ``index``-th message on
    ``topic`` keeps only its first ``keep`` bytes, as a record overwritten in a damaged file."""
    from tensegrity_ros.bag.reader import BagReader
    from tensegrity_ros.bag.writer import BagWriter

    reader = BagReader(source)
    seen = 0
    with BagWriter(folder) as writer:
        for t in reader.topics():
            encoding, text = reader.definitions()[t.type]
            writer.add_topic(t, text, encoding)
        for m in reader.messages():
            data = m.data
            if m.topic == topic:
                data, seen = (data[:keep] if seen == index else data), seen + 1
            writer.write(m.topic, data, m.log_time_ns)
    assert seen > index
