"""How fast the suite's processes stop (``python -m tests.bench --only shutdown [--full]``).

Each process is started as ``tensegrity up`` starts its children, waited for until it is
ready, left running for 0.5 s, and sent SIGINT or SIGTERM (alternating); reported: the
time from the signal to the process's exit, median and maximum per kind. Claim: every
stop within 2 s, exit code 0. Baseline, measured in the same run: a bare rclpy service
node (``tests/bench/ros_echo_server.py``, rclpy's own signal handling) stopped by SIGINT,
what ROS itself costs to shut down here.

Quick mode (CI's smoke run): 1 round of the bare node and of the simulator (every kind's
stops are tests/ros/test_shutdown.py's); full mode: 10 rounds of every kind.
"""

from __future__ import annotations

import contextlib
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tests.bench.harness import Context, Row, benchmark
from tests.process_groups import exited, kill_group, wait_group

TENSEGRITY = str(Path(sys.executable).with_name("tensegrity"))
SAMPLE_BAG = Path(__file__).resolve().parents[2] / "bags" / "ik_motion"
KINDS = {
    "node sim": (["node", "sim"], "publishing at"),
    "node ik": (["node", "ik"], "solve_ik ready"),
    "node formfind": (["node", "formfind"], "find_form ready"),
    "record": (["record", "-o", "{tmp}/bag"], "recording to"),
    "play": (["play", str(SAMPLE_BAG), "--loop"], "playing "),
    "up": (["up", "--record", "{tmp}/up_bag"], "publishing at"),
}


def _stop_time(argv: list[str], ready: str, sig: int, env: dict, held: bool = True) -> tuple[float, int]:
    """Seconds from ``sig`` to the exit of ``argv`` (started ``held`` as ``up`` starts its
    children: signals blocked until the suite's handling is in place), and its exit code."""
    from tensegrity_ros.rclpy_utils.stop_signals import signals_blocked

    with tempfile.TemporaryDirectory() as tmp:
        argv = [a.format(tmp=tmp) for a in argv]
        log = Path(tmp) / "log"
        with open(log, "w") as out, (signals_blocked() if held else contextlib.nullcontext()):
            proc = subprocess.Popen(argv, stdout=out, stderr=out, env=env, start_new_session=True)
        try:
            deadline = time.monotonic() + 120
            while ready not in log.read_text(errors="replace"):
                if exited(proc) or time.monotonic() > deadline:
                    raise RuntimeError(f"{argv} did not become ready: {log.read_text()[-500:]}")
                time.sleep(0.01)
            time.sleep(0.5)
            t0 = time.monotonic()
            proc.send_signal(sig)
            code = wait_group(proc, 60)
            return time.monotonic() - t0, code
        finally:
            kill_group(proc)


@benchmark
def stop_after_a_signal(ctx: Context) -> list[Row]:
    env = dict(os.environ)
    rounds = 1 if ctx.quick else 10
    bare = [_stop_time([sys.executable, "-m", "tests.bench.ros_echo_server"], "echo ready",
                       signal.SIGINT, env, held=False)[0] for _ in range(rounds)]
    rows = [Row("shutdown", "bare rclpy node, SIGINT to exit, median", statistics.median(bare), "s")]
    for name, (args, ready) in KINDS.items():
        if ctx.quick and name != "node sim":
            continue
        results = [_stop_time([TENSEGRITY, *args], ready, (signal.SIGINT, signal.SIGTERM)[k % 2], env)
                   for k in range(rounds)]
        times = [t for t, _ in results]
        codes = sorted({c for _, c in results})
        rows += [
            Row("shutdown", f"{name}: signal to exit, median", statistics.median(times), "s",
                baseline="bare rclpy node, SIGINT to exit, median", target="< 2 s",
                note=f"{rounds} rounds, exit codes {codes}"),
            Row("shutdown", f"{name}: signal to exit, max", max(times), "s", target="< 2 s"),
        ]
    return rows


@benchmark
def stress(ctx: Context) -> list[Row]:
    """Start/stop cycles that must all end cleanly (tests/shutdown_stress.py): in one process
    through each node's main, idle and loaded alternately (quick 8: each kind idle and loaded
    once, tests/ros/test_shutdown_stress.py runs 80; full 1,000); and real processes of every
    kind stopped by SIGINT or SIGTERM 0.2-1.5 s after they are ready, idle and under a load
    peer (quick: the simulator once each; full: every kind 25 times each). Claim: no cycle with
    a non-zero exit, a thread left alive, an abort or a traceback."""
    import random

    from tests.shutdown_stress import PROCESSES

    env = dict(os.environ)
    cycles = 8 if ctx.quick else 1000
    t0 = time.monotonic()
    out = subprocess.run([sys.executable, "-m", "tests.shutdown_stress", str(cycles)], capture_output=True,
                         text=True, env=env, timeout=7200)
    summary = next((line for line in out.stdout.splitlines() if line.startswith("cycles ")), "")
    if summary and out.returncode in (0, 1) and "terminate called" not in out.stderr:
        bad = int(summary.split("bad ")[1].split(",")[0])
    else:                     # the process itself ended badly: no cycle counts as clean
        bad = cycles
        print(f"   in-process cycles: exit {out.returncode}\n{out.stderr[-3000:]}", file=sys.stderr)
    rows = [Row("shutdown", "in-process node cycles with a problem", float(bad), "cycles", target="== 0",
                note=f"{cycles} cycles (sim, ik, formfind, controller; idle and loaded) in "
                     f"{time.monotonic() - t0:.0f} s, exit code {out.returncode}")]
    rounds, kinds = (1, ("sim",)) if ctx.quick else (25, tuple(PROCESSES))
    return rows + _real_cycles(kinds, rounds, random.Random(0), env)


def _real_cycles(kinds, rounds: int, rng, env: dict) -> list[Row]:
    from tests.shutdown_stress import process_cycle

    rows = []
    with tempfile.TemporaryDirectory(prefix="bench_stress_") as tmp:
        for kind in kinds:
            results = {mode: [process_cycle(kind, mode == "loaded", rng, Path(tmp) / f"{kind}_{mode}_{k}", env)
                              for k in range(rounds)] for mode in ("idle", "loaded")}
            failed = {mode: sum(1 for _, _, problem in r if problem) for mode, r in results.items()}
            for problems in results.values():
                for _, _, problem in problems:
                    if problem:
                        print(f"   {kind}: {problem[:2000]}", file=sys.stderr)
            took = [t for r in results.values() for _, t, _ in r]
            rows.append(Row("shutdown", f"real {kind} cycles with a problem", float(sum(failed.values())), "cycles",
                            target="== 0", note=f"{rounds} idle ({failed['idle']} bad) + {rounds} loaded "
                                                f"({failed['loaded']} bad); signal to exit at most {max(took):.2f} s"))
    return rows
