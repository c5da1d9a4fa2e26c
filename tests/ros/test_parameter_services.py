"""Every node of the suite answers hostile requests to its parameter services, refusing them
with a reason and keeping its parameters and its process (the nodes run as `tensegrity node
NAME`, each its own process, over DDS).

rclpy reads a request's ``ParameterValue.type`` before any check, and a type that is not one
of ``rcl_interfaces/ParameterType``'s used to raise out of the service callback and end the
node with a traceback (``tensegrity_ros/rclpy_utils/parameter_guard.py``). Every value a
``uint8`` type can take beyond ParameterType's (10-255) is sent, in one request per service.

And every node's parameters, as ``describe_parameters`` shows them to any client, follow ROS 2's
conventions: snake_case names, a description, read-only, a unit for every number.
"""

from __future__ import annotations

import math

import pytest

from tensegrity_ros.rclpy_utils.futures import spin_until_done
from tensegrity_ros.rclpy_utils.matching import wait_for_service
from tests.process_groups import exited
from tests.ros_support import Proc, probe

pytestmark = pytest.mark.ros

NS = "/param_test"
#: node name -> (``tensegrity node`` arguments, a parameter it declares)
NODES = {
    "tensegrity_sim": (["sim", "--ros-args", "-p", "initial_state:=paused", "-p", "paused_publish_rate:=0.0"],
                       "publish_rate"),
    "tensegrity_ik": (["ik"], "paper_range"),
    "tensegrity_controller": (["controller"], "max_force"),
    "tensegrity_cable_controller": (["cables", "--ros-args", "-p", "scene:=table_actuated"], "goal_tolerance"),
    "tensegrity_formfind": (["formfind"], "max_workers"),
}
UNKNOWN_TYPES = range(10, 256)          # ParameterValue.type is a uint8; 0-9 are ParameterType's


@pytest.fixture(scope="module")
def nodes(tmp_path_factory):
    """Every node running in NS, and a client of their parameter services in this process."""
    from rcl_interfaces.srv import (
        DescribeParameters,
        GetParameters,
        ListParameters,
        SetParameters,
        SetParametersAtomically,
    )

    folder = tmp_path_factory.mktemp("parameter_services")
    procs = {}
    for name, (args, _) in NODES.items():
        ros = [] if "--ros-args" in args else ["--ros-args"]
        procs[name] = Proc(["node", *args, *ros, "-r", f"__ns:={NS}"], folder / f"{name}.log")
    try:
        with probe("parameter_services_probe") as client_probe:
            node, executor = client_probe.node, client_probe.executor
            clients = {name: {srv: node.create_client(srv, f"{NS}/{name}/{suffix}")
                              for srv, suffix in ((SetParameters, "set_parameters"),
                                                  (SetParametersAtomically, "set_parameters_atomically"),
                                                  (GetParameters, "get_parameters"),
                                                  (ListParameters, "list_parameters"),
                                                  (DescribeParameters, "describe_parameters"))}
                       for name in NODES}
            for name, by_type in clients.items():
                for client in by_type.values():
                    assert wait_for_service(client, 120), f"{name}: {procs[name].stderr()}"

            def call(name, srv, request):
                future = clients[name][srv].call_async(request)
                assert spin_until_done(executor, future, 60), f"{name} did not answer: {procs[name].stderr()}"
                return future.result()

            yield call, procs
    finally:
        for proc in procs.values():
            proc.stop()


def _value(call, name, param):
    from rcl_interfaces.srv import GetParameters

    (value,) = call(name, GetParameters, GetParameters.Request(names=[param])).values
    return value


@pytest.mark.parametrize("name", NODES)
def test_parameter_requests_of_unknown_types_are_refused_and_the_node_lives_on(nodes, name):
    from rcl_interfaces.msg import Parameter, ParameterValue
    from rcl_interfaces.srv import SetParameters, SetParametersAtomically

    call, procs = nodes
    param = NODES[name][1]
    before = _value(call, name, param)
    assert before.type != 0                                     # declared, with a value
    hostile = [Parameter(name=param, value=ParameterValue(type=t)) for t in UNKNOWN_TYPES]
    mixed = [*hostile[:2], Parameter(name=param, value=ParameterValue(type=3, double_value=math.nan)),
             Parameter(name="no_such_parameter", value=ParameterValue(type=3, double_value=1.0))]

    results = call(name, SetParameters, SetParameters.Request(parameters=hostile + mixed)).results
    assert len(results) == len(hostile) + len(mixed)           # one result per parameter, in order
    assert not any(r.successful for r in results)
    for t, r in zip([*UNKNOWN_TYPES, 10, 11], results):
        assert r.reason == (f"parameter '{param}': value type {t} is not a parameter type "
                            "(rcl_interfaces/ParameterType: 0-9)")
    assert "read-only" in results[-2].reason                   # rclpy's own refusals, unchanged
    assert results[-1].reason

    atomic = call(name, SetParametersAtomically, SetParametersAtomically.Request(parameters=mixed)).result
    assert not atomic.successful and "value type 10 is not a parameter type" in atomic.reason

    assert _value(call, name, param) == before                  # nothing changed
    assert not exited(procs[name].popen), procs[name].stderr()
    assert "Traceback" not in procs[name].stderr()


#: Parameters rclpy declares on every node itself (not the suite's).
RCLPY_OWN = {"use_sim_time", "start_type_description_service"}
#: A unit in brackets (``[m]``, ``[s, wall time]``, ``[1]`` for a ratio) or a count.
UNIT = r"\[[^\]]+\]|\b(count|number of)\b"


@pytest.mark.parametrize("name", NODES)
def test_every_parameter_is_snake_case_read_only_and_says_its_unit(nodes, name):
    """ROS 2's conventions for a node's parameters, read over its parameter services as any
    client (rqt, ``ros2 param describe``) reads them: names in snake_case (REP 144's rule for
    names, the ROS 2 style guide's for parameters), a description, read-only where the node
    reads the value only as it starts (every parameter of the suite: docs/ros.md), and for a
    number its unit in brackets, REP 103's SI units (``[s]``, ``[Hz]``, ``[m]``, ``[N]``),
    or a count; a number's range in the descriptor (``additional_constraints`` or
    ``integer_range``) when it has one."""
    import re

    from rcl_interfaces.msg import ParameterType
    from rcl_interfaces.srv import DescribeParameters, ListParameters

    call, _ = nodes
    names = [n for n in call(name, ListParameters, ListParameters.Request()).result.names if n not in RCLPY_OWN]
    assert NODES[name][1] in names
    described = call(name, DescribeParameters, DescribeParameters.Request(names=names)).descriptors
    assert [d.name for d in described] == names
    problems = []
    for d in described:
        if not re.fullmatch(r"[a-z][a-z0-9]*(_[a-z0-9]+)*", d.name):
            problems.append(f"{d.name} is not snake_case")
        if not d.description.strip():
            problems.append(f"{d.name} has no description")
        if not d.read_only:
            problems.append(f"{d.name} is not read-only, but the node reads it only as it starts")
        if d.type in (ParameterType.PARAMETER_DOUBLE, ParameterType.PARAMETER_INTEGER) or d.dynamic_typing:
            if not re.search(UNIT, d.description):
                problems.append(f"{d.name}'s description gives no unit: {d.description!r}")
    assert not problems, f"{name}: " + "; ".join(problems)
