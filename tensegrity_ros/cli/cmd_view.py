"""``tensegrity view``: the live 3D view in the browser (tensegrity_ros/view/, docs/view.md)."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from tensegrity_ros.cli._common import CliError, Subparsers

if TYPE_CHECKING:
    from tensegrity_ros.view.source import Source

ORDER = 75


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expects a number, got {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def _port(text: str) -> int:
    try:
        port = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expects a port number, got {text!r}") from None
    if not 0 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"must be in 0..65535 (0: any free port), got {port}")
    return port


def _source(args: argparse.Namespace) -> Source:
    """The source the arguments name: a bag (of ``--scene``'s structure), a scene in this
    process, or the suite over ROS."""
    if args.bag:
        from tensegrity_ros.bag.errors import BagError
        from tensegrity_ros.view.bag_source import BagSource

        try:
            return BagSource(args.bag, scene=args.scene, fps=args.fps)
        except BagError as err:
            raise CliError(str(err), 1) from None
    if args.scene:
        from tensegrity_core.errors import TensegrityError
        from tensegrity_ros.view.scene_source import SceneSource

        try:
            return SceneSource(args.scene, step=args.step, force_limit=args.force_limit)
        except TensegrityError as err:
            raise CliError(str(err), 1) from None
    from tensegrity_ros.rclpy_utils.env import require_rclpy

    require_rclpy()
    from tensegrity_ros.cli.ros_clients import check_ros_name
    from tensegrity_ros.view.ros_source import RosSource

    if args.namespace:
        check_ros_name(args.namespace, "--namespace", namespace=True)
    return RosSource(args.namespace, force_limit=args.force_limit, ros_args=args.ros_args)


def _view(args: argparse.Namespace) -> int:
    from tensegrity_ros.rclpy_utils import stop_signals

    stop = stop_signals.install()
    from tensegrity_ros.view.server import ViewError, is_loopback, require_viser, start_server

    try:
        require_viser()
    except ViewError as err:
        raise CliError(str(err), 3) from None

    stop.enter_running()
    source = _source(args)
    try:
        first = source.first_frame(timeout=args.wait)
    except ViewError as err:
        source.stop()
        raise CliError(str(err), 3) from None
    if not is_loopback(args.host):
        print(f"warning: listening on {args.host}: anyone who can reach this machine can watch and drive the "
              "simulation", file=sys.stderr, flush=True)
    try:
        server = start_server(args.host, args.port, label="tensegrity view")
    except ViewError as err:
        source.stop()
        raise CliError(str(err), 2) from None
    from tensegrity_ros.view.app import View

    view = View(server, source, first, fps=args.fps)
    url = f"http://{args.host}:{server.get_port()}"
    suite = ", the suite keeps running" if not (args.bag or args.scene) else ""
    print(f"view ready: {url} ({source.label}); Ctrl-C stops the view{suite}", file=sys.stderr, flush=True)
    try:
        stop.wait()
    finally:
        view.close()
    return 0


def register(sub: Subparsers) -> None:
    p = sub.add_parser(
        "view", help="watch and drive a simulation in the browser (3D view, plots, controls)",
        description="Serve a live 3D view of the running suite (any --namespace), of a recorded BAG (timeline: play, "
        "pause, scrub, rate) or of a --scene simulated in this process, with plots and controls: pause, play, step, "
        "actuator-force sliders, the controller's move of node D. Listens on 127.0.0.1 unless --host names another "
        "address. docs/view.md.")
    p.add_argument("bag", nargs="?", help="a bag folder or .mcap file to play in the view (no suite needed)")
    p.add_argument("--scene", help="simulate this scene in the view's process instead (`tensegrity scenes`); with "
                   "a BAG of a general structure or robot: the scene it was recorded from (what to draw)")
    p.add_argument("--namespace", default="", help="the suite's namespace (e.g. /robot1; default: none)")
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=_port, default=8080, help="port (default 8080; 0: any free port)")
    p.add_argument("--fps", type=_positive, default=60.0, help="frames per second sent to the page at most (default 60)")
    p.add_argument("--force-limit", type=_positive, default=5.0,
                   help="class-2 force sliders span +-this [N] (default 5)")
    p.add_argument("--step", type=_positive, default=0.01, help="--scene: the simulation step [s] (default 0.01)")
    p.add_argument("--wait", type=_positive, default=30.0,
                   help="seconds to wait for the suite's first state (default 30)")
    p.set_defaults(func=_view, stop_signals=True)
