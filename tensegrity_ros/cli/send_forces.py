"""``tensegrity send-forces``: actuator forces published once or at a rate, checked first
against the simulator's limits, with a word about any other publisher of the topic."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING

from tensegrity_ros.cli._common import CliError
from tensegrity_ros.cli.ros_clients import DISCOVERY_S, check_ros_name, client_node

if TYPE_CHECKING:
    from rclpy.executors import Executor
    from rclpy.node import Node


def send_forces(args: argparse.Namespace) -> int:
    import time

    from tensegrity_ros.nodes.actuator_commands import CommandError, parse_command

    names = args.name or []
    try:
        parse_command(names, args.forces, max_abs_force=float("inf"))
    except CommandError as err:
        raise CliError(str(err)) from None
    if not (args.rate >= 0 and args.rate < float("inf")):
        raise CliError(f"--rate must be a number of Hz >= 0, got {args.rate}")
    check_ros_name(args.topic, "--topic")
    rclpy, node = client_node("tensegrity_send_forces", args.ros_args)
    from rclpy.executors import SingleThreadedExecutor
    from tensegrity_msgs.msg import ActuatorForces

    from tensegrity_ros.rclpy_utils.matching import wait_for_matches

    executor = SingleThreadedExecutor()
    executor.add_node(node)
    pub = node.create_publisher(ActuatorForces, args.topic, 10)
    topic = node.resolve_topic_name(args.topic)
    rivals = RivalPublishers(node, topic)
    try:
        # wait briefly for the subscribers so a one-shot command is not lost: every one the
        # graph knows (the controller listens too: the first match may not be the simulator)
        if wait_for_matches([pub], 1, 5.0, poll=lambda s: executor.spin_once(timeout_sec=s)):
            wait_for_matches([pub], node.count_subscribers(args.topic), 2.0,
                             poll=lambda s: executor.spin_once(timeout_sec=s))
            _check_against_the_simulator(node, executor, topic, names, args.forces)
        period = 1.0 / args.rate if args.rate > 0 else None
        while True:
            rivals.warn()
            msg = ActuatorForces(name=names, force=args.forces)
            msg.header.stamp = node.get_clock().now().to_msg()
            pub.publish(msg)
            if period is None:
                executor.spin_once(timeout_sec=0.2)
                break
            _spin_for(executor, period, time.monotonic)
        if pub.get_subscription_count() == 0:
            print(f"warning: nobody subscribes to {topic}", file=sys.stderr)
        else:   # a writer that goes away first cannot resend what a subscriber missed
            from rclpy.duration import Duration

            pub.wait_for_all_acked(Duration(seconds=2))
            rivals.warn()
        return 0
    except KeyboardInterrupt:      # Ctrl-C or SIGTERM: the end of a repeated command
        return 0
    finally:
        executor.shutdown()        # before the context: rclpy's finalizers break on a collected cycle
        node.destroy_node()
        rclpy.try_shutdown()


class RivalPublishers:
    """Says once who else publishes on the topic. The suite's controller
    (``tensegrity_controller``, started by ``tensegrity up``) stops commanding when it sees
    another node's command, until its next goal: a note says so. Any other publisher is a
    rival: the simulator applies the latest command, so a warning says these forces hold only
    until its next one. DDS discovers publishers over some time, so the graph is looked at
    again before each command, at most once a second. A publisher whose node discovery has
    not named yet (rmw reports ``_NODE_NAME_UNKNOWN_`` until the node's graph message
    arrives) is passed over until a later look names it."""

    CONTROLLER = "tensegrity_controller"
    UNNAMED = "_NODE_NAME_UNKNOWN_"

    def __init__(self, node: Node, topic: str) -> None:
        self.node, self.topic = node, topic
        self._looked = -math.inf
        self._said: set[str] = set()

    def warn(self) -> None:
        import time

        if time.monotonic() - self._looked < 1.0:
            return
        self._looked = time.monotonic()
        me = (self.node.get_name(), self.node.get_namespace())
        others = {(i.node_name, i.node_namespace) for i in self.node.get_publishers_info_by_topic(self.topic)
                  if i.node_name != self.UNNAMED} - {me}
        controllers = sorted(_full_name(n, ns) for n, ns in others if n == self.CONTROLLER)
        rivals = sorted(_full_name(n, ns) for n, ns in others if n != self.CONTROLLER)
        if controllers and "controller" not in self._said:
            self._said.add("controller")
            print(f"note: {', '.join(controllers)} stops commanding on seeing these forces, until its next goal "
                  "(tensegrity move or follow)", file=sys.stderr, flush=True)
        if rivals and "rivals" not in self._said:
            self._said.add("rivals")
            print(f"warning: {', '.join(rivals)} also publish{'es' if len(rivals) == 1 else ''} on {self.topic}, "
                  "and the simulator applies the latest command: these forces hold only until the next one",
                  file=sys.stderr, flush=True)


def _spin_for(executor: Executor, seconds: float, clock: Callable[[], float]) -> None:
    """Spin ``executor`` for ``seconds`` of ``clock()`` in waits of at most 0.1 s (an
    interrupt is taken between two of them)."""
    end = clock() + seconds
    while (left := end - clock()) > 0:
        executor.spin_once(timeout_sec=min(left, 0.1))


def _full_name(name: str, namespace: str) -> str:
    return f"{namespace.rstrip('/')}/{name}"


#: s to wait for a simulator known to read the topic to answer for its limits (a hang guard).
SIMULATOR_ANSWER_S = 30.0


def _check_against_the_simulator(node: Node, executor: Executor, topic: str, names: list[str], forces: list[float]) -> None:
    """Refuse forces that a simulator reading ``topic`` would reject: each simulator found is
    asked for its ``max_force`` parameter. A simulator ``N`` reads through its command node
    (``N`` + :data:`~tensegrity_ros.nodes.sim.COMMANDS_NODE_SUFFIX`): once discovery has named
    that subscriber, ``N`` is known to be there and gets :data:`SIMULATOR_ANSWER_S` to
    answer. Any other subscriber's namespace is looked at for a node offering
    ``get_simulator_features`` during :data:`DISCOVERY_S`, and that node gets as long to
    answer. Nothing is checked when no simulator is found or answers (the subscribers are
    something else)."""
    import time

    from tensegrity_ros.nodes.actuator_commands import CommandError, parse_command

    sims = _named_simulators(node, executor, topic)
    if not sims:
        namespaces = sorted({i.node_namespace for i in node.get_subscriptions_info_by_topic(topic)})
        end = time.monotonic() + DISCOVERY_S
        while not (found := [sim for ns in namespaces for sim in _simulators_in(node, ns)]) \
                and time.monotonic() < end:
            executor.spin_once(timeout_sec=0.1)         # the subscriber's node may not be known yet
        sims = dict.fromkeys(found, DISCOVERY_S)
    for sim, answer_s in sims.items():
        limit = _float_parameter(node, executor, sim, "max_force", answer_s)
        if limit is None:
            continue
        try:
            parse_command(names, forces, max_abs_force=limit)
        except CommandError as err:
            raise CliError(f"{sim} would reject this command: {err}", code=1) from None


def _named_simulators(node: Node, executor: Executor, topic: str) -> dict[str, float]:
    """The simulators whose command nodes subscribe to ``topic``, each with the time [s] it
    gets to answer. Waits (at most :data:`SIMULATOR_ANSWER_S`) until discovery has named every
    subscriber (rmw says ``_NODE_NAMESPACE_UNKNOWN_`` until the node's graph message arrives;
    the simulator's own node is in that message too, created before its command node)."""
    import time

    from tensegrity_ros.nodes.sim import COMMANDS_NODE_SUFFIX

    end = time.monotonic() + SIMULATOR_ANSWER_S
    while True:
        infos = node.get_subscriptions_info_by_topic(topic)
        if all(i.node_namespace.startswith("/") for i in infos) or time.monotonic() >= end:
            break
        executor.spin_once(timeout_sec=0.05)
    graph = set(node.get_node_names_and_namespaces())
    return {_full_name(i.node_name.removesuffix(COMMANDS_NODE_SUFFIX), i.node_namespace): SIMULATOR_ANSWER_S
            for i in infos if i.node_name.endswith(COMMANDS_NODE_SUFFIX)
            and (i.node_name.removesuffix(COMMANDS_NODE_SUFFIX), i.node_namespace) in graph}


def _simulators_in(node: Node, namespace: str) -> list[str]:
    """Full names of the nodes in ``namespace`` that offer ``get_simulator_features``."""
    found = []
    for name, ns in node.get_node_names_and_namespaces():
        if ns != namespace:
            continue
        try:
            services = node.get_service_names_and_types_by_node(name, ns)
        except Exception:  # noqa: BLE001 - the node left the graph in between
            continue
        if any(s.rsplit("/", 1)[-1] == "get_simulator_features" for s, _ in services):
            found.append(_full_name(name, ns))
    return found


def _float_parameter(node: Node, executor: Executor, owner: str, name: str, answer_s: float) -> float | None:
    """The value of the number parameter ``name`` of node ``owner`` (its parameter
    service), or None when its service does not show, or it does not answer, within
    ``answer_s`` [s] each, or it has none."""
    from rcl_interfaces.msg import ParameterType
    from rcl_interfaces.srv import GetParameters

    from tensegrity_ros.rclpy_utils.futures import spin_until_done
    from tensegrity_ros.rclpy_utils.matching import wait_for_service, wait_until_answered

    client = node.create_client(GetParameters, f"{owner}/get_parameters")
    try:
        # asked once the owner has matched this client's response reader (a probe made after
        # it answered), else the answer can be lost
        if not wait_for_service(client, answer_s) or not wait_until_answered(
                node, GetParameters, f"{owner}/get_parameters", lambda f, t: spin_until_done(executor, f, t), answer_s):
            return None
        future = client.call_async(GetParameters.Request(names=[name]))
        if not spin_until_done(executor, future, answer_s) or not future.result().values:
            return None
        value = future.result().values[0]
        return {ParameterType.PARAMETER_DOUBLE: value.double_value,
                ParameterType.PARAMETER_INTEGER: float(value.integer_value)}.get(value.type)
    finally:
        node.destroy_client(client)
