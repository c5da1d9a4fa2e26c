"""The units of work ``./run test`` spreads over its workers (tests/conftest.py): a file, a
test of :data:`SHARED_FILES` alone, the files of :data:`SAME_WORKER` together."""

from __future__ import annotations

from pathlib import Path

from tests.conftest import SAME_WORKER, SHARED_FILES, work_unit

ROOT = Path(__file__).resolve().parents[1]


def test_every_named_file_exists():
    """A renamed file would silently leave its group (or be shared no more)."""
    for file in (*SHARED_FILES, *SAME_WORKER):
        assert (ROOT / file).is_file(), file


def test_a_file_is_one_unit_a_shared_files_test_is_one_and_a_group_is_one():
    assert work_unit("tests/test_foundation.py::test_cli_help_lists_subcommands") == "tests/test_foundation.py"
    assert work_unit("tests/test_foundation.py::test_second_setup_rebuilds_nothing") == "tests/test_foundation.py"
    shared = f"{SHARED_FILES[0]}::test_the_harness_finds_every_bench_module"
    assert work_unit(shared) == shared
    units = {work_unit(f"{file}::test_x") for file in SAME_WORKER}
    assert units == set(SAME_WORKER.values())
    assert not units & {work_unit(f"tests/other_{i}.py::t") for i in range(3)}
