"""Robots in real time (``--only robots``): the 3-bar and the 6-bar at 1 ms fixed steps, one
core, beside MuJoCo on the exported robot in the same run.

Each robot starts as drawn (resting on its drawing's caps) with every effect of the drop
scenes (cables, motors holding their rest lengths, gravity, floor contact, friction,
sensors) and is simulated for ``T`` seconds (quick: 0.3 s, full: 5 s): the project's fixed
RK4 steps of 1 ms (integration only: its stepping, 100 samples per second kept), MuJoCo's
``mj_step`` at the exported model's 1 ms step and integrator. **Real-time factor** =
simulated seconds per wall-clock second, the best of a few runs; the ratio row is the
project's factor over MuJoCo's (target: at least 1, the issue's figures being about 33x for
a 3-bar and 26x for a 6-bar on this machine's kind).

The MuJoCo side needs the robot exporter (``export_mjcf(robot)``); without it, or without
mujoco, its rows are replaced by one row saying why.
"""

from __future__ import annotations

import math

import numpy as np
from threadpoolctl import threadpool_limits

from tests.bench.harness import Context, Row, benchmark, best_run

GROUP = "robots"
ROBOTS = ("three_bar", "six_bar")
EFFECTS = ["inertia", "cables", "motors", "gravity", "contact", "friction", "sensors"]
#: Samples per simulated second the project keeps.
RATE = 100


def _scene(robot: str, duration: float):
    from tensegrity_core.sim import load_scene

    return load_scene({"name": f"{robot}_bench", "model": {"kind": "robot", "robot": robot},
                       "initial": {"drawn": True}, "effects": EFFECTS, "duration": duration})


def project_wall(robot: str, duration: float, repeat: int) -> float:
    """Best wall time [s] of ``duration`` [s] of the robot (integration, samples kept)."""
    from tensegrity_core.sim import compile_scene

    model = compile_scene(_scene(robot, duration))
    times = np.arange(1, int(round(duration * RATE)) + 1) / RATE

    def run() -> None:
        state = model.initial_state(t_end=duration)
        model.record(state, times, [])
    run()                                                       # compile or load the kernels
    return best_run(run, repeat)[0]


def mujoco_wall(robot: str, duration: float, repeat: int) -> tuple[float, str]:
    """Best wall time [s] of ``duration`` [s] of MuJoCo's steps on the exported robot, and a note."""
    import mujoco

    from tensegrity_core.export import export_mjcf
    from tensegrity_core.robot.loading import load_robot

    exported = export_mjcf(load_robot(robot), timestep=1e-3)
    model = mujoco.MjModel.from_xml_string(exported.xml)
    data = mujoco.MjData(model)
    steps = int(round(duration / model.opt.timestep))

    def run() -> None:
        mujoco.mj_resetData(model, data)
        for _ in range(steps):
            mujoco.mj_step(model, data)
    run()
    return best_run(run, repeat)[0], f"{exported.integrator} at {model.opt.timestep * 1e3:g} ms, nq {model.nq}"


def _mujoco_missing() -> str:
    try:
        import mujoco  # noqa: F401

        from tensegrity_core.export import export_mjcf
        from tensegrity_core.robot.loading import load_robot
        export_mjcf(load_robot("three_bar"), timestep=1e-3)
    except Exception as err:            # no mujoco, or no robot exporter yet: say which
        return f"MuJoCo side not run: {type(err).__name__}: {err}"
    return ""


@benchmark
def real_time(ctx: Context) -> list[Row]:
    duration = 0.3 if ctx.quick else 5.0
    repeat = 2 if ctx.quick else 5
    missing = _mujoco_missing()
    rows: list[Row] = []
    data = {}
    with threadpool_limits(1):
        for robot in ROBOTS:
            wall = project_wall(robot, duration, repeat)
            rtf = duration / wall
            rows.append(Row(GROUP, f"{robot}: project RK4 1 ms", rtf, "x real time",
                            note=f"{duration:g} s simulated in {wall:.3g} s"))
            data[robot] = {"project_rtf": rtf}
            if missing:
                continue
            wall_m, note = mujoco_wall(robot, duration, repeat)
            rtf_m = duration / wall_m
            rows.append(Row(GROUP, f"{robot}: MuJoCo", rtf_m, "x real time", note=note))
            rows.append(Row(GROUP, f"{robot}: project / MuJoCo real-time factor", rtf / rtf_m, "ratio",
                            target=">= 1"))
            data[robot]["mujoco_rtf"] = rtf_m
    if missing:
        rows.append(Row(GROUP, "MuJoCo side", math.nan, "", note=missing))
    ctx.save_json("robots_real_time.json", {"duration_s": duration, "robots": data})
    return rows
