"""A service's first answer to a new client is not lost: the suite's Fast DDS profile makes a
server wait (up to 5 s) for the client's response reader to be matched before answering.

The loss is provoked, not waited for: the server's discovery socket gets a receive buffer
of 9 KB, and before each new client the client node announces 200 subscriptions at once,
so some of the announcements (the client's response reader among them) are dropped and
sent again later, while its request writer (announced on the other discovery stream)
arrives at once. The server then has a request and no reader to answer to. With a
``max_blocking_time`` of 0 it drops the answer and says so ("failed to send response");
with the suite's profile every call is answered. That loss is a race the provocation makes
likely, not certain (a fresh-clone CI run's server without the wait answered all of 60 new
clients of a new node), so it is described in docs/design/ros.md, not asserted.

The suite profile's new clients are made in a node whose participant the server already
knows (a first answer proves it), as a user's next call is: the server then learns of each new endpoint
from its own announcement, and a dropped one is resent after the next heartbeat. A
participant the server does not know yet is announced to it in one burst of everything it
has when the server finds it (Fast DDS's late-joiner path: a heartbeat, the server's
request, the writer's answer); the test's 9 KB buffer drops most of that burst, which then
comes back piece by piece, one resend per discovery heartbeat (1 s in Fast DDS 2.14), and
a loaded run's first call waited more than the profile's 5 s. That is the buffer's doing,
not a user's case: with the system's buffer (208 KB) the burst arrives whole.
docs/design/ros.md, "First answers".
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

PEER = Path(__file__).with_name("peer_node.py")
NOISE = 200                     # subscriptions announced just before each new client
LOST_LINE = "failed to send response"


def _server_profile(tmp_path: Path, name: str, *, blocking_s: int | None) -> Path:
    """The suite's profile with a 9 KB discovery receive buffer (``blocking_s``: the service
    response writer's max_blocking_time instead of the suite's, None: the suite's)."""
    from tensegrity_ros.rclpy_utils.env import LOOPBACK_PROFILE

    text = LOOPBACK_PROFILE.read_text()
    peers = "<maxInitialPeersRange>32</maxInitialPeersRange>"
    assert peers in text and "<sec>5</sec>" in text
    text = text.replace(peers, peers + "<receiveBufferSize>9216</receiveBufferSize><maxMessageSize>9000</maxMessageSize>")
    if blocking_s is not None:
        text = text.replace("<sec>5</sec>", f"<sec>{blocking_s}</sec>")
    path = tmp_path / f"{name}.xml"
    path.write_text(text)
    return path


def _start_server(profile: Path, namespace: str, log: Path) -> subprocess.Popen:
    env = dict(os.environ, FASTRTPS_DEFAULT_PROFILES_FILE=str(profile), ROS_AUTOMATIC_DISCOVERY_RANGE="SYSTEM_DEFAULT")
    server = subprocess.Popen([sys.executable, str(PEER), "--ros-args", "-r", f"__ns:={namespace}"],
                              stdout=subprocess.PIPE, stderr=log.open("w"), text=True, env=env)
    assert server.stdout is not None and server.stdout.readline().strip() == "ready", log.read_text()
    return server


def _first_calls(ctx, namespace: str, rounds: int, wait_s: float, *, known: bool,
                 heard: bool = False) -> list[bool]:
    """``rounds`` new clients of ``solve_ik``, each called once right after
    ``wait_for_service`` (``heard``: and after ``wait_until_service_heard``) and after
    :data:`NOISE` new subscriptions (``known``: in a node the server has answered once
    already): whether each was answered within ``wait_s`` (a liveness bound)."""
    from rcl_interfaces.srv import GetParameters
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from std_msgs.msg import Empty
    from tensegrity_msgs.srv import SolveIK

    from tensegrity_ros.rclpy_utils.futures import spin_until_done
    from tensegrity_ros.rclpy_utils.matching import wait_until_answered, wait_until_service_heard

    node = Node("first_answers_client", namespace=namespace, context=ctx)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    assert not known or wait_until_answered(node, GetParameters, f"{namespace}/smoke_peer/get_parameters",
                                            lambda future, s: spin_until_done(executor, future, s), 60), \
        "the server never heard this node"
    answered = []
    for i in range(rounds):
        noise = [node.create_subscription(Empty, f"noise_{i}_{k}", lambda _m: None, 1) for k in range(NOISE)]
        client = node.create_client(SolveIK, "solve_ik")
        assert client.wait_for_service(timeout_sec=30), "solve_ik never appeared"
        assert not heard or wait_until_service_heard(node, "solve_ik", lambda f, s: spin_until_done(executor, f, s), 60)
        future = client.call_async(SolveIK.Request(x=float(i), y=0.5))
        done = spin_until_done(executor, future, wait_s)
        answered.append(done and future.result().solutions[0].rho1 == float(i))
        client.remove_pending_request(future)
        node.destroy_client(client)
        for subscription in noise:
            node.destroy_subscription(subscription)
    executor.shutdown()
    node.destroy_node()
    return answered


def _stop(server: subprocess.Popen) -> None:
    server.terminate()
    server.wait(timeout=30)


def test_the_suite_profile_answers_every_first_call(ros_context, tmp_path):
    log = tmp_path / "server.log"
    server = _start_server(_server_profile(tmp_path, "suite", blocking_s=None), f"/first_kept_{os.getpid()}", log)
    try:
        answered = _first_calls(ros_context, f"/first_kept_{os.getpid()}", 20, 30.0, known=True)
    finally:
        _stop(server)
    assert all(answered), f"answered: {answered}\n{log.read_text()}"
    assert LOST_LINE not in log.read_text()


def test_a_client_that_waits_until_the_server_heard_it_gets_every_answer_from_a_server_that_does_not_wait(
        ros_context, tmp_path):
    """What the CLI's service calls do (``tensegrity sim``, ``call ik``, ``call formfind``):
    ``wait_until_service_heard`` before the request. A server with max_blocking_time 0 (it
    drops an answer to a reader it has not matched) answers each of 10 such clients; a probe's own answer may be
    dropped meanwhile (the probe asks again), the requests' never are."""
    log = tmp_path / "server.log"
    namespace = f"/first_heard_{os.getpid()}"
    server = _start_server(_server_profile(tmp_path, "no_wait_heard", blocking_s=0), namespace, log)
    try:
        answered = _first_calls(ros_context, namespace, 10, 30.0, known=False, heard=True)
    finally:
        _stop(server)
    assert all(answered), f"answered: {answered}\n{log.read_text()}"
