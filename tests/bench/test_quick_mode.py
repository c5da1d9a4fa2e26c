"""The benchmark harness in quick mode, as CI runs it (issue 8): every benchmark of the
project runs, the table is printed, the rows are written as JSON and the plots as PNG.

Nothing here asserts a timing (these machines are shared and noisy); it checks that the
harness works end to end and that what it reports is well formed. Each group runs in a
quick run of its own (``--only GROUP``), a test of its own and a unit of work of its own
for the suite's workers (``SHARED_FILES`` in tests/conftest.py), so the two workers share the
benchmarks and a broken benchmark is named by its group. The groups run in the test's
process (the runner's ``main``: the interpreter, its imports and the kernels are the worker's,
not started again for each of them); one group runs as the command ``python -m tests.bench``
in a process of its own instead, as a user and CI start it.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.slow, pytest.mark.ros]

ROOT = Path(__file__).resolve().parents[2]
GROUPS = sorted(p.stem.removeprefix("bench_") for p in (ROOT / "tests" / "bench").glob("bench_*.py"))
#: The plots (and the data behind them) a group's quick run writes.
PLOTS = {"precision": {"wp_paper_fold.png", "wp_stiff_fold.png", "energy_drift.png"},
         "precision_static": {"wp_formfind.png", "wp_ik.png", "wp_stiffness.png"}}


def _run_bench(args: list[str], timeout: float = 900.0) -> subprocess.CompletedProcess:
    """``python -m tests.bench ARGS`` in a session of its own; after ``timeout`` [s] the whole
    session is killed (the benchmark and every node it started: none outlives the test) and
    the test fails with what the run printed."""
    from tests.process_groups import kill_session

    proc = subprocess.Popen([sys.executable, "-m", "tests.bench", *args], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        stdout, stderr = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        kill_session(proc)
        stdout, stderr = proc.communicate()
        pytest.fail(f"python -m tests.bench {' '.join(args)} ran over {timeout:g} s; it printed:\n{stderr[-3000:]}")
    return subprocess.CompletedProcess(proc.args, proc.returncode, stdout, stderr)


#: The group the command-line test runs (in place of its run in the test's process).
COMMAND_LINE_GROUP = "hard"


@pytest.fixture
def bench_main(capsys):
    """``python -m tests.bench ARGS`` in this process: ``run(args)`` returns what the command's
    process would (exit code, stdout, stderr); the harness's mode is put back afterwards."""
    from tests.bench import harness
    from tests.bench.__main__ import main

    previous = harness.use_timing(harness.QUICK_TIMING)

    def run(args: list[str]) -> subprocess.CompletedProcess:
        capsys.readouterr()
        code = main(args)
        out, err = capsys.readouterr()
        return subprocess.CompletedProcess(["python", "-m", "tests.bench", *args], code, out, err)

    yield run
    harness.use_timing(previous)


def _quick_run_args(tmp_path: Path, group: str) -> list[str]:
    return ["--only", group, "--json", str(tmp_path / "rows.json"), "--plot-dir", str(tmp_path / "img"),
            "--data-dir", str(tmp_path / "data")]


@pytest.mark.timeout(900)            # a benchmark that hangs fails its test, as the command's run would
@pytest.mark.parametrize("group", [g for g in GROUPS if g != COMMAND_LINE_GROUP])
def test_each_group_runs_and_reports_its_rows_against_baselines_and_targets(group, tmp_path, bench_main):
    _check_quick_run(group, bench_main(_quick_run_args(tmp_path, group)), tmp_path)


def test_the_command_runs_a_group_and_reports_it(tmp_path):
    """The same run as the command ``python -m tests.bench`` starts it, in a process of its own:
    :data:`COMMAND_LINE_GROUP`'s quick run, which no test runs in its process."""
    _check_quick_run(COMMAND_LINE_GROUP, _run_bench(_quick_run_args(tmp_path, COMMAND_LINE_GROUP)), tmp_path)


def _check_quick_run(group: str, out: subprocess.CompletedProcess, tmp_path: Path) -> None:
    """What a quick run of ``group`` (:func:`_quick_run_args`) reports and writes."""
    rows_file = tmp_path / "rows.json"
    assert out.returncode == 0, out.stderr[-3000:]
    rows = json.loads(rows_file.read_text())
    # the group's own rows, numbers, baselines of its own
    assert rows and {r["group"] for r in rows} == {group}
    names = {r["name"] for r in rows}
    for r in rows:
        assert isinstance(r["value"], (int, float)), r
        if r["baseline"]:
            assert r["baseline"] in names, r
    # the table compares with the baselines
    header = next(line for line in out.stdout.splitlines() if line.startswith("group"))
    assert "vs baseline" in header
    if any(r["baseline"] and r["value"] for r in rows):
        assert re.search(r" \d+\.\d\dx( of baseline)?(  |$)", out.stdout, re.M), "no row shows a ratio to its baseline"
    # every row says whether its target was met (null: none, or one in words); the run ends
    # with the count and the missed ones
    assert all("met" in r for r in rows)
    checked = [r for r in rows if r["met"] is not None]
    assert all(r["target"] for r in checked)
    missed = sum(1 for r in checked if not r["met"])
    assert f"targets: {len(checked) - missed} met, {missed} missed of {len(checked)} checked" in out.stdout
    assert sum(line.startswith("  MISSED  ") for line in out.stdout.splitlines()) == missed
    # the plots and their data
    assert PLOTS.get(group, set()) <= {p.name for p in (tmp_path / "img").glob("*.png")}
    if group == "precision":
        data = json.loads((tmp_path / "data" / "precision_paper_fold.json").read_text())
        assert data["info"]["reference_agreement"] <= 1e-11
        assert any(p["default"] for p in data["points"])


def test_the_harness_finds_every_bench_module():
    from tests.bench import harness
    from tests.bench.__main__ import load_benchmarks

    load_benchmarks()
    assert {group for group, _ in harness.REGISTRY} == set(GROUPS)
    assert set(PLOTS) <= set(GROUPS)


def test_an_unknown_group_is_refused_naming_the_groups(capsys):
    """The runner's ``main`` in this process (its refusal is argparse's exit): the command's
    own process start is :func:`test_the_command_runs_a_group_and_reports_it`'s."""
    from tests.bench.__main__ import main

    with pytest.raises(SystemExit) as refused:
        main(["--only", "nonsense"])
    err = capsys.readouterr().err
    assert refused.value.code == 2
    assert "unknown group(s) nonsense" in err and "precision" in err


def test_quick_mode_never_writes_into_the_docs(capsys):
    """Quick mode's rough figures are refused a place under docs/ (where the full run's tracked
    table, data and plots live), before anything runs: the table there stays as it was."""
    from tests.bench.__main__ import main

    table = ROOT / "docs" / "bench" / "results.json"
    before = table.read_bytes()
    with pytest.raises(SystemExit) as refused:
        main(["--only", "class2_dyn", "--json", str(table)])
    assert refused.value.code == 2
    assert "would be written over the docs'" in capsys.readouterr().err
    assert table.read_bytes() == before


def test_the_full_run_says_where_it_writes(tmp_path, capsys, monkeypatch):
    """``--full`` names its table, data and plot folders before it runs (by default the docs'
    tracked files); a stand-in group of one row keeps the test cheap."""
    from tests.bench import harness
    from tests.bench.__main__ import load_benchmarks, main

    load_benchmarks()
    monkeypatch.setattr(harness, "REGISTRY", [("tiny", lambda ctx: [harness.Row("tiny", "one", 1.0, "s")])])
    previous = harness.use_timing(harness.FULL_TIMING)
    out = {k: tmp_path / k for k in ("rows.json", "img", "data")}
    try:
        assert main(["--full", "--only", "tiny", "--json", str(out["rows.json"]), "--plot-dir", str(out["img"]),
                     "--data-dir", str(out["data"])]) == 0
    finally:
        harness.use_timing(previous)
    err = capsys.readouterr().err
    assert (f"full mode writes the table to {out['rows.json']}, the data behind the plots into {out['data']}/ "
            f"and the plots into {out['img']}/") in err
    assert err.index("full mode writes") < err.index("== tiny")
    assert [r["name"] for r in json.loads(out["rows.json"].read_text())] == ["one"]
