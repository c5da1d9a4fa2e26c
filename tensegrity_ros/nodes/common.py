"""Shared node plumbing: typed parameter declaration, service QoS, main loop (the mechanism
from the scene: :mod:`tensegrity_ros.nodes.scene_param`)."""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Sequence
from typing import overload

from tensegrity_core.excerpt import excerpt
from tensegrity_ros.rclpy_utils.env import require_rclpy

rclpy = require_rclpy()
from rcl_interfaces.msg import IntegerRange, ParameterDescriptor  # noqa: E402
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException  # noqa: E402
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.qos import QoSProfile, qos_profile_services_default  # noqa: E402
from rclpy.signals import SignalHandlerOptions  # noqa: E402

from tensegrity_ros.rclpy_utils.stop_signals import stop_on_signals  # noqa: E402

#: Service QoS with a deep request queue: the default keeps only the last 10 requests,
#: so a burst of concurrent callers would silently lose requests.
SERVICE_QOS = QoSProfile(
    depth=1000,
    reliability=qos_profile_services_default.reliability,
    durability=qos_profile_services_default.durability,
    history=qos_profile_services_default.history,
)


class ParameterValueError(SystemExit):
    """A node parameter has the wrong type or is out of range, or its scene cannot be used (the
    node does not start; ``tensegrity node`` prints the message as one line and exits with 2)."""


#: What a parameter may hold here (its default's type).
ParameterValue = bool | int | float | str


@overload
def declare(node: Node, name: str, default: bool, description: str, *, lo: float | None = None,
            hi: float | None = None, read_only: bool = False) -> bool: ...
@overload
def declare(node: Node, name: str, default: int, description: str, *, lo: float | None = None,
            hi: float | None = None, read_only: bool = False) -> int: ...
@overload
def declare(node: Node, name: str, default: float, description: str, *, lo: float | None = None,
            hi: float | None = None, read_only: bool = False) -> float: ...
@overload
def declare(node: Node, name: str, default: str, description: str, *, lo: float | None = None,
            hi: float | None = None, read_only: bool = False) -> str: ...
def declare(node: Node, name: str, default: ParameterValue, description: str, *, lo: float | None = None,
            hi: float | None = None, read_only: bool = False) -> ParameterValue:
    """Declare a typed parameter with a description and an optional range; return its value.

    Floating-point parameters also accept integers (``-p publish_rate:=500`` works) and
    are returned as float; a wrong type or an out-of-range value stops the node with a
    message naming the parameter, the accepted range and the unit, which is the description's
    last bracket (``"... [Hz]"``: Hz; ``"[s, wall time]"``: s).
    """
    desc = ParameterDescriptor(description=description, read_only=read_only)
    is_float = isinstance(default, float)
    if is_float:
        desc.dynamic_typing = True
        if lo is not None or hi is not None:
            desc.additional_constraints = f"range [{-math.inf if lo is None else lo}, {math.inf if hi is None else hi}]"
    elif isinstance(default, int) and not isinstance(default, bool) and (lo is not None or hi is not None):
        desc.integer_range = [IntegerRange(from_value=int(lo or 0), to_value=int(hi or 2**31 - 1), step=1)]
    try:
        value: ParameterValue = node.declare_parameter(name, default, desc).value
    except InvalidParameterValueException as err:     # out of an integer range
        given = re.match(r"Invalid parameter value \((.*?)\) for parameter", str(err))
        raise ParameterValueError(
            f"{node.get_name()}: parameter {name} must be a whole number in [{int(lo or 0)}, {int(hi or 2**31 - 1)}]"
            f"{' ' + _unit(description) if _unit(description) else ''}, got {given.group(1) if given else err}"
        ) from None
    except InvalidParameterTypeException as err:      # an override of another type (paper_range:=maybe)
        raise ParameterValueError(f"{node.get_name()}: parameter {name} must be "
                                  f"{_expected(default, lo, hi, _unit(description))}, got {_given(str(err))}") from None
    except Exception as err:  # rclpy raises several types for bad overrides
        raise ParameterValueError(f"{node.get_name()}: parameter {name}: {err}") from None
    if is_float:
        unit = _unit(description)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ParameterValueError(f"{node.get_name()}: parameter {name} must be a number{unit and ' [' + unit + ']'}"
                                      f", got {excerpt(str(value))}")
        value = float(value)
        if not math.isfinite(value) or (lo is not None and value < lo) or (hi is not None and value > hi):
            raise ParameterValueError(f"{node.get_name()}: parameter {name} must be {_accepted(lo, hi, unit)}, "
                                      f"got {value:g}{unit and math.isfinite(value) and ' ' + unit or ''}")
    return value


def _unit(description: str) -> str:
    """The unit a parameter's description gives in its last bracket (before any comma), or ""."""
    found = re.findall(r"\[([^\]]*)\]", description)
    return found[-1].split(",")[0].strip() if found else ""


#: rclpy's parameter type names, as the error lines say them.
_TYPE_WORDS = {"BOOL": "a boolean", "INTEGER": "a whole number", "DOUBLE": "a number", "STRING": "text",
               "BYTE_ARRAY": "a list of bytes", "BOOL_ARRAY": "a list of true/false",
               "INTEGER_ARRAY": "a list of whole numbers", "DOUBLE_ARRAY": "a list of numbers",
               "STRING_ARRAY": "a list of texts"}


def _expected(default: ParameterValue, lo: float | None, hi: float | None, unit: str) -> str:
    """What a parameter of ``default``'s type (not float: those take any number, :func:`declare`)
    accepts, in words: ``true or false``, ``a whole number in [1, 64] s``, ``text``."""
    if isinstance(default, bool):
        kind = "true or false"
    elif isinstance(default, int):
        kind = _TYPE_WORDS["INTEGER"]
        if lo is not None or hi is not None:
            kind += f" in [{int(lo or 0)}, {int(hi or 2**31 - 1)}]"
    else:
        kind = _TYPE_WORDS["STRING"]
    return f"{kind} {unit}" if unit else kind


def _given(message: str) -> str:
    """The value and its type in words, from rclpy's InvalidParameterTypeException message
    ("Trying to set parameter 'x' to 'maybe' of type 'STRING', expecting type 'BOOL'")."""
    found = re.search(r" to '(.*)' of type '(\w+)'", message, re.DOTALL)
    if found is None:
        return excerpt(message)
    value, kind = found.groups()
    return f"{excerpt(value)} ({_TYPE_WORDS.get(kind, kind.lower())})"


def _accepted(lo: float | None, hi: float | None, unit: str) -> str:
    """``a finite number in [lo, hi] Hz``, ``>= lo``, ``<= hi`` or ``finite``, with the unit."""
    u = f" {unit}" if unit else ""
    if lo is not None and hi is not None:
        return f"a finite number in [{lo:g}, {hi:g}]{u}"
    if lo is not None:
        return f"a finite number >= {lo:g}{u}"
    if hi is not None:
        return f"a finite number <= {hi:g}{u}"
    return f"a finite number{u and ' of' + u}"


def spin_node(make_node: Callable[[], Node], args: Sequence[str] | None,
              executor_factory: Callable[[], Executor] | None = None) -> int:
    """Init, spin until SIGINT/SIGTERM (or an external shutdown), destroy, shut down; 0.

    Signals are the suite's stop requests (:mod:`tensegrity_ros.rclpy_utils.stop_signals`), not
    rclpy's: rclpy installs no handler, so nothing shuts the context down under the node.
    A stop request triggers a guard condition of the node, after the request is set, so the
    executor wakes whatever it was doing and the loop, which checks the request after every
    callback, ends. A signal before the node exists skips straight to shutdown.
    """
    with stop_on_signals() as stop:
        stop.enter_running()
        rclpy.init(args=list(args) if args is not None else None,
                   signal_handler_options=SignalHandlerOptions.NO)
        node = executor = None
        try:
            if not stop.is_set():
                node = make_node()
                executor = executor_factory() if executor_factory is not None else SingleThreadedExecutor()
                executor.add_node(node)
                wake = node.create_guard_condition(lambda: None)
                forget = stop.on_stop(wake.trigger)
                try:
                    while not stop.is_set():
                        executor.spin_once()
                finally:
                    forget()
        except ExternalShutdownException:
            pass
        finally:
            if executor is not None:
                executor.shutdown()
            if node is not None:
                node.destroy_node()
            rclpy.try_shutdown()
    return 0
