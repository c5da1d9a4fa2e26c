"""Parameter services that answer every request instead of ending the node.

rclpy's ``set_parameters`` and ``set_parameters_atomically`` services (Jazzy) turn each
``rcl_interfaces/Parameter`` of a request into an ``rclpy.parameter.Parameter`` before any
check, and a value whose ``type`` is not one of ``rcl_interfaces/ParameterType``'s (0 not
set, 1 bool ... 9 string array) raises ``ValueError`` out of the service callback. The
executor re-raises it from ``spin_once``, so one such request from any client of the graph
ends the node's process with a traceback. :func:`guard_parameter_services` wraps the two
callbacks of a node: a parameter of no known type gets ``SetParametersResult(successful=False,
reason=...)`` naming it and its type; every other request goes to rclpy's callback unchanged
(read-only parameters, wrong types and undeclared names are refused there).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rcl_interfaces.msg import ParameterType, SetParametersResult
from rcl_interfaces.srv import SetParameters, SetParametersAtomically
from rclpy.node import Node
from rclpy.parameter import Parameter

from tensegrity_core.excerpt import excerpt

#: The ``ParameterValue.type`` values rclpy can read.
KNOWN_TYPES = frozenset(t.value for t in Parameter.Type)


def unknown_type_reason(param: Any) -> str | None:
    """Why ``param`` (an ``rcl_interfaces/Parameter``) cannot be set, if its value's type is
    none of ParameterType's; None when it is one of them."""
    kind = param.value.type
    if kind in KNOWN_TYPES:
        return None
    return (f"parameter {excerpt(param.name)}: value type {kind} is not a parameter type "
            f"(rcl_interfaces/ParameterType: {ParameterType.PARAMETER_NOT_SET}-{ParameterType.PARAMETER_STRING_ARRAY})")


def guard_parameter_services(node: Node) -> None:
    """Make ``node``'s ``set_parameters`` and ``set_parameters_atomically`` refuse a parameter
    of unknown type with a reason (see the module's docstring). A node created without
    parameter services is left as it is."""
    for srv in node.services:
        if srv.srv_type is SetParameters:
            srv.callback = _each(srv.callback)
        elif srv.srv_type is SetParametersAtomically:
            srv.callback = _atomically(srv.callback)


Callback = Callable[[Any, Any], Any]


def _each(inner: Callback) -> Callback:
    """``set_parameters``: one result per parameter, in order; each known one set by rclpy."""
    def callback(request: Any, response: Any) -> Any:
        if all(unknown_type_reason(p) is None for p in request.parameters):
            return inner(request, response)
        for p in request.parameters:
            reason = unknown_type_reason(p)
            if reason is not None:
                response.results.append(SetParametersResult(successful=False, reason=reason))
            else:
                one = inner(SetParameters.Request(parameters=[p]), SetParameters.Response())
                response.results.extend(one.results)
        return response
    return callback


def _atomically(inner: Callback) -> Callback:
    """``set_parameters_atomically``: all or none; a parameter of unknown type makes it none."""
    def callback(request: Any, response: Any) -> Any:
        for p in request.parameters:
            reason = unknown_type_reason(p)
            if reason is not None:
                response.result = SetParametersResult(successful=False, reason=reason)
                return response
        return inner(request, response)
    return callback
