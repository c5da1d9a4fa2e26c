"""The player's end with a subscriber killed during the replay: not waited for, named.

A SIGKILLed subscriber's DDS reader stays matched until its participant's lease ends
(Fast DDS: 20 s) and never acknowledges; the player used to wait its whole
``--wait-for-all-acked``. Here that bound is 600 s, so only the player's finding that the
subscriber's node no longer answers (``tensegrity_ros/bag/acks.py``) ends the wait with its
one line; before the lease ends, nothing else could.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from tests.process_groups import wait_group
from tests.ros_support import probe, spawn

pytestmark = pytest.mark.ros

PEER = Path(__file__).resolve().parents[1] / "ros" / "peer_node.py"
FOLD = Path(__file__).resolve().parents[2] / "bags" / "fold"
PATIENCE = 120.0
#: Seconds between the player seeing the peer and its replay (see the test).
DISCOVERY_S = 5.0


@pytest.mark.parametrize("listener", ["smoke_peer", "smoke_peer_listener"])
def test_a_subscriber_killed_during_the_replay_is_named_and_not_waited_for(cli, listener):
    """``smoke_peer_listener``: the subscriber's node has no parameter services; its
    process's other node is asked instead."""
    from tensegrity_msgs.msg import ActuatorForces

    namespace = f"/gone_{os.getpid()}"          # the peer's and the replayed topic's: no other test's subscriber counts
    topic = f"{namespace}/actuator_forces"
    peer = spawn([sys.executable, str(PEER), "--ros-args", "-r", f"__ns:={namespace}", "-r", f"ping:={topic}"],
                 stdout=subprocess.PIPE, text=True,
                 env=dict(os.environ, PEER_LISTENER="1" if listener == "smoke_peer_listener" else "0"))
    try:
        assert peer.stdout.readline().strip() == "ready"
        with probe("gone_watch", namespace=namespace) as watch:
            echoed: list[ActuatorForces] = []
            watch.node.create_subscription(
                ActuatorForces, "pong", lambda m: echoed.append(m) if m.header.frame_id != "probe" else None, 10)
            # the round trip peer -> pong -> this test is matched before the replay starts: at load,
            # discovery could otherwise outlast the replay, whose end (the peer alive) would then
            # come before the kill
            ping = watch.node.create_publisher(ActuatorForces, topic, 10)
            round_trip: list[ActuatorForces] = []
            watch.node.create_subscription(
                ActuatorForces, "pong", lambda m: round_trip.append(m) if m.header.frame_id == "probe" else None, 10)
            while not round_trip:
                msg = ActuatorForces()
                msg.header.frame_id = "probe"
                ping.publish(msg)
                watch.executor.spin_once(timeout_sec=0.1)
                assert peer.poll() is None
            watch.node.destroy_publisher(ping)
            # 400 messages over 2.1 s, played at 0.2x: the replay lasts 10 s, and the peer is killed
            # at its first echo. The player sees the peer's reader before the peer's reader has
            # matched the player's writer; a reader that matches only after the replay is
            # sent everything at once and acknowledges it (a fresh-clone run at load ~14 saw the
            # first echo after the player had ended): the replay starts DISCOVERY_S after the
            # player sees the peer, the peer's discovery of the player has that long besides
            play = cli("play", str(FOLD), "--topics", "/actuator_forces", "--rate", "0.2",
                       "--wait-for-subscribers", "60", "--wait-for-all-acked", "600", "--delay", str(DISCOVERY_S),
                       "--ros-args", "-r", f"/actuator_forces:={topic}", log_name="play")
            while not echoed:
                watch.executor.spin_once(timeout_sec=0.1)
                assert peer.poll() is None and play.popen.poll() is None, play.stderr()
        assert play.popen.poll() is None and "played " not in play.stderr(), play.stderr()   # killed during the replay
        os.kill(peer.pid, signal.SIGKILL)
        peer.wait(PATIENCE)
        play.wait_for("played ", timeout=PATIENCE)
        assert wait_group(play.popen, PATIENCE) == 0
    finally:
        if peer.poll() is None:
            peer.kill()
            peer.wait(PATIENCE)
    lines = play.stderr().strip().splitlines()
    warnings = [line for line in lines if line.startswith("warning:")]
    assert len(warnings) == 1, lines
    assert f"{topic} (subscribed by {namespace}/{listener}; none of them answers: not waited for)" in warnings[0]
    assert lines[-1] == "played /actuator_forces 400" and "Traceback" not in play.stderr()
