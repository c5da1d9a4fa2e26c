"""The benchmark harness in quick mode, as CI runs it (issue 8): every benchmark of the
project runs, the table is printed, the rows are written as JSON and the plots as PNG.

Nothing here asserts a timing (these machines are shared and noisy); it checks that the
harness works end to end and that what it reports is well formed.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.slow, pytest.mark.ros]

ROOT = Path(__file__).resolve().parents[2]


def test_every_benchmark_runs_in_quick_mode(tmp_path):
    rows_file = tmp_path / "rows.json"
    out = subprocess.run([sys.executable, "-m", "tests.bench", "--json", str(rows_file),
                          "--plot-dir", str(tmp_path / "img"), "--data-dir", str(tmp_path / "data")],
                         cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    rows = json.loads(rows_file.read_text())
    groups = {r["group"] for r in rows}
    modules = {p.stem.removeprefix("bench_") for p in (ROOT / "tests" / "bench").glob("bench_*.py")}
    assert groups == modules
    header = next(line for line in out.stdout.splitlines() if line.startswith("group"))
    assert "vs baseline" in header
    for r in rows:
        assert isinstance(r["value"], (int, float)), r
        if r["baseline"]:
            assert any(b["name"] == r["baseline"] and b["group"] == r["group"] for b in rows), r
    pngs = {p.name for p in (tmp_path / "img").glob("*.png")}
    assert {"wp_paper_fold.png", "wp_stiff_fold.png", "energy_drift.png", "wp_formfind.png",
            "wp_ik.png", "wp_stiffness.png"} <= pngs
    data = json.loads((tmp_path / "data" / "precision_paper_fold.json").read_text())
    assert data["info"]["reference_agreement"] <= 1e-11
    assert any(p["default"] for p in data["points"])


def test_an_unknown_group_is_refused_naming_the_groups():
    out = subprocess.run([sys.executable, "-m", "tests.bench", "--only", "nonsense"], cwd=ROOT,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2
    assert "unknown group(s) nonsense" in out.stderr and "precision" in out.stderr
