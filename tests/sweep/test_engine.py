"""The Dask engine on real local clusters (loopback only): results independent of the worker,
a worker killed mid-sweep, a sweep killed mid-run and resumed, an unreachable scheduler.

The tests that need a running cluster, not a fresh one, share one embedded cluster (each
with a client of its own, as separate sessions would); the test that kills one of its
workers runs last on it. They come last in the module, after the tests that start clusters of
their own: the shared one lives until the module ends. It is the embedded cluster
(``start_local_cluster``), whose start ``run_sweep(workers=N)`` and the CLI's ``--workers N``
share: tests/sweep/test_cli.py starts it through the CLI."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tensegrity_core.sweep import SweepError, load_sweep, run_sweep
from tensegrity_ros.cli import main
from tests.process_groups import exited, kill_session
from tests.sweep.conftest import fold_sweep, monte_carlo_sweep

pytestmark = [pytest.mark.slow, pytest.mark.timeout(300)]


def same_rows(a, b) -> None:
    """Equal tables apart from the run times (NaN equal to NaN)."""
    import pandas as pd

    pd.testing.assert_frame_equal(a.drop(columns=["run_time"]).reset_index(drop=True),
                                  b.drop(columns=["run_time"]).reset_index(drop=True))


def listening(processes) -> set:
    import psutil

    out = set()
    for p in processes:
        try:
            out |= {(c.laddr.ip, c.laddr.port) for c in p.net_connections(kind="inet") if c.status == psutil.CONN_LISTEN}
        except psutil.NoSuchProcess:
            pass
    return out


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def cli(*args, **kw):
    return subprocess.Popen([sys.executable, "-m", "tensegrity_ros.cli", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True, **kw)


def test_an_unreachable_scheduler_is_one_error_line_naming_it_and_nothing_is_written(tmp_path, capsys):
    """The command run in this process (its ``main``): what it says and writes is the
    check, not its process (an interpreter start importing Dask and pandas)."""
    sweep = tmp_path / "s.yaml"
    sweep.write_text(json.dumps(fold_sweep()))
    address = f"tcp://127.0.0.1:{free_port()}"
    code = main(["sweep", str(sweep), "-o", str(tmp_path / "r.parquet"), "--scheduler", address,
                 "--connect-timeout", "2", "--plot", str(tmp_path / "r.png")])
    err = capsys.readouterr().err
    assert code == 1, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: cannot reach the Dask scheduler at "), err
    assert address in lines[0] and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.yaml"]


def test_a_scheduler_without_workers_is_one_error_line_after_the_connect_timeout(tmp_path, capsys):
    """A scheduler that answers but has no worker: one line naming it and the wait, exit 1,
    nothing written. The scheduler runs in this process (no worker processes to start)."""
    from distributed import LocalCluster

    sweep = tmp_path / "s.yaml"
    sweep.write_text(json.dumps(fold_sweep()))
    with LocalCluster(n_workers=0, processes=False, protocol="tcp", host="127.0.0.1",
                      dashboard_address=None) as cluster:
        code = main(["sweep", str(sweep), "-o", str(tmp_path / "r.parquet"), "--scheduler",
                     cluster.scheduler_address, "--connect-timeout", "0.5"])
    err = capsys.readouterr().err
    assert code == 1, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert lines == [f"error: the Dask scheduler at {cluster.scheduler_address!r} has no workers (waited 0.5 s): "
                     "no worker joined within 0.5 s"], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.yaml"]


def test_a_cluster_whose_workers_lack_the_package_is_refused_before_any_task(tmp_path, capsys):
    """An existing cluster (``dask scheduler`` and ``dask worker``) whose worker cannot import
    this package: one error line naming the scheduler, the worker and its ImportError, exit
    1, nothing written. (Dask would send the tasks anyway; the worker that cannot unpickle
    one closes, and the sweep waited for workers for ever.) The command runs in this process
    (its ``main``; the worker is the process that lacks the package)."""
    shadow = tmp_path / "shadow" / "tensegrity_core"
    shadow.mkdir(parents=True)
    # a remote text of many lines, long (under Dask's own cut, 10,000 characters)
    said = "no tensegrity_core on this worker\n" + ("x" * 99 + "\n") * 30
    (shadow / "__init__.py").write_text(f"raise ImportError({said!r})\n")
    work = tmp_path / "work"
    work.mkdir()
    sweep = work / "s.yaml"
    sweep.write_text(json.dumps(fold_sweep()))
    address = f"tcp://127.0.0.1:{free_port()}"
    dask = str(Path(sys.executable).with_name("dask"))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(shadow.parent), os.environ.get("PYTHONPATH")]))}
    scheduler = subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", address.rsplit(":", 1)[1],
                                  "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                 start_new_session=True)
    worker = subprocess.Popen([dask, "worker", address, "--nworkers", "1", "--nthreads", "1", "--no-dashboard"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True, env=env)
    try:
        code = main(["sweep", str(sweep), "-o", str(work / "r.parquet"), "--scheduler", address,
                     "--connect-timeout", "120"])     # waits for the scheduler and its worker
    finally:
        kill_session(worker)
        kill_session(scheduler)
    err = capsys.readouterr().err
    assert code == 1, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith(f"error: 1 of 1 workers of the Dask scheduler at {address!r} cannot run sweeps (tcp://")
    assert "ImportError: no tensegrity_core on this worker xxx" in lines[0]
    assert lines[0].endswith(f"… ({len(said.strip())} characters)); install this project with its sweep extra "
                             "there (pip install '.[sweep]')")
    assert len(lines[0]) < 500
    assert sorted(p.name for p in work.iterdir()) == ["s.yaml"]


def test_a_killed_sweep_keeps_its_finished_points_and_resume_runs_only_the_others(tmp_path):
    """The sweep's process SIGKILLed mid-run: its journal keeps the finished points, and
    resume runs only the others. The killed sweep runs its points in its own process
    (``--workers 0``): the journal is written by that process whatever engine runs the points
    (``run_sweep``'s store), and an embedded cluster's start (a worker process importing Dask
    and the core) proves nothing more here; the cluster's journal after a Ctrl-C is
    tests/sweep/test_cli.py::test_ctrl_c_ends_the_sweep_with_one_line_and_resume_runs_the_rest_once.
    The kept rows are compared with a serial run of their points alone: the rows run at the
    resume ran in this process as a serial run of all 40 would (35 more points)."""
    import pandas as pd

    doc = fold_sweep(vary={"inputs.f1.gain": {"grid": {"from": 6.0, "to": 14.0, "num": 40}}},
                     compute="simulate")
    (tmp_path / "s.yaml").write_text(json.dumps(doc))
    out = tmp_path / "r.csv"
    journal = tmp_path / "r.csv.partial.jsonl"
    proc = cli("sweep", "s.yaml", "-o", "r.csv", "--workers", "0", "--quiet", cwd=tmp_path)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not exited(proc):
            if journal.exists() and len(journal.read_text().splitlines()) >= 1 + 5:
                break
            time.sleep(0.02)
        assert not exited(proc), "the sweep ended before it could be killed"
    finally:
        kill_session(proc)
    assert not out.exists()
    lines = journal.read_text().splitlines()
    kept = {}
    for line in lines[1:]:
        try:
            row = json.loads(line)
        except json.JSONDecodeError:     # a line the kill cut short
            continue
        kept[row["point"]] = row
    assert 5 <= len(kept) < 40
    sweep = load_sweep(str(tmp_path / "s.yaml"))
    table = run_sweep(sweep, output=out, resume=True, workers=0, progress=False)
    assert table.attrs == {"ran": 40 - len(kept), "kept": len(kept)}
    assert list(table["point"]) == list(range(40)) and set(table["status"]) == {"ok"}
    for index, row in kept.items():        # the finished points were kept, not run again
        assert table["run_time"][index] == row["run_time"]
    assert not journal.exists()
    # every row is its point; the killed process's rows are what a serial run of those points
    # gives (the rows run now ran here, one after another, as a fresh serial run would)
    assert [(row["inputs.f1.gain"], row["seed"]) for _, row in table.iterrows()] == \
        [(p.values[0], p.seed) for p in sweep.points()]
    alone = run_sweep(fold_sweep(vary={"inputs.f1.gain": [row["inputs.f1.gain"] for _, row in sorted(kept.items())]},
                                 compute="simulate"), workers=0, progress=False)
    results = [c for c in table.columns if c not in ("point", "seed", "run_time", "sweep_id")]
    pd.testing.assert_frame_equal(table.loc[sorted(kept), results].reset_index(drop=True),
                                  alone[results].reset_index(drop=True))
    back = pd.read_csv(out)
    assert list(back["point"]) == list(range(40))


def test_resume_drops_a_line_cut_short_and_refuses_another_sweeps_output(tmp_path):
    out = tmp_path / "r.parquet"
    sweep = fold_sweep(vary={"inputs.f1.gain": [8.0, 9.0, 10.0, 11.0]})

    def stop_after_two(done, failed, total):
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(sweep, output=out, workers=0, progress=stop_after_two)
    journal = tmp_path / "r.parquet.partial.jsonl"
    with open(journal, "a") as fh:
        fh.write('{"point": 2, "inputs.f1.ga')         # what a kill in mid-write leaves
    table = run_sweep(sweep, output=out, resume=True, workers=0, progress=False)
    assert table.attrs == {"ran": 2, "kept": 2} and list(table["point"]) == [0, 1, 2, 3]
    again = run_sweep(sweep, output=out, resume=True, workers=0, progress=False)
    assert again.attrs == {"ran": 0, "kept": 4}
    same_rows(table, again)
    with pytest.raises(SweepError, match="comes from another sweep"):
        run_sweep({**sweep, "seed": 1}, output=out, resume=True, workers=0, progress=False)
    with pytest.raises(SweepError, match="has inputs.f1.gain = 9.0, this sweep 9.5"):
        run_sweep({**sweep, "vary": {"inputs.f1.gain": [8.0, 9.5, 10.0, 11.0]}}, output=out, resume=True,
                  workers=0, progress=False)
    more = run_sweep({**sweep, "vary": {"inputs.f1.gain": [8.0, 9.0, 10.0, 11.0, 12.0]}}, output=out,
                     resume=True, workers=0, progress=False)       # one more value: one more point run
    assert more.attrs == {"ran": 1, "kept": 4}


def test_a_ctrl_c_while_the_table_is_written_leaves_the_journal_and_no_half_written_file(tmp_path, monkeypatch):
    """The table is written to a temporary file and renamed: interrupted while writing, no
    output and no temporary file are left, and the journal still holds every point."""
    import pandas as pd

    out = tmp_path / "r.parquet"
    sweep = fold_sweep(vary={"inputs.f1.gain": [8.0, 9.0]})
    real = pd.DataFrame.to_parquet

    def cut_short(self, path, *args, **kwargs):
        Path(path).write_bytes(b"PAR1")              # a start of the file, then the Ctrl-C
        raise KeyboardInterrupt

    monkeypatch.setattr(pd.DataFrame, "to_parquet", cut_short)
    with pytest.raises(KeyboardInterrupt):
        run_sweep(sweep, output=out, workers=0, progress=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.parquet.partial.jsonl"]
    monkeypatch.setattr(pd.DataFrame, "to_parquet", real)
    assert run_sweep(sweep, output=out, resume=True, workers=0, progress=False).attrs == {"ran": 0, "kept": 2}


@pytest.fixture(scope="module")
def shared_cluster():
    """The module's embedded 2-worker cluster (``start_local_cluster``, what ``run_sweep``
    starts for ``workers=2``), its workers warmed by a sweep of the fold (they import the core
    on their first task); ``cluster.listening_before`` is what this process and its children
    listened on before it started."""
    import psutil

    from tensegrity_core.sweep.engine import start_local_cluster

    me = psutil.Process()
    before = listening([me, *me.children(recursive=True)])     # not the cluster's
    with start_local_cluster(2) as cluster:
        cluster.listening_before = before
        run_sweep(fold_sweep(), scheduler=cluster.scheduler_address, batch=1, progress=False)
        yield cluster


def test_the_embedded_cluster_gives_the_serial_results_and_listens_on_loopback_only(shared_cluster):
    """On the embedded cluster (the one ``run_sweep(workers=2)`` starts: the same
    ``start_local_cluster``; the CLI's Ctrl-C tests start it through ``--workers 2``), the rows
    of the serial run; its scheduler and workers listen on 127.0.0.1 only, no dashboard."""
    import psutil

    sweep = load_sweep(monte_carlo_sweep(samples=8))
    serial = run_sweep(sweep, workers=0, progress=False)
    me = psutil.Process()
    seen: dict = {}

    def watch(done, failed, total):
        if "sockets" not in seen:
            workers = me.children(recursive=True)
            seen["sockets"] = listening([me, *workers]) - shared_cluster.listening_before
            seen["workers"] = len([p for p in workers if "python" in p.name().lower()])

    table = run_sweep(sweep, scheduler=shared_cluster.scheduler_address, progress=watch)
    same_rows(serial, table)
    assert table.attrs["ran"] == 8 and list(table["status"]) == ["ok"] * 8
    assert seen["sockets"] and {ip for ip, _ in seen["sockets"]} == {"127.0.0.1"}, seen
    assert 8787 not in {port for _, port in seen["sockets"]}          # no dashboard
    assert seen["workers"] >= 2


def test_a_connected_client_runs_several_sweeps_and_is_left_open_for_its_owner(monkeypatch, shared_cluster):
    from distributed import Client

    from tensegrity_core.sweep import engine

    sweep = load_sweep(fold_sweep())
    serial = run_sweep(sweep, workers=0, progress=False)
    with Client(shared_cluster) as client:
        asked = []                   # the question whether a worker can run sweeps: once per worker
        run = client.run
        client.run = lambda fn, *args, **kw: asked.append(kw.get("workers")) or run(fn, *args, **kw)
        try:
            for _ in range(2):
                same_rows(serial, run_sweep(sweep, scheduler=client, progress=False))
            assert asked == [sorted(client.nthreads())]
        finally:
            del client.run
        assert client.status == "running"
        # the plan (3 KB) travelled inside the tasks; one over INLINE_PLAN_BYTES is scattered
        # to the workers once, with the same rows
        scattered = []
        scatter = client.scatter
        client.scatter = lambda data, **kw: scattered.append(data) or scatter(data, **kw)
        try:
            same_rows(serial, run_sweep(sweep, scheduler=client, progress=False))
            assert scattered == []
            monkeypatch.setattr(engine, "INLINE_PLAN_BYTES", 1000)
            same_rows(serial, run_sweep(sweep, scheduler=client, progress=False))
            assert len(scattered) == 1
        finally:
            del client.scatter
        assert client.run(lambda: 1) == {w: 1 for w in client.scheduler_info()["workers"]}
    with pytest.raises(SweepError, match="the Dask client given as the scheduler is closed, not running"):
        run_sweep(sweep, scheduler=client, progress=False)


@pytest.mark.parametrize("how", ["ctrl-c", "callback raises"])
def test_a_sweep_stopped_early_cancels_its_tasks_and_leaves_a_kept_client_free(caplog, how, shared_cluster):
    """A sweep that stops early (Ctrl-C while it waits for results, or the caller's progress
    callback raising) cancels its tasks still queued or running, even while the traceback
    (which holds the engine's futures) is kept, as an interactive session keeps the last one:
    nothing of it is left on the cluster of a client the caller keeps, the next sweep runs
    there, and nothing is logged as an error."""
    import _thread
    import logging
    import threading

    from distributed import Client

    # 5 s of the fold, ~0.07 s of CPU a point: after the first point 39 are left, ~1.4 s on each
    # worker, far more than the 0.05 s before the Ctrl-C. A task already running when the sweep
    # stops runs to its end (Dask does not cut a running task short): its points are short
    slow = fold_sweep(vary={"inputs.f1.gain": {"grid": {"from": 6.0, "to": 14.0, "num": 40}}},
                      compute="simulate")

    def stop(done, failed, total):
        if how == "callback raises":
            raise KeyboardInterrupt
        if done == 1:                        # Ctrl-C a moment later, in whatever the sweep then does
            threading.Timer(0.05, _thread.interrupt_main).start()

    def tasks_on_the_scheduler() -> int:
        return client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks))

    with Client(shared_cluster) as client:
        with pytest.raises(KeyboardInterrupt) as kept:
            run_sweep(slow, scheduler=client, progress=stop)
        deadline = time.monotonic() + 60          # a guard against a hang, not a timing
        while tasks_on_the_scheduler():
            assert time.monotonic() < deadline, "the stopped sweep's tasks are still on the cluster"
            time.sleep(0.02)
        assert set(run_sweep(fold_sweep(), scheduler=client, progress=False)["status"]) == {"ok"}
        assert kept.tb is not None
    assert not [r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR]


def test_ctrl_c_inside_a_blocking_dask_call_stops_the_sweep_when_the_call_returns(monkeypatch, shared_cluster):
    """A Ctrl-C that lands while the sweep waits in one of distributed's blocking calls before
    the client's event loop has started that call's coroutine (here: asking the cluster for
    its workers while the loop is busy) is held until the call returns, then stops the sweep
    with ``KeyboardInterrupt``; nothing is logged. Delivered at once, it made distributed's
    clean-up of the call fail on the loop (``NameError``) and log that traceback on the
    terminal, below the sweep's one line."""
    import logging
    import threading

    from distributed import Client

    from tensegrity_core.sweep import engine

    monkeypatch.setattr(engine, "THREADS_REFRESH", 0.0)    # the workers asked before every submission
    logged: list[str] = []

    class Keep(logging.Handler):
        def emit(self, record):
            logged.append(record.getMessage())

    # distributed's logging set-up stops these two at their own handlers (they do not propagate)
    loggers = [logging.getLogger(name) for name in ("tornado.application", "distributed")]
    keep = Keep(logging.ERROR)
    for logger in loggers:
        logger.addHandler(keep)
    # after the first point 39 are left (~1.4 s on each worker), far more than the 0.1 s before the Ctrl-C
    slow = fold_sweep(vary={"inputs.f1.gain": {"grid": {"from": 6.0, "to": 14.0, "num": 40}}}, compute="simulate")
    with Client(shared_cluster) as client:

        def stop(done, failed, total):
            if done == 1:   # the loop busy for 0.5 s: the next call's coroutine waits behind it
                client.loop.add_callback(time.sleep, 0.5)
                # a real SIGINT to this thread: it wakes the wait (``interrupt_main`` would not)
                threading.Timer(0.1, signal.pthread_kill, (threading.get_ident(), signal.SIGINT)).start()

        try:
            with pytest.raises(KeyboardInterrupt):
                run_sweep(slow, scheduler=client, progress=stop)
            time.sleep(0.6)                      # a failing clean-up runs once the loop is free
        finally:
            for logger in loggers:
                logger.removeHandler(keep)
        assert set(run_sweep(fold_sweep(), scheduler=client, progress=False)["status"]) == {"ok"}
    assert logged == []


def test_a_killed_workers_points_run_elsewhere_and_every_point_is_in_the_output_once(tmp_path, shared_cluster):
    # the last test on the shared cluster (its nanny restarts the killed worker meanwhile)
    import threading

    import pandas as pd
    from distributed import Client

    # 12 runs of 20 s of the paper's fold, a few tenths of a second each
    sweep = load_sweep(fold_sweep(vary={"inputs.f1.gain": {"grid": {"from": 6.0, "to": 14.0, "num": 12}}},
                                  compute={"simulate": {"duration": 20.0}}))
    out = tmp_path / "r.parquet"
    state: dict = {"kills": 0, "rerun": []}
    started, finished = threading.Event(), threading.Event()
    cluster = shared_cluster
    with Client(cluster) as watcher:
        def on_scheduler(fn):
            """``fn(scheduler)`` on the scheduler's own event loop (its state is not thread-safe)."""
            return watcher.run_on_scheduler(lambda dask_scheduler: fn(dask_scheduler))

        def rerun_after(keys, t_kill) -> list:
            return on_scheduler(lambda s: [t.key for t in s.story(*keys)
                                           if t.finish == "processing" and t.timestamp > t_kill])

        def all_done(keys) -> bool:
            return on_scheduler(lambda s: all(s.tasks.get(k) is None or s.tasks[k].state == "memory" for k in keys))

        def known(address) -> bool:
            return on_scheduler(lambda s: address in s.workers)

        def kill_busy_workers():
            """Once 2 points are in, SIGKILL a worker that runs a task, until one of the tasks it
            had is seen running again (a kill can land just after its task finished: try again)."""
            started.wait()
            while not finished.is_set() and not state["rerun"] and state["kills"] < 5:
                busy = {w: keys for w, keys in watcher.processing().items() if keys}
                nanny = next((n for n in cluster.workers.values() if n.worker_address in busy and n.pid), None)
                if nanny is None:
                    finished.wait(0.005)
                    continue
                address, keys, t_kill = nanny.worker_address, list(busy[nanny.worker_address]), time.time()
                os.kill(nanny.pid, signal.SIGKILL)
                state["kills"] += 1
                while not finished.is_set() and known(address):
                    finished.wait(0.01)                        # the scheduler drops the dead worker
                while not finished.is_set() and not state["rerun"]:
                    state["rerun"] = rerun_after(keys, t_kill)
                    if all_done(keys):
                        state["rerun"] = state["rerun"] or rerun_after(keys, t_kill)
                        break                                  # they had finished before the kill
                    finished.wait(0.01)

        killer = threading.Thread(target=kill_busy_workers)
        killer.start()
        try:
            table = run_sweep(sweep, scheduler=cluster.scheduler_address, batch=1, output=out,
                              progress=lambda done, failed, total: done >= 2 and started.set())
        finally:
            started.set()
            finished.set()
            killer.join()
    assert state["kills"] >= 1 and state["rerun"], f"no killed task was seen running again: {state}"
    back = pd.read_parquet(out)
    assert sorted(back["point"]) == list(range(12)) and list(table["point"]) == list(range(12))
    assert set(back["status"]) == {"ok"}
    same_rows(run_sweep(sweep, workers=0, progress=False), table)

