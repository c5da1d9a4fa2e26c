"""Whether the suite already runs where ``tensegrity up`` would start it.

Two suites in one namespace of one ROS domain publish the same topics and serve the same
services: two simulators' ``joint_states`` interleave, a goal is taken by either
controller. ROS itself lets that happen (``ros2 launch`` starts nodes whose names are
taken, and ``ros2 node list`` only warns that nodes share an exact name), so ``up`` looks
before any of its own nodes joins the graph (they import meanwhile, held at their start
gates: :mod:`tensegrity_ros.apps.start_gate`), in two ways (:func:`running_suite`):

- another ``up`` on this machine holds a claim on the namespace
  (:mod:`tensegrity_ros.apps.suite_claim`): found at once, whatever the load;
- otherwise the graph is watched for up to :data:`LOOK_S` seconds for a node of the suite in
  the namespace the new one would take (its nodes started by hand, or on another machine
  when the user's DDS set-up reaches one).

``up`` refuses with :func:`refusal`. Another namespace (``--namespace``) or domain
(``ROS_DOMAIN_ID``) is another suite's place. DDS discovery cannot prove an absence: a suite
without a claim that the graph does not show within :data:`LOOK_S` (a machine under heavy
load) is not seen.
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import dataclass

from tensegrity_ros.apps.suite_claim import SuiteClaim, claim
from tensegrity_ros.bag.recorder import RECORDER_NODE

#: The node each child of ``tensegrity up`` (by its launcher name) runs.
NODE_OF_CHILD = {"sim": "tensegrity_sim", "ik": "tensegrity_ik", "controller": "tensegrity_controller",
                 "cables": "tensegrity_cable_controller", "formfind": "tensegrity_formfind", "record": RECORDER_NODE}
#: The names of the nodes ``tensegrity up`` starts.
SUITE_NODES = frozenset(NODE_OF_CHILD.values())
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


@dataclass
class Presence:
    """What :func:`running_suite` found where a suite would start."""
    #: full names of the running suite's nodes there (empty: none seen)
    found: list[str]
    #: the namespace (absolute) and ROS domain the new suite would take
    namespace: str
    domain: int
    #: the claim on them, held when nothing was found (keep it while the suite runs)
    claim: SuiteClaim | None


def running_suite(ros_args: list[str], children: Iterable[str], look_s: float = LOOK_S) -> Presence:
    """Whether the suite runs where the ``children`` (launcher names, :data:`NODE_OF_CHILD`)
    started with ``ros_args`` would (their namespace after its remapping, the ROS domain):
    a claim on this machine answers at once; without one the graph is watched until a node
    of the suite shows or ``look_s`` seconds passed. Nothing found: the claim is taken."""
    from tensegrity_ros.rclpy_utils.env import require_rclpy

    rclpy = require_rclpy()
    from rclpy.context import Context
    from rclpy.signals import SignalHandlerOptions

    context = Context()
    rclpy.init(args=["tensegrity", *ros_args], context=context, signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = rclpy.create_node("tensegrity_up_look", context=context, start_parameter_services=False)
        namespace, domain = node.get_namespace(), context.get_domain_id()
        held = claim(domain, namespace, [f"{namespace.rstrip('/')}/{NODE_OF_CHILD[c]}" for c in children])
        if not isinstance(held, SuiteClaim):          # another `up` on this machine runs there
            node.destroy_node()
            return Presence(held, namespace, domain, None)
        deadline = time.monotonic() + look_s
        while not (found := suite_nodes_in(node.get_node_names_and_namespaces(), namespace)):
            if time.monotonic() >= deadline:
                break
            time.sleep(0.1)
        node.destroy_node()
        if found:
            held.release()
            return Presence(found, namespace, domain, None)
        return Presence([], namespace, domain, held)
    finally:
        context.try_shutdown()
