"""Repair a bag whose recording was killed: recover every complete chunk, rewrite, re-index.

A recorder killed with SIGKILL leaves an MCAP file without summary or footer (and no
``metadata.yaml``, or a stale one). :func:`repair_bag` reads everything the recovery scan
of :class:`~tensegrity_ros.bag.reader.BagReader` finds (all chunks written completely),
writes it into a new, valid MCAP file with the same schemas, channels, QoS metadata, log
and publish times and sequence numbers, and writes a ``metadata.yaml`` whose counts are
those of the recovered messages. The ``custom_data`` (the recorded scene, ...) is the
damaged bag's (:attr:`~tensegrity_ros.bag.reader.BagReader.custom_data`: the record the
recorder wrote at the start of its file survives the kill); the new file and
``metadata.yaml`` both carry it. A ``custom_data`` the reader refuses (a malformed record
from a hostile file or another tool) does not stop the repair: the messages are what it
saves, the bag is repaired without ``custom_data``, and :attr:`RepairResult.notes` says
why. The damaged file is kept as ``<file>.orig`` unless
``keep_original=False``. An intact bag only gets its ``metadata.yaml`` regenerated.

Repair touches nothing outside the bag folder: the storage files it reads, renames or
deletes are the ones the reader resolved inside the folder (:mod:`.untrusted`), the new
file is written in a fresh temporary folder inside the bag folder and renamed into place.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from tensegrity_ros.bag.errors import BagError
from tensegrity_ros.bag.metadata import BagMetadata, FileInfo, write_metadata
from tensegrity_ros.bag.reader import BagReader
from tensegrity_ros.bag.writer import BagWriter, mcap_file_name


@dataclass
class RepairResult:
    """What :func:`repair_bag` did."""

    folder: Path
    rewritten: bool                  # False: storage was intact, only metadata.yaml rewritten
    message_count: int
    topic_counts: dict[str, int]
    damage: list[str] = field(default_factory=list)   # where the scan stopped, per file
    originals: list[Path] = field(default_factory=list)  # kept damaged files
    notes: list[str] = field(default_factory=list)      # what was left out, one line each


def _custom_data(reader: BagReader) -> tuple[dict[str, str] | None, list[str]]:
    """The bag's ``custom_data`` and no note, or None and a note saying why it is dropped."""
    try:
        return reader.custom_data, []
    except BagError as err:
        return None, [f"custom_data left out (the repaired bag has none): {err}"]


def _metadata_from_reader(reader: BagReader, files: list[FileInfo],
                          custom: dict[str, str] | None) -> BagMetadata:
    topics = reader.topics()
    count = sum(t.message_count for t in topics)
    start = reader.start_ns or 0
    duration = (reader.end_ns - start) if reader.end_ns is not None else 0
    return BagMetadata(topics=topics, files=files, starting_time_ns=start,
                       duration_ns=duration, message_count=count, custom_data=custom)


def repair_bag(folder: str | os.PathLike[str], *, keep_original: bool = True,
               compression: str = "zstd") -> RepairResult:
    """Recover and re-index the bag in ``folder`` (see the module docstring)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise BagError(f"{folder} is a file, not a bag folder" if folder.exists()
                       else f"bag folder {folder} does not exist")
    reader = BagReader(folder)
    custom, notes = _custom_data(reader)
    if not reader.recovered:
        meta = _metadata_from_reader(reader, reader.file_infos(), custom)
        write_metadata(folder, meta)
        return RepairResult(folder, False, meta.message_count,
                            {t.name: t.message_count for t in meta.topics}, notes=notes)

    work = Path(tempfile.mkdtemp(prefix=".repair-", dir=folder))
    tmp = work / "bag"
    target = mcap_file_name(folder)
    try:
        definitions = reader.definitions()
        with BagWriter(tmp, compression=compression, file_name=target, custom_data=custom) as writer:
            for topic in reader.topics():
                topic.message_count = 0
                encoding, text = definitions.get(topic.type, ("ros2msg", None))
                writer.add_topic(topic, definition=text, encoding=encoding)
            for m in reader.messages():
                writer.write(m.topic, m.data, m.log_time_ns, m.publish_time_ns, m.sequence)
            meta = writer.metadata()
    except OSError as err:
        shutil.rmtree(work, ignore_errors=True)
        raise BagError(f"cannot write the repaired bag in {folder}: {err.strerror}") from None
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    originals = []
    try:
        for path in reader.files:
            if keep_original:
                kept = path.with_name(path.name + ".orig")
                os.replace(path, kept)
                originals.append(kept)
            else:
                path.unlink()
        os.replace(tmp / target, folder / target)
        meta.custom_data = custom
        write_metadata(folder, meta)
    except OSError as err:  # the repaired storage stays where it was written
        raise BagError(f"cannot put the repaired storage in place in {folder} "
                       f"({err.strerror}: {err.filename}); it is in {tmp / target}") from None
    shutil.rmtree(work, ignore_errors=True)
    return RepairResult(folder, True, meta.message_count,
                        {t.name: t.message_count for t in meta.topics},
                        reader.damage, originals, notes)
