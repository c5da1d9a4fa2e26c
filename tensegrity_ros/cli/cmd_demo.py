"""``tensegrity demo``: the suite end to end (see :mod:`tensegrity_ros.apps.demo`)."""

from __future__ import annotations

from pathlib import Path

ORDER = 1


def register(sub) -> None:
    p = sub.add_parser("demo", help="start the suite, drive the mechanism, call the services, record bags",
                       description="Starts sim + IK + form-finding, drives the mechanism through IK "
                       "waypoints and the paper's fold scenario via actuator_forces (recording a bag of "
                       "each), calls find_form on the tensegrity table, and prints a summary.")
    p.add_argument("--out", "-o", default="demo_out", help="folder for the bags and the suite log")
    p.add_argument("--real-time-factor", type=float, default=2.0,
                   help="simulated seconds per wall second (default 2)")
    p.add_argument("--no-record", action="store_true", help="do not record bags")
    p.set_defaults(func=_demo)


def _demo(args) -> int:
    from tensegrity_ros.cli._common import CliError
    from tensegrity_ros.apps.demo import run_demo

    if not args.real_time_factor > 0:
        raise CliError(f"--real-time-factor must be > 0, got {args.real_time_factor}")
    return run_demo(Path(args.out), real_time_factor=args.real_time_factor, record=not args.no_record)
