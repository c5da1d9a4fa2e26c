"""pytest's rewritten test modules written ahead (tests/assertion_cache.py): pytest takes them
with ``PYTHONDONTWRITEBYTECODE`` set, they are what it writes itself, and every test file of
the suite is among them."""

from __future__ import annotations

import marshal
import os
import subprocess
import sys
from pathlib import Path

from tests.assertion_cache import ROOT, rewritten_modules, write_missing

FAILING = "def test_sum():\n    values = [1, 2]\n    assert sum(values) == 4\n"


def _pytest(folder: Path, *args: str, write: bool) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONDONTWRITEBYTECODE", "PYTEST_ADDOPTS")}
    if not write:
        env["PYTHONDONTWRITEBYTECODE"] = "1"
    return subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-p", "no:xdist",
                           "-p", "no:randomly", "--rootdir", str(folder), *args], cwd=folder, env=env,
                          capture_output=True, text=True, timeout=120)


def _code_of(pyc: Path) -> list[bytes]:
    """The byte-code of every code object in a pytest pyc (its header is 16 bytes)."""
    out, todo = [], [marshal.loads(pyc.read_bytes()[16:])]
    while todo:
        code = todo.pop()
        out.append(code.co_code)
        todo += [c for c in code.co_consts if hasattr(c, "co_code")]
    return out


def test_pytest_takes_the_written_module_and_it_is_what_pytest_writes(tmp_path):
    own, ahead = tmp_path / "own", tmp_path / "ahead"
    for folder in (own, ahead):
        (folder / "tests").mkdir(parents=True)
        (folder / "tests" / "test_one.py").write_text(FAILING)
    assert write_missing([ahead / "tests" / "test_one.py"]) == 1
    assert write_missing([ahead / "tests" / "test_one.py"]) == 0          # up to date: not again
    (pyc,) = (ahead / "tests" / "__pycache__").glob("test_one.*-pytest-*.pyc")

    # one run (a pytest start is ~1.5 s of CPU): its report and its debug log, which says where
    # the rewritten module came from
    run = _pytest(ahead, "tests/test_one.py", f"--debug={tmp_path / 'debug.log'}", write=False)
    assert run.returncode == 1
    assert "assert 3 == 4" in run.stdout and "where 3 = sum([1, 2])" in run.stdout   # rewritten
    assert f"found cached rewritten pyc for {ahead / 'tests' / 'test_one.py'}" in (tmp_path / "debug.log").read_text()

    assert _pytest(own, "tests/test_one.py", write=True).returncode == 1
    (written,) = (own / "tests" / "__pycache__").glob("test_one.*-pytest-*.pyc")
    assert written.name == pyc.name and written.read_bytes()[:16] == pyc.read_bytes()[:16]
    assert _code_of(written) == _code_of(pyc)


def test_a_changed_source_is_written_again(tmp_path):
    test = tmp_path / "tests" / "test_one.py"
    test.parent.mkdir()
    test.write_text(FAILING)
    assert write_missing([test]) == 1
    test.write_text(FAILING.replace("4", "5"))
    assert write_missing([test]) == 1


def test_every_test_module_of_the_suite_and_every_conftest_is_written_ahead(request):
    ahead = set(rewritten_modules())
    collected = {Path(item.path) for item in request.session.items}
    assert collected <= ahead, sorted(collected - ahead)[:5]
    assert ROOT / "tests" / "conftest.py" in ahead
    assert not any("__pycache__" in p.parts for p in ahead)
