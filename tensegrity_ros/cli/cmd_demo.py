"""``tensegrity demo``: the suite end to end (see :mod:`tensegrity_ros.apps.demo`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from tensegrity_ros.cli._common import Subparsers

ORDER = 1


def register(sub: Subparsers) -> None:
    p = sub.add_parser("demo", help="start the suite, drive the mechanism in lockstep, call the services, record bags",
                       description="Starts the simulator (lockstep: one command per control period), the IK, "
                       "form-finding and controller nodes; moves D through four waypoints with the controller's "
                       "move_end_effector action and follows an actuator trajectory with "
                       "follow_actuator_trajectory (each goal's settled error, settling time, overshoot and force); "
                       "then stops the controller and drives the paper's fold scenario on actuator_forces; records "
                       "a bag of each, shows that reruns and the core's sampled-data run of the fold are "
                       "identical, tabulates the control period against the continuous-time fold, calls "
                       "find_form on the tensegrity table; rolls the 6-bar robot in closed loop in lockstep (recorded, rerun identical: "
                       "distance, faces, peak tensions) and prints a summary.")
    p.add_argument("--out", "-o", default="demo_out", help="folder for the bags and the suite log")
    p.add_argument("--control-period", type=float, default=0.01, metavar="S",
                   help="the lockstep control period [s] (default 0.01: 100 Hz)")
    p.add_argument("--no-record", action="store_true", help="do not record bags")
    p.add_argument("--robot-faces", type=int, default=3, metavar="N",
                   help="faces the 6-bar robot rolls in closed loop (1..8; 0: no robot phase)")
    p.set_defaults(func=_demo)


def _demo(args: argparse.Namespace) -> int:
    from tensegrity_ros.apps.demo import run_demo
    from tensegrity_ros.cli._common import CliError

    if not 1e-4 <= args.control_period <= 0.5:
        raise CliError(f"--control-period must be in [1e-4, 0.5] s, got {args.control_period}")
    if not 0 <= args.robot_faces <= 8:
        raise CliError(f"--robot-faces must be in [0, 8], got {args.robot_faces}")
    return run_demo(Path(args.out), control_period=args.control_period, record=not args.no_record,
                    robot_faces=args.robot_faces)
