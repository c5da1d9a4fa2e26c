"""Waiting until publishers are matched on *both* sides before sending what must arrive.

``Publisher.get_subscription_count()`` counts the readers the writer has matched. With
Fast DDS the reader can match the writer a little later (each side learns of the other
from its own discovery message), and a volatile reader drops what was written in that
gap although the writer already counted it (eProsima/Fast-DDS#2641). Seen here under load
on a 2-core machine: the first one or two messages of a replay at 200 Hz lost, i.e. a gap
of 5-10 ms. Nothing on the writer side reports the reader's match, so after every
publisher has its subscribers :func:`wait_for_matches` holds for ``settle_s`` more (the
count must stay up for that whole time), which covers that gap when the reader's process
runs in it; a reader's process that gets no CPU then (a loaded machine, a stopped process)
is still behind. Where the reader's node serves something, an answer proves its match:
:func:`wait_until_answered` asks it through a client made after the writers (a lockstep
client's commands), :func:`wait_until_server_heard` before an action goal is sent,
:func:`wait_until_service_heard` before a service request is sent, and
:func:`wait_until_subscribers_heard` asks every subscribing node (a replay's first messages).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from typing import Any

#: Seconds the matches must hold before sending (about 25x the gap seen under load).
MATCH_SETTLE_S = 0.25
#: Seconds between two looks of :func:`wait_for_service` and :func:`wait_for_action_server`.
SERVER_POLL_S = 0.01


def wait_for_service(client: Any, timeout_s: float) -> bool:
    """Whether the service ``client`` (rclpy's ``Client``) has a server: True as soon as it
    has, False after ``timeout_s`` s of wall time or once its context is shut down.

    ``Client.wait_for_service`` (rclpy 7.1.6) looks every 0.25 s and counts its sleeps, not
    the time (a placeholder, ros2/rclpy#58: no graph event for it): a server that discovery
    gives a fresh client in ~0.1 s on loopback was seen ~0.25 s after the client was made,
    at every client's start (measured: 0.25 s, against 0.09-0.12 s looking every 10 ms), and
    on a loaded machine its timeout ran long. ``service_is_ready`` is one call into rcl."""
    return _wait_until_ready(client.service_is_ready, client.context, timeout_s)


def wait_for_action_server(node: Any, client: Any, timeout_s: float) -> bool:
    """Whether the action ``client`` (rclpy's ``ActionClient``, made on ``node``) has a
    server: True as soon as it has, False after ``timeout_s`` s of wall time or once
    ``node``'s context is shut down. ``ActionClient.wait_for_server`` has the same 0.25 s
    sleeps as ``Client.wait_for_service`` (:func:`wait_for_service`)."""
    return _wait_until_ready(client.server_is_ready, node.context, timeout_s)


def _wait_until_ready(ready: Callable[[], bool], context: Any, timeout_s: float) -> bool:
    """Whether ``ready()`` turned true, looked at every :data:`SERVER_POLL_S` s until
    ``timeout_s`` s of wall time have passed or ``context`` is shut down."""
    deadline = time.monotonic() + timeout_s
    while context.ok():
        if ready():
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(SERVER_POLL_S)
    return False


def subscribed_by(node: Any, publishers: Iterable[Any], name: str) -> bool:
    """Whether the node ``name`` in ``node``'s namespace has a subscription on the topic of
    every one of ``publishers`` (the graph's endpoint lists: another subscriber of a topic,
    such as a controller on joint_states, does not count for it)."""
    ns = node.get_namespace()
    return all(any(i.node_name == name and i.node_namespace == ns
                   for i in node.get_subscriptions_info_by_topic(p.topic_name)) for p in publishers)


def wait_for_matches(publishers: Iterable[Any], minimum: int = 1, timeout_s: float | None = None,
                     *, settle_s: float = MATCH_SETTLE_S,
                     should_stop: Callable[[], bool] = lambda: False,
                     poll: Callable[[float], object] = time.sleep,
                     also: Callable[[], bool] = lambda: True) -> bool:
    """Return True once every publisher has had at least ``minimum`` matched subscriptions,
    and ``also()`` has been true, for ``settle_s`` seconds without interruption; False when they are not all matched
    after ``timeout_s`` (None: no limit) or when ``should_stop()`` turns true. ``poll(seconds)`` waits between checks (pass an
    executor's ``spin_once`` when the caller must keep spinning)."""
    pubs = list(publishers)
    deadline = None if timeout_s is None else time.monotonic() + timeout_s
    matched_since = None
    while True:
        now = time.monotonic()
        if all(p.get_subscription_count() >= minimum for p in pubs) and also():
            matched_since = now if matched_since is None else matched_since
            if now - matched_since >= settle_s:
                return True
        else:
            matched_since = None
            if deadline is not None and now > deadline:
                return False
        if should_stop():
            return False
        poll(0.01)


def wait_until_server_heard(node: Any, action_name: str, wait: Callable[[Any, float], bool], timeout_s: float,
                            *, attempt_s: float = 1.0) -> bool:
    """Return True once the node serving the action ``action_name`` is known to have matched
    every endpoint that ``node``'s participant created before this call -- in particular the
    request writers and reply readers of an ``ActionClient`` made just before -- False after
    ``timeout_s``.

    ``ActionClient.wait_for_server()`` reports only this participant's side of discovery. The
    server's participant learns of a new client's endpoints later, from discovery messages of
    its own; rmw_fastrtps waits the response writer's ``max_blocking_time`` for the client's
    reader when it answers a request (100 ms by default, 5 s under the suite's profile:
    docs/design/ros.md, "First answers"), then drops the answer, and a goal sent at once never
    gets its response (a goal of a loaded fresh-clone run waited 30 s). Proof that the server
    has matched both: an answer to a request whose writer and reply reader were created
    *after* the action client's. A participant announces its writers and its readers in
    creation order, each on one reliable, in-order discovery stream (SEDP), so a server that
    has matched the later endpoints (the request arrived, its answer came back) has matched
    every earlier one. The probe is the server node's ``get_parameters`` service with
    no names (no effect; every rclpy and rclcpp node has it unless started without parameter
    services), asked again every ``attempt_s`` s until one answer arrives; any answer counts.

    ``wait(future, seconds)`` waits for a future and returns whether it is done: the
    caller's ``spin_until_done`` with its executor, or ``futures.wait_done`` when another
    thread spins ``node``. A server whose node has no parameter services gives False at once:
    nothing proves the match then, and the caller goes on as before."""
    deadline = time.monotonic() + timeout_s
    # The graph names an endpoint's node only once that node's participant has said which
    # node owns it (until then rmw gives "_NODE_NAMESPACE_UNKNOWN_"); it fills in by itself.
    while not (servers := [i for i in node.get_publishers_info_by_topic(f"{action_name}/_action/status")
                           if i.node_namespace.startswith("/")]):
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    info = servers[0]
    return _node_answered(node, info.node_name, info.node_namespace, wait, deadline, attempt_s=attempt_s) is True


def wait_until_service_heard(node: Any, service: str, wait: Callable[[Any, float], bool], timeout_s: float,
                             *, attempt_s: float = 1.0) -> bool:
    """Return True once the node serving ``service`` (a name ``node`` resolves) is known to
    have matched every endpoint ``node``'s participant created before this call, the response
    reader of a service client made just before among them; False after ``timeout_s``.

    ``Client.wait_for_service()`` is this side's match only: a request sent at once can reach
    a server that has not yet matched the client's response reader, and rmw_fastrtps then
    drops the answer after the response writer's ``max_blocking_time``, 5 s under the suite's
    profile and 100 ms under any other (docs/design/ros.md, "First answers"). The proof is
    :func:`wait_until_server_heard`'s: the serving node answers its ``get_parameters``
    through a client made now. A server whose node has no parameter services gives False
    at once (nothing proves the match; the caller goes on as before).
    ``wait(future, seconds)`` as for :func:`wait_until_server_heard`."""
    deadline = time.monotonic() + timeout_s
    resolved = node.resolve_service_name(service)
    while (server := _server_of(node, resolved)) is None:
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return _node_answered(node, *server, wait, deadline, attempt_s=attempt_s) is True


def _server_of(node: Any, service: str) -> tuple[str, str] | None:
    """``(name, namespace)`` of a node the graph shows serving the fully qualified ``service``."""
    for name, namespace in node.get_node_names_and_namespaces():
        try:
            services = node.get_service_names_and_types_by_node(name, namespace)
        except Exception:  # noqa: BLE001 - rclpy raises a bare RuntimeError for a node that left the graph
            continue
        if any(found == service for found, _types in services):
            return name, namespace
    return None


def wait_until_subscribers_heard(node: Any, publishers: Iterable[Any], wait: Callable[[Any, float], bool],
                                 timeout_s: float, *, should_stop: Callable[[], bool] = lambda: False,
                                 attempt_s: float = 1.0) -> bool:
    """Return True once every node the graph shows subscribing to the topic of one of
    ``publishers`` has answered its ``get_parameters`` (no names: no effect) through a client
    made in this call, False after ``timeout_s`` or when ``should_stop()`` turns true.

    The writers count a subscription when *they* have matched its reader
    (:func:`wait_for_matches`); the reader matches the writers from discovery messages of
    its own, later on a loaded machine, and drops what comes before. The answer proves that
    the subscriber's participant has matched every endpoint ``node``'s participant created
    before this call, the ``publishers`` among them (:func:`wait_until_answered`). A
    subscribing node without parameter services cannot be asked and is passed over: for it,
    only the settle of :func:`wait_for_matches` stands. A subscription named in the graph
    comes after its node's parameter services on the participant's in-order discovery stream,
    so they are known by then. ``wait(future, seconds)`` as for :func:`wait_until_server_heard`."""
    deadline = time.monotonic() + timeout_s
    topics = [p.topic_name for p in publishers]
    # rmw names an endpoint's node "_NODE_NAMESPACE_UNKNOWN_" until that node's participant has
    # said which node owns it; it fills in by itself
    while True:
        infos = [i for t in topics for i in node.get_subscriptions_info_by_topic(t)]
        if all(i.node_namespace.startswith("/") for i in infos):
            break
        if time.monotonic() > deadline or should_stop():
            return False
        time.sleep(0.01)
    for name, namespace in sorted({(i.node_name, i.node_namespace) for i in infos}):
        if _node_answered(node, name, namespace, wait, deadline, should_stop, attempt_s=attempt_s) is False:
            return False
    return True


def _node_answered(node: Any, name: str, namespace: str, wait: Callable[[Any, float], bool], deadline: float,
                   should_stop: Callable[[], bool] = lambda: False, *, attempt_s: float) -> bool | None:
    """Whether the node ``name`` in ``namespace`` answered its ``get_parameters`` before
    ``deadline`` (monotonic s) through a client made now; None when it has no parameter
    services (nothing to ask)."""
    from rcl_interfaces.srv import GetParameters

    fq_node = f"{namespace.rstrip('/')}/{name}"
    try:
        services = node.get_service_names_and_types_by_node(name, namespace)
    except Exception:  # noqa: BLE001 - rclpy raises a bare RuntimeError for a node that left the graph
        return None
    if not any(service == f"{fq_node}/get_parameters" for service, _types in services):
        return None
    return wait_until_answered(node, GetParameters, f"{fq_node}/get_parameters", wait,
                               max(0.0, deadline - time.monotonic()), should_stop=should_stop, attempt_s=attempt_s)


def wait_until_answered(node: Any, srv_type: Any, srv_name: str, wait: Callable[[Any, float], bool], timeout_s: float,
                        *, should_stop: Callable[[], bool] = lambda: False, attempt_s: float = 1.0) -> bool:
    """Return True once the server of ``srv_name`` (type ``srv_type``; its default request
    must have no effect) has answered a request sent through a client made in this call,
    asked again every ``attempt_s`` s; False after ``timeout_s`` or when ``should_stop()``
    turns true (checked between attempts). The answer proves that the
    server's participant has matched every endpoint ``node``'s participant created before
    this call (announced in creation order on one reliable, in-order discovery stream each,
    see :func:`wait_until_server_heard`): in particular the readers of that server's node
    have matched this participant's earlier writers, so a message published on them now
    is taken, not dropped by a reader that has not yet discovered its writer.
    ``wait(future, seconds)`` as for :func:`wait_until_server_heard`."""
    deadline = time.monotonic() + timeout_s
    probe = node.create_client(srv_type, srv_name)
    try:
        if not wait_for_service(probe, max(0.0, deadline - time.monotonic())):
            return False
        asked: list[Any] = []
        while time.monotonic() < deadline and not should_stop():
            asked.append(probe.call_async(srv_type.Request()))
            if wait(asked[-1], min(attempt_s, max(0.0, deadline - time.monotonic()))) or any(f.done() for f in asked):
                return True
        return any(f.done() for f in asked)
    finally:
        node.destroy_client(probe)
