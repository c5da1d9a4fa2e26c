"""``tensegrity record``, ``tensegrity play`` and ``tensegrity bag info|plot|repair``."""

from __future__ import annotations

import argparse
import sys

from tensegrity_ros.cli._common import CliError, Handler, Subparsers, add_json_flag, check_seconds, print_json

ORDER = 70


def _bag_errors(fn: Handler) -> Handler:
    def run(args: argparse.Namespace) -> int:
        from tensegrity_ros.bag.errors import BagError
        try:
            return fn(args)
        except BagError as err:
            raise CliError(str(err), 1) from None
    return run


@_bag_errors
def _record(args: argparse.Namespace) -> int:
    from tensegrity_ros.rclpy_utils.env import require_rclpy

    require_rclpy()
    from tensegrity_ros.apps.start_gate import pass_gate
    from tensegrity_ros.bag.recorder import record
    from tensegrity_ros.cli.ros_clients import check_ros_name

    for topic in args.topics:
        check_ros_name(topic.rstrip("/") or topic, "topic")        # NAME/: every topic under NAME
    pass_gate()                          # imported: now wait for `tensegrity up`'s look, if it looks
    record(args.output, args.topics, record_all=args.all,
           max_duration=args.max_duration, chunk_size=args.chunk_size,
           compression=args.compression, flush_interval=args.flush_interval,
           ros_args=args.ros_args, custom_data=dict(args.custom_data) or None)
    return 0


def _key_value(text: str) -> tuple[str, str]:
    """``KEY=VALUE`` of ``--custom-data`` (``ros2 bag record``'s form)."""
    key, sep, value = text.partition("=")
    if not sep or not key.strip():
        raise argparse.ArgumentTypeError(f"expects KEY=VALUE, got {text!r}")
    return key.strip(), value


def _clock_rate(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--clock expects a rate in Hz, got {text!r}") from None


@_bag_errors
def _play(args: argparse.Namespace) -> int:
    from tensegrity_ros.rclpy_utils.env import require_rclpy

    require_rclpy()
    if args.resimulate:
        return _resimulate(args)
    from tensegrity_ros.bag.player import play
    from tensegrity_ros.bag.schedule import PlaybackOptions
    from tensegrity_ros.cli.ros_clients import check_ros_name

    for topic in args.topics or []:
        check_ros_name(topic, "--topics")
    if args.wait_for_subscribers is not None:
        check_seconds(args.wait_for_subscribers, "--wait-for-subscribers")
    check_seconds(args.wait_for_all_acked, "--wait-for-all-acked", zero="exit at once")
    from tensegrity_ros.bag.errors import BagError
    try:
        opts = PlaybackOptions(rate=args.rate, start_offset_s=args.start_offset, loop=args.loop,
                               clock_hz=args.clock)
    except BagError as err:             # a refused option value is usage (exit 2), not the bag
        raise CliError(str(err)) from None
    play(args.bag, args.topics, opts, delay_s=args.delay,
         wait_for_subscribers_s=args.wait_for_subscribers,
         wait_for_all_acked_s=args.wait_for_all_acked, ros_args=args.ros_args)
    return 0    # played to the end, or stopped on request (SIGINT/SIGTERM): both clean


def _resimulate(args: argparse.Namespace) -> int:
    from tensegrity_ros.apps.resimulate import resimulate

    if args.step_size is not None and not 1e-6 <= args.step_size <= 10.0:
        raise CliError(f"--step-size must be in [1e-6, 10] s, got {args.step_size}")
    from tensegrity_core.sim import SceneError

    try:
        report = resimulate(args.bag, scene=args.scene, step_size=args.step_size)
    except SceneError as err:
        raise CliError(f"cannot load the scene to re-simulate on: {err}") from None
    if report.warning():
        print(report.warning(), file=sys.stderr)
    if args.json:
        import dataclasses

        print_json(dataclasses.asdict(report))
    else:
        print(report.summary())
    return 0


@_bag_errors
def _info(args: argparse.Namespace) -> int:
    from tensegrity_ros.bag.info import bag_info, format_info

    info = bag_info(args.bag)
    if args.json:
        print_json(info)
    else:
        print(format_info(info))
    return 0


@_bag_errors
def _plot(args: argparse.Namespace) -> int:
    from pathlib import Path

    from tensegrity_ros.bag.plot import plot_bag

    folder = Path(args.output).parent
    if not folder.is_dir():
        raise CliError(f"cannot write {args.output!r}: folder {str(folder)!r} does not exist")
    try:
        print(plot_bag(args.bag, args.output))
    except OSError as err:
        raise CliError(f"cannot write {args.output!r}: {err.strerror or err}") from None
    return 0


@_bag_errors
def _repair(args: argparse.Namespace) -> int:
    from tensegrity_ros.bag.repair import repair_bag

    result = repair_bag(args.bag, keep_original=not args.no_backup)
    if args.json:
        print_json({"folder": str(result.folder), "rewritten": result.rewritten,
                    "message_count": result.message_count, "topics": result.topic_counts,
                    "damage": result.damage, "originals": [str(p) for p in result.originals],
                    "notes": result.notes})
        return 0
    if result.rewritten:
        print(f"recovered {result.message_count} messages into {result.folder}"
              f" ({', '.join(f'{t} {n}' for t, n in result.topic_counts.items())})")
        for line in result.damage:
            print(f"  damaged tail dropped: {line}")
        for path in result.originals:
            print(f"  original kept as {path}")
    else:
        print(f"storage of {result.folder} is intact ({result.message_count} messages); "
              "metadata.yaml regenerated")
    for note in result.notes:
        print(f"  {note}")
    return 0


def register(sub: Subparsers) -> None:
    p = sub.add_parser(
        "record", help="record topics to a rosbag2 MCAP bag folder",
        description="Record topics to a rosbag2-compatible bag folder (metadata.yaml + MCAP). "
        "Default topics: the suite's (joint_states, end_effector, mechanism_state, markers, "
        "/clock, actuator_forces, events; for general structures cable_states, body_states, cable_commands), "
        "subscribed as they appear. Stop with Ctrl-C or SIGTERM.")
    p.add_argument("topics", nargs="*", metavar="TOPIC", help="topics to record (relative names "
                   "follow the namespace)")
    p.add_argument("-o", "--output", required=True, metavar="DIR",
                   help="bag folder to create (must not exist)")
    p.add_argument("-a", "--all", action="store_true", help="record every (non-hidden) topic")
    p.add_argument("--max-duration", type=float, default=None, metavar="S",
                   help="stop after S seconds")
    p.add_argument("--chunk-size", type=int, default=None, metavar="BYTES",
                   help="MCAP chunk size (default 786432)")
    p.add_argument("--flush-interval", type=float, default=None, metavar="S",
                   help="write the open chunk to the file at the latest S seconds after its "
                   "first message: a recorder killed outright (SIGKILL) loses at most about "
                   "that (default 0.1)")
    p.add_argument("--compression", choices=("zstd", "lz4", "none"), default="zstd",
                   help="MCAP chunk compression (default zstd)")
    p.add_argument("--custom-data", type=_key_value, action="append", default=[], metavar="KEY=VALUE",
                   help="store KEY=VALUE in the bag's metadata (custom_data), as ros2 bag record does; "
                   "`tensegrity up --record` stores scene=NAME, which `tensegrity view BAG` draws")
    p.set_defaults(func=_record, stop_signals=True)

    p = sub.add_parser("play", help="replay a bag with its recorded timing",
                       description="Publish a bag's messages on their topics with the recorded "
                       "timing (bags written by rosbag2 or rosbags too).")
    p.add_argument("bag", metavar="DIR", help="bag folder (or .mcap file)")
    p.add_argument("-r", "--rate", type=float, default=1.0, help="rate factor (default 1)")
    p.add_argument("--start-offset", type=float, default=0.0, metavar="S",
                   help="start S seconds into the bag")
    p.add_argument("--topics", nargs="+", default=None, metavar="TOPIC",
                   help="play only these topics")
    p.add_argument("-l", "--loop", action="store_true", help="play again and again")
    p.add_argument("--clock", type=_clock_rate, nargs="?", const=40.0, default=None,
                   metavar="HZ", help="publish /clock from the recorded times at HZ "
                   "(default 40 Hz)")
    p.add_argument("-d", "--delay", type=float, default=0.0, metavar="S",
                   help="wait S seconds after creating the publishers")
    p.add_argument("--wait-for-subscribers", type=float, default=None, metavar="S",
                   help="first wait up to S seconds until every topic has a subscriber "
                   "(matched for 0.25 s, so that the subscriber's side has matched too)")
    p.add_argument("--wait-for-all-acked", type=float, default=10.0, metavar="S",
                   help="at the end wait up to S seconds until every reliable subscriber "
                   "acknowledged every message (default 10; 0: exit at once)")
    p.add_argument("--resimulate", action="store_true",
                   help="instead of replaying: feed the bag's actuator_forces into a lockstep simulator of "
                   "its own at their recorded steps and report the largest difference between the recorded "
                   "and the re-simulated joint states (0 for a lockstep recording)")
    p.add_argument("--scene", default=None,
                   help="--resimulate: the simulator's scene (default: the one the bag's metadata names, "
                   "else class2_at_rest, the node's default)")
    p.add_argument("--step-size", type=float, default=None, metavar="S",
                   help="--resimulate: the step [s] (default: the joint states' spacing in the bag)")
    add_json_flag(p)
    p.set_defaults(func=_play, stop_signals=True)

    p = sub.add_parser("bag", help="inspect, plot or repair a bag")
    bag_sub = p.add_subparsers(dest="bag_command", metavar="BAG_COMMAND", required=True)
    q = bag_sub.add_parser("info", help="topics, types, counts, duration, size")
    q.add_argument("bag", metavar="DIR")
    add_json_flag(q)
    q.set_defaults(func=_info)
    q = bag_sub.add_parser("plot", help="joint positions and end effector against time (PNG)")
    q.add_argument("bag", metavar="DIR")
    q.add_argument("-o", "--output", required=True, metavar="FILE.png")
    q.set_defaults(func=_plot)
    q = bag_sub.add_parser("repair", help="recover a killed recording and regenerate metadata.yaml")
    q.add_argument("bag", metavar="DIR")
    q.add_argument("--no-backup", action="store_true",
                   help="do not keep the damaged file as <file>.orig")
    add_json_flag(q)
    q.set_defaults(func=_repair)
