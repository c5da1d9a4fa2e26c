"""Running a sweep on Dask distributed: an embedded local cluster or an existing one.

Default: an embedded ``LocalCluster`` of ``workers`` worker *processes* (one thread each, so
a point's BLAS calls never share a core with another point's), listening on 127.0.0.1 only,
no dashboard (the scheduler's small HTTP server is bound to a random loopback port). With
``scheduler=ADDRESS`` the sweep runs on an existing cluster instead (``dask scheduler`` and
``dask worker ADDRESS`` on each machine, or the same workers started by dask-jobqueue or
dask-kubernetes); its workers need this package installed. ``scheduler=client`` (a connected
``distributed.Client``) runs on that client's cluster and leaves the client open, for several
sweeps in one session without a connection each. ``workers=0`` runs the points in this
process, one after another (the baseline of the benchmarks; no Dask needed).

The base document, computation and prepared results (the :class:`~tensegrity_core.sweep.spec.Plan`)
travel inside each task when small (the shipped sweeps' plans are 3 KB), or go to every
worker once (``scatter``) when larger; tasks carry batches of points. The points go out in a
spread order and each task is sized for the worker it is sent to (a loose restriction: it
runs elsewhere if that worker is gone) by :mod:`tensegrity_core.sweep.scheduling`: one
point first, then the worker's share of the rest as the measured costs allow, so that the
sweep takes few tasks and the workers finish together. About two tasks per worker thread are
in flight. Results stream back in the order they finish (``as_completed``) and go to the
journal at once (:mod:`tensegrity_core.sweep.store`). A worker that dies takes its running
batch with it; the scheduler runs that batch again on another worker, and the client
receives each batch's result once, so every point ends in the output exactly once. A batch
whose workers die ``distributed.scheduler.allowed-failures`` times (default 3) becomes rows of
status ``lost`` (``--resume`` runs them again).
"""

from __future__ import annotations

import logging
import math
import os
import pickle
import time
import weakref
from collections import deque
from collections.abc import Callable, Generator, Hashable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final, Literal

from tensegrity_core.excerpt import LIBRARY_MESSAGE, clip
from tensegrity_core.interrupts import sigint_deferred, sigint_ignored, start_without_sigint
from tensegrity_core.sweep.connect import client_of
from tensegrity_core.sweep.errors import SweepError, require
from tensegrity_core.sweep.points import Point
from tensegrity_core.sweep.scheduling import BatchPlanner, InFlight, spread_order
from tensegrity_core.sweep.spec import Plan, Sweep, SweepSource, load_sweep, prepare
from tensegrity_core.sweep.store import Store, TableColumn, check_output_path
from tensegrity_core.sweep.task import Row, RowStatus, inputs, missing, run_batch

if TYPE_CHECKING:
    from distributed import Client, Future, LocalCluster

#: ``progress(done, failed, total)`` after each finished batch.
ProgressCallback = Callable[[int, int, int], object]

#: Tasks in flight per worker thread: one running, one queued behind it, so that a worker
#: never waits for the client between tasks.
TASKS_PER_THREAD = 2
#: A plan that pickles to fewer bytes than this travels inside every task; a larger one is
#: scattered to every worker once. Measured on the embedded cluster with a 3 KB plan: the
#: scatter is a 5 ms round trip before any task can start, and a one-point task that refers to
#: the scattered plan finished 5-7 ms later than one that carries it (pickling it: 0.1 ms).
INLINE_PLAN_BYTES = 64 * 1024
THREADS_REFRESH = 2.0               # s
#: The worker a task is sized for while the cluster has none (sent without a restriction).
ANY_WORKER: Final = ""
#: Environment of the embedded cluster's worker processes: one BLAS / OpenMP thread.
WORKER_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
#: Dask settings of the embedded cluster, whose processes exist only to run points: no
#: statistical profiler (a stack sample every 10 ms in every worker, for a dashboard it does
#: not have), the event-loop watchdog every second instead of every 20 ms, the system monitor
#: (CPU, memory and network figures for the dashboard) every 2 s instead of 0.5 s, and the
#: memory limits checked every 0.5 s instead of 0.1 s (a worker over its limit is still
#: paused, and restarted by its nanny, within half a second). Idle, the scheduler, nannies and
#: two workers cost 0.16 CPU s per second with Dask's defaults (8 % of a 2-core machine),
#: 0.037 without the profiler and watchdog, 0.018 with all four, which a short sweep would
#: otherwise pay out of its own cores.
EMBEDDED_CONFIG: Final = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "1s",
                          "distributed.admin.system-monitor.interval": "2s",
                          "distributed.worker.memory.monitor-interval": "0.5s"}
DEFAULT_CONNECT_TIMEOUT = 10.0
#: Seconds between two questions for the workers of a cluster that has none yet.
WORKER_POLL_S = 0.1
#: Run by each embedded worker process as it starts: it ignores Ctrl-C (the sweep's process
#: handles it and closes the cluster).
WORKER_PRELOAD = "tensegrity_core.sweep.worker_setup"


def default_workers() -> int:
    """The number of cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def start_local_cluster(workers: int) -> LocalCluster:
    """The embedded cluster: a ``distributed.LocalCluster`` of ``workers`` worker processes
    with one thread each, on 127.0.0.1 only, without a dashboard, one BLAS thread per worker,
    ignoring SIGINT (:mod:`~tensegrity_core.sweep.worker_setup`).
    Close it (``with start_local_cluster(2) as cluster: run_sweep(..., scheduler=cluster.scheduler_address)``)
    to reuse one cluster for several sweeps.

    It is started from a thread of its own that blocks SIGINT
    (:func:`~tensegrity_core.interrupts.start_without_sigint`):
    the cluster's threads and worker processes inherit the block. Ctrl-C in a terminal signals
    the whole foreground process group: a worker still importing Dask (before its preload
    ignores SIGINT) printed a ``KeyboardInterrupt`` traceback, and the ``KeyboardInterrupt``
    of this process, raised inside a starting cluster, left it half started, which Dask's
    exit handler then failed to close (``AssertionError: Status.init``). A Ctrl-C while the
    cluster starts is raised here once the start has ended and the cluster is closed."""
    require("distributed")
    import dask
    from distributed import LocalCluster

    def start() -> LocalCluster:
        with dask.config.set(EMBEDDED_CONFIG):    # read as the scheduler and the workers start
            return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                                dashboard_address=None, scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                                silence_logs=logging.ERROR, env=WORKER_ENV, preload=[WORKER_PRELOAD])

    return start_without_sigint(start, lambda cluster: cluster.close())


def columns_of(sweep: Sweep, plan: Plan) -> tuple[list[TableColumn], list[str]]:
    """Every column of a row with its dtype, and the columns that define a point."""
    point_cols = ["point", *(q.column for q in sweep.quantities), "seed"]
    cols: list[TableColumn] = [(c, None) for c in point_cols]
    cols += list(plan.result_columns)
    cols += [("status", "str"), ("message", "str"), ("run_time", "float"), ("sweep_id", "str")]
    return cols, point_cols


def run_sweep(sweep: SweepSource, *, output: str | Path | None = None, resume: bool = False,
              workers: int | None = None, scheduler: str | Client | None = None,
              connect_timeout: float = DEFAULT_CONNECT_TIMEOUT, batch: int | None = None,
              progress: bool | ProgressCallback = True, plan: Plan | None = None) -> Any:
    """Run ``sweep`` (anything :func:`~tensegrity_core.sweep.spec.load_sweep` takes) and return
    its table (a pandas DataFrame, one row per point, sorted by point; ``table.attrs["ran"]``
    and ``["kept"]`` count the points run now and those kept from earlier runs).

    ``output``: a ``.parquet`` or ``.csv`` path (written at the end; the journal next to it
    while running). ``resume``: keep the rows of this sweep already in ``output`` or its
    journal and run only the others. ``workers``: size of the embedded cluster (default:
    the number of cores; 0: in this process). ``scheduler``: address of an existing Dask
    scheduler (``tcp://host:8786``) instead, or a connected ``distributed.Client`` (used, and
    left open for the caller to close). ``batch``: points per task (default: adaptive).
    ``progress``: True for a progress bar on stderr, False for none, or a callable
    ``progress(done, failed, total)`` called after each finished batch. ``plan``: the sweep's
    :func:`~tensegrity_core.sweep.spec.prepare` result when the caller has it already.
    Raises :class:`~tensegrity_core.sweep.errors.SweepError` when the sweep cannot run (nothing
    is written then); points that fail are rows, never exceptions."""
    require("pandas")
    sweep = load_sweep(sweep)
    output = Path(output) if output is not None else None
    if output is not None:
        check_output_path(output)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 0):
        raise SweepError(f"workers must be an integer >= 0, got {workers!r}")
    if batch is not None and (isinstance(batch, bool) or not isinstance(batch, int) or batch < 1):
        raise SweepError(f"batch must be an integer >= 1, got {batch!r}")
    if not (isinstance(connect_timeout, (int, float)) and connect_timeout > 0):
        raise SweepError(f"connect_timeout must be a positive number of seconds, got {connect_timeout!r}")
    points = sweep.points()
    plan = plan if plan is not None else prepare(sweep)
    columns, point_cols = columns_of(sweep, plan)
    store = Store(output, sweep.sweep_id, columns, point_cols)
    done = store.previous(points) if resume else {}
    todo = [p for p in points if p.index not in done]
    rows = list(done.values())
    if not todo:
        return _with_counts(store.finish(rows), 0, len(done))
    engine = _SerialEngine() if workers == 0 and scheduler is None else _DaskEngine(
        workers if workers is not None else default_workers(), scheduler, connect_timeout)
    with engine:                       # connects first: nothing is written if that fails
        store.open(rows)
        bar = _Progress(progress, total=len(points), done=len(done),
                        failed=sum(r["status"] != RowStatus.OK for r in rows), name=sweep.name)
        results = engine.run(plan, todo, batch)
        try:
            for got in results:
                store.append(got)
                rows.extend(got)
                bar.update(got)
        finally:
            results.close()            # stopped early: the engine cancels what is still running
            bar.close()
            store.close()
        table = store.finish(rows)     # written before the cluster closes (a second or more)
    return _with_counts(table, len(todo), len(done))


def _with_counts(table: Any, ran: int, kept: int) -> Any:
    """``table.attrs``: how many points this call ran and how many it kept from earlier runs."""
    table.attrs.update(ran=ran, kept=kept)
    return table


class _Progress:
    """Points done and failed, and the time left (tqdm's estimate), or a callback."""

    def __init__(self, progress: bool | ProgressCallback, *, total: int, done: int, failed: int, name: str):
        self.callback = progress if callable(progress) else None
        self.total, self.done, self.failed = total, done, failed
        self.bar: Any = None                   # a tqdm bar
        if progress is True:
            import sys

            from tqdm import tqdm

            self.bar = tqdm(total=total, initial=done, desc=name, unit="pt", file=sys.stderr, leave=False,
                            dynamic_ncols=True, smoothing=0.1)
            self.bar.set_postfix_str(f"failed {failed}", refresh=False)

    def update(self, rows: list[Row]) -> None:
        self.done += len(rows)
        self.failed += sum(r["status"] != RowStatus.OK for r in rows)
        if self.bar is not None:
            self.bar.set_postfix_str(f"failed {self.failed}", refresh=False)
            self.bar.update(len(rows))
        if self.callback is not None:
            self.callback(self.done, self.failed, self.total)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


class _SerialEngine:
    """The points one after another in this process."""

    def __enter__(self) -> _SerialEngine:
        return self

    def __exit__(self, *exc: object) -> Literal[False]:
        return False

    def run(self, plan: Plan, points: Sequence[Point], batch: int | None) -> Generator[list[Row], None, None]:
        for p in points:
            yield run_batch(plan, [p])


class _DaskEngine:
    """An embedded LocalCluster (``scheduler=None``) or a client of an existing scheduler."""

    def __init__(self, workers: int, scheduler: str | Client | None, connect_timeout: float):
        self.workers = max(1, workers)
        self.address = scheduler
        self.timeout = float(connect_timeout)
        self.cluster: LocalCluster | None = None
        self.client: Client | None = None
        self._owns_client = True
        self._threads_of: dict[str, int] | None = None
        self._asked = 0.0

    def __enter__(self) -> _DaskEngine:
        require("distributed")
        from distributed import Client

        if isinstance(self.address, Client):
            if self.address.status != "running":
                raise SweepError(f"the Dask client given as the scheduler is {self.address.status}, not running")
            self.client, self._owns_client = self.address, False
            self._seen(_check_workers(self.client, "the given Dask client's cluster"))
            return self
        try:
            if self.address is None:
                self._start_embedded()
            else:
                self._connect(self.address)
        except BaseException:     # failed or interrupted: what has started is closed first
            self._close()
            raise
        return self

    def _start_embedded(self) -> None:
        from distributed import Client

        try:
            self.cluster = start_local_cluster(self.workers)
            with sigint_deferred():
                self.client = Client(self.cluster, timeout=self.timeout)
        except Exception as err:  # noqa: BLE001 - any start-up failure: say so
            raise SweepError(f"cannot start the local Dask cluster: {err}") from None

    def _connect(self, address: str) -> None:
        self.client = client = client_of(address, self.timeout)
        try:
            _wait_for_a_worker(client, self.timeout)
        except (TimeoutError, OSError) as err:
            raise SweepError(f"the Dask scheduler at {address!r} has no workers "
                             f"(waited {self.timeout:g} s): {err}") from None
        self._seen(_check_workers(client, f"the Dask scheduler at {address!r}"))

    def __exit__(self, *exc: object) -> Literal[False]:
        self._close()
        return False

    def _close(self) -> None:
        """Close the client and the embedded cluster, with Ctrl-C ignored meanwhile: a close
        cut short leaves nannies running, which Dask's exit handler then fails to close
        (``AssertionError: Status.running``, after waiting up to 10 s)."""
        with sigint_ignored():
            if self.client is not None and self._owns_client:
                self.client.close()
            self.client = None
            if self.cluster is not None:
                self.cluster.close()
                self.cluster = None

    def run(self, plan: Plan, points: Sequence[Point], batch: int | None) -> Generator[list[Row], None, None]:
        from distributed import as_completed

        client = self.client
        if client is None:
            raise SweepError("the Dask engine runs inside its with block (connected)")
        plan_ref: Any = plan
        if len(pickle.dumps(plan)) >= INLINE_PLAN_BYTES:
            with sigint_deferred():
                plan_ref = client.scatter(plan, broadcast=True, hash=False)
        pending = deque(spread_order(points))
        planner = BatchPlanner(batch)
        batches: dict[Hashable, tuple[list[Point], str, InFlight]] = {}   # task -> points, worker, flight
        flights: dict[str, list[InFlight]] = {}                    # worker -> its tasks, oldest first
        finished: dict[str, float] = {}                            # worker -> its last task's end

        def submit(seq: as_completed) -> None:
            threads = self._workers(client)
            waiting: set[str] = set()                 # workers whose share is in flight already
            while pending:
                free = {w: TASKS_PER_THREAD * n - len(flights.get(w, ())) for w, n in threads.items() if w not in waiting}
                worker = max(sorted(free), key=free.__getitem__, default=None)
                if worker is None or free[worker] <= 0:
                    return
                now = time.monotonic()
                size = planner.size(worker, threads, flights, finished, len(pending), now)
                if size == 0:
                    waiting.add(worker)
                    continue
                chunk = [pending.popleft() for _ in range(size)]
                # a loose restriction: another worker runs it if this one is gone
                where = {"workers": [worker], "allow_other_workers": True} if worker != ANY_WORKER else {}
                fut = client.submit(run_batch, plan_ref, chunk, pure=False, **where)
                flight = InFlight(len(chunk), now)
                batches[fut.key] = (chunk, worker, flight)
                flights.setdefault(worker, []).append(flight)
                seq.add(fut)

        # results fetched on the event loop as tasks finish (a blocking ``result()`` per task
        # costs the client another ~1 ms of CPU); a failed task's "result" is its error.
        # ``loop``: not the default client's loop, another client may be first.
        seq = as_completed(loop=client.loop, with_results=True, raise_errors=False)
        try:
            submit(seq)
            for fut, result in seq:
                chunk, worker, flight = batches.pop(fut.key)
                flights[worker] = [f for f in flights[worker] if f is not flight]
                finished[worker] = time.monotonic()
                if fut.status == "finished":
                    got = result
                    planner.record(worker, [r["run_time"] for r in got])
                else:
                    got = [_lost(plan, p, fut) for p in chunk]
                fut.release()
                yield got
                submit(seq)
        finally:
            if batches:         # abandoned (interrupted, or the caller failed): stop the rest
                _abandon(client, seq)

    def _workers(self, client: Client) -> dict[str, int]:
        """Threads of each worker of the cluster (asked again every few seconds: workers may come and go)."""
        if self._threads_of is None or time.monotonic() - self._asked > THREADS_REFRESH:
            with sigint_deferred():
                return self._seen(client.nthreads())
        return self._threads_of

    def _seen(self, nthreads: dict[str, int]) -> dict[str, int]:
        """The cluster's workers and their threads as just asked (ANY_WORKER while it has none)."""
        self._threads_of = {w: max(1, n) for w, n in nthreads.items()} or {ANY_WORKER: 1}
        self._asked = time.monotonic()
        return self._threads_of


#: Workers of each connected client's cluster that answered they can run sweeps: a client
#: kept for several sweeps asks each of its workers once, not once a sweep (a round trip of
#: 2-3 ms, against ~0.4 s for a 200-point sweep of the benchmarks).
_ABLE: weakref.WeakKeyDictionary[Client, set[str]] = weakref.WeakKeyDictionary()


def _check_workers(client: Client, cluster: str) -> dict[str, int]:
    """Refuse a cluster whose workers cannot import this package, before any task is sent:
    a Dask worker that cannot unpickle a task closes, and the sweep would then wait for
    workers that never come. Asks each worker not asked before through this client (a round
    trip of a few milliseconds); workers that join during a sweep are not asked. Returns
    the cluster's workers and their threads, as asked for this check."""
    able = _ABLE.setdefault(client, set())
    with sigint_deferred():
        nthreads = dict(client.nthreads())
    new = sorted(set(nthreads) - able)
    if not new:
        return nthreads
    # ``exec`` pickles by reference to the builtins, so even a worker without this package
    # can run the question and answer with its ImportError
    with sigint_deferred():
        answers = client.run(exec, f"import {run_batch.__module__}", {}, workers=new, on_error="return")
    bad = {worker: err for worker, err in answers.items() if isinstance(err, BaseException)}
    if bad:
        worker, err = min(bad.items())
        said = clip(" ".join(str(err).split()), LIBRARY_MESSAGE)     # a remote text: one bounded line
        raise SweepError(f"{len(bad)} of {len(answers)} workers of {cluster} cannot run sweeps "
                         f"({clip(worker, 100)}: {type(err).__name__}: {said}); install this project with its sweep extra there (pip install '.[sweep]')")
    able.update(answers)
    return nthreads


def _wait_for_a_worker(client: Client, timeout: float) -> None:
    """Return once the cluster has a worker, or raise ``TimeoutError`` after ``timeout``
    seconds. Asked every :data:`WORKER_POLL_S` in short calls (not one ``wait_for_workers``
    call) so that a Ctrl-C, held back only during a call, is answered within a poll."""
    deadline = time.monotonic() + timeout
    while True:
        with sigint_deferred():
            if client.nthreads():
                return
        if time.monotonic() >= deadline:
            raise TimeoutError(f"no worker joined within {timeout:g} s")
        time.sleep(WORKER_POLL_S)


def _abandon(client: Client, seq: Any) -> None:
    """Cancel the tasks still queued or running and stop collecting their results, so that
    closing the client does not cut a result's transfer short (Dask would log that as an
    error on the terminal); their points are not in the output (``--resume`` runs them)."""
    futures = list(seq.futures)
    seq.clear()
    try:
        with sigint_ignored():
            client.cancel(futures)
    except Exception:  # noqa: BLE001 - the cluster is already gone: nothing left to stop
        pass


def _lost(plan: Plan, point: Point, future: Future[list[Row]]) -> Row:
    """The row of a point whose batch the engine could not get run."""
    try:
        with sigint_deferred():
            err = future.exception()
        reason = f"{type(err).__name__}: {err}"
    except Exception as exc:  # noqa: BLE001 - the future itself is gone
        reason = f"{type(exc).__name__}: {exc}"
    row = inputs(plan, point)
    row.update({c: missing(t) for c, t in plan.result_columns})
    row.update(status=RowStatus.LOST, message=f"the engine could not run this point ({reason}); --resume runs it again",
               run_time=math.nan)
    return row

