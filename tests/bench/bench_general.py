"""Benchmarks of general-tensegrity form-finding (``--only general``).

All runs pin BLAS to one thread (the "one core" of the claims; threads also make small
dense problems erratic on shared machines). Structures: the tensegrity spine generator
with ``n`` vertebrae (lowest fixed), rest-length ratios perturbed by +-0.03 (seeded) so the
equilibrium is a non-trivial curved shape: ``6 (n - 1)`` DOF, ``8 (n - 1)`` members.

- ``dense_vs_sparse``: the paper's procedure (dense K_T, full eigenvalues every iteration,
  Eq. 81 shift, dense Cholesky) against the sparse one (LDL^T attempts with increasing
  shift) on the same structure: total time, time per iteration, and the largest difference
  of the two equilibria relative to the structure size. Quick: 300 DOF; full: 3,000 DOF.
- ``scaling``: sparse form-finding time against members, 100 .. 10,000 (quick: up to
  1,000); the growth exponent from a log-log fit; a PNG when ``--plot-dir`` is given.
- ``methods``: Newton against dynamic relaxation on small examples.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from tests.bench.harness import Context, Row, benchmark


def _spine(members: int):
    from tensegrity_core.general import tensegrity_spine

    return tensegrity_spine(members // 8 + 1, perturbation=0.03, seed=0)


def _timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


@benchmark
def dense_vs_sparse(ctx: Context) -> list[Row]:
    from tensegrity_core.general import form_find

    dof = 300 if ctx.quick else 3000
    s = _spine(8 * dof // 6)
    with threadpool_limits(1):
        sparse, t_sparse = _timed(lambda: form_find(s, linear_solver="sparse"))
        dense, t_dense = _timed(lambda: form_find(s, linear_solver="dense"))
    assert sparse.success and dense.success, (sparse.message, dense.message)
    size = float(np.ptp(dense.nodes, axis=0).max())
    diff = float(np.abs(sparse.nodes - dense.nodes).max()) / size
    tag = f"{s.layout.n_dof} DOF"
    return [
        Row("general", f"paper dense Newton, {tag}", t_dense, "s",
            note=f"{dense.iterations} it, {t_dense / dense.iterations:.3g} s/it"),
        Row("general", f"sparse Newton, {tag}", t_sparse, "s", baseline=f"paper dense Newton, {tag}",
            target=">= 50x at 3000 DOF", note=f"{sparse.iterations} it, {t_sparse / sparse.iterations:.3g} s/it"),
        Row("general", f"equilibrium difference, {tag}", diff, "rel", target="<= 1e-8",
            note="max node distance / structure size"),
    ]


@benchmark
def scaling(ctx: Context) -> list[Row]:
    from tensegrity_core.general import form_find

    sizes = [100, 300, 1000] if ctx.quick else [100, 300, 1000, 3000, 10000]
    members, times, per_it = [], [], []
    rows = []
    with threadpool_limits(1):
        for m in sizes:
            s = _spine(m)
            r, t = _timed(lambda s=s: form_find(s, linear_solver="sparse"))
            assert r.success, r.message
            members.append(s.n_members)
            times.append(t)
            per_it.append(t / max(r.iterations, 1))
            rows.append(Row("general", f"sparse form-finding, {s.n_members} members", t, "s",
                            target="< 30 s" if s.n_members >= 10_000 else "",
                            note=f"{s.layout.n_dof} DOF, {r.iterations} it"))
    slope = float(np.polyfit(np.log(members), np.log(times), 1)[0])
    slope_it = float(np.polyfit(np.log(members), np.log(per_it), 1)[0])
    big = np.array(members) >= 1000
    slope_big = float(np.polyfit(np.log(np.array(members)[big]), np.log(np.array(per_it)[big]), 1)[0]) \
        if big.sum() >= 2 else float("nan")
    rows.append(Row("general", "growth exponent of time", slope, "",
                    note="includes the iteration count, which grows with the chain's deformation"))
    rows.append(Row("general", "growth exponent of time per iteration", slope_it, "", target="close to 1",
                    note=f"{slope_big:.2f} from 1,000 members up"))
    if ctx.plot_dir:
        _plot(Path(ctx.plot_dir), np.array(members), np.array(times), np.array(per_it), slope, slope_it)
    return rows


def _plot(folder: Path, members, times, per_it, slope, slope_it) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.loglog(members, times, "o-", label=f"form-finding (slope {slope:.2f})")
    ax.loglog(members, per_it, "s--", label=f"per Newton iteration (slope {slope_it:.2f})")
    ref = times[0] * members / members[0]
    ax.loglog(members, ref, ":", color="0.5", label="linear growth")
    ax.set_xlabel("members")
    ax.set_ylabel("time [s] (one core)")
    ax.set_title("Sparse form-finding of perturbed tensegrity spines")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.savefig(folder / "scaling.png", dpi=120, bbox_inches="tight")
    plt.close(fig)


@benchmark
def methods(ctx: Context) -> list[Row]:
    from tensegrity_core.general import form_find, load_example

    rows = []
    with threadpool_limits(1):
        for name in ("t_bar", "spherical_tetrahedron"):
            s = load_example(name)
            n, t_n = _timed(lambda s=s: form_find(s))
            d, t_d = _timed(lambda s=s: form_find(s, method="dynamic_relaxation"))
            assert n.success and d.success
            rows.append(Row("general", f"dynamic relaxation, {name}", t_d, "s",
                            note=f"{d.iterations} it"))
            rows.append(Row("general", f"Newton, {name}", t_n, "s", baseline=f"dynamic relaxation, {name}",
                            note=f"{n.iterations} it"))
    return rows
