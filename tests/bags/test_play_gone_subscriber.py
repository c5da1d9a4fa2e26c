"""The player's end with its subscribers killed during the replay: not waited for, named.

A SIGKILLed subscriber's DDS reader stays matched until its participant's lease ends
(Fast DDS: 20 s) and never acknowledges; the player used to wait its whole
``--wait-for-all-acked``. Here that bound is 600 s, so only the player's finding that the
subscribers' nodes no longer answer (``tensegrity_ros/bag/acks.py``) ends the wait with its
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
#: Seconds between the player seeing the peers and its replay (see the test).
DISCOVERY_S = 5.0
#: The subscribers, each in a process of its own and a namespace of its own under the test's:
#: ``smoke_peer`` serves parameters itself; ``smoke_peer_listener`` has no parameter services,
#: so its process's other node is asked instead. The topic is given up only when neither answers.
LISTENERS = ("smoke_peer", "smoke_peer_listener")


def test_subscribers_killed_during_the_replay_are_named_and_not_waited_for(cli):
    from tensegrity_msgs.msg import ActuatorForces

    namespace = f"/gone_{os.getpid()}"          # the peers' and the replayed topic's: no other test's subscriber counts
    topic = f"{namespace}/actuator_forces"
    peers = {listener: spawn([sys.executable, str(PEER), "--ros-args", "-r", f"__ns:={namespace}/{listener}",
                              "-r", f"ping:={topic}"], stdout=subprocess.PIPE, text=True,
                             env=dict(os.environ, PEER_LISTENER="1" if listener == "smoke_peer_listener" else "0"))
             for listener in LISTENERS}
    try:
        for peer in peers.values():
            assert peer.stdout.readline().strip() == "ready"
        with probe("gone_watch", namespace=namespace) as watch:
            echoed: dict[str, list[ActuatorForces]] = {listener: [] for listener in LISTENERS}
            round_trip: dict[str, list[ActuatorForces]] = {listener: [] for listener in LISTENERS}
            for listener in LISTENERS:
                watch.node.create_subscription(
                    ActuatorForces, f"{namespace}/{listener}/pong",
                    lambda m, e=echoed[listener], r=round_trip[listener]: (r if m.header.frame_id == "probe"
                                                                            else e).append(m), 10)
            # each round trip peer -> pong -> this test is matched before the replay starts: at load,
            # discovery could otherwise outlast the replay, whose end (the peers alive) would then
            # come before the kill
            ping = watch.node.create_publisher(ActuatorForces, topic, 10)
            while not all(round_trip.values()):
                msg = ActuatorForces()
                msg.header.frame_id = "probe"
                ping.publish(msg)
                watch.executor.spin_once(timeout_sec=0.1)
                assert all(peer.poll() is None for peer in peers.values())
            watch.node.destroy_publisher(ping)
            # 400 messages over 2.1 s, played at 0.2x: the replay lasts 10 s, and the peers are
            # killed once both echoed. The player sees a peer's reader before that reader has
            # matched the player's writer; a reader that matches only after the replay is
            # sent everything at once and acknowledges it (a fresh-clone run at load ~14 saw the
            # first echo after the player had ended): the replay starts DISCOVERY_S after the
            # player sees the peers, the peers' discovery of the player has that long besides
            play = cli("play", str(FOLD), "--topics", "/actuator_forces", "--rate", "0.2",
                       "--wait-for-subscribers", "60", "--wait-for-all-acked", "600", "--delay", str(DISCOVERY_S),
                       "--ros-args", "-r", f"/actuator_forces:={topic}", log_name="play")
            while not all(echoed.values()):
                watch.executor.spin_once(timeout_sec=0.1)
                assert all(peer.poll() is None for peer in peers.values()) and play.popen.poll() is None, \
                    play.stderr()
            # killed at once, during the replay: leaving the probe (its node's teardown) can take
            # seconds on a loaded machine, long enough for the replay to end first
            replaying = play.popen.poll() is None and "played " not in play.stderr()
            for peer in peers.values():
                os.kill(peer.pid, signal.SIGKILL)
        assert replaying, play.stderr()
        for peer in peers.values():
            peer.wait(PATIENCE)
        play.wait_for("played ", timeout=PATIENCE)
        assert wait_group(play.popen, PATIENCE) == 0
    finally:
        for peer in peers.values():
            if peer.poll() is None:
                peer.kill()
                peer.wait(PATIENCE)
    lines = play.stderr().strip().splitlines()
    warnings = [line for line in lines if line.startswith("warning:")]
    assert len(warnings) == 1, lines
    nodes = ", ".join(f"{namespace}/{listener}/{listener}" for listener in LISTENERS)
    assert f"{topic} (subscribed by {nodes}; none of them answers: not waited for)" in warnings[0]
    assert lines[-1] == "played /actuator_forces 400" and "Traceback" not in play.stderr()
