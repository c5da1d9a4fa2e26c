"""Benchmarks of tensegrity-ros. Run all of them with ``./run bench`` (quick) or
``./run bench --full``; see :mod:`tests.bench.harness` for how to add one."""
