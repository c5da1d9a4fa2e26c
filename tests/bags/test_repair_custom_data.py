"""A malformed ``custom_data`` record never stops ``tensegrity bag repair``: the messages
are what repair saves. The bags are written by another tool (the ``mcap`` library's own
writer, not the suite's), with a hostile ``tensegrity_custom_data`` or ``rosbag2`` record
and no ``metadata.yaml``; the repaired storage is read back with ``mcap``'s reader."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml
from mcap.reader import make_reader
from mcap.writer import Writer

from tensegrity_ros.bag.metadata import MAX_TEXT
from tensegrity_ros.bag.reader import BagReader
from tests.bags.conftest import rosbags_cdr_samples, run_cli_here

MAX_LINE = 400       # a note quotes excerpts only: far below the hostile records' sizes

HOSTILE = {
    "long_value": ({"tensegrity_custom_data": {"scene": "s" * (MAX_TEXT + 1)}}, "at most"),
    "long_key": ({"tensegrity_custom_data": {"k" * (MAX_TEXT + 1): "six_bar_rest"}}, "at most"),
    "rosbag2_not_yaml": ({"rosbag2": {"serialized_metadata": "custom_data: [unclosed"}}, "not valid YAML"),
    # aliases that would expand to ~10^9 strings: refused while parsing (bounded reader)
    "rosbag2_alias_bomb": ({"rosbag2": {"serialized_metadata": "a: &a [x, x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{chr(98 + i)}: &{chr(98 + i)} [{', '.join(['*' + chr(97 + i)] * 10)}]\n" for i in range(8))}}, "YAML"),
    "rosbag2_custom_data_a_list": (
        {"rosbag2": {"serialized_metadata": "custom_data: [scene, six_bar_rest]\n"}}, "must be a mapping"),
    "rosbag2_value_not_text": (
        {"rosbag2": {"serialized_metadata": "custom_data: {scene: [1, 2]}\n"}}, "must be a string"),
}


def _foreign_bag(folder: Path, records: dict[str, dict[str, str]]) -> list[bytes]:
    """A bag folder holding one MCAP file written by ``mcap``'s writer: ``records`` as
    metadata records right after the header (where a recorder writes its custom_data), then
    ten JointState messages. Returns the messages' CDR bytes in order."""
    folder.mkdir()
    samples = [s for s in rosbags_cdr_samples(10) if s[0] == "/joint_states"]
    with open(folder / f"{folder.name}_0.mcap", "wb") as f:
        writer = Writer(f)
        writer.start(profile="ros2", library="another tool")
        for name, data in records.items():
            writer.add_metadata(name, data)
        schema = writer.register_schema("sensor_msgs/msg/JointState", "ros2msg",
                                        b"std_msgs/Header header\nstring[] name\nfloat64[] position\n"
                                        b"float64[] velocity\nfloat64[] effort\n")
        channel = writer.register_channel("/joint_states", "cdr", schema)
        for seq, (_, _, t, data, _) in enumerate(samples):
            writer.add_message(channel, t, data, t, sequence=seq)
        writer.finish()
    return [s[3] for s in samples]


def _stored(path: Path) -> tuple[list[bytes], set[str]]:
    """Message bytes in log-time order and metadata record names, as ``mcap`` reads them."""
    with open(path, "rb") as f:
        reader = make_reader(f)
        messages = [m.data for _, _, m in reader.iter_messages(log_time_order=True)]
        names = {m.name for m in reader.iter_metadata()}
    return messages, names


@pytest.mark.parametrize("killed", [True, False], ids=["killed", "intact"])
@pytest.mark.parametrize("kind", sorted(HOSTILE))
def test_repair_saves_the_messages_and_says_the_custom_data_is_left_out(tmp_path, kind, killed):
    records, needle = HOSTILE[kind]
    folder = tmp_path / "bag"
    sent = _foreign_bag(folder, records)
    storage = folder / "bag_0.mcap"
    if killed:      # no summary, no footer: the recovery scan reads it
        storage.write_bytes(storage.read_bytes()[:-40])
    before = storage.read_bytes()

    done = run_cli_here("bag", "repair", str(folder))
    assert done.returncode == 0, done.stderr
    notes = [line for line in done.stdout.splitlines() if "left out" in line]
    assert len(notes) == 1 and notes[0].startswith("  custom_data left out"), done.stdout
    assert needle in notes[0] and len(notes[0]) < MAX_LINE, notes[0][:MAX_LINE]

    messages, names = _stored(storage)
    assert messages == sent
    if killed:      # rewritten without the hostile record, the damaged file kept beside it
        assert "tensegrity_custom_data" not in names
        assert (folder / "bag_0.mcap.orig").read_bytes() == before
    else:           # intact storage is left as it was; only metadata.yaml is written
        assert storage.read_bytes() == before
    info = yaml.safe_load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["custom_data"] is None and info["message_count"] == len(sent)
    assert BagReader(folder).custom_data is None


def test_repair_json_lists_the_note(tmp_path):
    records, needle = HOSTILE["long_value"]
    folder = tmp_path / "bag"
    sent = _foreign_bag(folder, records)
    done = run_cli_here("bag", "repair", str(folder), "--json")
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result["message_count"] == len(sent)
    assert len(result["notes"]) == 1 and needle in result["notes"][0]


def test_a_sound_custom_data_record_is_kept_without_a_note(tmp_path):
    """The control: the same foreign bag with a well-formed record keeps its custom_data."""
    folder = tmp_path / "bag"
    _foreign_bag(folder, {"tensegrity_custom_data": {"scene": "six_bar_rest"}})
    storage = folder / "bag_0.mcap"
    storage.write_bytes(storage.read_bytes()[:-40])
    done = run_cli_here("bag", "repair", str(folder))
    assert done.returncode == 0 and "left out" not in done.stdout, done.stdout
    info = yaml.safe_load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["custom_data"] == {"scene": "six_bar_rest"}
    assert "tensegrity_custom_data" in _stored(storage)[1]
