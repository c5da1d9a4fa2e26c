"""ROS subcommands: run nodes, bring the suite up, and talk to it without the ros2 CLI."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

from tensegrity_ros.cli._common import CliError, Subparsers, add_json_flag, check_count, check_seconds
from tensegrity_ros.cli.ros_clients import DISCOVERY_S, check_ros_args, check_ros_name, client_node, namespace_hint
from tensegrity_ros.cli.send_forces import send_forces

if TYPE_CHECKING:
    from rclpy.node import Node

    from tensegrity_core.sim.model import Interface

ORDER = 50

NODES = {
    "sim": "tensegrity_ros.nodes.sim.node",
    "ik": "tensegrity_ros.nodes.ik",
    "formfind": "tensegrity_ros.nodes.formfind",
    "controller": "tensegrity_ros.nodes.controller",
    "cables": "tensegrity_ros.nodes.cable_controller",
}


def register(sub: Subparsers) -> None:
    p = sub.add_parser("node", help="run one node of the suite (sim, ik, formfind, controller or cables)",
                       description="Run one node. ROS arguments follow --ros-args, e.g. "
                       "`tensegrity node sim --ros-args -r __ns:=/robot1 -p publish_rate:=500.0`.")
    p.add_argument("name", choices=sorted(NODES))
    p.set_defaults(func=_node, stop_signals=True)

    p = sub.add_parser("up", help="start the suite (sim + IK + controller + form-finding [+ recorder]; for a "
                       "general structure sim + cable controller + form-finding); Ctrl-C stops it",
                       description="Start the suite; Ctrl-C stops it. Refused (exit 1) when the suite already runs in "
                       "the same namespace of the same ROS domain: start another with --namespace.")
    p.add_argument("--scene", default=None, help="scene file or shipped scene name (the simulator, the IK node "
                   "and the controller all take the mechanism from it; a general structure's scene starts the "
                   "cable controller instead of the IK node and the class-2 controller)")
    p.add_argument("--namespace", "-n", default=None, help="ROS namespace for every node, e.g. /robot1")
    p.add_argument("--params-file", default=None, help="ROS parameter YAML file applied to every node")
    p.add_argument("--record", metavar="DIR", default=None, help="also record the suite's topics to this bag folder "
                   "(the simulator starts its clock once the recorder has subscribed: the bag holds the run from t = 0)")
    p.add_argument("--no-formfind", action="store_true", help="do not start the form-finding node")
    p.add_argument("--no-controller", action="store_true",
                   help="do not start the controller (actuator_forces or cable_commands then come only from you)")
    p.set_defaults(func=_up, stop_signals=True)

    p = sub.add_parser("send-forces", help="publish actuator forces (positive = tensile) on actuator_forces")
    p.add_argument("forces", nargs="+", type=float, metavar="F", help="forces [N] for f1 f2 (or those named)")
    p.add_argument("--name", action="append", default=None, help="actuator name per force (f1, f2)")
    p.add_argument("--rate", type=float, default=0.0, help="repeat at this rate [Hz] until Ctrl-C (0 = once)")
    p.add_argument("--topic", default="actuator_forces")
    p.set_defaults(func=send_forces)

    p = sub.add_parser("call-ik", help="call the solve_ik service for the end-effector target (X, Y)")
    p.add_argument("x", type=float)
    p.add_argument("y", type=float)
    p.add_argument("--seed", nargs=2, type=float, metavar=("RHO1", "RHO2"), default=None)
    p.add_argument("--service", default="solve_ik")
    p.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for the service")
    add_json_flag(p)
    p.set_defaults(func=_call_ik)

    p = sub.add_parser("call-formfind", help="call the find_form service with a structure file")
    p.add_argument("file", help="structure description (YAML file) or a shipped example name")
    p.add_argument("--tol", type=float, default=0.0,
                   help="tolerance on the relative residual (dimensionless; 0 = default, docs/general.md)")
    p.add_argument("--max-iter", type=int, default=0, help="iteration limit (0 = default)")
    p.add_argument("--service", default="find_form")
    p.add_argument("--timeout", type=float, default=120.0)
    add_json_flag(p)
    p.set_defaults(func=_call_formfind)

    p = sub.add_parser("sim", help="run control of the simulator: state, play, pause, stop, step N, reset "
                       "(the simulation_interfaces services)",
                       description="Call the simulator's simulation_interfaces services: `state` (GetSimulationState), "
                       "`play`, `pause`, `stop` (SetSimulationState; stop resets, clock at 0), `step N` "
                       "(StepSimulation: N steps, only while paused; in lockstep each waits for its command) "
                       "and `reset` (ResetSimulation, scope all). Exit 0 when the simulator answers OK "
                       "(or is in the asked state already), 1 with its reason otherwise.")
    p.add_argument("action", choices=SIM_ACTIONS)
    p.add_argument("steps", nargs="?", type=int, default=None, help="number of steps, for `step`")
    p.add_argument("--timeout", type=float, default=10.0,
                   help="seconds to wait for the service, and for its answer (for `step`, that much more per 1,000 "
                   "steps)")
    add_json_flag(p)
    p.set_defaults(func=_sim)

    p = sub.add_parser("echo", help="print the messages arriving on a topic")
    p.add_argument("topic")
    p.add_argument("--count", "-c", type=int, default=0, help="stop after this many messages (0 = never)")
    p.add_argument("--timeout", type=float, default=0.0, help="give up after this many seconds (0 = never)")
    add_json_flag(p)
    p.set_defaults(func=_echo)


#: ``tensegrity sim`` actions -> simulation_interfaces service name.
SIM_ACTIONS = {"state": "get_simulation_state", "play": "set_simulation_state", "pause": "set_simulation_state",
               "stop": "set_simulation_state", "step": "step_simulation", "reset": "reset_simulation"}


def _sim(args: argparse.Namespace) -> int:
    from tensegrity_ros.rclpy_utils.env import require_rclpy

    require_rclpy()
    from simulation_interfaces.msg import Result, SimulationState
    from simulation_interfaces.srv import GetSimulationState, ResetSimulation, SetSimulationState, StepSimulation

    if (args.action == "step") != (args.steps is not None):
        raise CliError("give a number of steps with `step` (and only there), e.g. `tensegrity sim step 100`")
    if args.steps is not None:
        check_count(args.steps, "steps", 1, 2**64 - 1)      # StepSimulation's uint64
    check_seconds(args.timeout, "--timeout")
    args.service = SIM_ACTIONS[args.action]
    answer_timeout = args.timeout
    states = {"play": SimulationState.STATE_PLAYING, "pause": SimulationState.STATE_PAUSED,
              "stop": SimulationState.STATE_STOPPED}
    if args.action == "state":
        srv, request = GetSimulationState, GetSimulationState.Request()
    elif args.action in states:
        srv, request = SetSimulationState, SetSimulationState.Request()
        request.state.state = states[args.action]
    elif args.action == "step":
        srv, request = StepSimulation, StepSimulation.Request(steps=args.steps)
        answer_timeout = args.timeout + args.timeout * args.steps / 1000.0
    else:
        srv, request = ResetSimulation, ResetSimulation.Request(scope=ResetSimulation.Request.SCOPE_ALL)
    res = _call_service(args, "tensegrity_sim_control", srv, request, answer_timeout)
    code = res.result.result
    ok = code == Result.RESULT_OK or code == SetSimulationState.Response.ALREADY_IN_TARGET_STATE
    names = {v: k for cls in (Result, SetSimulationState.Response) for k, v in vars(cls).items()
             if k.isupper() and isinstance(v, int)}
    if args.json:
        from tensegrity_ros.cli._common import print_json
        from tensegrity_ros.rclpy_utils.messages import message_to_dict

        print_json({"ok": ok, "code": names.get(code, str(code)), **message_to_dict(res)})
    else:
        print(f"{'ok' if ok else f'failed ({names.get(code, code)})'}: {res.result.error_message}")
    return 0 if ok else 1


def _node(args: argparse.Namespace) -> int:
    import importlib

    from tensegrity_ros.rclpy_utils.env import require_rclpy

    require_rclpy()

    module = importlib.import_module(NODES[args.name])
    from tensegrity_ros.apps.start_gate import pass_gate
    from tensegrity_ros.nodes.common import ParameterValueError

    pass_gate()                          # imported: now wait for `tensegrity up`'s look, if it looks

    try:
        return int(module.main([f"tensegrity-{args.name}", *args.ros_args]))
    except ParameterValueError as err:           # one line, exit 2, as any other refused argument
        raise CliError(str(err.code)) from None


def _up(args: argparse.Namespace) -> int:
    from tensegrity_ros.apps.launch import Launcher, ProcessSpec
    from tensegrity_ros.rclpy_utils.env import require_rclpy

    require_rclpy()      # fail here, once, if ROS is missing

    exe = [sys.executable, "-m", "tensegrity_ros.cli"]
    ros = ["--ros-args"]
    if args.namespace:
        check_ros_name(args.namespace, "--namespace", namespace=True)
        ros += ["-r", f"__ns:={args.namespace if args.namespace.startswith('/') else '/' + args.namespace}"]
    if args.params_file:
        ros += ["--params-file", args.params_file]
    ros += args.ros_args[1:] if args.ros_args else []
    check_ros_args(ros)                  # --namespace and --params-file too, before any child starts
    mech = ros + (["-p", f"scene:={args.scene}"] if args.scene else [])    # one source of the mechanism
    # recording: the simulator's clock starts once the recorder itself subscribes to every output
    # topic (another node's subscription, such as the controller's on joint_states, does not
    # count), so the bag holds the run from t = 0 (before the user's own arguments, which may
    # override it)
    from tensegrity_ros.bag.recorder import RECORDER_NODE

    sim = ["--ros-args", "-p", f"wait_for_node:={RECORDER_NODE}", *mech[1:]] if args.record else mech
    specs = [ProcessSpec("sim", exe + ["node", "sim"] + sim)]
    interface = _scene_interface(args.scene)
    if interface.command == "force":          # the class-2 mechanism: IK and its controller
        specs.append(ProcessSpec("ik", exe + ["node", "ik"] + mech))
        if not args.no_controller:
            specs.append(ProcessSpec("controller", exe + ["node", "controller"] + mech))
    elif any(interface.commanded) and not args.no_controller:    # a general structure's commanded cables
        specs.append(ProcessSpec("cables", exe + ["node", "cables"] + mech))
    if not args.no_formfind:
        specs.append(ProcessSpec("formfind", exe + ["node", "formfind"] + ros))
    if args.record:
        from tensegrity_ros.nodes.scene_param import DEFAULT_SCENE

        # the scene goes into the bag's metadata: `tensegrity view BAG` then knows what to draw
        scene = ["--custom-data", f"scene={args.scene or DEFAULT_SCENE}"]
        # stopped after the others have exited: the bag holds their last messages
        specs.append(ProcessSpec("record", exe + ["record", "-o", args.record, *scene] + ros, stops_last=True))
    from tensegrity_ros.apps.suite_claim import SuiteClaim
    from tensegrity_ros.apps.suite_presence import refusal, running_suite

    claims: list[SuiteClaim] = []            # held until every child has exited

    def look() -> None:
        """Refuse when the suite runs here already (the children import meanwhile, held at
        their start gates: none of them is in the graph yet, :mod:`tensegrity_ros.apps.start_gate`)."""
        presence = running_suite(ros, [s.name for s in specs])
        if presence.found:               # a second suite would publish and serve the same names
            raise CliError(refusal(presence.found, presence.namespace, presence.domain), code=1)
        claims.extend([presence.claim] if presence.claim else [])
        print(f"starting {', '.join(s.name for s in specs)} (Ctrl-C stops all)", flush=True)

    try:
        return Launcher(specs).run(look)
    finally:
        for held in claims:
            held.release()


def _scene_interface(scene: str | None) -> Interface:
    """What the ``up`` scene's inputs take (the default scene's if None); a bad scene is a CliError."""
    from tensegrity_core.errors import TensegrityError
    from tensegrity_core.excerpt import excerpt
    from tensegrity_core.sim import compile_scene, load_scene
    from tensegrity_ros.nodes.scene_param import DEFAULT_SCENE

    try:
        return compile_scene(load_scene(scene or DEFAULT_SCENE)).interface
    except TensegrityError as err:
        raise CliError(f"cannot load scene {excerpt(scene)}: {err}") from None


def _call_service(args: argparse.Namespace, node_name: str, srv_type: Any, request: Any,
                  answer_timeout: float | None = None) -> Any:
    """One service call from a short-lived client node; the response, or a CliError. The
    service is waited for ``args.timeout`` s, its answer ``answer_timeout`` s (default the same)."""
    from rclpy.executors import SingleThreadedExecutor

    from tensegrity_ros.rclpy_utils.futures import spin_until_done
    from tensegrity_ros.rclpy_utils.matching import wait_for_service, wait_until_service_heard

    check_ros_name(args.service, "--service")
    rclpy, node = client_node(node_name, args.ros_args)
    executor = SingleThreadedExecutor()
    try:
        client = node.create_client(srv_type, args.service)
        if not wait_for_service(client, args.timeout):
            services = (n for n, _ in node.get_service_names_and_types())
            raise CliError(f"service {node.resolve_service_name(args.service)} not available after "
                           f"{args.timeout:g} s (is the suite up? `tensegrity up`)"
                           f"{namespace_hint(args.service, services)}", code=3)
        executor.add_node(node)
        # the request once the server has matched this client's response reader: a request
        # that comes before loses its answer (stepping and resets cannot simply be sent again)
        wait_until_service_heard(node, args.service, lambda f, t: spin_until_done(executor, f, t), args.timeout)
        future = client.call_async(request)
        answer_timeout = args.timeout if answer_timeout is None else answer_timeout
        if not spin_until_done(executor, future, answer_timeout):
            raise CliError(f"no answer from {args.service} within {answer_timeout:g} s", code=3)
        return future.result()
    finally:
        executor.shutdown()        # before the context: rclpy's finalizers break on a collected cycle
        node.destroy_node()
        rclpy.try_shutdown()


def _show(args: argparse.Namespace, res: Any, lines: Iterable[str]) -> int:
    """Print a response as JSON or as the given human-readable lines; exit code by success."""
    from tensegrity_ros.cli._common import print_json
    from tensegrity_ros.rclpy_utils.messages import message_to_dict

    if args.json:
        print_json(message_to_dict(res))
    else:
        print(f"{'ok' if res.success else 'failed'}: {res.message}")
        for line in lines:
            print(f"  {line}")
    return 0 if res.success else 1


def _call_ik(args: argparse.Namespace) -> int:
    from tensegrity_ros.rclpy_utils.env import require_rclpy

    check_seconds(args.timeout, "--timeout")
    require_rclpy()
    from tensegrity_msgs.srv import SolveIK

    res = _call_service(args, "tensegrity_call_ik", SolveIK,
                        SolveIK.Request(x=args.x, y=args.y, seed=list(args.seed or [])))
    return _show(args, res, [
        f"rho1 = {s.rho1:.9f} m  rho2 = {s.rho2:.9f} m  beta = {s.beta:.9f} rad  (delta1 {s.delta1:+d}, "
        f"delta2 {s.delta2:+d}, d2U/dbeta2 = {s.stiffness_beta:.4g} J/rad^2; nearest singular set "
        f"{s.singular_set} at {s.singularity_distance:.3g} L)" for s in res.solutions])


def _call_formfind(args: argparse.Namespace) -> int:
    from pathlib import Path

    from tensegrity_ros.rclpy_utils.env import require_rclpy

    check_seconds(args.timeout, "--timeout")
    if not (math.isfinite(args.tol) and args.tol >= 0):
        raise CliError(f"--tol must be a finite relative residual >= 0 (dimensionless; 0 = the default), got {args.tol:g}")
    check_count(args.max_iter, "--max-iter", 0, 2**32 - 1)      # FindForm's uint32; 0 = the default
    path = Path(args.file)
    if not path.exists():
        from tensegrity_core.general import example_names, example_path

        if args.file not in example_names():
            raise CliError(f"cannot read {args.file}: no such file or shipped example")
        path = example_path(args.file)
    from tensegrity_core.schema import SchemaError
    from tensegrity_core.schema.documents import decode_utf8, read_bytes
    from tensegrity_core.schema.limits import Limits

    try:   # the request's bound (the node's default max_request_bytes), UTF-8 named by line
        text = decode_utf8(read_bytes(path, Limits(max_bytes=4_000_000), SchemaError, "structure file"),
                           SchemaError, path.name)
    except SchemaError as err:
        raise CliError(str(err)) from None
    require_rclpy()
    from tensegrity_msgs.srv import FindForm

    res = _call_service(args, "tensegrity_call_formfind", FindForm,
                        FindForm.Request(structure=text, tolerance=args.tol, max_iterations=args.max_iter))
    from tensegrity_ros.cli.cmd_formfind import answer_summary

    structure = None
    names = [str(i) for i in range(len(res.member_forces))]
    if res.success:   # a structure with rigid bodies has moments and rotations too
        from tensegrity_core.general import structure_from_text

        structure = structure_from_text(text)
        names = list(structure.member_names)   # the answer keeps the description's member order
    return _show(args, res, [answer_summary(res, structure),
                             *(f"member {name}: {t:.6g} N" for name, t in zip(names, res.member_forces))])


def _echo(args: argparse.Namespace) -> int:
    import json
    import time

    import yaml

    from tensegrity_ros.rclpy_utils.messages import message_class, message_to_dict

    check_seconds(args.timeout, "--timeout", zero="never")
    check_count(args.count, "--count", 0, 2**63 - 1)
    check_ros_name(args.topic, "topic")
    rclpy, node = client_node("tensegrity_echo", args.ros_args)
    from rclpy.executors import SingleThreadedExecutor

    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        topic = node.resolve_topic_name(args.topic)
        start = time.monotonic()
        deadline = start + (args.timeout or float("inf"))
        said: str | None = None         # the suggestion said last ("": none)
        while not (types := dict(node.get_topic_names_and_types()).get(topic, [])):
            if time.monotonic() > deadline:
                raise CliError(f"topic {topic} not found within {args.timeout:g} s{_topic_hint(node, topic)}",
                               code=3)
            # said after a moment, and again when discovery brings a closer name
            if time.monotonic() - start > DISCOVERY_S and (close := _closest_topic(node, topic)) != said:
                print(f"waiting for topic {topic}: nobody publishes or subscribes to it yet"
                      f"{_topic_hint(node, topic)} (Ctrl-C stops)", file=sys.stderr, flush=True)
                said = close
            executor.spin_once(timeout_sec=0.1)
        try:
            cls = message_class(types[0])
        except ValueError as err:        # a type of another node whose package is not installed here
            raise CliError(f"cannot echo {topic}: {err}", code=1) from None
        received = []

        def show(msg: Any) -> None:
            received.append(1)
            data = message_to_dict(msg)
            if args.json:
                print(json.dumps(data), flush=True)
            else:
                print(yaml.safe_dump(data, sort_keys=False).rstrip() + "\n---", flush=True)

        from rclpy.qos import qos_profile_sensor_data

        from tensegrity_core.interrupts import sigint_deferred

        # never interrupted half-way (see tensegrity_core.interrupts: rclpy's create_subscription)
        with sigint_deferred(sigterm=True):
            node.create_subscription(cls, topic, show, qos_profile_sensor_data)
        while not args.count or len(received) < args.count:
            if time.monotonic() > deadline:
                break
            executor.spin_once(timeout_sec=0.1)
        return 0
    except (KeyboardInterrupt, BrokenPipeError):    # Ctrl-C or SIGTERM: the end of an echo
        return 0
    finally:
        executor.shutdown()        # before the context: rclpy's finalizers break on a collected cycle
        node.destroy_node()
        rclpy.try_shutdown()


def _topics(node: Node) -> list[str]:
    """The graph's topics, but ROS's own and hidden ones (as ``ros2 topic list`` shows them)."""
    return sorted(name for name, _ in node.get_topic_names_and_types()
                  if name not in ("/rosout", "/parameter_events") and "/_" not in name)


def _closest_topic(node: Node, topic: str) -> str:
    """The graph's topic closest to ``topic`` by spelling, or "" when none is close."""
    import difflib

    return next(iter(difflib.get_close_matches(topic, _topics(node), n=1)), "")


def _topic_hint(node: Node, topic: str) -> str:
    """``" (did you mean /joint_states?); topics now: ..."`` for a topic not in the graph."""
    topics = _topics(node)
    if not topics:
        return "; no topic is published now (is the suite up? `tensegrity up`)"
    close = _closest_topic(node, topic)
    shown = ", ".join(topics[:15]) + (", ..." if len(topics) > 15 else "")
    return (f" (did you mean {close}?)" if close else "") + f"; topics now: {shown}"
