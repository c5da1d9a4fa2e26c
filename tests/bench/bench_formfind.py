"""Form-finding at a million members (``--only formfind``, issue 16).

One BLAS thread throughout. Structures from the generators of ``tensegrity_core.general``:

- ``large_structures``: strips of ``10 x c`` 4-prisms standing on the ground
  (:func:`prism_grid`, 16 members per prism), every string's rest length 1 % shorter than
  drawn (one step of a rest-length path from the drawn equilibrium). Each size runs in a
  fresh process: the structure is written as ``.npz``, then loaded (timed: "load"),
  form-found (Newton iterations and the stability verdict timed apart), and the process's
  peak resident memory read (``ru_maxrss``, the interpreter and numpy included). Wall time
  and the process's CPU time (the machine is shared). The growth exponent of the total
  is fitted from 10,000 members up (quick: over both sizes). Quick: 1,000 and 3,000 members
  (two sizes: the least a fitted exponent needs); full: to 10^6.
  Targets: 100,000 members under 10 s in total, 10^6 under 5 minutes and 16 GB, exponent
  at most 1.1.
- ``verdict``: the stability verdict of prism towers (:func:`prism_tower`, drawn in their
  equilibrium, pinned base) against the eigenvalue computation it replaced (shift-invert
  about ``-beta``, ``beta = 1e-9 max |K_ii|`` raised x4 until the factor exists, for the
  scaled and for the physical matrix, written out here) and its fixed threshold 1e-11 on
  the scaled eigenvalue: time, and the margin over the rounding level. Quick: 1,800
  members; full: 9,990 and 19,998 (the issue's towers), 49,986 and 99,990.
- ``spine_threads``: the dense Newton algebra of a C spine of 40 vertebrae (234 DOF, under
  ``DENSE_LIMIT``) with one BLAS thread against two: one shifted step and the stability
  eigenvalue at the straight start, process CPU time (spinning threads included) and wall
  time per call (the best of 20 calls; quick: one call). Full mode adds form-finding of the
  40- and the 100-vertebra C spine (the latter sparse) with the exact ``K_T``
  (``slack_stiffness=False``), the run that took 49 s against 3 s with BLAS's default
  threads on a busy machine.
- ``shift``: Newton with the default shift (the rounding level of a definite matrix)
  against the paper's fixed shift 1e-10 on the scaled matrix, towers after a 1 %
  rest-length step: time and iterations. Quick: 1,800 members; full: 18,000 and 36,000.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from tests.bench.harness import Context, Row, benchmark

ROOT = Path(__file__).resolve().parents[2]
ROWS = 10                                   # prisms across the strip


def rest_length_step(s, factor: float):
    """Every string's rest length times ``factor``."""
    return s.with_rest_lengths(np.where(s.is_string, factor, 1.0) * s.rest_lengths)


def _strip(members: int):
    """A ``ROWS x c`` strip of prisms with about ``members`` members, after the 1 % step."""
    from tensegrity_core.general.generators import prism_grid

    columns = max(1, round((members + 2 * ROWS) / (16 * ROWS - 2)))
    return rest_length_step(prism_grid(ROWS, columns), 0.99)


def measure(path: str) -> dict:
    """In this (fresh) process: load the structure file, form-find it; times, iterations,
    the verdict and the peak memory."""
    import resource

    from tensegrity_core.general import form_find, structure_from_file

    with threadpool_limits(1):
        wall, cpu = time.perf_counter(), time.process_time()
        s = structure_from_file(path)
        load = time.perf_counter() - wall
        started = time.perf_counter()
        r = form_find(s)
        solve = time.perf_counter() - started
        total_cpu = time.process_time() - cpu
    return {"members": s.n_members, "dof": s.layout.n_dof, "load": load, "form_find": solve,
            "newton": r.timings["iterations"], "stability": r.timings["stability"], "total": load + solve,
            "cpu": total_cpu, "iterations": r.iterations, "status": r.status, "residual": r.residual,
            "margin": r.stability_margin, "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            "message": r.message}


def _measure_in_a_process(structure, folder: Path) -> dict:
    from tensegrity_core.general import save_structure

    path = save_structure(structure, folder / f"strip{structure.n_members}.npz")
    out = subprocess.run([sys.executable, "-m", "tests.bench.bench_formfind", str(path)], cwd=ROOT,
                         capture_output=True, text=True, timeout=3600)
    if out.returncode != 0:
        raise RuntimeError(f"the measuring process failed: {out.stderr[-2000:]}")
    return json.loads(out.stdout.splitlines()[-1])


@benchmark
def large_structures(ctx: Context) -> list[Row]:
    sizes = [1_000, 3_000] if ctx.quick else [1_000, 3_000, 10_000, 30_000, 100_000, 300_000, 1_000_000]
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        for m in sizes:
            run = _measure_in_a_process(_strip(m), Path(tmp))
            assert run["status"] == 0, run["message"]
            runs.append(run)
    rows = []
    for run in runs:
        n = run["members"]
        target = "< 10 s" if 90_000 <= n <= 110_000 else "< 300 s, 16 GB" if n >= 900_000 else ""
        shares = {k: run[k] / run["total"] for k in ("load", "newton", "stability")}
        rows.append(Row("formfind", f"load + form-find + verdict, {n} members", run["total"], "s", target=target,
                        note=f"{run['dof']} DOF, {run['iterations']} it, load {shares['load']:.0%} / Newton "
                             f"{shares['newton']:.0%} / verdict {shares['stability']:.0%}, CPU {run['cpu']:.3g} s, "
                             f"peak {run['peak_mb']:.0f} MB, margin {run['margin']:.2g}"))
    members = np.array([r["members"] for r in runs], dtype=float)
    big = members >= (0 if ctx.quick else 9_000)       # quick: too few sizes from 10,000 up
    exponents = {}
    for key in ("total", "newton", "stability", "load", "peak_mb"):
        values = np.array([r[key] for r in runs])
        exponents[key] = float(np.polyfit(np.log(members[big]), np.log(values[big]), 1)[0]) if big.sum() >= 2 \
            else float("nan")
    rows.append(Row("formfind", f"growth exponent of the total, from {int(members[big].min())} members",
                    exponents["total"], "", target="<= 1.1 from 10,000", note=f"Newton {exponents['newton']:.2f}, verdict {exponents['stability']:.2f}, "
                                          f"load {exponents['load']:.2f}, peak memory {exponents['peak_mb']:.2f}"))
    iterations = sorted({r["iterations"] for r in runs})
    rows.append(Row("formfind", "Newton iterations, every size", float(max(iterations)), "it",
                    note=f"{iterations} over {int(members.min())}-{int(members.max())} members"))
    ctx.save_json("formfind_scaling.json", runs)
    path = ctx.plot_path("formfind_scaling.png")
    if path is not None:
        _plot(path, runs, exponents)
    return rows


def _plot(path: Path, runs: list[dict], exponents: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    m = np.array([r["members"] for r in runs], dtype=float)
    fig, ax = plt.subplots(figsize=(7, 4.8))
    for key, label, style in (("total", "total", "o-"), ("newton", "Newton iterations", "s--"),
                              ("stability", "stability verdict", "^--"), ("load", "load (.npz)", "v:")):
        ax.loglog(m, [r[key] for r in runs], style, label=f"{label} (slope {exponents[key]:.2f})")
    ax.loglog(m, runs[-1]["total"] * m / m[-1], color="0.6", lw=0.8, label="linear growth")
    ax.set_xlabel("members")
    ax.set_ylabel("wall time [s] (one core)")
    ax.grid(True, which="both", alpha=0.3)
    right = ax.twinx()
    right.loglog(m, [r["peak_mb"] / 1024 for r in runs], "k.", ms=9, label="peak memory")
    right.set_ylabel("peak memory [GB] (dots)")
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title("Form-finding of prism strips after a 1 % rest-length step")
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def old_lowest_eigenvalue(K) -> float:
    """The verdict's eigenvalue before issue 16, for a supported structure: shift-invert
    Lanczos about ``-beta``, ``beta = 1e-9 max |K_ii|`` raised x4 until ``K + beta I`` has a
    positive definite factor, tol 1e-10."""
    import scipy.sparse as sp
    from scipy.sparse.linalg import LinearOperator, eigsh

    from tensegrity_core.general.linalg import factor_if_positive_definite

    K = sp.csc_matrix(K)
    n = K.shape[0]
    beta = 1e-9 * float(np.abs(K.diagonal()).max())
    lu = factor_if_positive_definite(K + beta * sp.identity(n, format="csc"))
    while lu is None:
        beta *= 4.0
        lu = factor_if_positive_definite(K + beta * sp.identity(n, format="csc"))
    solve = LinearOperator((n, n), matvec=lu.solve, dtype=float)
    v0 = np.random.default_rng(0).standard_normal(n)
    return float(eigsh(K, k=1, sigma=-beta, which="LM", OPinv=solve, v0=v0, tol=1e-10,
                       return_eigenvectors=False)[0])


@benchmark
def verdict(ctx: Context) -> list[Row]:
    import scipy.sparse as sp

    from tensegrity_core.general import Configuration, tangent_stiffness
    from tensegrity_core.general.generators import prism_tower
    from tensegrity_core.general.linalg import jacobi_scaling
    from tensegrity_core.general.stability import lowest_mode

    rows = []
    with threadpool_limits(1):
        for stages in ([100] if ctx.quick else [555, 1111, 2777, 5555]):
            s = prism_tower(stages)
            config = Configuration.initial(s)
            K = tangent_stiffness(s, config, sparse=True)
            started = time.perf_counter()
            low = lowest_mode(K, config, dense=False)
            t_new = time.perf_counter() - started
            started = time.perf_counter()
            D = sp.diags(jacobi_scaling(K))
            scaled_old = old_lowest_eigenvalue(D @ K @ D)
            old_lowest_eigenvalue(K)
            t_old = time.perf_counter() - started
            old = "stable" if scaled_old > 1e-11 else "unstable" if scaled_old < -1e-11 else "neutral"
            tag = f"tower {s.n_members} members"
            rows.append(Row("formfind", f"verdict before, {tag}", t_old, "s",
                            note=f"scaled eigenvalue {scaled_old:.3g}: {old} (fixed threshold 1e-11)"))
            rows.append(Row("formfind", f"verdict, {tag}", t_new, "s", baseline=f"verdict before, {tag}",
                            note=f"scaled eigenvalue {low.scaled:.3g} = {low.margin:.3g} x rounding level "
                                 f"{low.rounding:.2g}: {low.verdict}"))
    return rows


def _cpu_and_wall(fn, repeat: int) -> tuple[float, float]:
    """Best process CPU time and best wall time [s] of ``fn()`` over ``repeat`` runs."""
    cpu, wall = float("inf"), float("inf")
    for _ in range(repeat):
        c0, w0 = time.process_time(), time.perf_counter()
        fn()
        cpu, wall = min(cpu, time.process_time() - c0), min(wall, time.perf_counter() - w0)
    return cpu, wall


@benchmark
def spine_threads(ctx: Context) -> list[Row]:
    from tensegrity_core.general import Configuration, form_find, tangent_stiffness, tensegrity_spine
    from tensegrity_core.general.convergence import balance
    from tensegrity_core.general.linalg import moving_coordinates, shifted_step_dense
    from tensegrity_core.general.stability import lowest_mode

    s = tensegrity_spine(40, shape="C")
    config = Configuration.initial(s)
    K = tangent_stiffness(s, config)
    keep = moving_coordinates(config)
    P = balance(s, config).physical.generalized[keep]

    def dense_algebra():
        shifted_step_dense(K[np.ix_(keep, keep)], P)
        lowest_mode(K, config, dense=True)

    rows = []
    label = f"dense shifted step and stability eigenvalue, C spine 40 vertebrae ({s.layout.n_dof} DOF)"
    for threads in (1, 2):
        with threadpool_limits(threads, user_api="blas"):
            cpu, wall = _cpu_and_wall(dense_algebra, 1 if ctx.quick else 20)
        base = None if threads == 1 else "{what}, 1 BLAS thread"
        for what, value in (("CPU", cpu), ("wall", wall)):
            rows.append(Row("formfind", f"{label}, {what}, {threads} BLAS thread{'s' * (threads > 1)}", value, "s",
                            baseline=base and base.format(what=f"{label}, {what}")))
    if ctx.quick:
        return rows
    times = {}
    for n in (100, 40):
        spine = tensegrity_spine(n, shape="C")
        c0, w0 = time.process_time(), time.perf_counter()
        r = form_find(spine, slack_stiffness=False, max_iter=400)
        times[n] = (time.process_time() - c0, time.perf_counter() - w0, r)
        assert r.success, r.message
    for n in (100, 40):
        cpu, wall, r = times[n]
        tag = f"form-finding, C spine {n} vertebrae, exact K_T"
        for what, value in (("CPU", cpu), ("wall", wall)):
            rows.append(Row("formfind", f"{tag}, {what}", value, "s",
                            baseline=None if n == 100 else f"form-finding, C spine 100 vertebrae, exact K_T, {what}",
                            note=f"{r.iterations} it, {r.method}"))
    return rows


@benchmark
def shift(ctx: Context) -> list[Row]:
    from tensegrity_core.general import form_find
    from tensegrity_core.general.generators import prism_tower

    rows = []
    with threadpool_limits(1):
        for stages in ([100] if ctx.quick else [1000, 2000]):
            s = rest_length_step(prism_tower(stages), 0.99)
            tag = f"tower {s.n_members} members"
            started = time.perf_counter()
            fixed = form_find(s, shift=1e-10, check_stability=False)
            t_fixed = time.perf_counter() - started
            started = time.perf_counter()
            adaptive = form_find(s, check_stability=False)
            t_adaptive = time.perf_counter() - started
            assert fixed.success and adaptive.success, (fixed.message, adaptive.message)
            rows.append(Row("formfind", f"Newton, fixed shift 1e-10, {tag}", t_fixed, "s",
                            note=f"{fixed.iterations} it"))
            rows.append(Row("formfind", f"Newton, default shift, {tag}", t_adaptive, "s",
                            baseline=f"Newton, fixed shift 1e-10, {tag}", note=f"{adaptive.iterations} it"))
    return rows


if __name__ == "__main__":
    print(json.dumps(measure(sys.argv[1])))
