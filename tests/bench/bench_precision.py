"""Work-precision study: what each digit of accuracy costs (``--only precision``).

One BLAS thread throughout. Each study sweeps a method's accuracy setting from loose to
tight and measures, per run, the error against a reference and the best wall time; the
plots show error against time and against evaluations (``precision_tools``). Errors:

- dynamics (the scenes as shipped, through :func:`tensegrity_core.sim.simulate`): the
  largest node-position error over all output samples, relative to the structure's size,
  against a reference that two different methods at rtol 1e-13 agree on (their
  disagreement is reported; the requirement is <= 1e-11; for the general structures,
  whose reference runs cost minutes, rtol 1e-11 and an agreement of ~1e-9). Quick mode
  (CI's smoke run: every row reported, no speed proven) shortens the scenes (the paper's fold
  to 2 s of its 5, which keeps its fold and release events at 1.4-1.75 s; the stiff fold,
  without events before 1.4 s, to 0.2 s; the energy drift's runs to 5 s) and uses three
  tolerances. Methods: scipy's RK23, RK45, DOP853, Radau, BDF and LSODA, rtol 1e-3 .. 1e-12
  with the scene's atol/rtol ratio. A
  method's sweep stops once a run exceeds the time budget (reported). In the stiff scene
  the explicit methods' cost is set by stability, not by the tolerance: they run 0.01 s
  and their time is extrapolated (a vertical line in the plot);
- energy drift: the undamped class-2 mechanism without forces, max |E(t) - E(0)| / E(0);
- form-finding: the physical residual [N] at each iteration of one tight run per method
  (the paper's Newton and dynamic relaxation), against iterations and time: the cost of
  each residual tolerance is read off the history;
- inverse kinematics: max |FK(IK(p)) - p| / L over random workspace targets, closed form
  against scipy's hybrid Powell root finder at several xtol;
- stiffness: max |K - K_analytic| / max |K_analytic| of central differences of the
  potential energy at several steps, against the closed procedure (two analytic routes
  agree to 1e-12).

Full mode writes ``docs/bench/precision_*.json`` and ``docs/img/performance/*.png``;
``docs/design/performance.md`` reads them in words.
"""

from __future__ import annotations

import copy
import math
import sys
import time

import numpy as np
from threadpoolctl import threadpool_limits
from tqdm import tqdm

from tests.bench.harness import Context, Row, benchmark, best_run
from tests.bench.precision_tools import (
    Point,
    cost_per_digit,
    dominating,
    pareto_front,
    save_study,
    time_at_error,
    usable,
)

METHODS = ("RK23", "RK45", "DOP853", "Radau", "BDF", "LSODA")
EXPLICIT = ("RK23", "RK45", "DOP853")


def _rtols(ctx: Context) -> list[float]:
    return [1e-3, 1e-6] if ctx.quick else [10.0 ** -k for k in range(3, 13)]


def _progress(total: int, desc: str):
    return tqdm(total=total, desc=desc, file=sys.stderr, leave=False, mininterval=0.5)


# ----------------------------------------------------------------------------------- dynamics
def _scene_data(name: str) -> dict:
    from tensegrity_core.sim import load_scene

    scene = load_scene(name)
    d = copy.deepcopy(scene.data)
    if scene.model.kind == "general":
        d["model"]["structure"] = str(scene.model.source)
    return d


def _run_scene(data: dict, method: str, rtol: float, atol: float, duration: float | None = None):
    """A run of the scene with ``method`` at ``rtol``, ``atol``; for RK4, ``rtol`` is its
    fixed step [s] (the setting its work-precision points sweep)."""
    from tensegrity_core.sim import load_scene, simulate

    d = copy.deepcopy(data)
    d["integrator"] = {"method": method, "rtol": rtol, "atol": atol} if method != "RK4" else \
        {"method": method, "max_step": rtol}
    if duration is not None:
        d["duration"] = duration
    return simulate(load_scene(d))


def _position_error(traj, ref) -> float:
    """Largest node-position difference over the common output samples / structure size."""
    n = min(len(traj.times), len(ref.times))
    if n == 0 or not np.allclose(traj.times[:n], ref.times[:n]):
        return math.inf
    size = float(np.ptp(ref.nodes.reshape(-1, 3), axis=0).max())
    return float(np.abs(traj.nodes[:n] - ref.nodes[:n]).max()) / size


def scene_study(ctx: Context, name: str, methods=METHODS, *, reference=("DOP853", "LSODA"),
                ref_rtol: float = 1e-13, duration: float | None = None, rtols=None,
                budget: float | None = None, explicit_horizon: float | None = None, rk4_steps=()):
    """Work-precision points of shipped scene ``name`` (over ``duration`` s if given);
    ``(points, info)``. The reference: ``reference`` methods at ``ref_rtol``. ``rk4_steps``:
    the fixed steps [s] of RK4's points (their setting), if RK4 is among the methods."""
    data = _scene_data(name)
    if duration is not None:
        data["duration"] = duration
    default = data["integrator"]
    ratio = float(default.get("atol", 1e-10)) / float(default.get("rtol", 1e-8))
    budget = budget if budget is not None else (3.0 if ctx.quick else 30.0)
    refs = []
    for m in reference:
        t0 = time.perf_counter()
        refs.append(_run_scene(data, m, ref_rtol, ref_rtol * min(ratio, 1e-2)))
        refs[-1].stats["bench_seconds"] = time.perf_counter() - t0
    agreement = _position_error(refs[1], refs[0])
    ref = refs[0]
    repeat, min_time = (1, 0.0) if ctx.quick else (3, 0.3)
    grid = list(rtols) if rtols is not None else _rtols(ctx)
    rtols = sorted(set(grid) | {float(default["rtol"])}, reverse=True)
    points: list[Point] = []
    vlines = []
    bar = _progress(len(methods) * len(rtols), f"{name}")
    for m in methods:
        settings = sorted(rk4_steps, reverse=True) if m == "RK4" else rtols
        over_budget = False
        if explicit_horizon is not None and m in EXPLICIT:
            # cost set by stability: a short run, its time scaled to the scene's duration
            scale = float(data["duration"]) / explicit_horizon
            wall, traj = best_run(lambda m=m: _run_scene(data, m, 1e-6, 1e-6 * ratio, explicit_horizon), 1, 0.0)
            vlines.append((wall * scale, f"{m}, any rtol: {traj.stats['nfev'] * scale:.2g} evaluations "
                                         f"(extrapolated from {explicit_horizon:g} s)"))
            points.append(Point(name, m, math.nan, math.inf, wall * scale, int(traj.stats["nfev"] * scale),
                                ok=False, note=f"stability-bound: extrapolated from a {explicit_horizon:g} s run"))
            bar.update(len(rtols))
            continue
        for rtol in settings:
            bar.update(1)
            is_default = m == default.get("method") and (
                rtol == float(default["max_step"]) if m == "RK4" else rtol == float(default["rtol"]))
            if over_budget or (m != "RK4" and rtol == float(default["rtol"]) and rtol not in grid and not is_default):
                continue
            atol = rtol * ratio
            try:
                wall, traj = best_run(lambda m=m, rtol=rtol, atol=atol: _run_scene(data, m, rtol, atol), repeat,
                                      min_time, max_time=3.0)
            except Exception as err:  # a method that cannot do this scene: reported, not fatal
                points.append(Point(name, m, rtol, math.inf, math.nan, ok=False, default=is_default,
                                    note=f"{type(err).__name__}: {err}"[:200]))
                continue
            ok = bool(traj.success)
            err_ = _position_error(traj, ref) if ok else math.inf
            points.append(Point(name, m, rtol, err_, wall, int(traj.stats.get("nfev", 0)), ok=ok,
                                default=is_default, note="" if ok else traj.message[:200],
                                extra={"atol": atol, "steps": traj.stats.get("steps")}))
            if wall > budget:
                over_budget = True
                points[-1].note = (points[-1].note + f" (over the {budget:g} s budget: tighter settings skipped)").strip()
    bar.close()
    info = {"scene": name, "duration": float(data["duration"]),
            "reference": [f"{m} rtol {ref_rtol:g}" for m in reference],
            "reference_agreement": agreement, "reference_seconds": [r.stats["bench_seconds"] for r in refs],
            "default": default, "vlines": vlines}
    return points, info


def _front_rows(group: str, label: str, points, info, *, baseline_method: str = "RK45") -> list[Row]:
    """Table rows of one study: the reference, the front, the default and its standing."""
    rows = [Row(group, f"{label}: reference agreement", info["reference_agreement"], "rel",
                target="<= 1e-11", note=" vs ".join(info["reference"]))]
    front = pareto_front(points)
    rows.append(Row(group, f"{label}: Pareto front", len(front), "points",
                    note="; ".join(f"{p.method} {p.setting:g}: {p.error:.1e} in {p.seconds * 1e3:.3g} ms"
                                   for p in front)))
    for p in points:
        if p.default:
            beaten = dominating(p, points)
            rows.append(Row(group, f"{label}: default {p.method} rtol {p.setting:g}", p.seconds, "s",
                            target="on the front", met=not beaten,
                            note=(f"error {p.error:.1e}; " + ("on the front" if not beaten else
                                  "beaten by " + ", ".join(f"{q.method} {q.setting:g} ({q.error:.1e}, "
                                                           f"{q.seconds:.3g} s)" for q in beaten[:3])))))
            per_digit = cost_per_digit(points, p.method)
            if per_digit is not None:
                rows.append(Row(group, f"{label}: {p.method} time per extra digit", per_digit, "x",
                                note="least-squares slope of log time against -log error"))
            t_base = time_at_error(points, baseline_method, p.error) if p.method != baseline_method else None
            if t_base is not None:
                rows.append(Row(group, f"{label}: {baseline_method} at the default's error", t_base, "s",
                                note=f"interpolated along {baseline_method}'s curve at {p.error:.1e}"))
                rows.append(Row(group, f"{label}: default vs {baseline_method} at equal error", p.seconds, "s",
                                baseline=f"{label}: {baseline_method} at the default's error"))
    failed = [p for p in points if not p.ok and math.isfinite(p.setting)]
    if failed:
        rows.append(Row(group, f"{label}: runs that failed", len(failed), "runs",
                        note="; ".join(f"{p.method} {p.setting:g}: {p.note[:80]}" for p in failed[:4])))
    return rows


@benchmark
def dynamics_class2(ctx: Context) -> list[Row]:
    """The paper's fold scenario and the stiff fold (k_a = k_b = 1e6 N/m)."""
    rows = []
    with threadpool_limits(1):
        points, info = scene_study(ctx, "paper_fold", duration=2.0 if ctx.quick else None)
        # the ROS node's default scene (class2_at_rest) integrates the same model: its
        # setting is judged on this front too
        at_rest = _scene_data("class2_at_rest")["integrator"]
        for p in points:
            p.extra["class2_at_rest_default"] = (p.method == at_rest["method"]
                                                 and p.setting == float(at_rest["rtol"]))
        save_study(ctx, "paper_fold", f"paper's fold scenario, {info['duration']:g} s (node-position error / L)",
              points, info)
        rows += _front_rows("precision", "paper fold", points, info)
        node = [p for p in points if p.extra.get("class2_at_rest_default")]
        if node:
            beaten = dominating(node[0], points)
            rows.append(Row("precision", f"paper fold: class2_at_rest's DOP853 rtol {node[0].setting:g}",
                            node[0].seconds, "s", target="on the front", met=not beaten,
                            note=f"error {node[0].error:.1e}; " + ("on the front" if not beaten else
                                                                    f"beaten by {beaten[0].method} {beaten[0].setting:g}")))
        points, info = scene_study(ctx, "stiff_fold", reference=("Radau", "BDF"),
                                   # quick: 0.25 ms, ~3,000-5,000 evaluations at the stability limit, whose
                                   # extrapolation to the scene is within 1 % of a 1 ms run's (RK23, RK45, DOP853)
                                   explicit_horizon=0.00025 if ctx.quick else 0.01,
                                   duration=0.2 if ctx.quick else None)
        save_study(ctx, "stiff_fold", f"stiff fold (k_a/k = 1e6), {info['duration']:g} s (node-position error / L)",
              points, info)
        rows += _front_rows("precision", "stiff fold", points, info, baseline_method="BDF")
    return rows


@benchmark
def dynamics_general(ctx: Context) -> list[Row]:
    """The general-structure scenes (nodal dynamics): the table under load and the spine.
    DOP853 and RK4 run their compiled stages (numba); RK4's points are its fixed steps."""
    rows = []
    methods = ("Radau", "BDF", "LSODA", "DOP853", "RK4")
    with threadpool_limits(1):
        for name, label, quick_duration in (("table_gravity", "table under load", 0.02),
                                            ("spine_release", "spine release", 0.05)):
            points, info = scene_study(ctx, name, methods, reference=("DOP853", "LSODA"),
                                       ref_rtol=1e-10 if ctx.quick else 1e-11,
                                       duration=quick_duration if ctx.quick else None,
                                       rtols=[1e-3, 1e-6] if ctx.quick else None,
                                       budget=2.0 if ctx.quick else 60.0,
                                       rk4_steps=[5e-4] if ctx.quick else [1e-3, 5e-4, 2.5e-4, 1.25e-4, 6.25e-5,
                                                                           3.125e-5])
            save_study(ctx, name, f"{label}, {info['duration']:g} s (node-position error / structure size)",
                  points, info)
            rows += _front_rows("precision", label, points, info, baseline_method="BDF")
    return rows


# ------------------------------------------------------------------------------- energy drift
UNDAMPED = {
    "model": {"kind": "class2", "params": {"L": 1.0, "k": 1.0, "c": 0.0, "m": 2.0}},
    "initial": {"q": [0.6, 0.5, 1.0], "qdot": [0.3, -0.2, 0.5]},
    "inputs": {"f1": 0.0, "f2": 0.0},
    "effects": ["inertia", "springs"],
    "output": {"rate": 10},
}


CURVE_RTOL = 1e-8     # the tolerance whose drift is drawn against time


def _drift(traj) -> np.ndarray:
    E = traj.potential_energy + traj.kinetic_energy
    return np.abs(E - E[0]) / abs(E[0])


@benchmark
def energy_drift(ctx: Context) -> list[Row]:
    """Long undamped runs (no forces, no damping, no fold limit): the energy error grows
    with time at a rate set by the method and the tolerance."""
    from tensegrity_core.sim import load_scene, simulate

    # 100 s: from this start the undamped motion reaches the lambda1 singular set at ~191 s
    duration = 5.0 if ctx.quick else 100.0
    rtols = [1e-6, CURVE_RTOL] if ctx.quick else [1e-4, 1e-6, CURVE_RTOL, 1e-10, 1e-12]
    methods = ("RK45", "DOP853", "Radau", "BDF", "LSODA")
    points, curves = [], {}
    bar = _progress(len(methods) * len(rtols), "energy drift")
    with threadpool_limits(1):
        for m in methods:
            for rtol in rtols:
                bar.update(1)
                d = copy.deepcopy(UNDAMPED)
                d.update(duration=duration, integrator={"method": m, "rtol": rtol, "atol": rtol * 1e-2})
                scene = load_scene(d)
                t0 = time.perf_counter()
                traj = simulate(scene)
                wall = time.perf_counter() - t0
                drift = _drift(traj)
                points.append(Point("energy drift", m, rtol, float(drift.max()), wall, int(traj.stats["nfev"]),
                                    ok=bool(traj.success), note=traj.message[:200],
                                    extra={"drift_per_second": float(drift.max()) / duration}))
                if rtol == CURVE_RTOL:
                    curves[m] = (traj.times.tolist(), drift.tolist())
    bar.close()
    ctx.save_json("precision_energy_drift.json", {"duration": duration, "points": [p.as_dict() for p in points],
                                                  "curve_rtol": CURVE_RTOL, "curves": curves})
    path = ctx.plot_path("energy_drift.png")
    if path is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), constrained_layout=True)
        for m, (t, dr) in curves.items():
            t, dr = np.array(t), np.array(dr)
            axes[0].semilogy(t[1:], np.maximum(dr[1:], 1e-17), lw=1, label=m)
        axes[0].set(xlabel="t [s]", ylabel="|E(t) - E(0)| / E(0)", title=f"energy error over time, rtol {CURVE_RTOL:g}")
        for m in methods:
            pts = [p for p in usable(points) if p.method == m]
            axes[1].loglog([p.seconds for p in pts], [p.error for p in pts], marker="o", label=m)
        axes[1].set(xlabel="wall time [s]", ylabel=f"max energy error over {duration:g} s",
                    title=f"energy error against cost (rtol {rtols[0]:g} .. {rtols[-1]:g})")
        for ax in axes:
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=8)
        fig.savefig(path, dpi=110)
        plt.close(fig)
    rows = []
    for p in points:
        rows.append(Row("precision", f"energy drift {duration:g} s, {p.method} rtol {p.setting:g}", p.error, "rel",
                        note=f"{p.seconds:.3g} s, {p.evaluations} evaluations, "
                             f"{p.extra['drift_per_second']:.1e} per simulated second"))
    return rows
