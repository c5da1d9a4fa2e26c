"""``tensegrity export mjcf SOURCE -o model.xml``: a MuJoCo model of a scene, robot or structure.

SOURCE is a general scene with inertia (a file or a shipped scene's name), a robot (a file or
a shipped robot's name: rods, cables, motors, floor, sensors) or a structure (a file or a
shipped example's name; exported with its own gravity and loads, no damping, from the
drawing at rest). The model has the physics of the general dynamics; docs/mujoco.md
maps every element and lists what MuJoCo does differently. Input errors exit with code 2
and one ``error:`` line; nothing is written then.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from tensegrity_ros.cli._common import CliError, Subparsers, add_json_flag, print_json

ORDER = 55


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser("export", help="export a scene, robot or structure to another simulator's format "
                                             "(MJCF)",
                              description="Write a model of a scene, robot or structure for another simulator.")
    formats = p.add_subparsers(dest="format", metavar="FORMAT", required=True)
    q = formats.add_parser(
        "mjcf", help="a MuJoCo model (MJCF) with the same physics as the general dynamics",
        description="Write a MuJoCo model (MJCF XML) of a general scene with inertia, or of a structure "
                    "(its own gravity and loads, no damping, from the drawing at rest): nodes as point masses "
                    "on slide joints, rigid bodies as free bodies, members as spatial tendons (strings with "
                    "a tension-only dead band), dampers, gravity, dead loads, the initial state as keyframe "
                    "'initial'. A robot: rods as free capsule bodies, cables as tendons, motors as actuators on them by "
                    "their modes (rest length, reel speed, tension; tension only), the floor with contact pairs at the end caps, cable-length and IMU "
                    "sensors. See docs/mujoco.md.")
    q.add_argument("source", metavar="SCENE_ROBOT_OR_STRUCTURE",
                   help="scene, robot or structure file, or the name of a shipped scene (tensegrity scenes), robot "
                        "(three_bar, six_bar, spine) or example")
    q.add_argument("-o", "--output", required=True, help="the model file to write (.xml)")
    q.add_argument("--timestep", type=float, default=None,
                   help="MuJoCo's time step [s] (default: 1, 2 or 5 x 10^k s at most 0.2/(the fastest rate of the "
                        "linearised dynamics); a robot's: 0.001)")
    q.add_argument("--integrator", default=None,
                   help="MuJoCo's integrator: RK4 (default; a robot's: implicitfast), Euler, implicit, implicitfast")
    add_json_flag(q)
    q.set_defaults(func=run_export_mjcf)


def _output(path: str) -> Path:
    """``-o``: an ``.xml`` file in an existing folder."""
    out = Path(path)
    if out.suffix.lower() != ".xml":
        raise CliError(f"-o/--output must end in .xml, got {path!r}")
    folder = out.parent
    if not folder.is_dir():
        raise CliError(f"cannot write {path!r}: folder {str(folder)!r} does not exist")
    if out.is_dir():
        raise CliError(f"cannot write {path!r}: it is a folder")
    return out


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}" if n == 1 else f"{n} {noun[:-1] + 'ies' if noun.endswith('y') else noun + 's'}"


def run_export_mjcf(args: argparse.Namespace) -> int:
    from tensegrity_core.errors import TensegrityError
    from tensegrity_core.export import export_mjcf
    from tensegrity_core.export.robot_motors import CTRL_MEANING
    from tensegrity_core.export.sources import load_source

    out = _output(args.output)
    try:
        model = export_mjcf(load_source(args.source), timestep=args.timestep, integrator=args.integrator)
    except TensegrityError as err:
        raise CliError(str(err)) from None
    try:
        model.write(out)
    except OSError as err:
        raise CliError(f"cannot write {str(out)!r}: {err.strerror or err}") from None
    summary = {"output": str(out), "model": model.name, "timestep": model.timestep, "integrator": model.integrator,
               "fastest_rate": model.fastest_rate, "node_bodies": model.node_bodies,
               "rigid_bodies": model.rigid_bodies, "tendons": model.tendons, "loads": model.loads,
               "actuator_members": model.actuator_members, "nq": model.nq, "nv": model.nv}
    if model.rods or model.motors or model.contacts:
        summary.update(rods=model.rods, motors=model.motors, contacts=model.contacts, sensors=model.sensors)
        del summary["fastest_rate"], summary["loads"], summary["actuator_members"]
    if args.json:
        print_json(summary)
        return 0
    print(f"wrote {out}: MuJoCo model of {model.name!r}")
    if "rods" in summary:
        print(f"  {_count(model.rods, 'rod')} and {_count(model.rigid_bodies - model.rods, 'rigid body')} on free "
              f"joints, {_count(model.node_bodies, 'point-mass node')} on slide joints, {_count(model.tendons, 'cable')} "
              f"({_count(model.motors, 'motor')}), {_count(model.contacts, 'floor contact')}, "
              f"{_count(model.sensors, 'sensor')}; nq = {model.nq}, nv = {model.nv}")
        print(f"  integrator {model.integrator}, time step {model.timestep:g} s; initial state: keyframe 'initial'; "
              f"motor {CTRL_MEANING}")
        return 0
    print(f"  {_count(model.node_bodies, 'free node')} on slide joints, {_count(model.rigid_bodies, 'rigid body')} "
          f"on free joints, {_count(model.tendons, 'tendon')}, {_count(model.loads, 'dead load')}, "
          f"{_count(model.actuator_members, 'actuator member')}; nq = {model.nq}, nv = {model.nv}")
    print(f"  integrator {model.integrator}, time step {model.timestep:g} s (fastest rate of the linearised "
          f"dynamics {model.fastest_rate:.4g} 1/s); initial state: keyframe 'initial'")
    return 0
