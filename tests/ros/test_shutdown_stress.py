"""Shutdown stress: many start/stop cycles end cleanly, idle and under load (issue 33).

The native aborts this guards against happened at a process's end: a Python thread still
inside rclpy when the interpreter finalizes is unwound through a ``noexcept`` pybind11
destructor ("terminate called without an active exception", SIGABRT; see
tensegrity_ros/rclpy_utils/spin_thread.py and process_exit.py). A stop must therefore
leave no thread of its own behind, every time.

- :func:`test_many_node_cycles_in_one_process`: the cheap form, the one that gives
  many cycles in CI. ``python -m tests.shutdown_stress`` starts and stops the nodes
  in turn in one process, as their processes do (``spin_node``, the stop request that
  SIGINT/SIGTERM set), idle and loaded alternately, checks after each stop that no thread
  of the cycle is alive, and at the end exits through the interpreter's normal
  finalization, which aborts if any thread was left in rclpy. ``TENSEGRITY_STRESS_CYCLES``
  (default 80: each node 10 times idle and 10 times loaded; about 0.2 s a cycle on a busy
  2-core machine) sets the number. The bugs of this kind came often: the benchmarks' echo
  server, whose spinning thread was not joined, aborted in 6 of its first 12 stops
  (docs/design/ros.md); ``./run bench --only shutdown --full`` runs 1,000 cycles.
- :func:`test_real_processes_stop_cleanly_under_load`: a few real processes (the simulator
  and form-finding nodes, ``up`` with its recorder) stopped while a peer keeps them busy. Hundreds of
  real-process cycles, idle and loaded, of every kind are the benchmark's
  (``./run bench --only shutdown --full``: tests/bench/bench_shutdown.py); the idle ones at
  random moments of a process's life are tests/ros/test_shutdown.py's.
"""

from __future__ import annotations

import os
import random
import subprocess
import sys

import pytest

from tests.shutdown_stress import process_cycle

pytestmark = [pytest.mark.ros, pytest.mark.slow]

CYCLES = int(os.environ.get("TENSEGRITY_STRESS_CYCLES", "80"))


def test_many_node_cycles_in_one_process():
    out = subprocess.run([sys.executable, "-m", "tests.shutdown_stress", str(CYCLES)], capture_output=True,
                         text=True, timeout=1200, env=dict(os.environ))
    text = out.stdout + out.stderr
    summary = [line for line in out.stdout.splitlines() if line.startswith("cycles ")]
    print(summary)
    assert out.returncode == 0, text[-5000:]
    assert summary and summary[0].startswith(f"cycles {CYCLES}, bad 0,"), text[-5000:]
    for sign in ("terminate called", "Fatal Python error", "Traceback"):
        assert sign not in text, text[-5000:]


@pytest.mark.parametrize("kind", ["sim", "formfind", "up"])
def test_real_processes_stop_cleanly_under_load(kind, tmp_path):
    """One loaded stop of the simulator (its loop and command threads busy), the form-finding
    node (requests in worker processes, the forkserver maybe still starting: a stop of
    ``up`` signals a child's whole process group) and ``up`` with its recorder."""
    code, took, problem = process_cycle(kind, True, random.Random(kind), tmp_path / "cycle", dict(os.environ))
    print(f"{kind} loaded: exit {code}, {took:.2f} s from the signal")
    assert not problem, problem
