"""A plain rclpy client, written as a ros2_control / rclpy user writes one: subscriptions that
keep what they receive, service and action calls, waits on what arrives (never sleeps).

Nothing here imports the suite's own client code: the contract tests check the suite from
the outside, with expectations taken from the ROS 2 conventions and the issues' contracts.
"""

from __future__ import annotations

import threading
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tests.ros_support import Proc, end_context

#: How long a wait may take before the test fails (generous: a busy 2-core machine; the
#: tests wait on arrivals and never spend this time when the suite works).
PATIENCE = 60.0


def stamp_ns(stamp: Any) -> int:
    """Integer nanoseconds of a builtin_interfaces Time or Duration."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


class Client:
    """One rclpy node in a private context, spun by an executor in a thread of its own (callbacks never block)."""

    def __init__(self, name: str) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        self.context = Context()
        rclpy.init(args=[], context=self.context)
        self.node = rclpy.create_node(name, context=self.context)
        self._executor = SingleThreadedExecutor(context=self.context)
        self._executor.add_node(self.node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()
        self._changed = threading.Condition()
        self.received: dict[str, list[Any]] = defaultdict(list)
        self.stamped: dict[str, dict[int, Any]] = defaultdict(dict)    # topic -> header stamp [ns] -> message
        self._actions: list[Any] = []

    def action_client(self, action_type: Any, name: str) -> Any:
        """An rclpy ActionClient of ``name``, once its server is there."""
        from rclpy.action import ActionClient

        from tensegrity_ros.rclpy_utils.matching import wait_for_action_server

        action = ActionClient(self.node, action_type, name)
        self._actions.append(action)
        assert wait_for_action_server(self.node, action, PATIENCE), f"no action server {name}"
        self._heard_by(name)
        return action

    def _heard_by(self, action_name: str) -> None:
        """Until the server of ``action_name`` answers a request whose reply reader was created
        after the action client's. ``wait_for_action_server`` is this participant's side of discovery
        only; the server matches the client's reply readers later, and Fast DDS drops an answer
        whose reader is still not matched after the response writer's max_blocking_time (100 ms
        by default). Readers are announced in creation
        order on one in-order stream, so that answer proves the earlier readers matched too. The
        request is the server node's ``get_parameters`` (no names: no effect), asked every second
        until one answer arrives."""
        from rcl_interfaces.srv import GetParameters

        from tensegrity_ros.rclpy_utils.matching import wait_for_service

        server = self.wait_until(lambda: [i for i in self.node.get_publishers_info_by_topic(
            f"{action_name}/_action/status") if i.node_namespace.startswith("/")],   # else its node is not known yet
            f"the server of {action_name} in the graph")[0]
        probe = self.node.create_client(GetParameters, f"{server.node_namespace.rstrip('/')}/{server.node_name}"
                                        "/get_parameters")
        try:
            assert wait_for_service(probe, PATIENCE), f"no parameter service of {server.node_name}"
            asked: list[Any] = []
            deadline = time.monotonic() + PATIENCE
            while not any(f.done() for f in asked):
                assert time.monotonic() < deadline, f"waited {PATIENCE:g} s for {server.node_name} to answer"
                asked.append(probe.call_async(GetParameters.Request()))
                arrived = threading.Event()
                asked[-1].add_done_callback(lambda _f, arrived=arrived: arrived.set())
                arrived.wait(1.0)
        finally:
            self.node.destroy_client(probe)

    def stamped_copy(self, topic: str) -> dict[int, Any]:
        """A copy of ``stamped[topic]``, taken under the lock the spin thread adds under: the
        dict grows while a test iterates it (RuntimeError: dictionary changed size)."""
        with self._changed:
            return dict(self.stamped[topic])

    def listen(self, msg_type: Any, topic: str, qos: Any = 100) -> None:
        """Keep every message of ``topic`` in ``received[topic]`` (and, when it has a header,
        in ``stamped[topic]`` by its stamp)."""
        def keep(msg: Any) -> None:
            with self._changed:
                self.received[topic].append(msg)
                if hasattr(msg, "header"):
                    self.stamped[topic][stamp_ns(msg.header.stamp)] = msg
                self._changed.notify_all()

        self.node.create_subscription(msg_type, topic, keep, qos)

    def wait(self, found: Callable[[], Any], what: str, timeout: float = PATIENCE) -> Any:
        """The first true value of ``found()`` (evaluated whenever a message arrives)."""
        with self._changed:
            value = self._changed.wait_for(found, timeout)
        assert value, f"waited {timeout:g} s for {what}"
        return value

    def wait_for(self, topic: str, found: Callable[[Any], Any], what: str, *, since: int = 0,
                 timeout: float = PATIENCE) -> Any:
        """The first message of ``topic`` from ``received[topic][since]`` on for which
        ``found(message)`` is true. Each message is tested once: :meth:`wait` evaluates its
        condition at every arrival on any topic (some 400 a second) holding the lock the spin
        thread adds under, so a condition over every message so far (thousands, late in a
        module) holds that thread up until its readers' queues overflow and drop the very
        messages waited for."""
        checked = since

        def scan() -> tuple[Any] | None:
            nonlocal checked
            received = self.received[topic]
            while checked < len(received):
                checked += 1
                if found(received[checked - 1]):
                    return (received[checked - 1],)
            return None

        return self.wait(scan, what, timeout)[0]

    def wait_count(self, topic: str, n: int, timeout: float = PATIENCE) -> list[Any]:
        """Until ``n`` more messages of ``topic`` have arrived; those messages."""
        start = len(self.received[topic])
        self.wait(lambda: len(self.received[topic]) >= start + n, f"{n} messages on {topic}", timeout)
        return self.received[topic][start:start + n]

    def wait_future(self, future: Any, what: str, timeout: float = PATIENCE) -> Any:
        done = threading.Event()
        future.add_done_callback(lambda _f: done.set())
        assert done.wait(timeout), f"waited {timeout:g} s for {what}"
        return future.result()

    def ask(self, call: Callable[[], Any], what: str, timeout: float = PATIENCE) -> Any:
        """The result of the future ``call()`` returns (an action client's ``send_goal_async``,
        ``get_result_async``, ``cancel_goal_async``), ``call`` made by the spinning thread.
        rclpy's ActionClient (Jazzy) registers a request's future only after sending it, without
        a lock: sent from this thread while the spin thread runs, the answer can come before the
        future exists and is dropped ("Ignoring unexpected goal response"), so a careful rclpy
        user sends from the executor's thread."""
        return self.wait_future(self.request(call, what, timeout), what, timeout)

    def request(self, call: Callable[[], Any], what: str, timeout: float = PATIENCE) -> Any:
        """The future ``call()`` returns, ``call`` made by the spinning thread (as in
        :meth:`ask`), for a test that does something else before it waits for the answer."""
        return self.wait_future(self._executor.create_task(call), f"the spin thread to ask for {what}", timeout)

    def call(self, srv_type: Any, name: str, request: Any = None, timeout: float = PATIENCE) -> Any:
        """One call of the service ``name`` through a new client, once its server has heard
        the client: the server's node answers its ``get_parameters`` through a probe made
        after the client (wait_until_answered; ``wait_for_service`` is this side's match only,
        and the request is sent once: it need not be idempotent)."""
        from rcl_interfaces.srv import GetParameters

        from tensegrity_ros.rclpy_utils.futures import wait_done
        from tensegrity_ros.rclpy_utils.matching import wait_for_service, wait_until_answered

        client = self.node.create_client(srv_type, name)
        try:
            assert wait_for_service(client, timeout), f"no service {name}"
            resolved = self.node.resolve_service_name(name)
            server = self.wait_until(lambda: self._server_of(resolved), f"the node serving {resolved}")
            assert wait_until_answered(self.node, GetParameters, f"{server}/get_parameters", wait_done, timeout), \
                f"{server} did not answer within {timeout:g} s"
            return self.wait_future(client.call_async(request or srv_type.Request()), f"the answer of {name}",
                                    timeout)
        finally:
            self.node.destroy_client(client)

    def _server_of(self, service: str) -> str | None:
        """The fully qualified name of the node the graph shows serving ``service``, or None."""
        for node, namespace in self.node.get_node_names_and_namespaces():
            try:
                services = self.node.get_service_names_and_types_by_node(node, namespace)
            except Exception:  # noqa: BLE001 - rclpy raises a bare RuntimeError for a node that left the graph
                continue
            if any(name == service for name, _types in services):
                return f"{namespace.rstrip('/')}/{node}"
        return None

    def publisher(self, msg_type: Any, topic: str, depth: int = 1000, subscribers: int = 1) -> Any:
        """A publisher of ``topic``, once ``subscribers`` readers have matched it."""
        pub = self.node.create_publisher(msg_type, topic, depth)
        self.wait_until(lambda: pub.get_subscription_count() >= subscribers, f"a subscriber of {topic}")
        return pub

    def wait_until(self, found: Callable[[], Any], what: str, timeout: float = PATIENCE) -> Any:
        """Like :meth:`wait` for a condition on the graph, which notifies no subscription:
        polled at 20 Hz."""
        deadline = time.monotonic() + timeout
        while not (value := found()):
            assert time.monotonic() < deadline, f"waited {timeout:g} s for {what}"
            threading.Event().wait(0.05)
        return value

    def topics_of(self, node: str, namespace: str = "/") -> dict[str, list[str]]:
        """Topic -> types that ``node`` publishes, once the graph knows the node (its
        publications may reach this client before its graph entry does)."""
        self.wait_until(lambda: (node, namespace) in self.node.get_node_names_and_namespaces(),
                        f"node {namespace.rstrip('/')}/{node} in the graph")
        return dict(self.node.get_publisher_names_and_types_by_node(node, namespace))

    def add_node(self, node: Any) -> None:
        """Spin another node of this client's context too."""
        self._executor.add_node(node)

    def drop_node(self, node: Any) -> None:
        """Stop spinning ``node`` and destroy it, both done by the spin thread between two
        waits. From this thread they could come while the spin thread builds its wait set
        from ``node``'s entities: rclpy (Jazzy) guards a subscription's handle there but not
        its QoS event handlers, which then raise ``InvalidHandle`` in the spin thread and
        end it."""
        def drop() -> None:
            self._executor.remove_node(node)
            node.destroy_node()

        self.wait_future(self._executor.create_task(drop), "the spin thread to drop a node")

    def _spin(self) -> None:
        while not self._stop.is_set():
            self._executor.spin_once(timeout_sec=0.05)

    def close(self) -> None:
        # the spin thread ends before the executor goes: shutting an executor down while its
        # thread runs a callback destroys the guard condition that callback then triggers
        self._stop.set()
        self._thread.join(10.0)
        self._executor.shutdown()
        for action in self._actions:       # not while the executor waits on them
            action.destroy()
        end_context(self.context)


def start_sim(folder: Path, scene: str, *params: str, name: str = "sim", remap: tuple[str, ...] = ()) -> Proc:
    """``tensegrity node sim`` on ``scene`` with ``-p`` parameters and ``-r`` remappings, ready
    to publish."""
    args = ["node", "sim", "--ros-args", "-p", f"scene:={scene}"]
    for p in params:
        args += ["-p", p]
    for r in remap:
        args += ["-r", r]
    proc = Proc(args, folder / f"{name}.log")
    proc.wait_for("publishing at", timeout=PATIENCE)
    return proc
