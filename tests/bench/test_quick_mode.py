"""The benchmark harness in quick mode, as CI runs it (issue 8): every benchmark of the
project runs, the table is printed, the rows are written as JSON and the plots as PNG.

Nothing here asserts a timing (these machines are shared and noisy); it checks that the
harness works end to end and that what it reports is well formed. The harness runs once
(a module fixture, ~2 minutes); each group's rows are a test of their own, so a broken
benchmark is named by its group.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

pytestmark = [pytest.mark.slow, pytest.mark.ros]

ROOT = Path(__file__).resolve().parents[2]
GROUPS = sorted(p.stem.removeprefix("bench_") for p in (ROOT / "tests" / "bench").glob("bench_*.py"))


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    """One quick run of every benchmark: its stdout, rows and the folders it wrote."""
    tmp = tmp_path_factory.mktemp("bench")
    rows_file = tmp / "rows.json"
    out = subprocess.run([sys.executable, "-m", "tests.bench", "--json", str(rows_file),
                          "--plot-dir", str(tmp / "img"), "--data-dir", str(tmp / "data")],
                         cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    return SimpleNamespace(stdout=out.stdout, rows=json.loads(rows_file.read_text()),
                           img=tmp / "img", data=tmp / "data")


def test_the_groups_reported_are_the_bench_modules(quick_run):
    assert {r["group"] for r in quick_run.rows} == set(GROUPS)


@pytest.mark.parametrize("group", GROUPS)
def test_each_group_reports_numbers_and_baselines_of_its_own(quick_run, group):
    rows = [r for r in quick_run.rows if r["group"] == group]
    assert rows, f"group {group} reported no rows"
    names = {r["name"] for r in rows}
    for r in rows:
        assert isinstance(r["value"], (int, float)), r
        if r["baseline"]:
            assert r["baseline"] in names, r


def test_the_table_compares_with_baselines(quick_run):
    header = next(line for line in quick_run.stdout.splitlines() if line.startswith("group"))
    assert "vs baseline" in header
    assert re.search(r" \d+\.\d\dx(  |$)", quick_run.stdout, re.M), "no row shows a ratio to its baseline"


def test_the_plots_and_their_data_are_written(quick_run):
    pngs = {p.name for p in quick_run.img.glob("*.png")}
    assert {"wp_paper_fold.png", "wp_stiff_fold.png", "energy_drift.png", "wp_formfind.png",
            "wp_ik.png", "wp_stiffness.png"} <= pngs
    data = json.loads((quick_run.data / "precision_paper_fold.json").read_text())
    assert data["info"]["reference_agreement"] <= 1e-11
    assert any(p["default"] for p in data["points"])


def test_an_unknown_group_is_refused_naming_the_groups():
    out = subprocess.run([sys.executable, "-m", "tests.bench", "--only", "nonsense"], cwd=ROOT,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2
    assert "unknown group(s) nonsense" in out.stderr and "precision" in out.stderr


def test_the_targets_are_checked_and_summarised(quick_run):
    """Every row says whether its target was met (null: none, or one in words), the table
    has the verdict column and the run ends with the count and the missed ones."""
    assert all("met" in r for r in quick_run.rows)
    checked = [r for r in quick_run.rows if r["met"] is not None]
    assert checked and all(r["target"] for r in checked)
    missed = sum(1 for r in checked if not r["met"])
    assert f"targets: {len(checked) - missed} met, {missed} missed of {len(checked)} checked" in quick_run.stdout
    assert sum(line.startswith("  MISSED  ") for line in quick_run.stdout.splitlines()) == missed
