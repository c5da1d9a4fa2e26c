"""``tensegrity move X Y`` and ``tensegrity follow FILE``: goals for the running controller.

Both send a goal to ``tensegrity_controller`` (started by ``tensegrity up``), show its
progress on stderr while it runs (a tqdm bar with the feedback), print the result and exit
with 0 when the goal succeeded, 1 when it failed or was refused (the reason is printed),
3 when no controller answers. Ctrl-C cancels the goal (the controller then holds where its
reference was) and exits with 130.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from typing import Any

from tensegrity_ros.cli._common import CliError, Subparsers, add_json_flag, check_seconds

ORDER = 55
#: the suffix of an action's goal service in the graph (an action NAME shows as NAME + SEND_GOAL)
SEND_GOAL = "/_action/send_goal"


def register(sub: Subparsers) -> None:
    p = sub.add_parser("move", help="move the end-effector D to (X, Y) [m] through the controller",
                       description="Send a MoveEndEffector goal: D moves along a straight line to (X, Y), "
                       "rest to rest, in --duration seconds or at a peak speed of at most --speed m/s.")
    p.add_argument("x", type=float, help="target x of D [m]")
    p.add_argument("y", type=float, help="target y of D [m]")
    p.add_argument("--duration", type=float, default=0.0, help="duration of the move [s] (0: not given)")
    p.add_argument("--speed", type=float, default=0.0, help="limit on the peak speed of D [m/s]; slower "
                   "when the force budget needs it (0: not given; with neither, the controller's max_speed "
                   "parameter, 0.05 m/s by default)")
    p.add_argument("--tolerance", type=float, default=0.0, help="goal tolerance of D [m] (0: the controller's)")
    p.add_argument("--action", default="move_end_effector")
    p.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for the controller")
    add_json_flag(p)
    p.set_defaults(func=_move)

    p = sub.add_parser("follow", help="make the actuator lengths follow a trajectory file (CSV or YAML)",
                       description="Send a FollowActuatorTrajectory goal read from FILE (.csv: time, rho1, "
                       "rho2[, rho1_velocity, rho2_velocity[, ...]]; .yaml: points and tolerances, see "
                       "docs/control.md).")
    p.add_argument("file", help="trajectory file (.csv or .yaml)")
    p.add_argument("--path-tolerance", type=float, default=None, help="path tolerance of each length [m]")
    p.add_argument("--goal-tolerance", type=float, default=None, help="goal tolerance of each length [m]")
    p.add_argument("--goal-time-tolerance", type=float, default=None, help="[s] after the last point")
    p.add_argument("--action", default="follow_actuator_trajectory")
    p.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for the controller")
    add_json_flag(p)
    p.set_defaults(func=_follow)


def _move(args: argparse.Namespace) -> int:
    for name in ("x", "y", "duration", "speed", "tolerance"):
        if not math.isfinite(getattr(args, name)):
            raise CliError(f"{name} must be a finite number, got {getattr(args, name)}")
    check_seconds(args.timeout, "--timeout")
    from tensegrity_ros.rclpy_utils.env import require_rclpy

    require_rclpy()
    from tensegrity_msgs.action import MoveEndEffector

    goal = MoveEndEffector.Goal(x=args.x, y=args.y, duration=args.duration, max_speed=args.speed,
                                goal_tolerance=args.tolerance)

    def progress(bar: Any, fb: Any) -> None:
        bar.n = round(fb.time_from_start, 2)
        bar.set_postfix_str(f"{fb.phase}, D = ({fb.end_effector.x:.4f}, {fb.end_effector.y:.4f}) m, "
                            f"{fb.distance_to_target * 1e3:.3f} mm to go", refresh=True)

    def summary(res: Any) -> str:
        return (f"D = ({res.end_effector.x:.6f}, {res.end_effector.y:.6f}) m, settled error "
                f"{res.settled_error * 1e3:.4f} mm, settling time {res.settling_time:.3f} s, "
                f"peak force {res.max_force:.3f} N")

    return _run_goal(args, "tensegrity_move", MoveEndEffector, goal, None, progress, summary)


def _follow(args: argparse.Namespace) -> int:
    from tensegrity_ros.trajectory_file import TrajectoryFileError, read_trajectory

    check_seconds(args.timeout, "--timeout")
    try:
        data = read_trajectory(args.file)
    except TrajectoryFileError as err:
        raise CliError(str(err)) from None
    for name in ("path_tolerance", "goal_tolerance", "goal_time_tolerance"):
        v = getattr(args, name)
        if v is not None and not math.isfinite(v):
            raise CliError(f"--{name.replace('_', '-')} must be a finite number, got {v}")
    from tensegrity_ros.rclpy_utils.env import require_rclpy

    require_rclpy()
    from builtin_interfaces.msg import Duration
    from tensegrity_msgs.action import FollowActuatorTrajectory
    from tensegrity_msgs.msg import JointTolerance
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    def duration(s: float) -> Duration:
        sec = math.floor(s)
        return Duration(sec=int(sec), nanosec=min(int(round((s - sec) * 1e9)), 999_999_999))

    traj = JointTrajectory(joint_names=data.joint_names)
    for i, t in enumerate(data.times):
        if not (math.isfinite(t) and abs(t) < 1e9):
            raise CliError(f"{args.file}: point {i}: time {t} is not a usable number of seconds")
        point = JointTrajectoryPoint(positions=data.positions[i], time_from_start=duration(t))
        if i < len(data.velocities):
            point.velocities = data.velocities[i]
        if i < len(data.accelerations):
            point.accelerations = data.accelerations[i]
        traj.points.append(point)

    def tolerances(values: dict[str, float], override: float | None) -> list[Any]:
        names = data.joint_names if override is not None else list(values)
        return [JointTolerance(name=n, position=float(override if override is not None else values[n]))
                for n in names]

    goal_time = args.goal_time_tolerance if args.goal_time_tolerance is not None else data.goal_time_tolerance
    if not 0 <= goal_time < 1e9:         # a builtin_interfaces/Duration holds int32 seconds
        raise CliError(f"the goal time tolerance must be a finite number of seconds in [0, 1e9) (0 = the "
                       f"controller's default), got {goal_time:g}")
    goal = FollowActuatorTrajectory.Goal(
        trajectory=traj, path_tolerance=tolerances(data.path_tolerance, args.path_tolerance),
        goal_tolerance=tolerances(data.goal_tolerance, args.goal_tolerance),
        goal_time_tolerance=duration(goal_time))
    total = max(data.times) if data.times else None

    def progress(bar: Any, fb: Any) -> None:
        bar.n = round(min(fb.actual.time_from_start.sec + 1e-9 * fb.actual.time_from_start.nanosec,
                          bar.total or math.inf), 2)
        e = fb.error.positions
        bar.set_postfix_str(f"rho = ({fb.actual.positions[0]:.4f}, {fb.actual.positions[1]:.4f}) m, error "
                            f"({e[0] * 1e3:.3f}, {e[1] * 1e3:.3f}) mm", refresh=True)

    def summary(res: Any) -> str:
        err = ", ".join(f"{v * 1e3:.4f}" for v in res.final_error)
        return (f"final error ({err}) mm, end-effector error {res.end_effector_error * 1e3:.4f} mm, "
                f"peak force {res.max_force:.3f} N")

    return _run_goal(args, "tensegrity_follow", FollowActuatorTrajectory, goal, total, progress, summary)


def _code_name(action: Any, code: int) -> str:
    names = {getattr(action.Result, n): n for n in dir(action.Result) if n.isupper() and not n.startswith("_")
             and isinstance(getattr(action.Result, n), int)}
    return names.get(code, str(code))


def _run_goal(args: argparse.Namespace, node_name: str, action: Any, goal: Any, total: float | None,
              progress: Callable[[Any, Any], None], summary: Callable[[Any], str]) -> int:
    from rclpy.action import ActionClient
    from rclpy.executors import SingleThreadedExecutor
    from tqdm import tqdm

    from tensegrity_ros.cli.ros_clients import check_ros_name, client_node, namespace_hint
    from tensegrity_ros.rclpy_utils.futures import spin_until_done
    from tensegrity_ros.rclpy_utils.matching import wait_for_action_server, wait_until_server_heard

    check_ros_name(args.action, "--action")
    rclpy, node = client_node(node_name, args.ros_args)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    client = ActionClient(node, action, args.action)
    bar: Any = None              # shown once the controller is there: an error before it is one line
    handle = None
    try:
        if not wait_for_action_server(node, client, args.timeout):
            actions = (n[:-len(SEND_GOAL)] for n, _ in node.get_service_names_and_types() if n.endswith(SEND_GOAL))
            raise CliError(f"action {node.resolve_topic_name(args.action)} not available after {args.timeout:g} s "
                           f"(is the controller up? `tensegrity up`){namespace_hint(args.action, actions)}", code=3)
        wait_until_server_heard(node, args.action, lambda f, t: spin_until_done(executor, f, t), args.timeout)
        bar = tqdm(total=total, unit="s", file=sys.stderr, disable=args.json, dynamic_ncols=True,
                   bar_format="{l_bar}{bar}| {n:.2f}/{total_fmt} s {postfix}" if total else "{n:.2f} s {postfix}")
        sent = client.send_goal_async(goal, feedback_callback=lambda msg: progress(bar, msg.feedback))
        if not spin_until_done(executor, sent, args.timeout):
            raise CliError(f"the controller did not answer the goal within {args.timeout:g} s", code=3)
        handle = sent.result()
        if not handle.accepted:
            raise CliError("the controller rejected the goal", code=1)
        result = handle.get_result_async()
        while not spin_until_done(executor, result, 1.0):
            pass
        handle = None
        res = result.result().result
        ok = res.error_code == 0
        if ok and total:                  # feedback may stop short of the end: the goal is done
            bar.n = total
            bar.refresh()
        bar.close()
        if args.json:
            from tensegrity_ros.cli._common import print_json
            from tensegrity_ros.rclpy_utils.messages import message_to_dict

            print_json({"status": _code_name(action, res.error_code), **message_to_dict(res)})
        else:
            print(f"{'succeeded' if ok else 'failed (' + _code_name(action, res.error_code) + ')'}: "
                  f"{res.error_string}")
            if ok or res.error_code < -3:
                print(f"  {summary(res)}")
        return 0 if ok else 1
    except KeyboardInterrupt:
        if handle is not None:
            cancel = handle.cancel_goal_async()
            spin_until_done(executor, cancel, 5.0)
            bar.close()
            print("cancelled", file=sys.stderr)
        return 130
    finally:
        if bar is not None:
            bar.close()
        executor.shutdown()        # before the context: rclpy's finalizers break on a collected cycle
        client.destroy()
        node.destroy_node()
        rclpy.try_shutdown()
