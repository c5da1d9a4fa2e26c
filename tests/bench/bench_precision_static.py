"""Work-precision of the static computations (``--only precision_static``): form-finding,
inverse kinematics, stiffness. See ``bench_precision`` for the conventions (one BLAS
thread, best wall times, plots and JSON in full mode).

- form-finding: the relative residual (out-of-balance force at a node over the forces that
  meet there, docs/general.md) after every iteration of one tight run per method (the paper's Newton with sparse and with dense algebra, dynamic relaxation capped
  by a time budget), on the tensegrity table with one long string shortened (rest length
  0.25 instead of 0.3 of its drawn length, so the start is far from equilibrium) and on a
  spine with perturbed rest lengths (80 members quick, 1,000 full). A residual tolerance
  costs the iterations and time until the history first falls below it;
- inverse kinematics: max |FK(IK(p)) - p| / L over random workspace targets, the closed
  form against scipy's hybrid Powell root finder of FK(rho) = p at xtol 1e-2 .. 1e-14;
- stiffness: central differences of the potential energy (step h L, h = 1e-1 .. 1e-7)
  against the analytic procedure; error max |K_h - K| / max |K|, time per matrix.
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy import optimize
from threadpoolctl import threadpool_limits

from tests.bench.harness import Context, Row, benchmark, time_per_call
from tests.bench.precision_tools import Point, save_study

LEVELS = [10.0 ** -k for k in range(4, 15, 2)]      # relative residual


def _short_string_table():
    from tensegrity_core.general import example_path, load_structure

    text = example_path("tensegrity_table").read_text()
    text = text.replace("- {name: long1, nodes: [f1, c1]}",
                        "- {name: long1, nodes: [f1, c1], rest_length_ratio: 0.25}")
    assert "0.25" in text
    return load_structure(text)


def _history(structure, method: str, budget: float, **options):
    """(iterations, relative residuals, seconds) after every iteration of one run at a
    tolerance below every level (stopped by ``budget`` s, or at the rounding level), and
    the result."""
    from tensegrity_core.general import form_find

    its, res, secs = [], [], []
    t0 = time.perf_counter()

    def callback(info):
        its.append(info.iteration)
        res.append(info.residual)
        secs.append(time.perf_counter() - t0)
        return secs[-1] > budget

    tol = 0.1 * LEVELS[-1]
    r = form_find(structure, method=method, tol=tol, max_iter=200 if method == "newton" else 10**8,
                  callback=callback, **options)
    return np.array(its), np.array(res), np.array(secs), r


def _thinned(history: dict, keep: int = 300) -> dict:
    """A history with at most ~``keep`` iterations (log-spaced, the last one kept) for the
    JSON file: dynamic relaxation runs tens of thousands of steps."""
    n = len(history["iterations"])
    idx = np.unique(np.r_[np.geomspace(1, max(n, 1), keep).astype(int) - 1, n - 1]) if n else np.array([], int)
    return {k: (v[idx] if isinstance(v, np.ndarray) else v) for k, v in history.items()}


@benchmark
def formfind_work_precision(ctx: Context) -> list[Row]:
    from tensegrity_core.general import tensegrity_spine

    budget = 0.3 if ctx.quick else 30.0      # quick: Newton converges well within it, relaxation is cut
    n_vert = 11 if ctx.quick else 126
    structures = {"table, long1 shortened": _short_string_table(),
                  f"spine, {8 * (n_vert - 1)} members": tensegrity_spine(n_vert, perturbation=0.03, seed=0)}
    methods = {"Newton (sparse)": ("newton", {"linear_solver": "sparse"}),
               "Newton (dense, the paper's)": ("newton", {"linear_solver": "dense"}),
               "dynamic relaxation": ("dynamic_relaxation", {})}
    rows, data = [], {}
    with threadpool_limits(1):
        for sname, s in structures.items():
            data[sname] = {}
            for mname, (method, opts) in methods.items():
                its, res, secs, r = _history(s, method, budget, **opts)
                data[sname][mname] = {"iterations": its, "residual": res, "seconds": secs,
                                      "final": r.message}
                reached = []
                for level in LEVELS:
                    hit = np.nonzero(res <= level)[0]
                    if hit.size:
                        k = int(hit[0])
                        reached.append(f"{level:.0e}: {its[k]} it / {secs[k] * 1e3:.3g} ms")
                    else:
                        reached.append(f"{level:.0e}: not in {secs[-1] if secs.size else 0:.2g} s")
                rows.append(Row("precision_static", f"form-finding {sname}, {mname}",
                                float(secs[-1]) if secs.size else math.nan, "s",
                                note="relative residual -> " + "; ".join(reached)))
    ctx.save_json("precision_formfind.json", {s: {m: _thinned(h) for m, h in by.items()} for s, by in data.items()})
    path = ctx.plot_path("wp_formfind.png")
    if path is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(len(structures), 2, figsize=(12, 4.2 * len(structures)),
                                 constrained_layout=True, squeeze=False)
        for row, (sname, by_method) in zip(axes, data.items()):
            for mname, h in by_method.items():
                rel = np.maximum(h["residual"], 1e-18)
                row[0].loglog(np.maximum(h["iterations"], 1), rel, lw=1, label=mname)
                row[1].loglog(np.maximum(h["seconds"], 1e-5), rel, lw=1, label=mname)
            for ax, xl in zip(row, ("iterations", "wall time [s]")):
                ax.set(xlabel=xl, ylabel="relative residual", title=sname)
                ax.grid(True, which="both", alpha=0.3)
                ax.legend(fontsize=8)
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return rows


def _ik_targets(n: int, seed: int = 5):
    rng = np.random.default_rng(seed)
    rho1 = rng.uniform(0.05, 0.95, n)
    beta = rng.uniform(0.05, np.pi / 2 - 0.05, n)
    return rho1 + np.cos(beta), np.sin(beta)


@benchmark
def ik_work_precision(ctx: Context) -> list[Row]:
    from tensegrity_core.class2 import PAPER_PARAMS
    from tensegrity_core.class2.inverse_kinematics import inverse_kinematics
    from tensegrity_core.class2.kinematics import fk_array

    n = 50 if ctx.quick else 300
    xs, ys = _ik_targets(n)

    def fk(rho):
        out = fk_array(rho[0], rho[1], PAPER_PARAMS)
        return np.array([float(out.x), float(out.y)])

    def closed(x, y):
        sol = [c for c in inverse_kinematics(x, y).candidates if c.valid]
        return np.array([sol[0].rho1, sol[0].rho2]) if sol else None

    def root(x, y, xtol):
        r = optimize.root(lambda rho: fk(rho) - (x, y), (0.5, 0.5), method="hybr", options={"xtol": xtol})
        return r.x if r.success else None

    points, rows = [], []
    with threadpool_limits(1):
        variants = [("closed form", None, closed)] + [
            ("scipy root (hybr)", xtol, (lambda x, y, xtol=xtol: root(x, y, xtol)))
            for xtol in ([1e-3, 1e-8, 1e-14] if ctx.quick else [10.0 ** -k for k in range(2, 15, 2)])]
        for label, setting, solve in variants:
            errors, failed, t0 = [], 0, time.perf_counter()
            for x, y in zip(xs, ys):
                rho = solve(x, y)
                if rho is None or not (0 <= rho[0] <= 1 and 0 <= rho[1] and rho[0] + rho[1] <= 2):
                    failed += 1
                    continue
                errors.append(float(np.hypot(*(fk(rho) - (x, y)))))
            per_call = time_per_call(lambda solve=solve: solve(xs[0], ys[0]), min_time=0.05, repeat=3)
            err = max(errors) if errors else math.inf
            points.append(Point("ik", label, setting if setting is not None else math.nan, max(err, 1e-17),
                                per_call, ok=bool(errors), default=setting is None,
                                note=f"{failed} of {n} targets failed or left the domain",
                                extra={"wall_all_targets": time.perf_counter() - t0}))
            rows.append(Row("precision_static", f"IK {label}" + (f" xtol {setting:g}" if setting else ""),
                            per_call * 1e6, "us/call", baseline=None if setting is None else "IK closed form",
                            note=f"max |FK(IK(p)) - p| / L = {err:.1e} over {n} targets; {failed} failed"))
    # a ratio < 1 in the table is how much slower the root finder is than the closed form
    save_study(ctx, "ik", "inverse kinematics: max |FK(IK(p)) - p| / L", points, setting_label="xtol")
    return rows


@benchmark
def stiffness_work_precision(ctx: Context) -> list[Row]:
    from tensegrity_core.class2.stiffness import (
        stiffness_matrix_assembled,
        stiffness_matrix_energy_fd,
        stiffness_matrix_paper,
    )

    configs = [(0.7, 0.7, 1.0), (0.5, 0.8, 0.0), (0.3, 0.9, 2.0)]
    steps = [1e-2, 1e-4, 1e-6] if ctx.quick else [10.0 ** -k for k in range(1, 8)]
    timing = {} if ctx.quick else {"min_time": 0.1, "repeat": 3}      # quick: the mode's (harness.QUICK_TIMING)
    rows, points = [], []
    with threadpool_limits(1):
        Ks = {c: stiffness_matrix_paper(*c) for c in configs}
        agree = max(float(np.abs(stiffness_matrix_assembled(*c) - Ks[c]).max() / np.abs(Ks[c]).max())
                    for c in configs)
        t_paper = time_per_call(lambda: stiffness_matrix_paper(*configs[0]), **timing)
        t_asm = time_per_call(lambda: stiffness_matrix_assembled(*configs[0]), **timing)
        rows += [Row("precision_static", "stiffness: paper's procedure (analytic)", t_paper * 1e6, "us"),
                 Row("precision_static", "stiffness: generic assembly (analytic)", t_asm * 1e6, "us",
                     baseline="stiffness: paper's procedure (analytic)",
                     note=f"the two analytic routes agree to {agree:.1e} relative")]
        points.append(Point("stiffness", "analytic (paper's procedure)", math.nan, max(agree, 1e-17), t_paper,
                            evaluations=1, default=True,
                            note="error: its difference from the generic assembly"))
        for h in steps:
            err = max(float(np.abs(stiffness_matrix_energy_fd(*c, step=h) - Ks[c]).max() / np.abs(Ks[c]).max())
                      for c in configs)
            t = time_per_call(lambda h=h: stiffness_matrix_energy_fd(*configs[0], step=h), **timing)
            points.append(Point("stiffness", "central differences of U", h, err, t, evaluations=4 * 28))
            rows.append(Row("precision_static", f"stiffness: energy differences, step {h:g} L", t * 1e6, "us",
                            baseline="stiffness: paper's procedure (analytic)",
                            note=f"max |K_h - K| / max |K| = {err:.1e} over {len(configs)} configurations"))
    save_study(ctx, "stiffness", "stiffness matrix: max |K - K_ref| / max |K_ref|", points,
               evaluations_label="energy evaluations", setting_label="step / L")
    return rows
