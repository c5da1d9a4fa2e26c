"""A malformed ``custom_data`` in a bag folder's ``metadata.yaml`` loses only itself: the
messages still ``info``, ``play``, ``repair`` and ``view``, each saying in one line that the
custom_data could not be read and what that loses (the recorded scene). The bags are copies
of the shipped ones with their ``metadata.yaml`` edited as a user's editor or another tool
might leave it; the counts they must keep are read from the MCAP file by ``mcap``'s own reader."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml

from tensegrity_ros.bag.errors import BagError
from tensegrity_ros.bag.metadata import MAX_TEXT
from tensegrity_ros.bag.reader import BagReader
from tensegrity_ros.bag.scene import recorded_scene
from tests.bags.conftest import run_cli, run_cli_here

BAGS = Path(__file__).resolve().parents[2] / "bags"

#: custom_data values the metadata reader refuses, and a word of its reason.
MALFORMED = {
    "a_list": (["scene", "six_bar_rest"], "must be a mapping"),
    "a_nested_value": ({"scene": {"name": "six_bar_rest"}}, "must be a string"),
    "a_long_value": ({"scene": "s" * (MAX_TEXT + 1)}, "at most"),
    "a_number_key": ({7: "six_bar_rest"}, "must be a string"),
}
UNREAD = "custom_data of bag"


def _copy(tmp_path: Path, bag: str, custom) -> Path:
    """The shipped ``bag`` in ``tmp_path`` with ``custom`` as its metadata.yaml's custom_data."""
    folder = tmp_path / bag
    shutil.copytree(BAGS / bag, folder)
    meta = yaml.safe_load((folder / "metadata.yaml").read_text())
    meta["rosbag2_bagfile_information"]["custom_data"] = custom
    (folder / "metadata.yaml").write_text(yaml.safe_dump(meta, sort_keys=False))
    return folder


def _stored_count(folder: Path) -> int:
    from mcap.reader import make_reader

    with open(next(folder.glob("*.mcap")), "rb") as f:
        return make_reader(f).get_summary().statistics.message_count


@pytest.mark.parametrize("kind", list(MALFORMED))
def test_info_reads_the_messages_and_notes_the_custom_data_it_cannot_read(tmp_path, kind):
    custom, reason = MALFORMED[kind]
    folder = _copy(tmp_path, "six_bar_roll", custom)
    done = run_cli_here("bag", "info", str(folder))
    assert done.returncode == 0, done.stderr
    assert f"Messages:          {_stored_count(folder)}" in done.stdout
    notes = [line for line in done.stdout.splitlines() if UNREAD in line]
    assert len(notes) == 1 and "cannot be read" in notes[0] and "--scene NAME" in notes[0], done.stdout
    assert "custom_data" in notes[0].partition("):")[2] and reason in notes[0], notes[0]   # the field and why
    with pytest.raises(BagError, match="--scene NAME"):     # what needs the scene says it is unknown
        recorded_scene(BagReader(folder), folder)


def test_a_sound_custom_data_is_read_without_a_note(tmp_path):
    """The control: the same copy with a well-formed custom_data names its scene."""
    folder = _copy(tmp_path, "six_bar_roll", {"scene": "six_bar_rest"})
    done = run_cli_here("bag", "info", str(folder))
    assert done.returncode == 0 and UNREAD not in done.stdout, done.stdout
    assert recorded_scene(BagReader(folder), folder) == "six_bar_rest"


def test_repair_keeps_the_messages_and_drops_the_custom_data_with_a_note(tmp_path):
    folder = _copy(tmp_path, "fold", MALFORMED["a_list"][0])
    count = _stored_count(folder)
    done = run_cli_here("bag", "repair", str(folder))
    assert done.returncode == 0, done.stderr
    assert "custom_data left out" in done.stdout + done.stderr
    info = yaml.safe_load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["custom_data"] is None and info["message_count"] == count


@pytest.mark.ros
def test_play_plays_every_message_and_warns_once(tmp_path):
    """The class-2 fold bag (2 s, played ten times faster)."""
    folder = _copy(tmp_path, "fold", MALFORMED["a_nested_value"][0])
    done = run_cli("play", str(folder), "--rate", "10", "--wait-for-all-acked", "0")
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    warnings = [line for line in done.stderr.splitlines() if UNREAD in line]
    assert len(warnings) == 1 and warnings[0].startswith("warning: "), done.stderr
    played = done.stderr.strip().splitlines()[-1]
    assert played.startswith("played ") and "(stopped)" not in played
    published = sum(int(part.rsplit(" ", 1)[1]) for part in played.removeprefix("played ").split(", "))
    assert published == _stored_count(folder), played


def test_the_view_draws_a_class2_bag_and_a_robot_bag_from_its_markers(tmp_path):
    """In-process (no browser): the class-2 bag needs no scene; the 6-bar's is drawn from its
    own markers and says why (its custom_data cannot be read)."""
    pytest.importorskip("viser")
    from tensegrity_ros.view.bag_source import BagSource

    fold = BagSource(_copy(tmp_path, "fold", MALFORMED["a_long_value"][0]))
    assert fold.duration > 0
    robot = BagSource(_copy(tmp_path, "six_bar_roll", MALFORMED["a_list"][0]))
    assert robot.duration > 0 and robot.topology.kind == "robot" and len(robot.topology.node_names) == 12
