"""Start/stop cycles of the suite's nodes, idle and under load, for the shutdown stress test
(tests/ros/test_shutdown_stress.py) and its benchmark (tests/bench/bench_shutdown.py).

A *cycle* starts a node as its process does (``main(argv)`` of its module: the suite's
``spin_node``: context, node, executor, stop request), lets it run a random moment, sets
the stop request (what SIGINT and SIGTERM do) and checks what the stop left behind:
``main`` returned 0, and no thread of the cycle is alive (a Python thread still inside
rclpy when the interpreter finalizes aborts the process: "terminate called without an
active exception"; :mod:`tensegrity_ros.rclpy_utils.spin_thread`). A *loaded* cycle runs a
:class:`Load` peer beside the node, on a context and a thread of its own, that keeps the
node busy while it stops (:data:`LOADS`): commands at 500 Hz and a joint-state reader for
the simulator, back-to-back ``solve_ik`` calls, ``find_form`` calls (a worker process each),
joint states at 100 Hz and a ``move_end_effector`` goal (planned on the controller's
planning thread) for the controller.

:func:`process_cycle` does the same with a real process of a node, of ``record``, ``play``
or ``up`` (started as ``up`` starts its children, stopped by SIGINT or SIGTERM).

``python -m tests.shutdown_stress CYCLES [--seed S]`` runs CYCLES cycles in one process
(the kinds in turn, idle and loaded alternately), prints one line of counts and exits
through the interpreter's normal finalization, which aborts if any cycle left a thread in
rclpy: the test checks the exit code and the output.
"""

from __future__ import annotations

import argparse
import importlib
import random
import re
import signal
import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path

SAMPLE_BAG = Path(__file__).resolve().parents[1] / "bags" / "ik_motion"
#: The node kinds: module of the node's ``main``.
NODE_MODULES = {"sim": "tensegrity_ros.nodes.sim.node", "ik": "tensegrity_ros.nodes.ik",
                "formfind": "tensegrity_ros.nodes.formfind", "controller": "tensegrity_ros.nodes.controller"}
#: Threads a stopped cycle may leave: the pool of the form-finding node's
#: MultiThreadedExecutor (idle; rclpy 7.1 never shuts that pool down, and Python's exit
#: joins its threads before finalizing) and the stop-signal watcher of the released
#: request, which ends at once (its pipe is closed).
ALLOWED_THREADS = ("ThreadPoolExecutor-", "stop_signal_watcher")


#: What keeps each kind busy in a loaded cycle (parts of :class:`Load`).
LOADS = {"sim": ("commands",), "ik": ("ik_calls",), "formfind": ("formfind_calls",),
         "controller": ("joint_states", "moves"), "record": ("commands", "joint_states"),
         "play": ("commands",), "up": ("ik_calls", "formfind_calls", "moves")}


class Load:
    """A peer that keeps the node(s) of a cycle busy, on a context and a spinning thread of
    its own, in ``namespace``. Parts: ``commands`` (actuator_forces at 500 Hz, and a reader of
    joint_states), ``ik_calls`` (solve_ik, 4 calls in flight), ``formfind_calls`` (find_form
    on the tensegrity table, 2 in flight: a worker process each), ``joint_states`` (the
    mechanism at rest, 100 Hz of simulated time), ``moves`` (a move_end_effector goal of 2 cm
    as soon as the controller is there)."""

    def __init__(self, parts: tuple[str, ...], namespace: str = "/"):
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        from tensegrity_ros.rclpy_utils.spin_thread import SpinThread

        self.context = Context()
        rclpy.init(args=[], context=self.context)
        self.node = rclpy.create_node("stress_load", namespace=namespace, context=self.context)
        self.sent: Counter = Counter()
        for part in parts:
            getattr(self, f"_{part}")()
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._spinning = SpinThread(self.executor, "stress_load", poll_s=0.05).start()

    def _commands(self) -> None:
        from rclpy.qos import QoSProfile
        from sensor_msgs.msg import JointState
        from tensegrity_msgs.msg import ActuatorForces

        pub = self.node.create_publisher(ActuatorForces, "actuator_forces", QoSProfile(depth=10))
        self.node.create_subscription(JointState, "joint_states", lambda _m: None, QoSProfile(depth=10), raw=True)

        def command() -> None:
            pub.publish(ActuatorForces(name=["f1", "f2"], force=[-0.35, 0.35]))
            self.sent["commands"] += 1

        self.node.create_timer(0.002, command)

    def _ik_calls(self) -> None:
        from tensegrity_msgs.srv import SolveIK

        self._calls(SolveIK, "solve_ik", lambda: SolveIK.Request(x=1.45, y=0.7, seed=[0.7, 0.7]), 4, 0.005)

    def _formfind_calls(self) -> None:
        from tensegrity_msgs.srv import FindForm

        from tests.hostile_requests import TABLE

        self._calls(FindForm, "find_form", lambda: FindForm.Request(structure=TABLE), 2, 0.05)

    def _calls(self, srv, name: str, request, in_flight: int, period: float) -> None:
        client = self.node.create_client(srv, name)
        pending: list = []

        def call() -> None:
            pending[:] = [f for f in pending if not f.done()]
            if client.service_is_ready() and len(pending) < in_flight:
                pending.append(client.call_async(request()))
                self.sent[name] += 1

        self.node.create_timer(period, call)

    def _joint_states(self) -> None:
        from rclpy.qos import QoSProfile
        from sensor_msgs.msg import JointState

        from tensegrity_core.class2 import forward_kinematics

        rest = forward_kinematics(0.7, 0.7)
        pub = self.node.create_publisher(JointState, "joint_states", QoSProfile(depth=10))

        def state() -> None:
            self.sent["joint_states"] += 1
            msg = JointState(name=["rho1", "rho2", "beta"], position=[rest.rho1, rest.rho2, rest.beta],
                             velocity=[0.0, 0.0, 0.0], effort=[0.0, 0.0, 0.0])
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(self.sent["joint_states"] * 10_000_000,
                                                                    1_000_000_000)
            pub.publish(msg)

        self.node.create_timer(0.01, state)

    def _moves(self) -> None:
        from rclpy.action import ActionClient
        from tensegrity_msgs.action import MoveEndEffector

        from tensegrity_core.class2 import forward_kinematics

        rest = forward_kinematics(0.7, 0.7)
        goals = ActionClient(self.node, MoveEndEffector, "move_end_effector")

        def move() -> None:
            if not self.sent["moves"] and goals.server_is_ready():
                goals.send_goal_async(MoveEndEffector.Goal(x=rest.x + 0.02, y=rest.y, duration=2.0))
                self.sent["moves"] += 1

        self.node.create_timer(0.05, move)

    def stop(self) -> None:
        import rclpy

        self._spinning.stop()
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def cycle(kind: str, loaded: bool, rng: random.Random, *, run_s: tuple[float, float] = (0.0, 0.3)) -> str:
    """One start/stop cycle of a node of ``kind`` in this process: "" when clean, else what
    went wrong (a non-zero return, threads left alive)."""
    from tensegrity_ros.rclpy_utils import stop_signals

    module = importlib.import_module(NODE_MODULES[kind])
    load = Load(LOADS[kind]) if loaded else None
    before = set(threading.enumerate())
    try:
        request = stop_signals.install()
        stopper = threading.Timer(rng.uniform(*run_s), request.set)
        stopper.start()
        try:
            code = module.main([f"tensegrity-{kind}"])
        finally:
            stopper.cancel()
            stopper.join()
            stop_signals.release()
    finally:
        if load is not None:
            load.stop()
    deadline = time.monotonic() + 2.0
    while (left := _left_threads(before)) and time.monotonic() < deadline:
        time.sleep(0.01)
    problems = [f"main returned {code}"] if code != 0 else []
    if left:
        problems.append(f"threads alive after the stop: {', '.join(sorted(left))}")
    return "; ".join(problems)


#: A real process of each kind: arguments of ``tensegrity`` ("{tmp}": a folder of the cycle)
#: and the stderr line that says it is ready.
PROCESSES = {
    "sim": (["node", "sim"], "publishing at"),
    "ik": (["node", "ik"], "solve_ik ready"),
    "formfind": (["node", "formfind"], "find_form ready"),
    "controller": (["node", "controller"], "controller ready"),
    "record": (["record", "-o", "{tmp}/bag"], "recording to"),
    "play": (["play", str(SAMPLE_BAG), "--loop"], "playing "),
    "up": (["up", "--record", "{tmp}/up_bag"], "publishing at"),
}
#: What a stopped process must not have printed (an abort, a crash report, a traceback, a
#: child of ``up`` ended by a signal or with an error code).
BAD_OUTPUT = ("terminate called", "Fatal Python error", "Traceback", "Exception ignored", "[launch] ")
#: ``up``'s hand-over to its recorder once every other child exited (tensegrity_ros/apps/launch.py).
HAND_OVER = re.compile(r"^\[launch\] [a-z, ]+ exited; stopping record$")


def process_cycle(kind: str, loaded: bool, rng: random.Random, folder: Path, env: dict) -> tuple[object, float, str]:
    """One start/stop cycle of a real process of ``kind`` (started as ``tensegrity up``
    starts its children), stopped by SIGINT or SIGTERM 0.2-1.5 s after it said it is ready,
    with a :class:`Load` peer in this process when ``loaded`` (``env``'s ROS_DOMAIN_ID must be
    this process's). ``(exit code, seconds from the signal to the exit, "" or what went
    wrong)``."""
    from tests.process_groups import exited, kill_group, wait_group
    from tests.ros_support import TENSEGRITY, spawn

    args, ready = PROCESSES[kind]
    folder.mkdir(parents=True)
    log = folder / "output.log"
    with open(log, "w") as out:
        proc = spawn([TENSEGRITY, *(a.format(tmp=folder) for a in args)], stdout=out, stderr=out, env=env)
    load = None
    try:
        deadline = time.monotonic() + 120
        while ready not in log.read_text(errors="replace"):
            if exited(proc) or time.monotonic() > deadline:
                return "never ready", 0.0, log.read_text(errors="replace")[-3000:]
            time.sleep(0.01)
        load = Load(LOADS[kind]) if loaded else None
        time.sleep(rng.uniform(0.2, 1.5))
        sig = rng.choice((signal.SIGINT, signal.SIGTERM))
        t0 = time.monotonic()
        proc.send_signal(sig)
        try:
            code: object = wait_group(proc, 60)
        except subprocess.TimeoutExpired:
            code = "no exit within 60 s"
        took = time.monotonic() - t0
    finally:
        kill_group(proc)
        if load is not None:
            load.stop()
    text = log.read_text(errors="replace")
    # up's one line of a normal stop: its children exited, the recorder is stopped last
    judged = "".join(line for line in text.splitlines(keepends=True) if not HAND_OVER.match(line))
    printed = [b for b in BAD_OUTPUT if b in judged]
    if code == 0 and not printed:
        return code, took, ""
    return code, took, f"{signal.Signals(sig).name}: exit {code}, printed {printed}\n{text[-3000:]}"


def _left_threads(before: set[threading.Thread]) -> list[str]:
    return [t.name for t in threading.enumerate()
            if t not in before and t.is_alive() and not t.name.startswith(ALLOWED_THREADS)]


def run(cycles: int, seed: int = 0, kinds: tuple[str, ...] = tuple(NODE_MODULES)) -> Counter:
    """``cycles`` cycles, the kinds in turn, idle and loaded alternately (a kind's cycles
    alternate too); a count of outcomes per (kind, idle/loaded), and every problem printed."""
    rng = random.Random(seed)
    counts: Counter = Counter()
    for k in range(cycles):
        kind = kinds[k % len(kinds)]
        loaded = bool((k // len(kinds)) % 2)
        problem = cycle(kind, loaded, rng)
        counts[(kind, "loaded" if loaded else "idle", "bad" if problem else "ok")] += 1
        if problem:
            print(f"cycle {k} ({kind}, {'loaded' if loaded else 'idle'}): {problem}", flush=True)
    return counts


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tests.shutdown_stress")
    parser.add_argument("cycles", type=int)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    from tensegrity_ros.rclpy_utils.env import ensure_ros_environment

    ensure_ros_environment()
    started = time.monotonic()
    counts = run(args.cycles, args.seed)
    bad = sum(n for key, n in counts.items() if key[2] == "bad")
    print(f"cycles {args.cycles}, bad {bad}, in {time.monotonic() - started:.1f} s; "
          + ", ".join(f"{kind} {mode} {outcome} {n}" for (kind, mode, outcome), n in sorted(counts.items())),
          flush=True)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
