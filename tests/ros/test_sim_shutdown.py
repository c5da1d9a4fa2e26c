"""A simulator stopped by SIGINT has delivered every message it published: a probe in
another process receives, on every output topic of the robot, exactly as many messages as
the simulator's own summary says it published (its last log line), the last ones included."""

from __future__ import annotations

import os
import re
import signal
import time

import pytest

pytestmark = pytest.mark.ros

PROBE = "sim_shutdown_probe"
#: The simulator's topics outside its namespace.
ABSOLUTE = ("/clock", "/tf")


def _published_counts(stderr: str) -> dict[str, int]:
    """The simulator's summary line ``published: joint_states 812, events 3, /clock 812; ...``."""
    found = re.search(r"published: ([^;]*);", stderr)
    assert found, f"no summary line in the simulator's log:\n{stderr[-2000:]}"
    return {name: int(count) for name, count in (item.rsplit(" ", 1) for item in found.group(1).split(", "))}


def test_every_state_published_before_sigint_is_delivered(cli, ros_context):
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    from rclpy.node import Node
    from rclpy.qos import QoSProfile

    from tensegrity_ros.rclpy_utils.messages import message_class

    namespace = f"/sim_shutdown_{os.getpid()}"
    # the clock starts once the probe subscribes to every output topic: it sees the run from t = 0
    sim = cli("node", "sim", "--ros-args", "-p", "scene:=six_bar_rest", "-p", "publish_rate:=500.0",
              "-p", f"wait_for_node:={PROBE}", "-r", f"__ns:={namespace}", log_name="sim")
    sim.wait_for("waiting for")
    node = Node(PROBE, namespace=namespace, context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(node)
    received: dict[str, int] = {}

    def subscribe_new_topics() -> None:
        try:
            found = node.get_publisher_names_and_types_by_node("tensegrity_sim", namespace)
        except _rclpy.NodeNameNonExistentError:
            return                                 # not discovered yet
        for name, types in found:
            relative = name if name in ABSOLUTE else name[len(namespace) + 1:]
            if not (name in ABSOLUTE or name.startswith(namespace + "/")) or "/_action/" in name or relative in received:
                continue
            received[relative] = 0

            def count(_msg: object, relative: str = relative) -> None:
                received[relative] += 1

            # every message is kept until taken: a loss can only be the simulator's
            node.create_subscription(message_class(types[0]), relative, count, QoSProfile(depth=100_000))

    # the simulator starts its clock only once this node subscribes to all its output topics
    deadline = time.monotonic() + 60
    while sum(received.values()) < 2000:          # a few seconds of the run
        assert time.monotonic() < deadline, f"received only {received}"
        subscribe_new_topics()
        executor.spin_once(timeout_sec=0.1)
    sim.popen.send_signal(signal.SIGINT)
    assert sim.stop(timeout=60) == 0, sim.stderr()
    published = _published_counts(sim.stderr())
    for topic in ABSOLUTE:           # absolute: other simulators of this run publish them too
        published.pop(topic)

    def delivered() -> dict[str, int]:
        return {topic: n for topic, n in received.items() if topic not in ABSOLUTE}

    assert set(published) == set(delivered()), (published, received)
    # What was delivered is already in this node's readers (the simulator waited for their
    # acknowledgements): take all of it. Tens of thousands of messages, one callback each,
    # take this process ~30 s at load 20, so the bound is on progress, not on the whole
    # drain: 30 s in which nothing of this simulator's arrives is a reader with nothing left
    # (/clock and /tf are not counted: another simulator of the domain may publish them).
    taken, last_progress = sum(delivered().values()), time.monotonic()
    while delivered() != published and time.monotonic() - last_progress < 30:
        executor.spin_once(timeout_sec=0.1)
        if sum(delivered().values()) != taken:
            taken, last_progress = sum(delivered().values()), time.monotonic()
    executor.shutdown()
    node.destroy_node()
    got = delivered()
    assert got == published, {k: (got[k], published[k]) for k in published if got[k] != published[k]}


def test_a_test_ends_its_simulator_so_that_it_leaves_the_graph_at_once(cli, ros_context):
    """What the suite's ``cli`` fixture does at a test's end (:func:`tests.ros_support.end_all`,
    SIGINT) takes the simulator out of the ROS graph at once: a client made after it does not
    find its action server, well within the participant's lease (~20 s), for which a SIGKILLed
    simulator stays in the graph, its action server ready to every new client of the domain
    (the module's next test sent its goal to a dead server and waited in vain)."""
    import rclpy
    from rclpy.action import ActionClient
    from simulation_interfaces.action import SimulateSteps

    from tensegrity_ros.rclpy_utils.matching import wait_for_action_server
    from tests.ros_support import end_all

    namespace = f"/sim_leaves_{os.getpid()}"
    sim = cli("node", "sim", "--ros-args", "-p", "initial_state:=paused", "-r", f"__ns:={namespace}", log_name="sim")
    sim.wait_for("publishing at")
    node = rclpy.create_node("graph_watch", namespace=namespace, context=ros_context)
    assert wait_for_action_server(node, ActionClient(node, SimulateSteps, "simulate_steps"), 60)
    end_all([sim])
    assert sim.popen.returncode == 0, sim.stderr()
    deadline = time.monotonic() + 10            # half the lease: a killed simulator is still there then
    while node.get_publishers_info_by_topic(f"{namespace}/simulate_steps/_action/status"):
        assert time.monotonic() < deadline, "the ended simulator is still in the graph after 10 s"
        time.sleep(0.05)
    fresh = ActionClient(node, SimulateSteps, "simulate_steps")
    time.sleep(0.5)                             # what discovery still had to say has been said
    assert not fresh.server_is_ready()
