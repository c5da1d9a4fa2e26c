"""Bad input and a 10 kHz command flood against the real simulator node and the real
recorder, over DDS on loopback (issue 9).

One flood, three observers: the simulator (must reject every bad command with a throttled
warning naming the problem, keep publishing joint_states at its rate, never integrate
NaN), the recorder (must store every command published: received == published) and the
bag itself, whose joint_states receive times measure the simulator's publish rate during
the flood independently of the simulator's own account.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from tensegrity_msgs.msg import ActuatorForces

from tensegrity_core.sim import Simulator, load_scene
from tensegrity_ros.bag.reader import BagReader

pytestmark = pytest.mark.ros

RATE, COUNT = 10_000.0, 20_000            # 2 s of commands at 10 kHz
#: The flood's own namespace. A reader its publisher matched on the bare topic and lost
#: without an unmatch (a process another module of the same ROS domain killed, whose DDS
#: participant outlives it for its lease) was waited for: the publisher's wait for every
#: acknowledgement then ran its whole 60 s (a 71 s set-up in a fresh-clone run, 12 s usually).
NS = "/flood"
PUBLISH_RATE = 100.0                      # the simulator node's default joint_states rate [Hz]


@pytest.fixture(scope="module")
def flood(tmp_path_factory):
    """Run the simulator and the recorder, flood them, stop them; return what each saw."""
    from tests.ros_support import Proc

    tmp = tmp_path_factory.mktemp("flood")
    hold = [float(f) for f in Simulator(load_scene("class2_at_rest")).command]
    # command_timeout 0: the hold under test is the last valid command's; the watchdog that drops
    # to safe_force after 0.5 s without one (tests/ros/test_sim_node.py) fired on a machine
    # loaded past its cores, where 0.5 s passed without the simulator taking a command
    sim = Proc(["node", "sim", "--ros-args", "-r", f"__ns:={NS}", "-p", "command_timeout:=0.0"], tmp / "sim.log")
    rec = Proc(["record", "-o", str(tmp / "bag"), f"{NS}/actuator_forces", f"{NS}/joint_states"], tmp / "rec.log")
    try:
        sim.wait_for("publishing at")
        rec.wait_for("recording to")
        rec.wait_for(f"recording {NS}/joint_states")
        out = subprocess.run([sys.executable, "-m", "tests.hard.flood_publisher", "--rate", str(RATE),
                              "--count", str(COUNT), "--hold", *map(str, hold), "--subscribers", "2",
                              "--namespace", NS],
                             capture_output=True, text=True, timeout=180)
        assert out.returncode == 0, out.stderr
        published = json.loads(out.stdout.strip().splitlines()[-1])
        import time
        time.sleep(1.0)                   # the simulator publishes on after the flood
    finally:
        rc_rec = rec.stop()
        rc_sim = sim.stop()
    assert rc_rec == 0 and rc_sim == 0
    messages = list(BagReader(tmp / "bag").messages())
    return {"published": published, "hold": hold, "sim_log": sim.stderr(), "rec_log": rec.stderr(),
            "commands": [m for m in messages if m.topic == f"{NS}/actuator_forces"],
            "joints": [m for m in messages if m.topic == f"{NS}/joint_states"]}


def test_flood_published_every_command(flood, record_property):
    """Paced at 10 kHz. The achieved rate depends on what else the shared 2-core machine
    runs (three processes compete here), so it is reported, not asserted (measured
    2.8-10 kHz; the benchmarks hold the timing claims)."""
    p = flood["published"]
    assert p["published"] == COUNT
    record_property("achieved_rate_hz", p["published"] / p["seconds"])
    record_property("every_command_acknowledged_within_60_s", p["acked"])
    print(f"flood: {COUNT} commands in {p['seconds']:.2f} s = {COUNT / p['seconds']:.0f} Hz")


def test_recorder_under_the_flood_loses_no_message(flood):
    """Every command published is in the bag, in order (received == published)."""
    cmds = flood["commands"]
    assert len(cmds) == flood["published"]["published"]
    from tests.hard.flood_publisher import PATTERN

    hold = flood["hold"]
    for k in (0, 1, 4, 5, COUNT - 1):
        msg = deserialize_message(cmds[k].data, ActuatorForces)
        _, names, forces = PATTERN[k % len(PATTERN)]
        assert list(msg.name) == names
        expected = hold if forces is None else forces
        assert np.array_equal(np.array(msg.force), np.array(expected), equal_nan=True)
    assert f"recorded {len(cmds) + len(flood['joints'])} messages" in flood["rec_log"]


def test_simulator_keeps_publishing_through_the_flood(flood, record_property):
    """joint_states go on while the commands arrive (the DDS source timestamps the recorder
    stored, i.e. when the simulator published), their simulated time never going back and advancing.
    Their rate and largest gap are wall-time figures of a machine shared by three processes
    here (and by a second test worker): reported, not asserted (>= 96 Hz and gaps <= 0.1 s
    alone; gaps up to 0.33 s with two busy processes beside the suite)."""
    p = flood["published"]
    t = np.array([m.publish_time_ns for m in flood["joints"]])
    inside = (t >= p["start_ns"]) & (t <= p["end_ns"])
    during = t[inside]
    assert len(during) >= 2
    stamps = [deserialize_message(m.data, JointState).header.stamp for m, keep in zip(flood["joints"], inside)
              if keep]
    sim_ns = np.array([s.sec * 10**9 + s.nanosec for s in stamps])
    assert (np.diff(sim_ns) >= 0).all() and sim_ns[-1] > sim_ns[0]
    rate, gap = len(during) / p["seconds"], float(np.diff(during).max()) / 1e9
    record_property("joint_states_rate_hz", rate)
    record_property("largest_gap_s", gap)
    print(f"flood: joint_states at {rate:.0f} Hz during it (publish_rate {PUBLISH_RATE:g}), largest gap {gap:.3f} s")


def test_simulator_never_integrates_nan_and_holds_the_last_valid_command(flood):
    """Every joint state finite; the applied force (effort) is always the hold force of a
    valid command, never a rejected value; the mechanism stays at rest."""
    js = [deserialize_message(m.data, JointState) for m in flood["joints"]]
    q = np.array([m.position for m in js])
    effort = np.array([m.effort for m in js])
    assert np.isfinite(q).all() and np.isfinite(effort).all()
    p = flood["published"]
    t = np.array([m.publish_time_ns for m in flood["joints"]])
    during = (t >= p["start_ns"]) & (t <= p["end_ns"])
    np.testing.assert_allclose(effort[during][:, :2], np.broadcast_to(flood["hold"], (during.sum(), 2)), rtol=1e-12)
    np.testing.assert_allclose(q[during], np.broadcast_to(q[0], q[during].shape), atol=1e-9)


def test_bad_commands_get_a_throttled_warning_naming_the_problem(flood):
    """Each kind of bad command is named in a warning; at most ~1 warning per second
    per kind (throttled per reason), while many more were rejected; the count of rejections is reported, in
    the warnings and in the summary at exit. How many of the 13,333 bad commands the
    simulator takes depends on the machine: its command subscription keeps only the latest
    (a flood never builds a backlog); each kind is one reason, throttled on its own."""
    log = flood["sim_log"]
    warnings = [line for line in log.splitlines() if "rejected actuator command" in line]
    named = ("is not finite", "unnamed command must give 2 forces", "unknown actuator name",
             "exceeds the limit max_force", "names but")
    assert 1 <= len(warnings) <= len(named) * 2 * (flood["published"]["seconds"] + 2)   # throttled per reason
    assert any(any(n in w for n in named) for w in warnings)
    counts = [int(m) for m in re.findall(r"\((\d+) rejected so far\)", log)]
    total = [int(m) for m in re.findall(r"rejected commands: (\d+);", log)]
    assert counts == sorted(counts) and total and total[-1] >= counts[-1]
    assert total[-1] > len(warnings)                  # the throttle held back the rest
    assert "simulation stopped" not in log
