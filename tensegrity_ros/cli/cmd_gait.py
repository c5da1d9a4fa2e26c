"""``tensegrity gait ROBOT GAIT``: play a shipped gait on the running suite's robot, or roll
it in closed loop (``GAIT`` = ``roll``).

The gait (:func:`tensegrity_ros.apps.gait_goal.gait_named`: a shipped gait or a robot
scene's) goes to the cable controller (``tensegrity_cable_controller``, started by
``tensegrity up --scene`` a robot scene whose motors take commands) as one
``control_msgs/FollowJointTrajectory`` goal, exactly the goal a client written for
ros2_control's joint_trajectory_controller would send: joint names = the gait's cables,
positions = rest lengths [m] (:func:`~tensegrity_ros.apps.gait_goal.trajectory_points`).
``--faces N`` cuts a rolling gait to its first N faces, ``--repeats N`` plays a periodic
gait N cycles. Progress on stderr (the feedback's time along the trajectory); at the end
the result and what the robot did (:mod:`tensegrity_ros.apps.roll_summary`) from the goal's
start until the robot is at rest (watched up to ``--settle`` s of simulation time after the
goal: the goal ends when the motors reach the last rest lengths, and a robot still rolling
then goes on): distance rolled [m], faces rolled, peak tensions [N], and when it came to rest
or how fast it still moved.

``tensegrity gait ROBOT roll --faces N [--heading X Y]`` is the closed-loop rolling gait
(:mod:`tensegrity_ros.apps.gait_loop`): no table, the controller of
:mod:`tensegrity_core.robot.roll_control` reads the caps on the floor and the rods' poses at
50 Hz of simulation time and commands each tip on ``cable_commands`` until N new faces are
reached (robots with a shipped table of tipping moves; ``--max-time`` s of simulation time,
default 10 a face, before it gives up). A roll lasts at most a day of simulation time (the
longest trajectory the cable controller accepts), so ``--faces`` is at most 8640 and
``--max-time`` at most 86400 s. The same summary follows.

Before sending, the simulator's ``scene`` parameter says which robot runs: a suite that is
not up (exit 3), runs another robot or a scene whose motors take no commands (exit 1) is
one line. Exit 0 when the goal succeeded, 1 when it failed; Ctrl-C cancels the goal (the
cables hold where they are) and exits 130.
"""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING, Any

from tensegrity_ros.cli._common import CliError

if TYPE_CHECKING:
    from tensegrity_core.robot.description import Robot
    from tensegrity_core.robot.gait import Gait

ORDER = 57

ACTION = "tensegrity_cable_controller/follow_joint_trajectory"
#: The GAIT argument that runs the closed-loop rolling gait.
ROLL = "roll"
#: s of simulation time watched after the goal for the robot to come to rest
SETTLE_S = 2.0


def register(sub: Any) -> None:
    p = sub.add_parser("gait", help="play a shipped gait on the running suite's robot (FollowJointTrajectory), "
                       "or roll it N faces in closed loop (GAIT = roll)",
                       description="Send a shipped gait (six_bar_roll, three_bar_crawl, ...) to the running suite's "
                       "cable controller as a control_msgs/FollowJointTrajectory goal (cable rest lengths [m]), "
                       f"or with GAIT = {ROLL} roll the robot --faces N faces in closed loop (the contacts and rod "
                       "poses read, cable_commands published at 50 Hz of simulation time); print the distance "
                       "rolled [m], the faces rolled and the peak cable tensions [N]. Start the suite first, e.g. "
                       "`tensegrity up --scene six_bar_rest`.")
    p.add_argument("robot", help="the robot the gait is for (six_bar, three_bar, ...)")
    p.add_argument("gait", help=f"a shipped gait or a robot scene that plays one (six_bar_roll, three_bar_crawl), "
                   f"or {ROLL}: the closed-loop rolling gait")
    p.add_argument("--faces", type=int, default=None, metavar="N",
                   help=f"roll only the first N faces of a rolling gait (six_bar_roll: 1..8); with {ROLL}: the "
                   "faces to roll (required)")
    p.add_argument("--heading", type=float, nargs=2, default=None, metavar=("X", "Y"),
                   help=f"with {ROLL}: the direction to roll in on the floor (world x, y; default 1 0)")
    p.add_argument("--max-time", type=float, default=None, metavar="S",
                   help=f"with {ROLL}: seconds of simulation time before giving up (default 10 a face)")
    p.add_argument("--repeats", type=int, default=None, metavar="N", help="cycles of a periodic gait")
    p.add_argument("--namespace", "-n", default="", help="the suite's ROS namespace (as given to `tensegrity up`)")
    p.add_argument("--action", default=ACTION, help=f"the FollowJointTrajectory action (default {ACTION})")
    p.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for the suite to answer")
    p.add_argument("--settle", type=float, default=SETTLE_S, metavar="S",
                   help=f"seconds of simulation time to watch the robot after the goal until it is at rest "
                   f"(default {SETTLE_S:g}); the summary runs to the rest or to the end of this watch")
    p.set_defaults(func=_gait)


def build_gait(robot_name: str, gait_name: str, faces: int | None, repeats: int | None) -> tuple[Robot, Gait]:
    """``(robot, gait)``: the gait checked against the robot and cut or repeated as asked;
    CliError with one line otherwise."""
    from tensegrity_core.errors import TensegrityError
    from tensegrity_core.robot.loading import load_robot, robot_names
    from tensegrity_ros.apps.gait_goal import first_faces, gait_named

    if robot_name not in robot_names():
        raise CliError(f"no shipped robot {robot_name!r}; robots: {', '.join(robot_names())}")
    robot = load_robot(robot_name)
    try:
        gait = gait_named(gait_name)
        actuated = [robot.cables.names[j] for j in robot.cables.actuated]
        foreign = [c for c in gait.cables if c not in actuated]
        if foreign:
            raise CliError(f"gait {gait_name!r} drives cables that are not motor cables of {robot_name} "
                           f"({', '.join(foreign[:3])}{', ...' if len(foreign) > 3 else ''}): it is another robot's")
        if repeats is not None:
            if gait.period is None:
                raise CliError(f"gait {gait_name!r} is not periodic: --repeats needs a periodic gait")
            if repeats < 1:
                raise CliError(f"--repeats must be >= 1, got {repeats}")
            gait = gait.with_options(cycles=repeats)
        if faces is not None:
            gait = first_faces(gait, faces)
    except TensegrityError as err:
        raise CliError(str(err)) from None
    return robot, gait


def check_roll(robot_name: str, faces: int | None, heading: list[float] | None, max_time: float | None,
               repeats: int | None) -> tuple[int, tuple[float, float], float]:
    """``(faces, heading, max_time [s])`` of a closed-loop roll as asked; CliError with one line otherwise."""
    import math

    from tensegrity_core.robot.loading import robot_names
    from tensegrity_core.robot.roll_control import TIPS_DIR
    from tensegrity_ros.apps.gait_loop import FACE_TIME, MAX_FACES, MAX_TIME, default_max_time

    if robot_name not in robot_names():
        raise CliError(f"no shipped robot {robot_name!r}; robots: {', '.join(robot_names())}")
    shipped = sorted(p.stem for p in TIPS_DIR.glob("*.yaml"))
    if robot_name not in shipped:
        raise CliError(f"the closed-loop {ROLL} needs a table of tipping moves, shipped for: {', '.join(shipped)} "
                       f"(not {robot_name})")
    if faces is None or faces < 1:
        raise CliError(f"{ROLL} needs --faces N, the faces to roll (N >= 1)" + ("" if faces is None else
                                                                                f", got {faces}"))
    if faces > MAX_FACES:
        raise CliError(f"--faces must be at most {MAX_FACES} ({FACE_TIME:g} s of simulation time a face within "
                       f"a roll's {MAX_TIME:g} s, a day), got {faces}")
    if repeats is not None:
        raise CliError(f"--repeats is for periodic gaits, not {ROLL}")
    h = (1.0, 0.0) if heading is None else (heading[0], heading[1])
    if not (all(math.isfinite(v) for v in h) and math.hypot(*h) > 0):
        raise CliError(f"--heading must be a nonzero direction X Y on the floor, got {h[0]:g} {h[1]:g}")
    limit = default_max_time(faces) if max_time is None else max_time
    if not (math.isfinite(limit) and 0 < limit <= MAX_TIME):
        raise CliError(f"--max-time must be > 0 s and at most {MAX_TIME:g} s (a day of simulation time), got {limit}")
    return faces, h, limit


def _gait(args: Any) -> int:
    import math

    if not (math.isfinite(args.timeout) and args.timeout > 0):
        raise CliError(f"--timeout must be > 0 s, got {args.timeout}")
    if not (math.isfinite(args.settle) and args.settle >= 0):
        raise CliError(f"--settle must be >= 0 s, got {args.settle}")
    if args.gait == ROLL:
        faces, heading, max_time = check_roll(args.robot, args.faces, args.heading, args.max_time, args.repeats)
    else:
        if args.heading is not None or args.max_time is not None:
            raise CliError(f"--heading and --max-time are for the closed-loop {ROLL}, not a gait table")
        _, gait = build_gait(args.robot, args.gait, args.faces, args.repeats)
    from tensegrity_ros.rclpy_utils.env import require_rclpy

    require_rclpy()
    from tensegrity_ros.apps.gait_run import SuiteError, play_gait
    from tensegrity_ros.cli.ros_clients import check_ros_name

    check_ros_name(args.action, "--action")
    if args.namespace:
        check_ros_name(args.namespace, "--namespace", namespace=True)
    ns = args.namespace if not args.namespace or args.namespace.startswith("/") else "/" + args.namespace
    ros_args = ["--ros-args", *(["-r", f"__ns:={ns}"] if ns else []), *args.ros_args[1:]]
    try:
        if args.gait == ROLL:
            from tensegrity_ros.apps.gait_loop import roll_closed_loop

            return roll_closed_loop(args.robot, faces, heading, ros_args, timeout=args.timeout, settle=args.settle,
                                    max_time=max_time, out=sys.stdout)
        return play_gait(args.robot, gait, ros_args, action=args.action, timeout=args.timeout,
                         settle=args.settle, out=sys.stdout)
    except SuiteError as err:
        raise CliError(str(err), code=err.code) from None
