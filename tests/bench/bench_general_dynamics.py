"""General dynamics at MuJoCo's speed (``--only general_dynamics``): the same structures in
both simulators, at matched accuracy, in one run.

One BLAS thread throughout. Structures (the issue's table): two stacked 3-prisms under a
step load (1 s), the 6-bar icosahedron falling and spinning with its strings going slack
and taut (0.5 s), ``table_gravity`` (0.2 s), ``spine_release`` (2 s) and two rigid bodies
spinning on strings (1.5 s). MuJoCo runs the model ``tensegrity export mjcf`` writes, from
the same initial state (``tests/mujoco_peer.py``).

- ``evaluations``: the right-hand side and the Jacobian per evaluation, compiled kernels
  (numba) against the numpy kernels, timed in turn (rounds of both), so that a change of
  the machine's load touches both sides of the ratio.
- ``versus_mujoco``: **error** = the largest node-position difference over the samples
  (200 per second) from a converged run of the *same* simulator, over the motion (the
  largest node displacement from the start): the project's converged run is DOP853 at
  rtol 1e-12; MuJoCo's error at a step is its difference to its run at a quarter of that
  step (RK4: 256 times more accurate). The project runs its default (DOP853 rtol 1e-7,
  compiled); MuJoCo runs RK4 at the exported step times 4, 2, 1, 1/2, ... and the
  **coarsest step at least as accurate** is timed against it (integration only: the
  project's stepping and sampling, MuJoCo's ``mj_step``). Also the project's RK4 at that
  same step (the same method and step in both), and the spine's real-time factor over wall
  seconds and over the process's CPU seconds (what one core does, whatever the load).
- ``growth``: prism towers of 9 .. 1,998 members, fixed-step RK4 at the exported step in
  both: time per simulated second against members, the growth exponent above 100 members,
  and the numpy kernels at the same sizes (the fallback's ratio), with the floor of a
  pure-numpy step of the smallest tower (its fewest numpy calls, each timed alone); and the
  fallback's ratio with moving bodies, on generated spines of 9 .. 576 rigid vertebrae.
- ``compile_cache``: numba's cost in a fresh process: compiling every kernel into an empty
  cache, then loading them from it.

Quick mode (CI's smoke run: every row reported, no speed proven): one round of
``evaluations``; the prisms and the table against MuJoCo, 1/20 of their durations, steps of 1
and 1/2 the exported one; towers of 9, 198 and 999 members (two above 100 for the growth
exponent; MuJoCo on none) and spines of 9 and 36 vertebrae, 5 ms each, one timed run of each
kernel, the numpy floor's calls timed over 1,000 calls a loop; the cache's loading alone.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass

import numpy as np
from threadpoolctl import threadpool_limits

from tests.bench.harness import Context, Row, benchmark, best_run, no_gc, time_per_call

GROUP = "general_dynamics"
#: The project's default: compiled DOP853 at this rtol (atol = rtol / 100).
DEFAULT_RTOL = 1e-7
#: Samples per simulated second (both sides).
RATE = 200.0
#: The structures quick mode (CI's smoke run) compares with MuJoCo.
QUICK_CASES = ("two stacked 3-prisms", "table_gravity")
#: [s] Quick mode's least time per kernel in ``growth``: one timed run each (after the first).
QUICK_MIN_TIME = 1e-9

BODIES = {
    "name": "two spinning bodies",
    "nodes": {"p1": [0, 0, 0], "p2": [1, 0, 0], "p3": [0, 1, 0],
              "q1": [0.2, 0.1, 1], "q2": [1.1, 0.3, 1.2], "q3": [0.1, 1.2, 0.9], "n": [0.5, 0.5, 2.0]},
    "members": [{"nodes": ["p1", "q1"], "EA": 500.0, "rest_length_ratio": 0.8},
                {"nodes": ["p2", "q2"], "EA": 600.0, "rest_length_ratio": 0.7},
                {"nodes": ["p3", "q3"], "EA": 400.0, "rest_length_ratio": 0.9},
                {"nodes": ["p1", "q3"], "type": "bar", "EA": 800.0},
                {"nodes": ["q2", "n"], "EA": 300.0, "rest_length_ratio": 0.9},
                {"nodes": ["p3", "n"], "EA": 300.0, "rest_length_ratio": 0.9}],
    "rigid_bodies": [{"name": "low", "nodes": ["p1", "p2", "p3"], "mass": 1.5},
                     {"name": "high", "nodes": ["q1", "q2", "q3"], "mass": 2.0}],
    "masses": {"n": 0.3, "q2": 0.4},
}


def _icosahedron() -> dict:
    """The 6-bar tensegrity icosahedron (expanded octahedron: bar pairs along x, y, z, 0.5 m
    apart, 2 m long), strings 0.5 % shorter than drawn, 0.1 kg per node, no supports."""
    L, d = 2.0, 0.5
    nodes = {}
    for axis in range(3):
        for side, offset in (("p", d / 2), ("m", -d / 2)):
            for end, s in (("a", 1.0), ("b", -1.0)):
                xyz = [0.0, 0.0, 0.0]
                xyz[axis] = s * L / 2
                xyz[(axis + 1) % 3] = offset
                nodes[f"{'xyz'[axis]}{side}{end}"] = xyz
    names = list(nodes)
    X = np.array([nodes[k] for k in names])
    members = [{"nodes": [names[i], names[i + 1]], "type": "bar", "EA": 5e4} for i in range(0, 12, 2)]
    D = np.linalg.norm(X[:, None] - X[None], axis=2)
    bars = {(i, i + 1) for i in range(0, 12, 2)}
    for i in range(12):
        for j in range(i + 1, 12):
            if (i, j) not in bars and D[i, j] < 1.4:
                members.append({"nodes": [names[i], names[j]], "EA": 5e3, "rest_length_ratio": 0.995})
    return {"name": "icosahedron", "nodes": nodes, "members": members, "masses": {k: 0.1 for k in names}}


def _prisms() -> dict:
    from tensegrity_core.general import prism_tower
    from tensegrity_core.general.writing import structure_to_dict

    s = prism_tower(2, sides=3, EA=2e4)
    return structure_to_dict(s.replace(node_masses=np.full(s.n_nodes, 0.2)))


@dataclass
class Case:
    name: str
    scene: object              # tensegrity_core.sim.Scene
    y0: np.ndarray | None      # a start other than the scene's initial state
    stride: float = 1.0 / RATE  # [s] between samples (a whole number of every step tried)


def _general(name: str, structure: dict, effects: list, duration: float, initial: dict | None = None):
    from tensegrity_core.sim import scene_from_dict

    return scene_from_dict({"name": name, "model": {"kind": "general", "structure": structure},
                            "initial": initial or {"drawn": True}, "effects": effects, "duration": duration,
                            "output": {"rate": RATE},
                            "integrator": {"method": "DOP853", "rtol": DEFAULT_RTOL, "atol": DEFAULT_RTOL / 100}})


def _spun(scene, omega, drift, seed: int | None = None) -> np.ndarray:
    """The scene's initial state with every node moving as a rigid spin ``omega`` [rad/s]
    about the centroid plus ``drift`` [m/s] (bodies: the same field), or random rates."""
    from tensegrity_core.sim import compile_scene

    model = compile_scene(scene)
    y = model.initial_state().y.copy()
    n = len(y) // 2
    if seed is not None:
        y[n:] = np.random.default_rng(seed).normal(0.0, 1.5, n)
        return y
    lay = scene.model.structure.layout
    X = scene.model.structure.nodes
    c = X.mean(axis=0)
    vel = np.asarray(drift) + np.cross(omega, X - c)
    free = lay.free_index >= 0
    y[n + lay.free_index[free]] = vel[free]
    for b, d in enumerate(lay.body_dof):
        y[n + d:n + d + 3] = np.asarray(drift) + np.cross(omega, lay.ref_centres[b] - c)
        y[n + d + 3:n + d + 6] = omega
    return y


def cases(quick: bool) -> list[Case]:
    from tensegrity_core.sim import load_scene

    k = 0.05 if quick else 1.0
    gravity = {"gravity": {"vector": [0.0, 0.0, -9.81]}}
    out = []
    prisms = _general("two stacked 3-prisms", _prisms(), ["inertia", "springs", gravity,
                                                          {"loads": {"6": [20.0, 0.0, 0.0]}}],
                      1.0 * k, initial={"equilibrium": True})
    out.append(Case("two stacked 3-prisms", prisms, None))
    ico = _general("6-bar icosahedron", _icosahedron(), ["inertia", "springs", gravity], 0.5 * k)
    out.append(Case("6-bar icosahedron falling", ico, _spun(ico, [1.0, 2.0, 3.0], [0.0, 0.0, -1.0])))
    for name, duration in (("table_gravity", 0.2), ("spine_release", 2.0)):
        out.append(Case(name, load_scene(name).with_duration(duration * k), None))
    spin = _general("two spinning bodies", BODIES, ["inertia", "springs"], 1.5 * k)
    out.append(Case("two spinning bodies", spin, _spun(spin, None, None, seed=1)))
    return out


def _with_integrator(scene, **integrator):
    import dataclasses

    return dataclasses.replace(scene, integrator=dataclasses.replace(scene.integrator, **integrator))


def _times(case: Case) -> np.ndarray:
    return case.stride * np.arange(math.floor(case.scene.duration / case.stride * (1 + 1e-9)) + 1)


def project_run(case: Case, *, min_time: float = 0.0, **integrator) -> tuple[float, np.ndarray, dict]:
    """(integration wall time [s], node positions (N, n, 3), stats) of the project; the stats
    with ``cpu_seconds``, the least CPU time of this process over the runs [s], which go on
    for at least ``min_time`` [s]."""
    run, cpu, model = _project_runner(case, **integrator)
    wall, (state, samples) = best_run(run, 2 if case.scene.duration < 0.1 else 3, min_time, max_time=5.0)  # the first: numba loads
    nodes = model.observe(samples)["nodes"]
    return wall, nodes, dict(model.stats(state), cpu_seconds=cpu[0])


def _project_runner(case: Case, **integrator):
    """``(run, cpu, model)``: ``run()`` integrates ``case`` with the project (its model
    compiled here, under this moment's kernel choice) and returns ``(state, samples)``;
    ``cpu[0]`` the least CPU time of this process over the runs so far [s]."""
    from tensegrity_core.sim import compile_scene

    scene = _with_integrator(case.scene, **integrator)
    model = compile_scene(scene)
    times = _times(case)
    cpu = [math.inf]

    def run():
        state = model.initial_state(t_end=scene.duration) if case.y0 is None else \
            model.state_from(case.y0, t_end=scene.duration)
        samples: list = []
        started = time.process_time()
        model.record(state, times, samples)
        cpu[0] = min(cpu[0], time.process_time() - started)
        return state, samples

    return run, cpu, model


def mujoco_run(case: Case, xml: str, dt: float) -> tuple[float, np.ndarray, int]:
    """(wall time of mj_step [s], node positions (N, n, 3), steps) of MuJoCo's RK4 at ``dt``."""
    from tensegrity_core.sim.general.setup import initial_configuration
    from tests.mujoco_peer import MujocoPeer, mujoco_state

    peer = MujocoPeer(xml, timestep=dt, integrator="RK4")
    structure = case.scene.model.structure
    times = _times(case)
    best, run = math.inf, None
    for _ in range(1 if case.scene.duration < 0.1 else 3):
        if case.y0 is None:
            peer.reset()
        else:
            peer.reset(*mujoco_state(peer, structure, case.y0, initial_configuration(case.scene).rotations))
        run = peer.rollout(times, nodes=structure.node_names)
        best = min(best, run.wall)
        if run.wall > 5.0:
            break
    return best, run.nodes, run.steps


def error(nodes: np.ndarray, reference: np.ndarray) -> float:
    """Largest node-position difference over the motion (the reference's largest displacement)."""
    if not np.all(np.isfinite(nodes)):
        return math.inf
    motion = np.abs(reference - reference[0]).max()
    return float(np.abs(nodes - reference).max() / motion)


def _warm() -> None:
    """Compile or load the numba kernels before anything is timed (``./run setup`` has
    usually compiled them already)."""
    from tensegrity_core.sim.general.kernels.jit import have_numba
    from tensegrity_core.sim.general.kernels.warm import warm

    if have_numba():
        warm()


def _mujoco_available() -> str:
    try:
        import mujoco  # noqa: F401

        from tensegrity_core.export import export_mjcf  # noqa: F401
        from tests.mujoco_peer import MujocoPeer  # noqa: F401
    except ImportError as err:
        return f"MuJoCo side not run: {err}"
    return ""


#: Rounds of ``evaluations``: each times both kernels (best of two each), the best round counts.
ROUNDS = 3


@benchmark
def evaluations(ctx: Context) -> list[Row]:
    from tensegrity_core.sim import compile_scene
    from tensegrity_core.sim.general.kernels.evaluator import Evaluator

    rows = []
    _warm()
    with threadpool_limits(1):
        for case in cases(True):
            model = compile_scene(case.scene)
            eq = model.equations(model.initial_state())
            y = model.initial_state().y if case.y0 is None else case.y0
            l0 = eq.rest_lengths(0.0)
            label = case.name
            evaluators = {kind: Evaluator(eq.plan, kind) for kind in ("numpy", "numba")}
            best = {(kind, part): math.inf for kind in evaluators for part in ("rhs", "jac")}
            for _ in range(1 if ctx.quick else ROUNDS):   # the two kernels in turn: a load change touches both
                for kind, ev in evaluators.items():
                    for part, fn in (("rhs", ev.derivative), ("jac", ev.jacobian)):
                        fn(y, eq.R_ref, l0)
                        seconds = time_per_call(lambda fn=fn, y=y, R=eq.R_ref, l0=l0: fn(y, R, l0), repeat=2)
                        best[kind, part] = min(best[kind, part], seconds)
            for kind, ev in evaluators.items():
                rhs, jac = best[kind, "rhs"], best[kind, "jac"]
                rows.append(Row(GROUP, f"{label}: rhs, {kind}", rhs * 1e6, "us",
                                baseline=None if kind == "numpy" else f"{label}: rhs, numpy",
                                note=f"{eq.n} DOF, {eq.structure.n_members} members, {eq.nb} bodies"))
                rows.append(Row(GROUP, f"{label}: Jacobian, {kind}", jac * 1e6, "us",
                                baseline=None if kind == "numpy" else f"{label}: Jacobian, numpy",
                                note=f"{ev.jacobian(y, eq.R_ref, l0).nnz} stored entries"))
    return rows


@benchmark
def versus_mujoco(ctx: Context) -> list[Row]:
    missing = _mujoco_available()
    rows: list[Row] = []
    study = []
    _warm()
    with threadpool_limits(1):
        for case in cases(ctx.quick):
            if ctx.quick and case.name not in QUICK_CASES:
                continue
            label = case.name
            factors = (1, 0.5) if ctx.quick else (4, 2, 1, 0.5, 0.25, 0.125, 0.0625)
            if not missing:
                from tensegrity_core.export import export_mjcf

                exported = export_mjcf(case.scene)
                dt0 = exported.timestep
                coarse = dt0 * factors[0]              # samples at whole numbers of every step
                case.stride = coarse * max(1, round(1.0 / RATE / coarse))
            _, reference, _ = project_run(case, method="DOP853", rtol=1e-12, atol=1e-14)
            wall_p, nodes_p, stats = project_run(case, method="DOP853", rtol=DEFAULT_RTOL, atol=DEFAULT_RTOL / 100)
            err_p = error(nodes_p, reference)
            cpu_p = stats.pop("cpu_seconds")
            T = case.scene.duration
            rows.append(Row(GROUP, f"{label}: project DOP853 rtol {DEFAULT_RTOL:g}", wall_p, "s",
                            note=f"{T:g} s simulated, error {err_p:.1e} of the motion, {stats['steps']} steps, "
                                 f"{stats['nfev'] / wall_p:.3g} evaluations/s, {T / wall_p:.3g}x real time"))
            entry = {"case": label, "duration": T, "samples": len(nodes_p), "project_seconds": wall_p,
                     "project_cpu_seconds": cpu_p, "project_error": err_p,
                     "project_steps": stats["steps"], "project_nfev": stats["nfev"]}
            if missing:
                study.append(entry)
                continue
            runs: dict[float, tuple[float, np.ndarray, int]] = {}
            for f in factors + (factors[-1] / 2, factors[-1] / 4):
                runs[f] = (math.nan, np.empty(0), 0)             # run on demand below
            matched = None
            ladder = []
            for f in factors:
                spent = [r[0] for r in runs.values() if r[2]]
                if spent and max(spent) > (5.0 if ctx.quick else 60.0):
                    break                                   # finer steps would take too long
                for g in (f, f / 4):
                    if not runs[g][2]:
                        runs[g] = mujoco_run(case, exported.xml, dt0 * g)
                wall_m, nodes_m, steps = runs[f]
                err_m = error(nodes_m, runs[f / 4][1])
                ladder.append((dt0 * f, err_m, wall_m, steps))
                if err_m <= err_p:
                    matched = (dt0 * f, err_m, wall_m, steps)
                    break
            entry["mujoco_ladder"] = ladder
            if matched is None:
                rows.append(Row(GROUP, f"{label}: MuJoCo at matched accuracy", math.nan, "s",
                                note=f"no step down to {dt0 * factors[-1]:.3g} s reached {err_p:.1e}"))
                study.append(entry)
                continue
            dt, err_m, wall_m, steps = matched
            entry.update(mujoco_step=dt, mujoco_error=err_m, mujoco_seconds=wall_m, mujoco_steps=steps)
            rows.append(Row(GROUP, f"{label}: MuJoCo RK4 at matched accuracy", wall_m, "s",
                            note=f"step {dt:.3g} s (exported {dt0:.3g} s), error {err_m:.1e}, "
                                 f"{steps / wall_m:.3g} steps/s"))
            rows.append(Row(GROUP, f"{label}: project vs MuJoCo", wall_p, "s",
                            baseline=f"{label}: MuJoCo RK4 at matched accuracy", target=">= 1x (MuJoCo / project)"))
            wall_r, nodes_r, stats_r = project_run(case, method="RK4", max_step=dt)
            entry.update(project_rk4_seconds=wall_r, project_rk4_error=error(nodes_r, reference))
            rows.append(Row(GROUP, f"{label}: project RK4 at MuJoCo's step", wall_r, "s",
                            baseline=f"{label}: MuJoCo RK4 at matched accuracy",
                            note=f"error {entry['project_rk4_error']:.1e}, "
                                 f"{stats_r['steps'] / wall_r:.3g} steps/s"))
            study.append(entry)
    spine = [e for e in study if e["case"] == "spine_release"]
    if spine:
        rows.append(Row(GROUP, "spine_release: real-time factor", spine[0]["duration"] / spine[0]["project_seconds"],
                        "x", target=">= 10", note="simulated over wall seconds, DOP853 rtol 1e-7, 200 Hz output"))
        rows.append(Row(GROUP, "spine_release: real-time factor per CPU second",
                        spine[0]["duration"] / spine[0]["project_cpu_seconds"], "x", target=">= 10",
                        note="simulated over the process's CPU seconds (the same run: what one core does, "
                             "whatever else the machine runs)"))
    if missing:
        rows.append(Row(GROUP, "MuJoCo side", math.nan, "", note=missing))
    ctx.save_json("general_dynamics_mujoco.json", study)
    _plot_versus(ctx, study)
    return rows


def _plot_versus(ctx: Context, study: list[dict]) -> None:
    path = ctx.plot_path("general_dynamics_mujoco.png")
    if path is None or not study:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 4.5), constrained_layout=True)
    x = np.arange(len(study))
    ax.bar(x - 0.2, [e["project_seconds"] for e in study], 0.38, label="project, DOP853 rtol 1e-7 (compiled)")
    ax.bar(x + 0.2, [e.get("mujoco_seconds", np.nan) for e in study], 0.38,
           label="MuJoCo RK4, coarsest step at least as accurate")
    for k, e in enumerate(study):
        ax.annotate(f"{e['project_error']:.0e}", (k - 0.2, e["project_seconds"]), ha="center", va="bottom", fontsize=7)
    ax.set_xticks(x, [f"{e['case']}\n{e['duration']:g} s" for e in study], fontsize=8)
    ax.set_yscale("log")
    ax.set(ylabel="integration wall time [s]",
           title="same structures, matched accuracy (labels: project's error / motion)")
    ax.grid(True, axis="y", which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _tower_scene(stages: int, duration: float):
    from tensegrity_core.general import prism_tower
    from tensegrity_core.general.writing import structure_to_dict

    s = prism_tower(stages, sides=3, EA=2e4)
    s = s.replace(node_masses=np.full(s.n_nodes, 0.1))
    top = s.node_names[-1]
    return _general(f"tower of {s.n_members} members", structure_to_dict(s),
                    ["inertia", "springs", {"loads": {top: [5.0, 0.0, 0.0]}}], duration)


#: [s] RK4's step on the generated spines: the exported model's (MuJoCo's default) for 9 and
#: 36 vertebrae, the same for every length (the vertebrae and cords are the same); fixed
#: because the exporter's linearisation takes minutes on the longest.
SPINE_STEP = 2e-5


def _spine_scene(vertebrae: int, duration: float):
    """``tensegrity_spine(vertebrae)`` (straight, cords of EA 500 N at 0.9 of their drawn
    lengths, vertebrae of 0.05 kg, the lowest fixed, damping beta 1e-3 s) released from its
    drawing: every cord stays taut (no event), every vertebra moves."""
    import dataclasses

    from tensegrity_core.general import tensegrity_spine
    from tensegrity_core.general.writing import structure_to_dict

    s = tensegrity_spine(vertebrae, EA=500.0)
    s = s.replace(bodies=tuple(dataclasses.replace(b, mass=0.05) for b in s.bodies))
    return _general(f"spine of {vertebrae} vertebrae", structure_to_dict(s),
                    ["inertia", "springs", {"damping": {"beta": 1e-3}}], duration)


def _both_kernels(scene, step: float, min_time: float) -> dict:
    """Per simulated second of fixed-step RK4 at ``step`` [s]: wall and CPU time [s/s] with
    the compiled kernels (``numba``, ``numba_cpu``) and the numpy kernels (``numpy``, ``numpy_cpu``),
    the least of runs of each, alternating, for at least ``min_time`` [s] each (runs of a few
    ms on small structures: a moment of load, or the machine's pace changing, falls on both
    kernels rather than on the one timed then)."""
    stride = step * max(1, round(min(0.005, scene.duration) / step))          # samples every 5 ms
    runners = {}
    for kernels in ("numba", "numpy"):
        os.environ["TENSEGRITY_KERNELS"] = kernels
        try:
            runners[kernels] = _project_runner(Case("growth", scene, None, stride=stride), method="RK4",
                                               max_step=step)
        finally:
            os.environ.pop("TENSEGRITY_KERNELS", None)
    for run, _, _ in runners.values():
        run()                                                                 # the first: numba loads
    wall = dict.fromkeys(runners, math.inf)
    spent = dict.fromkeys(runners, 0.0)
    with no_gc():
        while min(spent.values()) < min_time:
            for kernels, (run, _, _) in runners.items():
                started = time.perf_counter()
                run()
                took = time.perf_counter() - started
                wall[kernels], spent[kernels] = min(wall[kernels], took), spent[kernels] + took
    entry = {}
    for kernels, (_, cpu, _) in runners.items():
        entry[kernels] = wall[kernels] / scene.duration
        entry[f"{kernels}_cpu"] = cpu[0] / scene.duration
    return entry


@benchmark
def growth(ctx: Context) -> list[Row]:
    """Fixed-step RK4 at the exported step on prism towers: time per simulated second."""
    missing = _mujoco_available()
    stages = (1, 22, 111) if ctx.quick else (1, 2, 5, 11, 22, 56, 111, 222)
    duration = 0.005 if ctx.quick else 0.05
    rows, data = [], []
    _warm()
    with threadpool_limits(1):
        for k in stages:
            scene = _tower_scene(k, duration)
            members = scene.model.structure.n_members
            dt = _tower_step(scene)
            entry = {"members": members, "step": dt}
            entry.update(_both_kernels(scene, dt, QUICK_MIN_TIME if ctx.quick else 0.5))
            if not missing and (members >= 1998 or not ctx.quick):
                from tensegrity_core.export import export_mjcf

                wall, _, _ = mujoco_run(Case("tower", scene, None, stride=dt * max(1, round(0.005 / dt))),
                                        export_mjcf(scene).xml, dt)
                entry["mujoco"] = wall / duration
            data.append(entry)
        spines = []
        for vertebrae in (9, 36) if ctx.quick else (9, 36, 144, 576):
            scene = _spine_scene(vertebrae, 0.005 if ctx.quick else 0.02)
            entry = {"vertebrae": vertebrae, "members": scene.model.structure.n_members, "step": SPINE_STEP}
            entry.update(_both_kernels(scene, SPINE_STEP, QUICK_MIN_TIME if ctx.quick else 0.5))
            spines.append(entry)
    m = np.array([e["members"] for e in data], dtype=float)
    for kernels in ("numba", "numpy", "mujoco"):
        t = np.array([e.get(kernels, np.nan) for e in data])
        use = (m >= 100) & np.isfinite(t)
        if use.sum() >= 2:
            slope = float(np.polyfit(np.log(m[use]), np.log(t[use]), 1)[0])
            rows.append(Row(GROUP, f"towers: growth exponent, {kernels}", slope, "", target="report" if
                            kernels != "numba" else "~1",
                            note=f"time per simulated second ~ members^p over {int(m[use][0])}..{int(m[use][-1])}"))
    last = data[-1]
    rows.append(Row(GROUP, f"tower {last['members']} members: project RK4 (numba)", last["numba"], "s/s",
                    note=f"step {last['step']:.3g} s, per simulated second"))
    rows.append(Row(GROUP, f"tower {last['members']} members: numpy kernels", last["numpy"], "s/s",
                    baseline=f"tower {last['members']} members: project RK4 (numba)"))
    for e in data:                     # the fallback's ratio at every size
        rows.append(Row(GROUP, f"tower {e['members']} members: project RK4 (numba), CPU", e["numba_cpu"], "s/s",
                        note="CPU seconds of the process per simulated second (steadier than wall under load)"))
        rows.append(Row(GROUP, f"tower {e['members']} members: numpy kernels, CPU", e["numpy_cpu"], "s/s",
                        baseline=f"tower {e['members']} members: project RK4 (numba), CPU",
                        target="ratio >= 0.333 (fallback within 3x: compiled / numpy)"))
    first = data[0]
    rows += _numpy_floor(_tower_scene(stages[0], duration), first, 1_000 if ctx.quick else 50_000)
    rows.append(Row(GROUP, f"tower {first['members']} members: project RK4 (numba)", first["numba"], "s/s"))
    rows.append(Row(GROUP, f"tower {first['members']} members: numpy kernels", first["numpy"], "s/s",
                    baseline=f"tower {first['members']} members: project RK4 (numba)"))
    if "mujoco" in last:
        rows.append(Row(GROUP, f"tower {last['members']} members: MuJoCo RK4", last["mujoco"], "s/s",
                        note="same step"))
        rows.append(Row(GROUP, f"tower {last['members']} members: project vs MuJoCo", last["numba"], "s/s",
                        baseline=f"tower {last['members']} members: MuJoCo RK4", target=">= 1x (MuJoCo / project)"))
    for e in spines:                   # with moving bodies
        label = f"spine of {e['vertebrae']} vertebrae"
        rows.append(Row(GROUP, f"{label}: project RK4 (numba), CPU", e["numba_cpu"], "s/s",
                        note=f"{e['members']} members, {e['vertebrae'] - 1} moving bodies, step {e['step']:g} s; "
                             "CPU seconds per simulated second"))
        rows.append(Row(GROUP, f"{label}: numpy kernels, CPU", e["numpy_cpu"], "s/s",
                        baseline=f"{label}: project RK4 (numba), CPU",
                        target="ratio >= 0.333 (fallback within 3x: compiled / numpy)"))
    ctx.save_json("general_dynamics_growth.json", {"towers": data, "spines": spines})
    _plot_growth(ctx, data, spines)
    return rows


def _cpu_per_call(fn, n: int) -> float:
    """The least CPU time of one call of ``fn()`` [s] over three loops of ``n`` calls."""
    best = math.inf
    for _ in range(3):
        started = time.process_time()
        for _ in range(n):
            fn()
        best = min(best, (time.process_time() - started) / n)
    return best


def _numpy_floor(scene, first: dict, calls_per_loop: int) -> list[Row]:
    """The floor of a pure-numpy RK4 step of the smallest tower (docs/design/performance.md):
    the fewest numpy calls a step needs -- per evaluation the member vectors (one product),
    the lengths (no numpy call returns a row's norm in one call: the squared components, their
    sums by a product, the roots), the unit vectors (one division), the rates (one product); per stage its state
    (one product) -- each timed alone on the flat stages' own arrays in CPU time, outputs passed
    as the flat stages pass them, no Python between them and no event screen; against the
    compiled step and the numpy step measured in the same run (each call timed over
    ``calls_per_loop`` calls, the least of three loops). Also the calls of the event screen
    at a step's end (the signed gaps, the rates and their opposites, one reduction; the
    velocity differences come with the member vectors of the step's last evaluation), timed
    the same way: what a numpy step spends above the floor beyond them is Python."""
    from tensegrity_core.sim import compile_scene
    from tensegrity_core.sim.general.kernels.flat_stages import DOT, SUMS, FlatStages

    os.environ["TENSEGRITY_KERNELS"] = "numpy"
    try:
        model = compile_scene(scene)
        state = model.initial_state()
        system = model.equations(state).resume(state.t, state.y).system
    finally:
        os.environ.pop("TENSEGRITY_KERNELS", None)
    flat = system.stages
    assert isinstance(flat, FlatStages) and flat.dense
    flat.rk4(0.0, state.y, system.fun(0.0, state.y), first["step"])      # fills the buffers
    C, P, H, l, U, R, tail = flat._C, flat._positions, flat.h, flat.lengths, flat.u, flat._R, flat._tail
    Z, out, weights, state_row = flat._Z[0], flat._shaped(np.empty(len(state.y))), flat._weights[3], flat._state
    squares, L = np.empty(H.shape), np.empty(H.shape)
    assert flat._identity                  # the rate product carries v: one call
    rates_out = out[0]
    calls = {"member vectors (np.dot)": lambda: DOT(C, P, H),
             "squared components (np.multiply)": lambda: np.multiply(H, H, squares),
             "squared lengths (np.dot)": lambda: DOT(squares, SUMS, L),
             "lengths (np.sqrt)": lambda: np.sqrt(L, L),
             "unit vectors (np.divide)": lambda: np.divide(H, L, U),
             "rates (np.dot)": lambda: DOT(R, tail, rates_out),
             "stage state (np.dot)": lambda: DOT(weights, Z, state_row)}
    cost = {name: _cpu_per_call(fn, calls_per_loop) for name, fn in calls.items()}
    floor = 4 * sum(cost.values())
    E, sign, l0 = np.empty((3, len(l))), np.ones(len(l)), l.copy()
    gap, rate, opposite = E
    dv, products, ones = flat.dv, np.empty(H.shape), np.ones(3)
    screen = {"gaps (np.subtract)": lambda: np.subtract(l, l0, gap),
              "signed gaps (np.multiply)": lambda: np.multiply(gap, sign, gap),
              "rates' terms (np.multiply)": lambda: np.multiply(dv, U, products),
              "rates (np.dot)": lambda: DOT(products, ones, rate),
              "their opposites (np.negative)": lambda: np.negative(rate, opposite),
              "least of each (np.minimum.reduce, tolist)": lambda: np.minimum.reduce(E, 1, initial=np.inf).tolist()}
    screen_cost = {name: _cpu_per_call(fn, calls_per_loop) for name, fn in screen.items()}
    compiled = first["numba_cpu"] * first["step"]          # CPU seconds per step
    plain = first["numpy_cpu"] * first["step"]
    members = first["members"]
    first.update(floor=floor, calls=cost)
    rows = [Row(GROUP, f"tower {members} members: numpy call, {name}, CPU", c * 1e6, "us") for name, c in cost.items()]
    rows.append(Row(GROUP, f"tower {members} members: floor of a numpy RK4 step, CPU", floor * 1e6, "us",
                    note=f"4 x the {len(cost)} calls above; compiled step {compiled * 1e6:.2f} us, "
                         f"numpy step {plain * 1e6:.1f} us (CPU, same run)"))
    rows.append(Row(GROUP, f"tower {members} members: floor of a numpy step / compiled step", floor / compiled, "x",
                    target="report", note="what no pure-numpy RK4 step of this structure can beat"))
    rows += [Row(GROUP, f"tower {members} members: numpy screen call, {name}, CPU", c * 1e6, "us")
             for name, c in screen_cost.items()]
    screened = sum(screen_cost.values())
    rows.append(Row(GROUP, f"tower {members} members: numpy step above its floor and screen, CPU",
                    (plain - floor - screened) * 1e6, "us",
                    note=f"numpy step {plain * 1e6:.1f} us - floor {floor * 1e6:.1f} us - screen {screened * 1e6:.1f} us: "
                         "Python between the calls, and the run's own costs"))
    return rows


def _tower_step(scene) -> float:
    """The exported model's step (MuJoCo's default) or, without the exporter, 0.2 over the
    fastest rate of the linearised motion, as the exporter chooses it."""
    try:
        from tensegrity_core.export import export_mjcf

        return float(export_mjcf(scene).timestep)
    except ImportError:
        from tensegrity_core.sim import compile_scene

        model = compile_scene(scene)
        eq = model.equations(model.initial_state())
        rate = float(np.abs(np.linalg.eigvals(eq.jac(0.0, model.initial_state().y).toarray())).max())
        return 0.2 / rate


def _plot_growth(ctx: Context, data: list[dict], spines: list[dict]) -> None:
    path = ctx.plot_path("general_dynamics_growth.png")
    if path is None:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ratio) = plt.subplots(1, 2, figsize=(11, 6.0), constrained_layout=True)
    m = [e["members"] for e in data]
    for key, label, marker in (("numba", "project RK4, compiled kernels", "o"),
                               ("numpy", "project RK4, numpy kernels", "s"),
                               ("mujoco", "MuJoCo RK4", "^")):
        pts = [(mm, e[key]) for mm, e in zip(m, data) if key in e]
        if pts:
            ax.loglog(*zip(*pts), marker=marker, label=label)
    ax.set(xlabel="members", ylabel="wall time per simulated second [s/s]",
           title="prism towers, fixed-step RK4 at the exported step")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ratio.loglog(m, [e["numpy"] / e["numba"] for e in data], marker="s", label="numpy / compiled, wall time")
    ratio.loglog(m, [e["numpy_cpu"] / e["numba_cpu"] for e in data], marker="D",
                   label="numpy / compiled, CPU time of the process")
    floors = [(e["members"], e["floor"] / (e["numba_cpu"] * e["step"])) for e in data if "floor" in e]
    if floors:
        ratio.loglog(*zip(*floors), marker="*", markersize=12, linestyle="none",
                     label="floor: the fewest numpy calls of a step / compiled, CPU time")
    if spines:
        ratio.loglog([e["members"] for e in spines], [e["numpy_cpu"] / e["numba_cpu"] for e in spines], marker="v",
                     label=f"spines of {spines[0]['vertebrae']} .. {spines[-1]['vertebrae']} rigid vertebrae "
                           "(moving bodies; labels: vertebrae), CPU time")
        for e in spines:
            ratio.annotate(f"{e['vertebrae']}", (e["members"], e["numpy_cpu"] / e["numba_cpu"]),
                           textcoords="offset points", xytext=(4, 4), fontsize=7)
    ratio.axhline(3.0, color="k", linestyle="--", label="target: within 3x")
    ratio.set(xlabel="members", ylabel="time ratio [-]", title="the numpy fallback against the compiled path")
    ratio.grid(True, which="both", alpha=0.3)
    ratio.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.13))
    fig.savefig(path, dpi=110)
    plt.close(fig)


COMPILE_PROBE = """
import time
t0 = time.perf_counter()
from tensegrity_core.sim import load_scene, simulate
t1 = time.perf_counter()
simulate(load_scene("spine_release").with_duration(0.01))
t2 = time.perf_counter()
simulate(load_scene("spine_release").with_duration(0.01))
t3 = time.perf_counter()
print(t1 - t0, t2 - t1, t3 - t2)
"""


def _probe(env: dict) -> tuple[float, float]:
    """(first, second) seconds of a 10 ms spine run in a fresh process."""
    done = subprocess.run([sys.executable, "-c", COMPILE_PROBE], env=env, capture_output=True, text=True, check=True)
    _, first, again = (float(v) for v in done.stdout.split())
    return first, again


@benchmark
def compile_cache(ctx: Context) -> list[Row]:
    """numba's one-off cost in a fresh process: the kernels loaded from the cache ``./run
    setup`` filled; in full mode also compiled into an empty cache (minutes on a busy machine)."""
    _warm()
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    first, again = _probe(env)
    rows = [Row(GROUP, "numba: first run, cache filled", first - again, "s",
                note=f"loading the compiled kernels (a 10 ms spine run, minus a second run's {again * 1e3:.3g} ms)")]
    if not ctx.quick:
        with tempfile.TemporaryDirectory() as cache:
            first, again = _probe(dict(env, NUMBA_CACHE_DIR=cache))
        rows.append(Row(GROUP, "numba: first run, empty cache", first - again, "s",
                        baseline="numba: first run, cache filled", note="compiling every kernel the run needs"))
    return rows
