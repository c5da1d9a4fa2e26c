"""Whether the suite already runs where ``tensegrity up`` would start it.

Two suites in one namespace of one ROS domain publish the same topics and serve the same
services: two simulators' ``joint_states`` interleave, a goal is taken by either
controller. ROS itself lets that happen (``ros2 launch`` starts nodes whose names are
taken, and ``ros2 node list`` only warns that nodes share an exact name), so ``up`` looks
before any of its own nodes joins the graph (they import meanwhile, held at their start
gates: :mod:`tensegrity_ros.apps.start_gate`): :func:`running_suite` watches the graph for up to :data:`LOOK_S` seconds for a node
of the suite in the namespace the new one would take, and ``up`` refuses with
:func:`refusal`. Another namespace (``--namespace``) or domain (``ROS_DOMAIN_ID``) is
another suite's place. DDS discovery cannot prove an absence: a suite that the graph does
not show within :data:`LOOK_S` (a machine under heavy load) is not seen.
"""

from __future__ import annotations

import time
from collections.abc import Iterable

from tensegrity_ros.bag.recorder import RECORDER_NODE

#: The names of the nodes ``tensegrity up`` starts.
SUITE_NODES = frozenset({"tensegrity_sim", "tensegrity_ik", "tensegrity_controller", "tensegrity_cable_controller",
                         "tensegrity_formfind", RECORDER_NODE})
#: Seconds ``up`` watches the graph for a running suite (discovery on loopback: a few
#: hundred ms; seconds under load).
LOOK_S = 3.0


def suite_nodes_in(graph: Iterable[tuple[str, str]], namespace: str) -> list[str]:
    """The full names of the suite's nodes in ``namespace`` among the graph's ``(name,
    namespace)`` pairs, sorted, each once."""
    return sorted({f"{namespace.rstrip('/')}/{name}" for name, ns in graph if ns == namespace and name in SUITE_NODES})


def refusal(found: list[str], namespace: str, domain: int) -> str:
    """The one line ``up`` refuses with when ``found`` (full node names) run already."""
    where = "" if namespace == "/" else f" in namespace {namespace}"
    return (f"the suite is already running in ROS domain {domain}{where} ({', '.join(found)}): stop it first, "
            "or start this one in another namespace (--namespace /robot2) or domain (ROS_DOMAIN_ID)")


def running_suite(ros_args: list[str], look_s: float = LOOK_S) -> tuple[list[str], str, int]:
    """The suite's nodes already running where nodes started with ``ros_args`` would be
    (their namespace after its remapping), that namespace and the ROS domain; the graph is
    watched until one shows or ``look_s`` seconds passed."""
    from tensegrity_ros.rclpy_utils.env import require_rclpy

    rclpy = require_rclpy()
    from rclpy.context import Context
    from rclpy.signals import SignalHandlerOptions

    context = Context()
    rclpy.init(args=["tensegrity", *ros_args], context=context, signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = rclpy.create_node("tensegrity_up_look", context=context, start_parameter_services=False)
        namespace, domain = node.get_namespace(), context.get_domain_id()
        deadline = time.monotonic() + look_s
        while not (found := suite_nodes_in(node.get_node_names_and_namespaces(), namespace)):
            if time.monotonic() >= deadline:
                break
            time.sleep(0.1)
        node.destroy_node()
        return found, namespace, domain
    finally:
        context.try_shutdown()
