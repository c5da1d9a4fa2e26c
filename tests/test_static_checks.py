"""The static checks that keep the code as it is laid out: ruff over the whole tree and
mypy, strict, over the packages ``[tool.mypy]`` lists (tensegrity_core, studies and
tensegrity_ros, but the modules its ``ignore_errors`` override names), both configured in
pyproject.toml and pinned in its ``test`` extra (a new release may find new things: that
arrives by a bump, not by a fresh clone).

mypy starts from a copy of the cache ``./run test``'s set-up fills once per set of dependencies
(``ensure_mypy_cache`` in ``run``): it then analyses again only what changed since, and reports
the cached findings of what did not. The copy keeps the set-up's cache as set-up left it."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def test_ruff_finds_nothing():
    r = subprocess.run([str(BIN / "ruff"), "check", "--no-cache", "--output-format", "concise", "."],
                       cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-5000:] + r.stderr[-2000:]


def test_mypy_strict_passes(tmp_path):
    cache = tmp_path / "mypy_cache"
    filled = Path(sys.prefix) / "mypy-cache"
    if filled.is_dir():          # not there when the suite runs without ./run test's set-up
        shutil.copytree(filled, cache)
    r = subprocess.run([str(BIN / "mypy"), "--cache-dir", str(cache)],
                       cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-5000:] + r.stderr[-2000:]
    assert "Success: no issues found" in r.stdout
