"""``tensegrity sweep`` and ``tensegrity sweeps``: tables, plots, one-line errors, and the
core without the sweep's dependencies."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tensegrity_ros.cli import main
from tests.sweep.conftest import fold_sweep, monte_carlo_sweep

# among the suite's longest files: ./run test starts them first (tests/conftest.py)
pytestmark = pytest.mark.slow


def write(tmp_path, doc, name="s.yaml"):
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return str(path)


def test_sweeps_lists_the_shipped_examples(capsys):
    assert main(["sweeps", "--json"]) == 0
    rows = {r["name"]: r for r in json.loads(capsys.readouterr().out)}
    assert set(rows) == {"fold_time_kc", "fold_monte_carlo", "spine_stability", "three_bar_crawl"}
    assert rows["three_bar_crawl"]["vary"] == ["inputs.gait.time_scale", "effects[5].friction.mu_static"]
    assert rows["fold_time_kc"]["vary"] == ["model.params.k", "model.params.c"]
    assert rows["fold_monte_carlo"]["points"] == 400 and rows["spine_stability"]["compute"] == "stiffness"


# the line plot (one varied quantity) is drawn through the command by
# test_plot_without_a_file_draws_beside_the_output; its figure is checked in tests/sweep/test_plotting.py
@pytest.mark.parametrize("doc, panels", [
    (fold_sweep(vary={"inputs.f1.gain": [8.0, 10.0], "model.params.c": [0.0, 0.01, 0.1]}), "heat"),
    (monte_carlo_sweep(samples=6), "hist"),
])
def test_a_sweep_writes_its_table_and_plot(tmp_path, capsys, doc, panels):
    import pandas as pd

    out, plot = tmp_path / "r.parquet", tmp_path / "r.png"
    code = main(["sweep", write(tmp_path, doc), "-o", str(out), "--plot", str(plot), "--workers", "0", "--json"])
    summary = json.loads(capsys.readouterr().out)
    table = pd.read_parquet(out)
    assert code == 0 and summary["status"] == {"ok": len(table)} and summary["ran"] == len(table)
    assert plot.stat().st_size > 20_000 and plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert list(table.columns[:2]) == ["point", next(iter(doc["vary"])) if panels != "hist" else "k_factor"]


def test_run_time_is_plotted_when_asked_for_or_when_it_is_the_only_result(tmp_path, capsys):
    import pandas as pd

    from tensegrity_core.sweep import load_sweep
    from tensegrity_core.sweep.plotting import plotted_columns
    from tensegrity_core.sweep.spec import prepare

    doc = {**fold_sweep(), "results": ["run_time"]}
    assert plotted_columns(prepare(load_sweep(doc))) == ["run_time"]
    assert plotted_columns(prepare(load_sweep(fold_sweep())), ["run_time"]) == ["run_time"]
    plot = tmp_path / "t.png"
    assert main(["sweep", write(tmp_path, doc), "-o", str(tmp_path / "t.csv"), "--plot", str(plot),
                 "--workers", "0", "--quiet"]) == 0
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert list(pd.read_csv(tmp_path / "t.csv").columns) == ["point", "inputs.f1.gain", "seed", "status", "message",
                                                             "run_time", "sweep_id"]


def test_plot_without_a_file_draws_beside_the_output(tmp_path, capsys, monkeypatch):
    """``--plot`` without a file draws beside the output, named after it. One sweep is drawn
    through the command; the other outputs differ only in the name the command takes from
    ``default_plot_path`` (without ``-o``, the sweep's name: drawn through the command by
    test_plot_named_after_the_sweep_stays_in_the_current_folder)."""
    from pathlib import Path

    from tensegrity_ros.cli.cmd_sweep import default_plot_path

    assert default_plot_path("fold", "r.parquet") == Path("r.png")
    assert default_plot_path("fold", "out/r.csv") == Path("out/r.png")
    assert default_plot_path("fold", None) == Path("fold.png")
    monkeypatch.chdir(tmp_path)
    sweep = write(tmp_path, fold_sweep(name="fold"))
    assert main(["sweep", sweep, "-o", "r.csv", "--workers", "0", "--quiet", "--plot"]) == 0
    assert (tmp_path / "r.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "plot written to r.png" in capsys.readouterr().out


def test_plot_named_after_the_sweep_stays_in_the_current_folder(tmp_path, capsys, monkeypatch):
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    sweep = write(tmp_path, fold_sweep(name="../up/" + "x" * 300, vary={"inputs.f1.gain": [9.0, 10.0]}))
    assert main(["sweep", sweep, "--workers", "0", "--quiet", "--plot"]) == 0
    assert [p.name for p in work.iterdir()] == ["_up_" + "x" * 94 + ".png"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.yaml", "work"]


def test_failures_are_summarised_and_do_not_fail_the_command(tmp_path, capsys):
    doc = fold_sweep(vary={"model.params.k": [1.0, -1.0, -2.0]})
    assert main(["sweep", write(tmp_path, doc), "--workers", "0", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "3 points (2 invalid, 1 ok)" in out
    assert "2 invalid, e.g.: model.params.k: must be > 0 N/m, got -1.0 N/m" in out


def test_ctrl_c_ends_the_sweep_with_one_line_and_resume_runs_the_rest_once(tmp_path):
    """Ctrl-C in a terminal is SIGINT to the command's whole process group, the embedded
    cluster's workers included: exit 130, one line (no worker's traceback, no Dask error),
    no process left, the finished points in the journal; ``--resume`` runs only the others.
    The resume runs in this process (``--workers 0``): which points it runs is the journal's
    and the store's business, the same for every engine, and an embedded cluster's start (two
    worker processes, ~4-5 s of CPU) proves nothing more here."""
    import os
    import signal
    import time

    import pandas as pd

    from tests.process_groups import assert_all_end, exited, kill_group

    psutil = pytest.importorskip("psutil")
    # 20 s of the fold: ~0.3 s of CPU a point. After the first two rows (each worker's one-point
    # first task) 18 points are still to run, ~2.6 s on each of the 2 workers: the Ctrl-C, sent
    # within a poll of 20 ms, always finds the sweep running; those 18 are what the resume runs
    n = 20
    sweep = write(tmp_path, fold_sweep(vary={"inputs.f1.gain": {"grid": {"from": 6.0, "to": 14.0, "num": n}}},
                                       compute={"simulate": {"duration": 20.0}}))
    out = tmp_path / "r.parquet"
    journal = tmp_path / "r.parquet.partial.jsonl"
    proc = subprocess.Popen([sys.executable, "-m", "tensegrity_ros.cli", "sweep", sweep, "-o", str(out),
                             "--workers", "2", "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    try:
        deadline = time.monotonic() + 120     # a guard against a hang, not a timing
        while not (journal.exists() and len(journal.read_text().splitlines()) >= 3):  # header + 2 rows
            assert not exited(proc), "the sweep ended before it was interrupted"
            assert time.monotonic() < deadline, "no finished point in the journal after 120 s"
            time.sleep(0.02)
        family = psutil.Process(proc.pid).children(recursive=True)        # the cluster's processes
        os.killpg(proc.pid, signal.SIGINT)    # the leader is not reaped yet: the group is still its
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        kill_group(proc)                      # only if it is still there
    finished = [json.loads(line) for line in journal.read_text().splitlines()[1:]]
    assert proc.returncode == 130, stderr
    assert stderr.strip().splitlines() == [f"interrupted: {len(finished)} finished points kept in {journal}; "
                                           "--resume runs the others"], stderr[-3000:]
    assert not out.exists() and stdout == ""

    assert_all_end(family)  # the workers end with the cluster
    assert 2 <= len(finished) < n
    assert main(["sweep", sweep, "-o", str(out), "--resume", "--workers", "0", "--quiet"]) == 0
    table = pd.read_parquet(out)
    assert list(table["point"]) == list(range(n)) and set(table["status"]) == {"ok"}
    for row in finished:                     # kept, not run again
        assert table["run_time"][row["point"]] == row["run_time"]


def test_ctrl_c_while_the_cluster_starts_ends_with_one_line(tmp_path):
    """A Ctrl-C while the embedded cluster starts (its worker processes exist, no point has
    finished): the workers, which were importing Dask, print nothing, the cluster is closed
    as soon as its start ends (Dask's exit handler has nothing left to fail on: no
    AssertionError), exit 130 and one line; no process is left."""
    import os
    import signal
    import time

    from tests.process_groups import assert_all_end, exited, kill_group

    psutil = pytest.importorskip("psutil")
    sweep = write(tmp_path, fold_sweep(vary={"inputs.f1.gain": {"grid": {"from": 6.0, "to": 14.0, "num": 4}}}))
    out = tmp_path / "r.parquet"
    proc = subprocess.Popen([sys.executable, "-m", "tensegrity_ros.cli", "sweep", sweep, "-o", str(out),
                             "--workers", "2", "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    try:
        deadline = time.monotonic() + 120     # a guard against a hang, not a timing
        while len(family := psutil.Process(proc.pid).children(recursive=True)) < 2:   # worker processes
            assert not exited(proc), "the sweep ended before it was interrupted"
            assert time.monotonic() < deadline, "no worker process after 120 s"
            time.sleep(0.01)
        os.killpg(proc.pid, signal.SIGINT)    # the leader is not reaped yet: the group is still its
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        kill_group(proc)
    assert proc.returncode == 130, stderr
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("interrupted"), stderr[-3000:]
    assert not out.exists() and stdout == ""
    assert_all_end(family)


@pytest.mark.parametrize("args, message", [
    (["nofile.yaml"], "sweep file not found: 'nofile.yaml'"),
    (["fold_time_kx"], "neither a shipped sweep (did you mean 'fold_time_kc'?)"),
    (["fold_time_kc", "-o", "r.xlsx"], "the output must end in .parquet or .csv"),
    (["fold_time_kc", "--resume"], "--resume needs the output (-o)"),
    (["fold_time_kc", "--plot", "x.pdf"], "--plot must end in .png"),
    (["fold_time_kc", "--plot", "x.png", "--plot-result", "nope"], "no numeric result column 'nope' to plot"),
    (["fold_time_kc", "--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"], "--workers sizes the embedded"),
])
def test_bad_invocations_are_one_error_line_and_exit_2(tmp_path, capsys, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and message in err[0], err
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_a_bad_sweep_file_names_the_line(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text("base: {scene: paper_fold}\nvary:\n  model.params.kk.x: [1]\ncompute: simulate\nresults: [t_end]\n")
    assert main(["sweep", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: bad.yaml: vary.model.params.kk.x: model.params has no key 'kk' (did you mean 'k'?)")
    assert err.endswith("(line 3)")
    path.write_text("base: {scene: paper_fold}\nvary:\n  model.params.k: [1, 2]\n  model.params.cc: [0, 0.1]\n"
                    "compute: simulate\nresults: [t_end]\n")
    assert main(["sweep", str(path), "-o", str(tmp_path / "out.csv")]) == 2       # the last key's typo
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: bad.yaml: vary.model.params.cc: the base scene 'paper_fold' has no "
                          "'model.params.cc'") and "unknown key 'cc' (did you mean 'c'?)" in err
    assert err.endswith("(line 4)") and not (tmp_path / "out.csv").exists()


def test_the_core_reads_sweeps_and_runs_everything_else_without_dask_pandas_or_pyarrow():
    code = """
import sys
for name in ("dask", "distributed", "pandas", "pyarrow"):
    sys.modules[name] = None                  # as if not installed
from tensegrity_core.sweep import MissingDependencyError, load_sweep, run_sweep
from tensegrity_core.class2 import forward_kinematics
from tensegrity_ros.cli import main
assert load_sweep("fold_time_kc").n_points == 136
forward_kinematics(0.7, 0.7)
try:
    run_sweep("fold_time_kc", workers=0)
except MissingDependencyError as err:
    print(err)
sys.exit(main(["sweep", "fold_time_kc", "--workers", "0"]))
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1, proc.stderr
    assert "sweeps need the packages dask[distributed], pandas and pyarrow" in proc.stdout
    assert "pip install '.[sweep]' in the project's folder" in proc.stdout      # as the README says
    assert proc.stderr.strip().startswith("error: sweeps need the packages") and "Traceback" not in proc.stderr
