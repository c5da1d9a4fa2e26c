"""Benchmarks of parameter sweeps on Dask distributed (``--only sweep``).

Every sweep runs three ways in the same run, alternating (four with the fixed halves below):
the points one after another in this process (``workers=0``, the serial loop; BLAS pinned to
one thread as in the workers); on the embedded 2-worker cluster (``start_local_cluster(2)``,
loopback, one client), started and warmed once before the timing (its start-up is a row of
its own; quick mode starts one for all the group's benchmarks, full mode one for each); and, as the machine's ceiling, in two plain processes without any engine, each
running every other point in one loop (``concurrent.futures`` on the same task function,
which pins BLAS to one thread; no journal, no table). The first two give the same rows
(checked). The ceiling says what these two cores gave two static halves of the points at
that time.
- Where the cluster's time goes, from the points' own (wall) times measured where they ran:
  the fraction of the workers' wall time spent in points, ``sum(t_point) / (W T_cluster)``
  (the rest: the first tasks on their way, gaps between tasks, the workers finishing apart),
  and how much longer a point took on the cluster than in the serial loop, against the same
  figure for the two plain processes: both take in how the two shared cores slow each other
  down, the cluster's also the CPU its client and scheduler take from the workers.

- ``formfind_points``: form-findings of the T-bar (8 members, a few milliseconds each) over
  its top strings' rest-length ratio (0.6 .. 0.95 of the drawn length); ``simulate_points``: the paper's fold for 1.6 s
  (~6 ms each) over the gain. 200 points each (quick: ``QUICK_POINTS``).
- Overhead per point (target < 5 ms), two ways: wall, ``(W T_cluster - T_serial) / n`` with
  ``W = 2`` workers (the worker time each point costs beyond its own computation; it also
  takes in how the other sessions' load shares the cores between our processes), and CPU,
  the CPU seconds of client, scheduler and workers beyond the serial loop's, per point.
- Times are the best of 7 alternating runs each (``timeit``'s rule: the fastest run is the
  one the other sessions on these shared cores disturbed least); quick mode runs once.
- ``scaling``: speed-up and overhead per point for 50 .. 2,000 short simulations
  (quick: ``QUICK_POINTS``).
- ``task_cost``: what one Dask task costs on this machine, whatever it computes: 200 tasks
  (quick: ``QUICK_POINTS``) that return at once (with 5 rows each, like a batch's), sent and
  collected the engine's way (two per worker in flight, results fetched with ``as_completed``): the sweep process's CPU
  (client and scheduler), the workers' CPU and the wall time, per task. The sweep benchmarks
  also run the cluster with two fixed batches of half the points (``--batch n/2``: the fewest
  tasks, no cost measurement, no balancing) beside the adaptive batches.

The machine's load average (1 min) before and after is in each row's note: these 2-core
machines are shared, and a load above 2 takes cores from the cluster and the serial loop alike.
"""

from __future__ import annotations

import contextlib
import os
import statistics
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context

from threadpoolctl import threadpool_limits

from tests.bench.harness import Context, Row, benchmark

WORKERS = 2
#: Points of every sweep in quick mode (CI's smoke run: that each benchmark runs and reports,
#: no speed proven): more than the 2 tasks per worker in flight, so a task is sent as one completes.
QUICK_POINTS = 6


def _formfind_sweep(n: int) -> dict:
    return {"name": f"t_bar_{n}", "base": {"structure": "t_bar"}, "compute": "form_find",
            "vary": {"members[top*].rest_length_ratio": {"grid": {"from": 0.6, "to": 0.95, "num": n}}},
            "results": ["iterations", "residual", "min_eigenvalue", "stable"]}


def _simulate_sweep(n: int) -> dict:
    return {"name": f"fold_{n}", "base": {"scene": "paper_fold"}, "compute": {"simulate": {"duration": 1.6}},
            "vary": {"inputs.f1.gain": {"grid": {"from": 5.0, "to": 15.0, "num": n}}},
            "results": [{"first_event_time": {"kind": "fold"}}, "t_end"]}


def _load() -> float:
    return os.getloadavg()[0]


def _cpu(pids) -> float:
    """CPU seconds (user + system) used so far by the processes ``pids``."""
    import psutil

    total = 0.0
    for pid in pids:
        t = psutil.Process(pid).cpu_times()
        total += t.user + t.system
    return total


def _compare(sweep: dict, bench: _Cluster, repeat: int, halves_too: bool = False) -> dict:
    """Serial, cluster and two-process (no engine) wall times of one sweep, each the best of
    ``repeat`` alternating runs (a burst of the other sessions' load then hits one run, not
    one side), their CPU time, and a check that serial and cluster give the same rows.
    ``halves_too``: also the cluster with two fixed batches of half the points each."""
    from tensegrity_core.sweep import load_sweep, run_sweep
    from tensegrity_core.sweep.spec import prepare
    from tensegrity_core.sweep.task import run_batch

    s = load_sweep(sweep)
    plan, points = prepare(s), s.points()
    halves = [points[0::2], points[1::2]]
    workers = [n.pid for n in bench.cluster.workers.values()]
    load0 = _load()
    best = {k: float("inf") for k in ("serial", "cluster", "halves", "ceiling", "cpu_serial", "cpu_cluster")}
    pairs, pairs_halves = [], []                         # serial / cluster of each repetition
    busy, slower, slower_plain = [], [], []              # where the time went (module docstring)
    for _ in range(repeat):
        with threadpool_limits(1):
            c0, t0 = time.process_time(), time.perf_counter()
            serial = run_sweep(s, workers=0, progress=False)
            serial_time = time.perf_counter() - t0
            best["serial"] = min(best["serial"], serial_time)
            best["cpu_serial"] = min(best["cpu_serial"], time.process_time() - c0)
        c0, w0, t0 = time.process_time(), _cpu(workers), time.perf_counter()
        table = run_sweep(s, scheduler=bench.client, progress=False)
        cluster_time = time.perf_counter() - t0
        pairs.append(serial_time / cluster_time)
        worked, alone = float(table["run_time"].sum()), float(serial["run_time"].sum())
        busy.append(worked / (WORKERS * cluster_time))
        slower.append(worked / alone)
        best["cluster"] = min(best["cluster"], cluster_time)
        best["cpu_cluster"] = min(best["cpu_cluster"], time.process_time() - c0 + _cpu(workers) - w0)
        if halves_too:
            t0 = time.perf_counter()
            run_sweep(s, scheduler=bench.client, batch=-(-len(points) // WORKERS), progress=False)
            halves_time = time.perf_counter() - t0
            pairs_halves.append(serial_time / halves_time)
            best["halves"] = min(best["halves"], halves_time)
        t0 = time.perf_counter()
        plain = list(bench.pool.map(run_batch, [plan, plan], halves))
        best["ceiling"] = min(best["ceiling"], time.perf_counter() - t0)
        slower_plain.append(sum(row["run_time"] for rows in plain for row in rows) / alone)
        assert serial.drop(columns="run_time").equals(table.drop(columns="run_time")), \
            "the cluster's rows differ from the serial loop's"
        assert set(serial["status"]) == {"ok"}, serial["message"].unique()    # every point a real computation
    n = len(serial)
    return {"n": n, **best, "point": float(serial["run_time"].mean()), "pairs": sorted(pairs),
            "pairs_halves": sorted(pairs_halves),
            "busy": sorted(busy), "slower": sorted(slower), "slower_plain": sorted(slower_plain),
            "overhead": (WORKERS * best["cluster"] - best["serial"]) / n,
            "overhead_cpu": (best["cpu_cluster"] - best["cpu_serial"]) / n, "load": (load0, _load())}


def _ratios(values: list[float], unit: str = "x") -> str:
    return " ".join(f"{x:.2f}" for x in values) + unit


def _rows(name: str, r: dict) -> list[Row]:
    note = f"{r['n']} points of {1e3 * r['point']:.3g} ms; load {r['load'][0]:.1f} -> {r['load'][1]:.1f}"
    return [
        Row("sweep", f"{name}: serial loop, {r['n']} points", r["serial"], "s", note=note),
        Row("sweep", f"{name}: embedded {WORKERS}-worker cluster, {r['n']} points", r["cluster"], "s",
            baseline=f"{name}: serial loop, {r['n']} points", target=">= 1.7x",
            note=f"{note}; each repetition's serial / cluster: {_ratios(r['pairs'])}"),
        Row("sweep", f"{name}: embedded cluster, 2 fixed batches of n/2 points, {r['n']} points", r["halves"], "s",
            baseline=f"{name}: serial loop, {r['n']} points",
            note=f"--batch {-(-r['n'] // WORKERS)}: no cost measurement, no balancing, the fewest tasks; each "
                 f"repetition's serial / cluster: {_ratios(r['pairs_halves'])}"),
        Row("sweep", f"{name}: {WORKERS} processes without an engine (the machine's ceiling), {r['n']} points",
            r["ceiling"], "s", baseline=f"{name}: serial loop, {r['n']} points",
            note="every other point in each process, one loop, nothing collected"),
        Row("sweep", f"{name}: workers busy in the points, {r['n']} points", statistics.median(r["busy"]), "",
            note=f"median of each repetition's sum of point times / (W T_cluster): {_ratios(r['busy'], '')}; "
                 f"the rest of the workers' time is the engine's (sending, waiting, the tail)"),
        Row("sweep", f"{name}: point time on the cluster / in the serial loop, {r['n']} points",
            statistics.median(r["slower"]), "",
            note=f"median of each repetition's: {_ratios(r['slower'], '')}; in the 2 plain processes "
                 f"{_ratios(r['slower_plain'], '')} (median {statistics.median(r['slower_plain']):.2f})"),
        Row("sweep", f"{name}: engine overhead per point (wall), {r['n']} points", 1e3 * r["overhead"], "ms",
            target="< 5 ms", note="(W T_cluster - T_serial) / n, W = 2 workers"),
        Row("sweep", f"{name}: engine overhead per point (CPU), {r['n']} points", 1e3 * r["overhead_cpu"], "ms",
            target="< 5 ms", note=f"CPU of client, scheduler and workers beyond the serial loop's, per point; "
                                  f"2 CPU_serial / CPU_cluster = {2 * r['cpu_serial'] / r['cpu_cluster']:.2f}x "
                                  f"(the speed-up this CPU cost allows on 2 free cores)"),
    ]


class _Cluster:
    """The embedded cluster with one client, and two plain worker processes for the ceiling,
    started (the cluster timed) and warmed once for a benchmark."""

    def __enter__(self):
        from distributed import Client

        from tensegrity_core.sweep import run_sweep
        from tensegrity_core.sweep.engine import start_local_cluster

        t0 = time.perf_counter()
        self.cluster = start_local_cluster(WORKERS)
        self.startup = time.perf_counter() - t0
        self.client = Client(self.cluster)
        self.pool = ProcessPoolExecutor(WORKERS, mp_context=get_context("spawn"))
        # import the core and touch both computations in every process before timing
        for sweep in (_simulate_sweep(4), _formfind_sweep(4)):
            run_sweep(sweep, scheduler=self.client, batch=1, progress=False)
            self._warm_pool(sweep)
        return self

    def _warm_pool(self, sweep: dict) -> None:
        from tensegrity_core.sweep import load_sweep
        from tensegrity_core.sweep.spec import prepare
        from tensegrity_core.sweep.task import run_batch

        s = load_sweep(sweep)
        plan, points = prepare(s), s.points()
        list(self.pool.map(run_batch, [plan] * len(points), [[p] for p in points]))

    def __exit__(self, *exc):
        self.pool.shutdown()
        self.client.close()
        self.cluster.close()
        return False


def _cluster(ctx: Context) -> contextlib.AbstractContextManager[_Cluster]:
    """A benchmark's started and warmed cluster: its own in full mode; in quick mode (a smoke
    run) one that the group's benchmarks share, started once."""
    if ctx.quick:
        return contextlib.nullcontext(ctx.kept("sweep cluster", _Cluster))
    return _Cluster()


@benchmark
def formfind_points(ctx: Context) -> list[Row]:
    n = QUICK_POINTS if ctx.quick else 200
    with _cluster(ctx) as c:
        r = _compare(_formfind_sweep(n), c, 1 if ctx.quick else 7, halves_too=True)
    return [Row("sweep", "embedded cluster start-up (2 workers)", c.startup, "s",
                note="LocalCluster of 2 processes on 127.0.0.1")] + _rows("form-finding (T-bar)", r)


@benchmark
def simulate_points(ctx: Context) -> list[Row]:
    n = QUICK_POINTS if ctx.quick else 200
    with _cluster(ctx) as c:
        r = _compare(_simulate_sweep(n), c, 1 if ctx.quick else 7, halves_too=True)
    return _rows("simulation (paper fold, 1.6 s)", r)


def _empty_batch(plan: object, size: int) -> list[dict]:
    """A task that computes nothing and returns ``size`` rows of a point's shape."""
    return [{"point": i, "value": 1.0, "status": "ok", "message": "", "run_time": 0.0} for i in range(size)]


@benchmark
def task_cost(ctx: Context) -> list[Row]:
    from distributed import as_completed

    from tensegrity_core.sweep import load_sweep
    from tensegrity_core.sweep.spec import prepare

    n = QUICK_POINTS if ctx.quick else 200
    plan = prepare(load_sweep(_formfind_sweep(4)))      # the 3 KB plan every task carries
    with _cluster(ctx) as c:
        workers = [w.pid for w in c.cluster.workers.values()]
        best = None
        for _ in range(1 if ctx.quick else 5):
            c0, w0, t0 = time.process_time(), _cpu(workers), time.perf_counter()
            seq = as_completed(loop=c.client.loop, with_results=True, raise_errors=False)
            for _ in range(2 * WORKERS):
                seq.add(c.client.submit(_empty_batch, plan, 5, pure=False))
            sent = 2 * WORKERS
            for fut, _rows in seq:
                fut.release()
                if sent < n:
                    seq.add(c.client.submit(_empty_batch, plan, 5, pure=False))
                    sent += 1
            got = (time.perf_counter() - t0, time.process_time() - c0, _cpu(workers) - w0)
            best = got if best is None or got[0] < best[0] else best
    wall, client_cpu, worker_cpu = (1e3 * x / n for x in best)
    note = f"{n} empty tasks, two per worker in flight, as the engine sends them; fastest of the repetitions"
    return [Row("sweep", "Dask task cost: wall per task (2 workers)", wall, "ms", note=note),
            Row("sweep", "Dask task cost: sweep process's CPU per task (client and scheduler)", client_cpu, "ms",
                note=note),
            Row("sweep", "Dask task cost: workers' CPU per task", worker_cpu, "ms", note=note)]


@benchmark
def scaling(ctx: Context) -> list[Row]:
    sizes = [QUICK_POINTS] if ctx.quick else [50, 200, 1000, 2000]
    rows, table = [], []
    with _cluster(ctx) as c:
        for n in sizes:
            r = _compare(_simulate_sweep(n), c, 1 if ctx.quick or n >= 1000 else 3)
            table.append(r)
            rows.append(Row("sweep", f"scaling: {n} simulations, speed-up", r["serial"] / r["cluster"], "x",
                            note=f"serial {r['serial']:.2f} s, cluster {r['cluster']:.2f} s, "
                                 f"no engine {r['ceiling']:.2f} s ({r['serial'] / r['ceiling']:.2f}x); "
                                 f"workers busy {statistics.median(r['busy']):.2f}, point time x"
                                 f"{statistics.median(r['slower']):.2f} of the serial loop's (plain processes "
                                 f"x{statistics.median(r['slower_plain']):.2f}); "
                                 f"load {r['load'][0]:.1f} -> {r['load'][1]:.1f}"))
            rows.append(Row("sweep", f"scaling: {n} simulations, overhead per point (wall / CPU)",
                            1e3 * r["overhead"], "ms", target="< 5 ms",
                            note=f"CPU {1e3 * r['overhead_cpu']:.3g} ms; 2 CPU_serial / CPU_cluster = "
                                 f"{2 * r['cpu_serial'] / r['cpu_cluster']:.2f}x"))
    ctx.save_json("sweep_scaling.json", table)
    return rows
