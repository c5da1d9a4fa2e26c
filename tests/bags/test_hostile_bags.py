"""Bags are data from elsewhere (issue 12): nothing a bag names reaches outside its folder,
and a bag that is not a bag is one clear error line with a non-zero exit.

Attacks: ``metadata.yaml`` entries that are ``..`` paths, absolute paths, or links that
point out of the folder; a ``metadata.yaml`` (or the temporary file beside it) that is a
link out. Junk: binary or oversized metadata, fields of the wrong type, YAML alias bombs,
empty / 9-byte / non-MCAP storage, a FIFO named like storage, a zstd chunk that claims to
be small and decompresses to far more, a bag with nothing to play. Every CLI run must
print exactly one line ``error: ...`` (no traceback), of bounded length, and exit 1; the
files around the bag must be byte for byte what they were.

The verdicts of ``bag info``, ``repair`` and ``plot`` are taken from the command line run in
the test's process (:func:`run_cli_here`); one real process of each, and every ``play``,
check what a process prints and returns.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import pytest
import yaml

from tensegrity_ros.bag.errors import BagError
from tensegrity_ros.bag.metadata import TopicInfo
from tensegrity_ros.bag.reader import BagReader
from tensegrity_ros.bag.writer import BagWriter
from tests.bags.conftest import rosbags_cdr_samples, run_cli, run_cli_here

MAX_LINE = 400       # an error line quotes excerpts only: far below any input size used here


def _tree(root: Path) -> dict[str, str]:
    """Every path under ``root`` (links not followed) -> what it is and its content hash."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            rel = str(p.relative_to(root))
            if p.is_symlink():
                out[rel] = "link -> " + os.readlink(p)
            elif p.is_file():
                out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
            else:
                out[rel] = "dir"
    return out


def _bag(root: Path, name: str = "bag", n: int = 10) -> Path:
    folder = root / name
    with BagWriter(folder) as w:
        w.add_topic(TopicInfo("/joint_states", "sensor_msgs/msg/JointState"))
        for topic, _type, t, data, _ in rosbags_cdr_samples(n):
            if topic == "/joint_states":
                w.write(topic, data, t, t)
    return folder


def _damage(folder: Path) -> None:
    """Cut the storage file like a killed recording (no summary, no footer)."""
    path = folder / f"{folder.name}_0.mcap"
    data = path.read_bytes()
    path.write_bytes(data[: len(data) - 40])


def _set_files(folder: Path, entries: list[str]) -> None:
    meta = yaml.safe_load((folder / "metadata.yaml").read_text())
    info = meta["rosbag2_bagfile_information"]
    info["relative_file_paths"] = entries
    info["files"] = [dict(info["files"][0], path=e) for e in entries]
    (folder / "metadata.yaml").write_text(yaml.safe_dump(meta))


def _one_error_line(done, *needles: str) -> str:
    assert done.returncode == 1, (done.returncode, done.stdout, done.stderr)
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), done.stderr
    assert "Traceback" not in done.stderr and len(lines[0]) < MAX_LINE, lines[0][:MAX_LINE]
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


def _victim(root: Path) -> Path:
    """A file outside the bag that a hostile bag names: a damaged MCAP, so that a repair
    that followed the name would rename it (backup) or delete it (--no-backup)."""
    donor = _bag(root, "donor")
    _damage(donor)
    victim = root / "victim.mcap"
    victim.write_bytes((donor / "donor_0.mcap").read_bytes())
    return victim


@pytest.mark.parametrize("entry_kind", ["dotdot", "absolute", "link_out"])
@pytest.mark.parametrize("backup", [True, False], ids=["backup", "no_backup"])
def test_repair_never_touches_a_file_the_bag_names_outside_its_folder(tmp_path, entry_kind, backup):
    victim = _victim(tmp_path)
    folder = _bag(tmp_path)
    _damage(folder)
    if entry_kind == "dotdot":
        entry = "../victim.mcap"
    elif entry_kind == "absolute":
        entry = str(victim)
    else:
        (folder / "inside.mcap").symlink_to(victim)
        entry = "inside.mcap"
    _set_files(folder, [entry])
    before = _tree(tmp_path)
    done = run_cli_here("bag", "repair", str(folder), *([] if backup else ["--no-backup"]))
    _one_error_line(done, "outside the bag folder" if entry_kind != "absolute" else "absolute path")
    assert _tree(tmp_path) == before
    for command in (("bag", "info", str(folder)),):
        _one_error_line(run_cli_here(*command), "storage file")


def test_a_stray_mcap_link_out_of_the_folder_is_refused_too(tmp_path):
    """Without metadata.yaml the storage files are the folder's *.mcap: a link among them
    that points out of the folder is refused like a named one."""
    victim = _victim(tmp_path)
    folder = _bag(tmp_path)
    (folder / "metadata.yaml").unlink()
    (folder / "zz_1.mcap").symlink_to(victim)
    before = _tree(tmp_path)
    _one_error_line(run_cli_here("bag", "repair", str(folder), "--no-backup"), "outside the bag folder")
    assert _tree(tmp_path) == before


def test_metadata_links_out_of_the_folder_are_neither_read_nor_written_through(tmp_path):
    secret = tmp_path / "secret.yaml"
    secret.write_text("rosbag2_bagfile_information: {version: 9}\n")
    folder = _bag(tmp_path)
    (folder / "metadata.yaml").unlink()
    (folder / "metadata.yaml").symlink_to(secret)
    before = _tree(tmp_path)
    _one_error_line(run_cli_here("bag", "info", str(folder)), "metadata file", "outside the bag folder")
    _one_error_line(run_cli_here("bag", "repair", str(folder)), "outside the bag folder")
    assert _tree(tmp_path) == before


def test_repair_writes_metadata_through_no_prepared_link(tmp_path):
    """The temporary file beside metadata.yaml is a fresh name: a link placed where the old
    code put it (metadata.yaml.tmp) is not written through."""
    outside = tmp_path / "outside.txt"
    outside.write_text("keep me\n")
    folder = _bag(tmp_path)
    (folder / "metadata.yaml").unlink()
    (folder / "metadata.yaml.tmp").symlink_to(outside)
    done = run_cli_here("bag", "repair", str(folder))
    assert done.returncode == 0, done.stderr
    assert outside.read_text() == "keep me\n"
    assert BagReader(folder).metadata.message_count == 10
    # and a damaged bag is repaired inside its own folder: nothing appears beside it
    _damage(folder)
    (folder / "metadata.yaml").unlink()
    beside = sorted(p.name for p in tmp_path.iterdir())
    assert run_cli_here("bag", "repair", str(folder), "--no-backup").returncode == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == beside
    assert not [p for p in folder.iterdir() if p.name.startswith(".repair-")]


def _bomb(levels: int = 9) -> str:
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x]"]
    for k in range(1, levels):
        lines.append(f"a{k}: &a{k} [" + ", ".join([f"*a{k - 1}"] * 9) + "]")
    return "\n".join(lines) + "\n"


def _metadata_with(**fields) -> str:
    info = {"version": 9, "storage_identifier": "mcap", "duration": {"nanoseconds": 0},
            "starting_time": {"nanoseconds_since_epoch": 0}, "message_count": 0,
            "topics_with_message_count": [], "relative_file_paths": ["bag_0.mcap"], "files": []}
    info.update(fields)
    return yaml.safe_dump({"rosbag2_bagfile_information": info})


JUNK_METADATA = {
    "binary": (os.urandom(2000).replace(b"\x00", b"\x01") + b"\xff", "not UTF-8"),
    "oversized": (b"# " + b"x" * (5 * 1024 * 1024) + b"\n", "larger than"),
    "not_yaml": (b"rosbag2_bagfile_information: [unclosed\n", "not valid YAML"),
    "not_a_mapping": (b"- just\n- a list\n", "must be a mapping"),
    "alias_bomb_as_a_name": (
        (_bomb() + _metadata_with(topics_with_message_count=[{
            "topic_metadata": {"name": "PLACEHOLDER", "type": "sensor_msgs/msg/JointState"},
            "message_count": 1}])).replace("PLACEHOLDER", "*a8").replace("'*a8'", "*a8").encode(),
        "aliases expand to more than"),
    "huge_name": (_metadata_with(topics_with_message_count=[{
        "topic_metadata": {"name": "/" + "n" * 100_000, "type": "sensor_msgs/msg/JointState"},
        "message_count": 1}]).encode(), "at most"),
    "wrong_count_type": (_metadata_with(message_count=[1, 2]).encode(), "message_count: must be a non-negative integer"),
    "qos_bomb": ((_bomb() + _metadata_with(topics_with_message_count=[{
        "topic_metadata": {"name": "/t", "type": "sensor_msgs/msg/JointState",
                           "offered_qos_profiles": "PLACEHOLDER"},
        "message_count": 1}])).replace("PLACEHOLDER", "*a8").replace("'*a8'", "*a8").encode(),
        "aliases expand to more than"),
}


@pytest.mark.parametrize("kind", sorted(JUNK_METADATA))
def test_junk_metadata_is_one_error_line(tmp_path, kind):
    data, needle = JUNK_METADATA[kind]
    folder = _bag(tmp_path)
    (folder / "metadata.yaml").write_bytes(data)
    for command in (("bag", "info", str(folder)), ("bag", "repair", str(folder)),
                    ("bag", "plot", str(folder), "-o", str(tmp_path / "p.png"))):
        _one_error_line(run_cli_here(*command), needle)


@pytest.mark.parametrize("command", ["info", "repair", "plot"])
def test_a_process_refusing_a_bag_prints_one_error_line_and_exits_1(tmp_path, command):
    """The verdicts above, from a real ``tensegrity`` process: one line, no traceback, exit 1."""
    folder = _bag(tmp_path)
    (folder / "metadata.yaml").write_bytes(JUNK_METADATA["binary"][0])
    args = {"info": [], "repair": ["--no-backup"], "plot": ["-o", str(tmp_path / "p.png")]}[command]
    before = _tree(tmp_path)
    _one_error_line(run_cli("bag", command, str(folder), *args), "not UTF-8")
    assert _tree(tmp_path) == before


def _fifo(path: Path) -> None:
    os.mkfifo(path)


STORAGE = {
    "empty": (lambda p: p.write_bytes(b""), "is not an MCAP file"),
    "nine_bytes": (lambda p: p.write_bytes(b"\x89MCAP0\r\n\x01"), "is not an MCAP file"),
    "junk": (lambda p: p.write_bytes(os.urandom(5000)), "is not an MCAP file"),
    "fifo": (_fifo, "is not a regular file"),
    "directory": (lambda p: p.mkdir(), "is not a regular file"),
}


@pytest.mark.parametrize("kind", sorted(STORAGE))
def test_storage_that_is_not_mcap_is_one_error_line(tmp_path, kind):
    make, needle = STORAGE[kind]
    folder = tmp_path / "bag"
    folder.mkdir()
    make(folder / "bag_0.mcap")
    for command in (("bag", "info", str(folder)), ("bag", "repair", str(folder), "--no-backup")):
        _one_error_line(run_cli_here(*command), needle)
    assert os.path.lexists(folder / "bag_0.mcap")      # not renamed, not deleted


def _records(*records) -> bytes:
    from mcap.data_stream import RecordBuilder

    out = RecordBuilder()
    for r in records:
        r.write(out)
    return out.end()


def _header_record() -> bytes:
    from mcap.records import Header

    return _records(Header(profile="ros2", library="test"))


def _zstd_bomb_bag(folder: Path, claimed: int, real: int) -> None:
    """A recording cut after one zstd chunk that declares ``claimed`` uncompressed bytes
    and decompresses to ``real`` bytes (one message of zeros), written record by record."""
    import zstandard
    from mcap.records import Channel, Chunk, Message, Schema

    inner = _records(Message(channel_id=1, sequence=0, log_time=1, publish_time=1, data=bytes(real)))
    chunk = Chunk(compression="zstd", data=zstandard.compress(inner), message_start_time=1,
                  message_end_time=1, uncompressed_crc=0, uncompressed_size=claimed)
    folder.mkdir()
    (folder / "bag_0.mcap").write_bytes(
        b"\x89MCAP0\r\n" + _header_record()
        + _records(Schema(id=1, name="std_msgs/msg/String", encoding="ros2msg", data=b"string data"),
                   Channel(id=1, topic="/t", message_encoding="cdr", schema_id=1, metadata={}),
                   chunk))


def test_a_small_chunk_that_decompresses_to_far_more_is_refused(tmp_path, monkeypatch):
    """zstd frames carry their own content size, which the library's decompression trusts
    over the chunk's header: the reader bounds the output itself (limit lowered here so
    the test stays cheap: 64 MiB of zeros are 2 kB of zstd)."""
    from tensegrity_ros.bag import reader as reader_module

    monkeypatch.setattr(reader_module, "MAX_CHUNK_BYTES", 8 * 1024 * 1024)
    folder = tmp_path / "bag"
    _zstd_bomb_bag(folder, claimed=100, real=64 * 1024 * 1024)
    assert (folder / "bag_0.mcap").stat().st_size < 20_000
    reader = BagReader(folder)    # no summary: the recovery scan stops at the bomb
    assert reader.recovered and list(reader.messages()) == []
    assert "decompresses to more than 8388608 bytes" in reader.damage[0]
    # under the limit but not what the chunk declared: refused as damage too
    folder2 = tmp_path / "bag2"
    _zstd_bomb_bag(folder2, claimed=100, real=1024 * 1024)
    assert "its header says 100" in BagReader(folder2).damage[0]


@pytest.mark.ros
@pytest.mark.parametrize("kind", ["header_only", "no_messages_on_topics", "offset_beyond_end"])
def test_nothing_to_play_is_an_error(tmp_path, kind):
    folder = tmp_path / "bag"
    args = []
    if kind == "header_only":      # a recording killed before its first chunk
        folder.mkdir()
        (folder / "bag_0.mcap").write_bytes(b"\x89MCAP0\r\n" + _header_record())
        needle = "holds no messages"
    elif kind == "no_messages_on_topics":
        with BagWriter(folder) as w:
            w.add_topic(TopicInfo("/joint_states", "sensor_msgs/msg/JointState"))
            w.add_topic(TopicInfo("/end_effector", "geometry_msgs/msg/PointStamped"))
            for topic, _type, t, data, _ in rosbags_cdr_samples(3):
                if topic == "/joint_states":
                    w.write(topic, data, t, t)
        args = ["--topics", "/end_effector"]
        needle = "has no messages on"
    else:
        _bag(tmp_path)
        args = ["--start-offset", "100"]
        needle = "beyond the end"
    done = run_cli("play", str(folder), *args, "--wait-for-all-acked", "0")
    _one_error_line(done, "nothing to play", needle)


@pytest.mark.ros
@pytest.mark.parametrize("kind", ["binary_metadata", "empty_mcap", "nine_bytes", "link_out"])
def test_play_of_an_unreadable_bag_is_one_error_line(tmp_path, kind):
    folder = _bag(tmp_path)
    if kind == "binary_metadata":
        (folder / "metadata.yaml").write_bytes(b"\xff\xfe" + os.urandom(100))
    elif kind == "empty_mcap":
        (folder / "bag_0.mcap").write_bytes(b"")
    elif kind == "nine_bytes":
        (folder / "bag_0.mcap").write_bytes(b"\x89MCAP0\r\n\x01")
    else:
        _set_files(folder, ["../../" + "x" * 10_000])
    _one_error_line(run_cli("play", str(folder), "--wait-for-all-acked", "0"))


def test_reader_errors_quote_only_excerpts():
    """The message of a path refused is short however long the path was."""
    from tensegrity_ros.bag.untrusted import path_inside

    with pytest.raises(BagError) as err:
        path_inside("/tmp", "../" + "y" * 100_000, "storage file")
    assert len(str(err.value)) < MAX_LINE and "100003 characters" in str(err.value)
