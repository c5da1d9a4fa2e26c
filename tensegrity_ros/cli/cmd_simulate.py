"""``tensegrity simulate SCENE`` and ``tensegrity scenes``: scene-driven simulation.

SCENE is a scene file (YAML, see docs/scenes.md) or the name of a shipped scene. The run
shows a progress bar on stderr (simulated time reached, and simulated seconds per second),
prints a summary (``--json`` for scripts), and writes the trajectory (``-o OUT.npz`` or
``OUT.csv``) and a plot (``--plot OUT.png``). A scene whose explicit integration method
does not fit its stiffness gets a ``warning:`` line before the run. A scene error exits with
code 2 and one ``error:`` line; a run that stops early (singular configuration, no
equilibrium) or breaks an invariant of the physics (``error: invariant violated: ...``)
writes what it has and exits with code 1. Ctrl-C (or SIGTERM) ends the run at its next
sample: what was computed is written and plotted, said so, exit code 130; a second Ctrl-C
interrupts at once.
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any, cast

from tensegrity_ros.cli._common import CliError, Row, Subparsers, add_json_flag, add_listing, print_json

if TYPE_CHECKING:
    from tensegrity_core.events import LoggedEvent
    from tensegrity_core.sim.sampled import Controller, SampledRun
    from tensegrity_core.sim.trajectory import Trajectory

ORDER = 50


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser(
        "simulate", help="simulate a scene (class-2 mechanism or general structure)",
        description="Run a scene: only the effects it lists are simulated. Writes the trajectory "
                    "(NPZ or CSV) and a plot.")
    p.add_argument("scene", help="scene file (.yaml) or the name of a shipped scene (tensegrity scenes)")
    p.add_argument("-o", "--output", default=None, help="write the trajectory to OUT.npz or OUT.csv")
    p.add_argument("--plot", default=None, help="write a plot of the run (PNG)")
    p.add_argument("--duration", type=float, default=None, help="simulated time [s] (default: the scene's)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--control-period", type=float, default=None, metavar="DT",
                   help="sampled-data run: evaluate --controller every DT seconds on the state and hold its "
                   "output for one period (the loop a lockstep tensegrity_sim closes with a controller)")
    p.add_argument("--controller", default=None, metavar="MODULE:FUNCTION",
                   help="the controller of a sampled-data run: FUNCTION(sample) -> one force per input [N], "
                   "sample with t [s], q, qdot, applied_forces, end_effector (e.g. "
                   "tensegrity_core.class2.fold_law:paper_fold_forces)")
    add_json_flag(p)
    p.set_defaults(func=run_simulate)

    add_listing(subparsers, "scenes", help="list the shipped simulation scenes",
                description="The scenes shipped with tensegrity_core.sim, with their descriptions.",
                rows=_scene_rows, details=_scene_details)


def _scene_rows() -> list[Row]:
    from tensegrity_core.sim import load_scene, scene_names, scene_path

    rows = []
    for name in scene_names():
        scene = load_scene(scene_path(name))
        rows.append({"name": name, "model": scene.model.kind, "quasi_static": scene.quasi_static,
                     "effects": list(scene.effects), "duration": scene.duration, "description": scene.description})
    return rows


def _scene_details(r: Row) -> str:
    return (f"{r['model']}, {'quasi-static' if r['quasi_static'] else 'dynamic'}, {r['duration']:g} s; "
            f"effects: {', '.join(r['effects'])}")


def load_controller(spec: str) -> Controller:
    """The function named by ``MODULE:FUNCTION``, or a CliError saying what is wrong."""
    import importlib

    module_name, sep, name = spec.partition(":")
    if not sep or not module_name or not name:
        raise CliError(f"--controller expects MODULE:FUNCTION, got {spec!r}")
    try:
        module = importlib.import_module(module_name)
    except Exception as err:   # any import failure of user code is one line
        raise CliError(f"--controller: cannot import {module_name!r}: {type(err).__name__}: {err}") from None
    fn = getattr(module, name, None)
    if not callable(fn):
        raise CliError(f"--controller: {module_name!r} has no function {name!r}")
    return cast("Controller", fn)     # user code: the forces it returns are read with float()


def _output_path(args: argparse.Namespace) -> Path | None:
    """The trajectory file of ``-o`` (``.npz`` or ``.csv``), or None."""
    out = Path(args.output) if args.output else None
    if out is not None and out.suffix.lower() not in (".npz", ".csv"):
        raise CliError(f"-o/--output must end in .npz or .csv, got {str(out)!r}")
    return out


def _write(run: Trajectory | SampledRun, out: Path) -> None:
    """Write a run (a trajectory or a sampled-data run) to ``out``, NPZ or CSV by its suffix."""
    try:
        run.to_npz(out) if out.suffix.lower() == ".npz" else run.to_csv(out)
    except OSError as err:
        raise CliError(f"cannot write {str(out)!r}: {err.strerror}") from None


def run_sampled_cli(args: argparse.Namespace) -> int:
    """``simulate --control-period DT --controller MODULE:FUNCTION``."""
    from tensegrity_core.errors import TensegrityError
    from tensegrity_core.sim import SceneError, load_scene
    from tensegrity_core.sim.sampled import run_sampled

    if (args.control_period is None) != (args.controller is None):
        raise CliError("--control-period and --controller go together")
    if args.plot is not None:
        raise CliError("--plot is not available for a sampled-data run (write -o OUT.npz and plot that)")
    out = _output_path(args)
    if not (args.control_period > 0 and args.control_period < 3600):
        raise CliError(f"--control-period must be in (0, 3600) s, got {args.control_period}")
    controller = load_controller(args.controller)
    try:
        scene = load_scene(args.scene)
        with stop_requests() as stop:
            run = run_sampled(scene, controller, step_size=args.control_period,
                              duration=scene.duration if args.duration is None else args.duration,
                              stop=stop.is_set)
    except (SceneError, TensegrityError) as err:
        raise CliError(str(err)) from None
    if out is not None:
        _write(run, out)
    summary = {"scene": run.scene_name, "success": run.success, "message": run.message,
               "control_period_ns": run.step_ns, "controller": args.controller, "steps": len(run.commands),
               "t_end": float(run.times[-1]),
               "events": _events(run.events),
               "stats": run.stats, "final": {"q": run.q[-1]}, "output": str(out) if out else None}
    if args.json:
        print_json(summary)
    else:
        import numpy as np

        print(f"scene {run.scene_name}: sampled-data run, controller {args.controller} every "
              f"{run.step_ns / 1e9:.9g} s (zero-order hold)")
        print(f"{run.message}: to t = {summary['t_end']:.9g} s")
        _print_events(summary["events"])
        with np.printoptions(precision=6, suppress=True):
            print(f"final q {Q_UNITS.get(scene.model.kind, '')}= {run.q[-1]}")
        if out:
            print(f"trajectory written to {out}")
    return _outcome(run.success, run.message, stop.is_set(), out, None)


def _print_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                   file: object = None, line: str | None = None) -> None:
    print(f"warning: {message}", file=sys.stderr)


def run_simulate(args: argparse.Namespace) -> int:
    import warnings

    from tensegrity_core.errors import TensegrityError
    from tensegrity_core.schema import excerpt
    from tensegrity_core.sim import SceneError, load_scene, simulate
    from tensegrity_core.sim.stiffness_check import StiffnessWarning

    if args.control_period is not None or args.controller is not None:
        return run_sampled_cli(args)

    out = _output_path(args)
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
    bar: Any = None
    if not (args.quiet or args.json):
        from tqdm import tqdm

        bar = tqdm(total=scene.duration, desc=scene.name, unit="s", file=sys.stderr, leave=False,
                   dynamic_ncols=True,
                   bar_format="{l_bar}{bar}| {n:.4g}/{total:.4g} s simulated [{elapsed}<{remaining}{postfix}]")

    def progress(t: float, duration: float) -> None:
        elapsed = bar.format_dict["elapsed"]
        if elapsed > 0:
            bar.set_postfix_str(f"{t / elapsed:.3g} s simulated per s", refresh=False)
        bar.update(t - bar.n)

    try:
        with warnings.catch_warnings(), stop_requests() as stop:
            warnings.simplefilter("always", StiffnessWarning)
            warnings.showwarning = _print_warning     # at once: before the run, not after it
            traj = simulate(scene, progress=progress if bar is not None else None, stop=stop.is_set)
    except TensegrityError as err:
        raise CliError(str(err)) from None
    finally:
        if bar is not None:
            bar.close()
    if out is not None:
        _write(traj, out)
    if args.plot:
        from tensegrity_core.sim.plotting import plot_trajectory

        plot_trajectory(traj, args.plot)
    summary = {
        "scene": traj.scene_name, "success": traj.success, "message": traj.message,
        "model": scene.model.kind, "quasi_static": scene.quasi_static, "effects": list(scene.effects),
        "samples": len(traj), "t_end": float(traj.times[-1]) if len(traj) else 0.0,
        "events": _events(traj.events),
        "stats": traj.stats, "final": {"q": traj.q[-1] if len(traj) else [],
                                       "end_effector": traj.end_effector[-1] if len(traj) else []},
        "output": str(out) if out else None, "plot": args.plot, "violations": traj.violations,
    }
    if args.json:
        print_json(summary)
    else:
        _print_summary(summary)
    for violation in traj.violations:
        print(f"error: invariant violated: {violation}", file=sys.stderr)
    code = _outcome(traj.success, traj.message, stop.is_set(), out, args.plot)
    return code or (1 if traj.violations else 0)


def _outcome(success: bool, message: str, stopped: bool, out: Path | None, plot: str | None) -> int:
    """The exit code of a run, and its last line on stderr when it did not end as planned:
    130 when a stop was asked for (it ends at the next sample, and what was computed is
    written), 1 when it stopped early by itself."""
    if stopped and not success:
        kept = " and ".join(f"{what} {where}" for what, where in (("written to", out), ("plotted in", plot))
                            if where) or "not written (no -o)"
        print(f"{message}: the run up to there is {kept}", file=sys.stderr)
        return 130
    if not success:
        print(f"error: simulation stopped early: {message}", file=sys.stderr)
        return 1
    return 0


@contextlib.contextmanager
def stop_requests() -> Iterator[threading.Event]:
    """Within the block SIGINT (Ctrl-C) and SIGTERM set the returned event, which the run
    checks between samples; a second one raises ``KeyboardInterrupt`` at once."""
    asked = threading.Event()

    def ask(signum: int, frame: FrameType | None) -> None:
        if asked.is_set():
            raise KeyboardInterrupt
        asked.set()

    previous = {sig: signal.signal(sig, ask) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield asked
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _events(events: Iterable[LoggedEvent]) -> list[dict[str, Any]]:
    """Events for people and scripts: time [s], kind and what it is about by name (``rho1``:
    counted from 1, as every name is; ``""`` for kinds about nothing in particular)."""
    from tensegrity_core.events import event_subject

    return [{"t": float(t), "kind": k, "subject": event_subject(k, int(i))} for t, k, i in events]


#: What the printed final coordinates are, per model kind.
Q_UNITS = {"class2": "(rho1 [m], rho2 [m], beta [rad]) ",
           "general": "(free node coordinates and body centres [m], body rotation vectors [rad]) ",
           "robot": "(body centres [m] and rotation vectors [rad], per rod and body) "}


def _print_events(events: list[dict[str, Any]]) -> None:
    for e in events:
        print(f"  event at t = {e['t']:.9g} s: {e['kind']} {e['subject']}".rstrip())


def _print_summary(s: dict[str, Any]) -> None:
    import numpy as np

    kind = "quasi-static" if s["quasi_static"] else "dynamic"
    print(f"scene {s['scene']}: {s['model']}, {kind}; effects: {', '.join(s['effects'])}")
    stats = s["stats"]
    extra = ", ".join(f"{k} {v} s" if k == "step" else f"{k} {v}" for k, v in stats.items() if k not in ("wall_time",))
    print(f"{s['message']}: {s['samples']} samples to t = {s['t_end']:.6g} s in {stats['wall_time']:.3f} s ({extra})")
    _print_events(s["events"])
    with np.printoptions(precision=6, suppress=True):
        print(f"final q {Q_UNITS.get(s['model'], '')}= {np.asarray(s['final']['q'])}")
        print(f"final end effector [m] = {np.asarray(s['final']['end_effector'])}")
    for key, label in (("output", "trajectory"), ("plot", "plot")):
        if s[key]:
            print(f"{label} written to {s[key]}")
