"""The client commands users run without the ros2 CLI: call-ik, send-forces, echo (issue 6).

What a command says and returns is checked in this process (``run_cli_here``); what a
process prints in all (one exact error line), and how it stops on a signal, with processes."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import time

import pytest

from tests.process_groups import kill_group, wait_group
from tests.ros_support import TENSEGRITY, run_cli, run_cli_here, spawn

pytestmark = pytest.mark.ros


def test_call_ik_names_the_remap_to_a_service_in_another_namespace_and_through_it_reaches_the_target(cli):
    """call-ik without a namespace against an IK node in /hint_ns: the one error line names
    where the service is and the --ros-args that reach it; through them, the JSON answer
    reaches the target, a target out of reach fails, and a folded one is named singular."""
    ik = cli("node", "ik", "--ros-args", "-r", "__ns:=/hint_ns", log_name="ik")
    ik.wait_for("solve_ik ready")
    out = run_cli("call-ik", "1", "1", "--timeout", "5", timeout=60)
    assert out.returncode == 3
    assert out.stderr == ("error: service /solve_ik not available after 5 s (is the suite up? `tensegrity up`); "
                          "found /hint_ns/solve_ik: add --ros-args -r __ns:=/hint_ns\n"), out.stderr
    reach = ("--ros-args", "-r", "__ns:=/hint_ns")
    # D for rho = (0.5, 0.6) from the energy-minimising beta (paper parameters)
    beta = math.atan2(math.sqrt(4 - 1.1**2), 3 * 0.6 - 0.5)
    x, y = 0.5 + math.cos(beta), math.sin(beta)
    out = run_cli_here("call-ik", f"{x!r}", f"{y!r}", "--json", "--timeout", "30", *reach)
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert data["success"] and len(data["solutions"]) == 1
    s = data["solutions"][0]
    assert (s["rho1"], s["rho2"]) == pytest.approx((0.5, 0.6), abs=1e-10)
    bad = run_cli_here("call-ik", "5", "5", *reach)
    assert bad.returncode == 1 and bad.stdout.startswith("failed:")
    folded = run_cli_here("call-ik", "0", "1", *reach)        # the paper's q_F: valid, named singular
    assert folded.returncode == 0, folded.stderr
    assert "lies on the singular set folded" in folded.stdout.splitlines()[0]
    assert "nearest singular set folded at 0 L" in folded.stdout


def test_service_missing_is_one_clear_line():
    out = run_cli_here("call-ik", "1", "1", "--service", "no_such_service", "--timeout", "1")
    assert out.returncode == 3
    assert out.stderr.startswith("error: service /no_such_service not available")


def test_namespace_hint_only_for_a_relative_name_found_elsewhere():
    from tensegrity_ros.cli.ros_clients import namespace_hint

    graph = ["/a/b/solve_ik", "/robot1/solve_ik", "/robot1/find_form", "/x_solve_ik"]
    assert namespace_hint("solve_ik", graph) == "; found /a/b/solve_ik (and 1 more): add --ros-args -r __ns:=/a/b"
    assert namespace_hint("find_form", graph) == "; found /robot1/find_form: add --ros-args -r __ns:=/robot1"
    assert namespace_hint("/solve_ik", graph) == ""          # absolute: a namespace does not move it
    assert namespace_hint("reset", graph) == ""
    assert namespace_hint("solve_ik", ["/solve_ik"]) == ""   # there, just not answering


def _wait(condition, what: str, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f"never: {what}"
        time.sleep(0.02)


def test_send_forces_applies_forces_refuses_what_the_simulator_rejects_and_names_another_publisher(cli, ros_context,
                                                                                                   tmp_path):
    """Forces within the simulator's limits are applied (echo shows them). 5000 N is over
    the simulator's max_force (1000 N by default): refused with that limit, exit 1, nothing
    sent (the simulator counts no rejected command). Publishers of this
    process on actuator_forces: one named as the suite's controller gets a note (it steps
    aside until its next goal), any other a warning naming it (once discovery has shown
    them: commands at a rate go on until it has)."""
    from tensegrity_msgs.msg import ActuatorForces

    sim = cli("node", "sim", "--ros-args", "-p", "command_timeout:=0.0", log_name="sim")
    sim.wait_for("publishing at")
    # forces the simulator takes: applied, as echo shows
    out = run_cli_here("send-forces", "0.5", "-0.2")
    assert out.returncode == 0, out.stderr
    echo = run_cli_here("echo", "joint_states", "-c", "1", "--json", "--timeout", "30")
    assert echo.returncode == 0, echo.stderr
    msg = json.loads(echo.stdout.splitlines()[0])
    assert msg["name"] == ["rho1", "rho2", "beta"]
    assert msg["effort"][:2] == [0.5, -0.2]

    out = run_cli("send-forces", "5000", "0", timeout=120)
    assert out.returncode == 1, out.stderr
    assert out.stderr.strip().splitlines() == [
        "error: /tensegrity_sim would reject this command: force for f1 = 5000 N exceeds the limit "
        "max_force = 1000 N"]
    peers = [rclpy_node(ros_context, name) for name in ("rival_controller", "tensegrity_controller")]
    for peer in peers:                                 # (kept alive in `peers` until the end)
        peer.create_publisher(ActuatorForces, "actuator_forces", 10)
    log = tmp_path / "send.log"
    with open(log, "w") as err:
        proc = spawn([TENSEGRITY, "send-forces", "0.5", "-0.2", "--rate", "20"], stdout=err, stderr=err,
                     env=dict(os.environ))
    try:
        _wait(lambda: "warning" in log.read_text() and "note" in log.read_text(), f"the warning and the note in {log}")
        proc.send_signal(signal.SIGINT)
        assert wait_group(proc, 60) == 0
    finally:
        kill_group(proc)
    assert sorted(log.read_text().splitlines()) == [
        "note: /tensegrity_controller stops commanding on seeing these forces, until its next goal (tensegrity "
        "move or follow)",
        "warning: /rival_controller also publishes on /actuator_forces, and the simulator applies the latest "
        "command: these forces hold only until the next one"]
    assert sim.stop() == 0
    assert "rejected commands: 0;" in sim.stderr()


def rclpy_node(ctx, name: str):
    import rclpy

    return rclpy.create_node(name, context=ctx)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_echo_says_what_it_waits_for_and_stops_cleanly_on_a_signal(tmp_path, ros_context, sig):
    """A misspelt topic: after a moment echo says it is waiting, with the closest topic in
    the graph (again when discovery brings a closer one). Once the topic appears it waits for messages in silence; SIGTERM or Ctrl-C
    then ends it with exit code 0 and no traceback."""
    from std_msgs.msg import String

    node = rclpy_node(ros_context, "echo_test_peer")
    node.create_publisher(String, "quiet_topics", 10)
    log = tmp_path / "echo.log"
    with open(log, "w") as err:
        proc = spawn([TENSEGRITY, "echo", "quiet_topic"], stdout=subprocess.PIPE, stderr=err,
                     env=dict(os.environ))
    try:
        # said after a moment, and said again with the closest topic once discovery shows it
        _wait(lambda: "waiting for topic /quiet_topic: nobody publishes or subscribes to it yet (did you mean "
              "/quiet_topics?)" in log.read_text(), "echo's waiting line with the closest topic")
        pub = node.create_publisher(String, "quiet_topic", 10)
        _wait(lambda: pub.get_subscription_count() > 0, "echo's subscription")
        proc.send_signal(sig)
        code = wait_group(proc, 60)
    finally:
        kill_group(proc)
    assert code == 0, f"echo ended with exit code {code} on signal {sig.name}; its stderr:\n{log.read_text()}"
    assert "Traceback" not in log.read_text() and proc.stdout.read() == b""


def test_echo_interrupted_while_it_subscribes_ends_cleanly(ros_context, monkeypatch):
    """A Ctrl-C that lands inside rclpy's ``create_subscription``, after the subscription is
    listed and before its event handlers are (rclpy wakes the executors in between: the
    signal is sent from there), ends echo with exit code 0 and no traceback. Delivered at
    once, it left the node's lists apart and ``destroy_node`` raised ``ValueError`` (exit
    code 1; 1 of 45 loaded runs of the signal test above)."""
    import threading

    from rclpy.node import Node
    from std_msgs.msg import String

    peer = rclpy_node(ros_context, "echo_interrupt_peer")
    peer.create_publisher(String, "interrupted_topic", 10)
    wake = Node._wake_executor
    sent = []

    def wake_and_interrupt(self):
        if not sent and self.get_name() == "tensegrity_echo" and any(
                sub.topic_name == "/interrupted_topic" for sub in self.subscriptions):
            sent.append(1)
            signal.pthread_kill(threading.get_ident(), signal.SIGINT)
        return wake(self)

    monkeypatch.setattr(Node, "_wake_executor", wake_and_interrupt)
    out = run_cli_here("echo", "interrupted_topic", "--timeout", "60")
    assert sent, "echo never subscribed"
    assert out.returncode == 0 and out.stdout == "", out.stderr
    peer.destroy_node()


def test_send_forces_at_a_rate_stops_cleanly_on_sigterm(tmp_path, ros_context):
    from rclpy.qos import QoSProfile
    from tensegrity_msgs.msg import ActuatorForces

    from tensegrity_ros.rclpy_utils.raw_take import take_all

    node = rclpy_node(ros_context, "send_forces_test_peer")
    sub = node.create_subscription(ActuatorForces, "actuator_forces", lambda *_: None, QoSProfile(depth=10),
                                   raw=True)
    log = tmp_path / "send.log"
    with open(log, "w") as err:
        proc = spawn([TENSEGRITY, "send-forces", "0.1", "0.2", "--rate", "20"], stdout=err, stderr=err,
                     env=dict(os.environ))
    try:
        _wait(lambda: take_all(sub), "a command")
        proc.send_signal(signal.SIGTERM)
        assert wait_group(proc, 60) == 0
    finally:
        kill_group(proc)
    assert log.read_text() == ""


def test_a_publisher_discovery_has_not_named_yet_is_named_on_a_later_look(capsys, monkeypatch):
    """rmw reports a publisher's node as ``_NODE_NAME_UNKNOWN_`` until the node's graph
    message arrives: send-forces says nothing about it then, and names it on the look after."""
    from types import SimpleNamespace

    from tensegrity_ros.cli.send_forces import RivalPublishers

    graph = [[SimpleNamespace(node_name="_NODE_NAME_UNKNOWN_", node_namespace="_NODE_NAMESPACE_UNKNOWN_")],
             [SimpleNamespace(node_name="rival", node_namespace="/")]]
    node = SimpleNamespace(get_name=lambda: "send_forces", get_namespace=lambda: "/",
                           get_publishers_info_by_topic=lambda topic: graph.pop(0))
    clock = iter([0.0, 0.0, 1.5, 1.5])      # two looks a second and a half apart
    monkeypatch.setattr("time.monotonic", lambda: next(clock))
    rivals = RivalPublishers(node, "/actuator_forces")
    rivals.warn()
    assert capsys.readouterr().err == ""
    rivals.warn()
    assert capsys.readouterr().err.startswith("warning: /rival also publishes on /actuator_forces")


def test_send_forces_knows_a_simulator_from_its_command_node_without_looking_for_its_services(ros_context):
    """A subscriber ``N_commands`` is a simulator N's command node, so N is there and is asked
    for its limits however long its services take to show; a subscriber of another name is
    not taken for a simulator. Named only once discovery names the subscriber (polled until
    then: no window)."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from tensegrity_msgs.msg import ActuatorForces

    from tensegrity_ros.cli.send_forces import SIMULATOR_ANSWER_S, _named_simulators

    sim = rclpy.create_node("fake_sim", namespace="/named", context=ros_context)
    reader = rclpy.create_node("fake_sim_commands", namespace="/named", context=ros_context)
    other = rclpy.create_node("listener_commands_not", namespace="/named", context=ros_context)
    asker = rclpy.create_node("asker", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(asker)
    try:
        for node in (reader, other):
            node.create_subscription(ActuatorForces, "/named/actuator_forces", lambda _m: None, 10)
        deadline = time.monotonic() + 60
        while asker.count_subscribers("/named/actuator_forces") < 2:
            assert time.monotonic() < deadline
            executor.spin_once(timeout_sec=0.05)
        assert _named_simulators(asker, executor, "/named/actuator_forces") == {"/named/fake_sim": SIMULATOR_ANSWER_S}
    finally:
        executor.shutdown()
        for node in (sim, reader, other, asker):
            node.destroy_node()
