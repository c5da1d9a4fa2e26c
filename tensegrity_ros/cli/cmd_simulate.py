"""``tensegrity simulate SCENE`` and ``tensegrity scenes``: scene-driven simulation.

SCENE is a scene file (YAML, see docs/scenes.md) or the name of a shipped scene. The run
shows a progress bar on stderr, prints a summary (``--json`` for scripts), and writes the
trajectory (``-o OUT.npz`` or ``OUT.csv``) and a plot (``--plot OUT.png``). A scene error
exits with code 2 and one ``error:`` line; a run that stops early (singular configuration,
no equilibrium) writes what it has and exits with code 1.
"""

from __future__ import annotations

import sys
from pathlib import Path

from tensegrity_ros.cli._common import CliError, add_json_flag, print_json

ORDER = 50


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "simulate", help="simulate a scene (class-2 mechanism or general structure)",
        description="Run a scene: only the effects it lists are simulated. Writes the trajectory "
                    "(NPZ or CSV) and a plot.")
    p.add_argument("scene", help="scene file (.yaml) or the name of a shipped scene (tensegrity scenes)")
    p.add_argument("-o", "--output", default=None, help="write the trajectory to OUT.npz or OUT.csv")
    p.add_argument("--plot", default=None, help="write a plot of the run (PNG)")
    p.add_argument("--duration", type=float, default=None, help="simulated time [s] (default: the scene's)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_json_flag(p)
    p.set_defaults(func=run_simulate)

    q = subparsers.add_parser("scenes", help="list the shipped simulation scenes",
                              description="The scenes shipped with tensegrity_core.sim, with their descriptions.")
    add_json_flag(q)
    q.set_defaults(func=run_scenes)


def run_scenes(args) -> int:
    from tensegrity_core.sim import load_scene, scene_names, scene_path

    rows = []
    for name in scene_names():
        scene = load_scene(scene_path(name))
        rows.append({"name": name, "model": scene.model.kind, "quasi_static": scene.quasi_static,
                     "effects": list(scene.effects), "duration": scene.duration, "description": scene.description})
    if args.json:
        print_json(rows)
        return 0
    width = max(len(r["name"]) for r in rows)
    for r in rows:
        print(f"{r['name']:<{width}}  {r['description']}")
        print(f"{'':<{width}}  {r['model']}, {'quasi-static' if r['quasi_static'] else 'dynamic'}, "
              f"{r['duration']:g} s; effects: {', '.join(r['effects'])}")
    return 0


def run_simulate(args) -> int:
    from tensegrity_core.errors import TensegrityError
    from tensegrity_core.schema import excerpt
    from tensegrity_core.sim import SceneError, load_scene, simulate

    out = Path(args.output) if args.output else None
    if out is not None and out.suffix.lower() not in (".npz", ".csv"):
        raise CliError(f"-o/--output must end in .npz or .csv, got {str(out)!r}")
    if args.plot is not None and not args.plot.lower().endswith(".png"):
        raise CliError(f"--plot must end in .png, got {args.plot!r}")
    try:
        scene = load_scene(args.scene)
        if args.duration is not None:
            scene = scene.with_duration(args.duration)
    except SceneError as err:
        raise CliError(str(err)) from None
    except OSError as err:                   # e.g. a name longer than the system allows
        raise CliError(f"cannot read the scene {excerpt(args.scene)}: {err.strerror}") from None
    bar = None
    if not (args.quiet or args.json):
        from tqdm import tqdm

        bar = tqdm(total=scene.duration, desc=scene.name, unit="s", file=sys.stderr, leave=False,
                   dynamic_ncols=True, bar_format="{l_bar}{bar}| {n:.3g}/{total:.3g} s [{elapsed}<{remaining}]")

    def progress(t, duration):
        bar.update(t - bar.n)

    try:
        traj = simulate(scene, progress=progress if bar is not None else None)
    except TensegrityError as err:
        raise CliError(str(err)) from None
    finally:
        if bar is not None:
            bar.close()
    if out is not None:
        try:
            traj.to_npz(out) if out.suffix.lower() == ".npz" else traj.to_csv(out)
        except OSError as err:
            raise CliError(f"cannot write {str(out)!r}: {err.strerror}") from None
    if args.plot:
        from tensegrity_core.sim.plotting import plot_trajectory

        plot_trajectory(traj, args.plot)
    summary = {
        "scene": traj.scene_name, "success": traj.success, "message": traj.message,
        "model": scene.model.kind, "quasi_static": scene.quasi_static, "effects": list(scene.effects),
        "samples": len(traj), "t_end": float(traj.times[-1]) if len(traj) else 0.0,
        "events": [{"t": float(t), "kind": k, "index": int(i)} for t, k, i in traj.events],
        "stats": traj.stats, "final": {"q": traj.q[-1] if len(traj) else [],
                                       "end_effector": traj.end_effector[-1] if len(traj) else []},
        "output": str(out) if out else None, "plot": args.plot,
    }
    if args.json:
        print_json(summary)
    else:
        _print_summary(summary)
    if not traj.success:
        print(f"error: simulation stopped early: {traj.message}", file=sys.stderr)
        return 1
    return 0


def _print_summary(s: dict) -> None:
    import numpy as np

    kind = "quasi-static" if s["quasi_static"] else "dynamic"
    print(f"scene {s['scene']}: {s['model']}, {kind}; effects: {', '.join(s['effects'])}")
    stats = s["stats"]
    extra = ", ".join(f"{k} {v}" for k, v in stats.items() if k not in ("wall_time",))
    print(f"{s['message']}: {s['samples']} samples to t = {s['t_end']:.6g} s in {stats['wall_time']:.3f} s ({extra})")
    for e in s["events"]:
        print(f"  event at t = {e['t']:.9g} s: {e['kind']} {e['index']}")
    with np.printoptions(precision=6, suppress=True):
        print(f"final q = {np.asarray(s['final']['q'])}, end effector = {np.asarray(s['final']['end_effector'])}")
    for key, label in (("output", "trajectory"), ("plot", "plot")):
        if s[key]:
            print(f"{label} written to {s[key]}")
