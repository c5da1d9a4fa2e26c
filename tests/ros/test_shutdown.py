"""Shutdown that always works (issue 12): SIGINT or SIGTERM at any moment of a process's
life ends it cleanly, exit code 0, no traceback, for every node and for ``up``,
``record`` and ``play``.

Each round starts the process as ``tensegrity up`` starts its children (own session,
signals held until its handlers are in place: :func:`tests.ros_support.spawn`) and sends
one signal (SIGINT or SIGTERM, drawn) at a moment drawn from one of four phases, in turn:

- ``start``:  0-300 ms after the spawn (interpreter start, imports, argument parsing);
- ``ready``:  the instant it says it is ready (for the simulator: at its first
  ``joint_states``, seen by a subscriber here: the moment the issue's SIGTERM failed);
- ``init``:   before the process says it is ready (ROS context, node construction, rclpy
  and DDS start-up), uniformly over the time the last round that got ready took (the
  ``ready`` round before it);
- ``steady``: 0.2-1.2 s after it is ready; not for the simulator, the form-finding node
  and ``up``, which tests/ros/test_shutdown_stress.py stops in that phase (0.2-1.5 s after
  ready) while a peer keeps them busy: the same stop, loaded.

A stop that comes while a node is being built waits for the build (the process holds a ROS
context by then), so building a node must not import libraries: the last test checks that
for the nodes that read the scene (the IK node imported the simulator package and scipy
there: 0.7 s idle, about 3 s at load average 10; a SIGINT then took up to 4.7 s).

Rounds per process kind: ``TENSEGRITY_STRESS_ROUNDS`` (default: one per phase of the kind,
both signals among them for every kind but ``up``, whose SIGINT after ready is
tests/ros/test_up.py's Ctrl-C; the shutdown benchmark and the stress test
(tests/ros/test_shutdown_stress.py) stop the processes many more times); the random draws
are seeded by the round number, so a failing round can be rerun. The times
from signal to exit are printed (``-s``) and judged by the benchmark
``tests/bench/bench_shutdown.py``, not here: a round fails only on a non-zero exit, a
traceback or an exception report, or no exit within ``HANG_S`` (then its native stacks
are in the assertion message when gdb is there).
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.process_groups import exited, kill_group, wait_group
from tests.ros_support import TENSEGRITY, spawn

pytestmark = pytest.mark.ros

PHASES = ("start", "ready", "init", "steady")
#: the kinds whose ``steady`` stop is tests/ros/test_shutdown_stress.py's (loaded)
STEADY_ELSEWHERE = ("sim", "formfind", "up")
HANG_S = 30.0
SAMPLE_BAG = Path(__file__).resolve().parents[2] / "bags" / "ik_motion"

#: kind -> (arguments, the stderr line that says it is ready)
KINDS = {
    "sim": (["node", "sim"], "publishing at"),
    "ik": (["node", "ik"], "solve_ik ready"),
    "formfind": (["node", "formfind"], "find_form ready"),
    "record": (["record", "-o", "{tmp}/bag"], "recording to"),
    "play": (["play", str(SAMPLE_BAG), "--loop"], "playing "),
    "up": (["up", "--record", "{tmp}/up_bag"], "publishing at"),
}


class FirstJointState:
    """A subscriber in this process that notes the first joint_states of the simulator."""

    def __init__(self, ctx):
        import rclpy
        from rclpy.qos import QoSProfile
        from sensor_msgs.msg import JointState

        from tensegrity_ros.rclpy_utils.raw_take import take_all

        self._take_all = take_all
        self.node = rclpy.create_node("shutdown_probe", context=ctx)
        self.sub = self.node.create_subscription(JointState, "/joint_states", lambda *_: None,
                                                 QoSProfile(depth=10), raw=True)

    def seen(self) -> bool:
        return bool(self._take_all(self.sub))

    def close(self) -> None:
        self.node.destroy_node()


def _wait_ready(proc: subprocess.Popen, log: Path, ready: str, probe, timeout: float = 90.0) -> None:
    deadline = time.monotonic() + timeout
    while True:
        if probe is not None:
            if probe.seen():
                return
        elif ready in log.read_text(errors="replace"):
            return
        if exited(proc):
            raise AssertionError(f"exited early: {log.read_text()[-2000:]}")
        if time.monotonic() > deadline:
            raise AssertionError(f"never ready: {log.read_text()[-2000:]}")
        time.sleep(0.002)


def _native_stacks(pid: int) -> str:
    try:
        return subprocess.run(["gdb", "-p", str(pid), "-batch", "-ex", "thread apply all bt 15"],
                              capture_output=True, text=True, timeout=60).stdout[-6000:]
    except (OSError, subprocess.TimeoutExpired):
        return "(no gdb)"


def _phases(kind: str) -> tuple[str, ...]:
    return tuple(p for p in PHASES if not (p == "steady" and kind in STEADY_ELSEWHERE))


def _one_round(kind: str, k: int, tmp: Path, ctx, ready_time: list[float]) -> tuple:
    rng = random.Random(f"{kind}-{k}")
    phases = _phases(kind)
    phase = phases[k % len(phases)]
    sig = rng.choice((signal.SIGINT, signal.SIGTERM))
    args, ready = KINDS[kind]
    folder = tmp / f"{kind}{k}"
    folder.mkdir()
    argv = [TENSEGRITY, *(a.format(tmp=folder) for a in args)]
    log = folder / "stderr.log"
    probe = FirstJointState(ctx) if kind == "sim" and phase == "ready" else None
    with open(log, "w") as err:
        t0 = time.monotonic()
        proc = spawn(argv, stdout=err, stderr=err, env=dict(os.environ))
        try:
            if phase == "start":
                time.sleep(rng.uniform(0.0, 0.3))
            elif phase == "init":
                time.sleep(rng.uniform(0.0, ready_time[0]))
            else:
                _wait_ready(proc, log, ready, probe)
                ready_time[0] = time.monotonic() - t0
                if phase == "steady":
                    time.sleep(rng.uniform(0.2, 1.2))
            t_signal = time.monotonic()
            proc.send_signal(sig)
            try:
                code = wait_group(proc, HANG_S)
            except subprocess.TimeoutExpired:
                code = f"no exit within {HANG_S:g} s; stacks:\n{_native_stacks(proc.pid)}"
            took = time.monotonic() - t_signal
        finally:
            kill_group(proc)
            if probe is not None:
                probe.close()
    text = log.read_text(errors="replace")
    return phase, signal.Signals(sig).name, round(t_signal - t0, 3), code, round(took, 3), text


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_a_signal_at_any_moment_stops_cleanly(kind, tmp_path, ros_context):
    ready_time = [1.0]
    results, bad = [], []
    for k in range(int(os.environ.get("TENSEGRITY_STRESS_ROUNDS", len(_phases(kind))))):
        phase, sig, at, code, took, text = _one_round(kind, k, tmp_path, ros_context, ready_time)
        results.append((phase, sig, at, code, took))
        if code != 0 or "Traceback" in text or "Exception ignored" in text:
            bad.append(f"round {k} ({phase}, {sig} at {at} s): exit {code}, stderr:\n{text[-3000:]}")
    times = [r[4] for r in results]
    print(f"\n{kind}: {len(results)} rounds, exit codes {sorted({str(r[3]) for r in results})}, "
          f"signal-to-exit max {max(times):.2f} s, median {sorted(times)[len(times) // 2]:.2f} s; "
          + "; ".join(f"{p}/{s}@{a}s->{c} in {t}s" for p, s, a, c, t in results))
    assert not bad, "\n\n".join(bad)


@pytest.mark.parametrize("module, node_class", [("tensegrity_ros.nodes.ik", "IKNode"),
                                                ("tensegrity_ros.nodes.controller", "ControllerNode")])
def test_building_a_node_imports_no_library(module, node_class):
    """In a fresh interpreter: import the node's module (what the process does before it
    runs, where a stop ends it at once), then build the node and list the modules that the
    build imported: no numpy, scipy, matplotlib nor numerical core. (The simulator node is
    not here: building it imports the simulation backend its scene names, a few modules of
    ``tensegrity_core.sim.class2``, by design.)"""
    code = (f"import sys, importlib, rclpy\n"
            f"from rclpy.signals import SignalHandlerOptions\n"
            f"module = importlib.import_module({module!r})\n"
            f"rclpy.init(signal_handler_options=SignalHandlerOptions.NO)\n"
            f"before = set(sys.modules)\n"
            f"node = module.{node_class}()\n"
            f"print(' '.join(sorted(set(sys.modules) - before)))\n"
            f"node.destroy_node(); rclpy.try_shutdown()\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         env=dict(os.environ))
    assert out.returncode == 0, out.stderr[-3000:]
    imported = out.stdout.split()
    libraries = [m for m in imported if m.split(".")[0] in ("scipy", "numpy", "matplotlib", "tensegrity_core")]
    assert not libraries, libraries


def test_a_long_running_command_leaves_no_objects_for_the_exit_collection(tmp_path):
    """When a long-running command (``node``, ``up``, ``record``, ``play``) returns, its
    process exits: the interpreter's final garbage collection would walk every object it
    holds (0.1-0.3 s of CPU per node process, about 1 CPU-s for ``up`` and its children),
    so the command line freezes them out of the collector first."""
    code = ("import gc\n"
            "from tensegrity_ros.cli import main\n"
            f"main(['play', {str(tmp_path / 'no_such_bag')!r}])\n"
            "print(len(gc.get_objects()))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         env=dict(os.environ))
    assert out.returncode == 0, out.stderr[-3000:]
    assert "does not exist" in out.stderr
    assert int(out.stdout) < 100, out.stdout
