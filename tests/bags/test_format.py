"""The storage format without ROS traffic: schemas, QoS YAML, metadata, chunks, recovery.

Oracles: the independent parsers (mcap-ros2-support's and rosbags' .msg parsers, rosbags'
metadata/QoS reader), the installed .msg files, and the mcap library's own chunk index of
an intact file (which says which messages a cut at byte X leaves complete).
"""

from __future__ import annotations

import shutil

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader

from tensegrity_ros.bag.errors import BagError
from tensegrity_ros.bag.metadata import BagMetadata, TopicInfo, read_metadata
from tensegrity_ros.bag.msgdefs import DELIMITER, full_definition, msg_dependencies, msg_file
from tensegrity_ros.bag.qos import (
    INFINITE_NS,
    dump_profiles,
    normalize_profile,
    offer_for_replay,
    parse_profiles,
    request_for_offers,
)
from tensegrity_ros.bag.reader import BagMessage, BagReader
from tensegrity_ros.bag.repair import repair_bag
from tensegrity_ros.bag.schedule import PlaybackOptions, timeline
from tensegrity_ros.bag.writer import BagWriter

SUITE_TYPES = ["sensor_msgs/msg/JointState", "geometry_msgs/msg/PointStamped",
               "tensegrity_msgs/msg/MechanismState", "visualization_msgs/msg/MarkerArray",
               "rosgraph_msgs/msg/Clock", "tensegrity_msgs/msg/ActuatorForces"]


@pytest.mark.parametrize("type_name", SUITE_TYPES)
def test_full_definition_parses_with_both_independent_parsers(type_name):
    from mcap_ros2._dynamic import generate_dynamic
    from rosbags.typesys import get_types_from_msg

    text = full_definition(type_name)
    assert text.startswith(msg_file(type_name).read_text())
    blocks = text.split(f"\n{DELIMITER}\nMSG: ")
    names = [b.split("\n", 1)[0] for b in blocks[1:]]
    assert len(names) == len(set(names))                 # each dependency once
    assert all(n.count("/") == 1 for n in names)         # written pkg/Name
    # every dependency block is its installed .msg file, verbatim
    for block in blocks[1:]:
        name, body = block.split("\n", 1)
        pkg, short = name.split("/")
        assert body == msg_file(f"{pkg}/msg/{short}").read_text()
    assert type_name in generate_dynamic(type_name, text)
    assert type_name in get_types_from_msg(text, type_name)


def test_dependencies_are_closed_and_nothing_more():
    """Every non-primitive field type of every block is itself a block (closure), for the
    deepest suite type; and a same-package type is qualified with its package."""
    text = full_definition("visualization_msgs/msg/MarkerArray")
    blocks = dict(b.split("\n", 1) for b in text.split(f"\n{DELIMITER}\nMSG: ")[1:])
    top = text.split(f"\n{DELIMITER}\n")[0]
    needed = set(msg_dependencies(top, "visualization_msgs"))
    for name, body in blocks.items():
        needed |= set(msg_dependencies(body, name.split("/")[0]))
    assert needed == set(blocks)
    assert "visualization_msgs/Marker" in blocks          # "Marker[] markers" in MarkerArray
    assert msg_dependencies("int32 A=1\nstring<=5 s\nHeader h\n# Point p\n", "std_msgs") == \
        ["std_msgs/Header"]


def test_unknown_type_is_a_clear_error():
    with pytest.raises(BagError, match="no .msg definition found for 'nope_msgs/msg/Nothing'"):
        full_definition("nope_msgs/msg/Nothing")
    with pytest.raises(BagError, match="not of the form"):
        full_definition("JointState")


def test_qos_yaml_matches_rosbag2_form_and_rosbags_reads_it():
    from rosbags.rosbag2.metadata import parse_qos

    offered = {"history": "unknown", "depth": 0, "reliability": "reliable",
               "durability": "volatile", "deadline": {"sec": 9223372036, "nsec": 854775807},
               "lifespan": {"sec": 9223372036, "nsec": 854775807}, "liveliness": "automatic",
               "liveliness_lease_duration": {"sec": 9223372036, "nsec": 854775807},
               "avoid_ros_namespace_conventions": False}
    text = dump_profiles([offered])
    assert yaml.safe_load(text) == [offered]
    assert parse_profiles(text) == [offered]
    (theirs,) = parse_qos(text)
    assert theirs.reliability.name == "RELIABLE" and theirs.durability.name == "VOLATILE"
    assert theirs.deadline.sec * 10**9 + theirs.deadline.nsec == INFINITE_NS
    # version-8 bags store enum integers; Foxy's Fast DDS infinity maps to infinite
    v8 = normalize_profile({"history": 3, "depth": 0, "reliability": 2, "durability": 1,
                            "deadline": {"sec": 2147483647, "nsec": 4294967295},
                            "lifespan": {"sec": 0, "nsec": 0}, "liveliness": 1,
                            "liveliness_lease_duration": {"sec": 0, "nsec": 0},
                            "avoid_ros_namespace_conventions": False})
    assert (v8["reliability"], v8["durability"]) == ("best_effort", "transient_local")
    assert v8["deadline"] == {"sec": 9223372036, "nsec": 854775807}
    with pytest.raises(BagError, match="QoS reliability 'sometimes'"):
        normalize_profile({"reliability": "sometimes"})


def test_request_and_offer_follow_rosbag2_rules():
    rel = normalize_profile({"reliability": "reliable", "durability": "transient_local"})
    be = normalize_profile({"reliability": "best_effort", "durability": "volatile"})
    assert request_for_offers([rel], 1000)["reliability"] == "reliable"
    assert request_for_offers([rel], 1000)["durability"] == "transient_local"
    mixed = request_for_offers([rel, be], 7)
    assert (mixed["reliability"], mixed["durability"], mixed["depth"]) == \
        ("best_effort", "volatile", 7)
    assert offer_for_replay([rel, rel])["durability"] == "transient_local"
    assert offer_for_replay([rel, be])["reliability"] == "reliable"   # mixed: the default
    assert offer_for_replay([])["history"] == "keep_last"


def _write(folder, n=300, chunk_size=1024):
    """A bag of n JointState-typed payloads with distinct bytes; small chunks."""
    with BagWriter(folder, chunk_size=chunk_size, compression="none") as w:
        w.add_topic(TopicInfo("/a", "sensor_msgs/msg/JointState"))
        w.add_topic(TopicInfo("/b", "geometry_msgs/msg/PointStamped"))
        for k in range(n):
            w.write("/a" if k % 3 else "/b", k.to_bytes(4, "little") * 10, 1_000 + 10 * k,
                    995 + 10 * k, k)
    return folder


def test_writer_layout_and_metadata_agree_with_rosbags(tmp_path):
    from rosbags.rosbag2 import Reader

    folder = _write(tmp_path / "bag")
    assert sorted(p.name for p in folder.iterdir()) == ["bag_0.mcap", "metadata.yaml"]
    with open(folder / "bag_0.mcap", "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert reader.get_header().profile == "ros2"
        assert {s.name: s.encoding for s in summary.schemas.values()} == {
            "sensor_msgs/msg/JointState": "ros2msg", "geometry_msgs/msg/PointStamped": "ros2msg"}
        assert {c.topic for c in summary.channels.values()} == {"/a", "/b"}
        assert all(set(c.metadata) == {"offered_qos_profiles", "topic_type_hash"}
                   for c in summary.channels.values())
        assert len(summary.chunk_indexes) > 5
        (meta_record,) = [m for m in reader.iter_metadata() if m.name == "rosbag2"]
        assert yaml.safe_load(meta_record.metadata["serialized_metadata"])["message_count"] == 300
    with Reader(folder) as theirs:
        assert theirs.message_count == 300
        assert {c.topic: c.msgcount for c in theirs.connections} == {"/a": 200, "/b": 100}
        assert theirs.start_time == 1_000 and theirs.end_time == 1_000 + 10 * 299 + 1
    meta = read_metadata(folder)
    assert meta.to_dict() == BagMetadata.from_dict(meta.to_dict()).to_dict()
    with pytest.raises(BagError, match="exists already"):
        BagWriter(folder)


def _complete_prefix(intact, cut: int) -> list[int]:
    """Sequence numbers of messages in chunks that lie wholly before byte ``cut``."""
    with open(intact, "rb") as f:
        reader = make_reader(f)
        chunks = [c for c in reader.get_summary().chunk_indexes
                  if c.chunk_start_offset + c.chunk_length <= cut]
        if not chunks:
            return []
        last = max(c.message_end_time for c in chunks)
        return [m.sequence for _, _, m in reader.iter_messages(log_time_order=True)
                if m.log_time <= last]


@pytest.fixture(scope="module")
def intact_bag(tmp_path_factory):
    return _write(tmp_path_factory.mktemp("intact") / "whole")


@settings(max_examples=25)
@given(fraction=st.floats(0.0, 1.0))
def test_truncated_file_recovers_exactly_the_complete_chunks(intact_bag, tmp_path_factory, fraction):
    data = (intact_bag / "whole_0.mcap").read_bytes()
    cut = int(fraction * len(data))
    folder = tmp_path_factory.mktemp("cut") / "whole"
    folder.mkdir()
    (folder / "whole_0.mcap").write_bytes(data[:cut])
    header_end = 8 + 1 + 8 + int.from_bytes(data[9:17], "little")  # magic, opcode, length
    if cut < header_end:   # not even the header survived: not a bag, nothing to recover
        with pytest.raises(BagError, match="is not an MCAP file"):
            BagReader(folder)
        shutil.rmtree(folder.parent)
        return
    reader = BagReader(folder)
    got = [m.sequence for m in reader.messages()]
    assert got == _complete_prefix(intact_bag / "whole_0.mcap", cut)
    assert all(m.data == m.sequence.to_bytes(4, "little") * 10 for m in reader.messages())
    if got:
        result = repair_bag(folder)
        assert result.message_count == len(got)
        assert [m.sequence for m in BagReader(folder).messages()] == got
    shutil.rmtree(folder.parent)


def test_repair_of_an_intact_bag_only_rewrites_metadata(tmp_path):
    folder = _write(tmp_path / "ok")
    before = (folder / "ok_0.mcap").read_bytes()
    (folder / "metadata.yaml").unlink()
    result = repair_bag(folder)
    assert not result.rewritten and result.message_count == 300
    assert (folder / "ok_0.mcap").read_bytes() == before
    assert read_metadata(folder).message_count == 300


def _msgs(times, topic="/t"):
    return [BagMessage(topic, "x/msg/Y", bytes([i % 256]), t, t, i) for i, t in enumerate(times)]


def test_timeline_rate_offset_loop_and_validation():
    times = [0, 10, 30, 60]
    msgs = _msgs(times)
    events = list(timeline(lambda: msgs, 0, 60, PlaybackOptions(rate=2.0, start_offset_s=0)))
    assert [e.wall_ns for e in events] == [0, 5, 15, 30]
    events = list(timeline(lambda: msgs, 0, 60, PlaybackOptions(start_offset_s=20e-9)))
    assert [(e.wall_ns, e.message.sequence) for e in events] == [(10, 2), (40, 3)]
    looped = timeline(lambda: msgs, 0, 60, PlaybackOptions(loop=True), median_spacing_ns=20)
    first = [next(looped) for _ in range(8)]
    assert [e.wall_ns for e in first] == [0, 10, 30, 60, 80, 90, 110, 140]
    assert [e.loop for e in first] == [0] * 4 + [1] * 4
    assert list(timeline(lambda: [], 0, 60, PlaybackOptions(loop=True))) == []
    with pytest.raises(BagError, match="past the end"):
        list(timeline(lambda: msgs, 0, 60, PlaybackOptions(start_offset_s=1.0)))
    for bad in ({"rate": 0.0}, {"rate": float("nan")}, {"start_offset_s": -1.0},
                {"clock_hz": 0.0}):
        with pytest.raises(BagError):
            PlaybackOptions(**bad)


def test_metadata_gets_the_permissions_of_a_file_the_user_creates(tmp_path):
    """Under a umask of 027, every file the user creates is rw-r----- (0o666 less the umask):
    ``metadata.yaml`` as written and as repair rewrites it, like the storage file."""
    import os
    import stat

    old = os.umask(0o027)
    try:
        folder = _write(tmp_path / "perm", n=10)
        mode = lambda p: stat.S_IMODE(p.stat().st_mode)  # noqa: E731
        assert mode(folder / "metadata.yaml") == mode(folder / "perm_0.mcap") == 0o640
        (folder / "metadata.yaml").unlink()
        repair_bag(folder)
        assert mode(folder / "metadata.yaml") == 0o640
    finally:
        os.umask(old)
