"""A recorder killed with SIGKILL keeps its ``--custom-data`` (the recorded scene): the
record it writes at the start of its MCAP file survives the kill, and ``tensegrity bag
repair`` puts it back into ``metadata.yaml`` and the repaired file's ``rosbag2`` record.

The files are read here with the ``mcap`` package's own readers (its stream reader on the
killed file, which has no summary; its seeking reader on the repaired one), not the suite's.
"""

from __future__ import annotations

import signal
import time

import pytest
import yaml
from mcap.reader import make_reader
from mcap.records import Metadata
from mcap.stream_reader import StreamReader
from sensor_msgs.msg import JointState

from tensegrity_ros.bag.reader import BagReader

pytestmark = pytest.mark.ros

SCENE = {"scene": "six_bar_rest", "operator": "a b=c"}     # a value with a space and an '='


def test_a_sigkilled_recording_keeps_its_custom_data_through_repair(cli, ros_context, tmp_path):
    import rclpy

    node = rclpy.create_node("kill_custom_data_probe", context=ros_context)
    pub = node.create_publisher(JointState, "/kill_probe_states", 10)
    folder = tmp_path / "killed"
    rec = cli("record", "kill_probe_states", "-o", str(folder), "--custom-data", "scene=six_bar_rest",
              "--custom-data", "operator=a b=c", log_name="rec")
    rec.wait_for("recording")
    k = 0
    while not any(True for _ in BagReader(folder).messages()):     # a chunk reached the file
        pub.publish(JointState(name=["j"], position=[float(k)]))
        k += 1
        time.sleep(0.01)
        assert k < 6000, rec.stderr()
    rec.popen.send_signal(signal.SIGKILL)
    rec.popen.wait(30)
    node.destroy_node()

    assert not (folder / "metadata.yaml").exists()                  # killed: never closed
    killed = next(folder.glob("*.mcap"))
    with open(killed, "rb") as f:
        records = []
        try:
            for r in StreamReader(f, emit_chunks=True).records:
                records.append(r)
        except Exception:            # the killed file ends in a torn record or no footer
            pass
    assert [r.metadata for r in records if isinstance(r, Metadata)] == [SCENE]

    from tests.bags.conftest import run_cli_here

    out = run_cli_here("bag", "repair", str(folder))      # in this process: no interpreter start
    assert out.returncode == 0, out.stderr
    meta = yaml.safe_load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["custom_data"] == SCENE
    with open(folder / killed.name, "rb") as f:
        stored = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    assert yaml.safe_load(stored["rosbag2"]["serialized_metadata"])["custom_data"] == SCENE
    assert stored["tensegrity_custom_data"] == SCENE             # a second kill-proof copy
    assert BagReader(folder).custom_data == SCENE
