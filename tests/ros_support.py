"""Helpers for tests that run real nodes and CLI processes over DDS on loopback.

Every test talks over real DDS on loopback (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST) in the
run's own ROS_DOMAIN_ID (both set by tests/conftest.py).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from collections import defaultdict
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from tests.process_groups import exited, kill_group, wait_exited, wait_group

if TYPE_CHECKING:
    from rclpy.context import Context
    from rclpy.executors import Executor
    from rclpy.node import Node

TENSEGRITY = str(Path(sys.executable).with_name("tensegrity"))
#: Seconds a test's process is given to end on SIGINT at the test's end before it is killed.
END_GRACE_S = 15.0


@pytest.fixture
def ros_context():
    """A private rclpy context, ended by :func:`end_context` at teardown."""
    with open_context() as ctx:
        yield ctx


@contextmanager
def open_context() -> Iterator[Context]:
    """A private rclpy context, initialised, ended by :func:`end_context` on leaving."""
    import rclpy
    from rclpy.context import Context

    ctx = Context()
    rclpy.init(args=[], context=ctx)
    try:
        yield ctx
    finally:
        end_context(ctx)


@dataclass(frozen=True)
class Probe:
    """A test's own node in a private context, with the executor that spins it."""

    context: Context
    node: Node
    executor: Executor


@contextmanager
def probe(name: str, *, multithreaded: bool = False, spin: bool = False, **node_options) -> Iterator[Probe]:
    """A node ``name`` (``node_options`` as ``rclpy.create_node`` takes them) in a private
    context (:func:`open_context`), added to a single-threaded executor (``multithreaded``: a
    ``MultiThreadedExecutor``); ``spin`` spins it on a :class:`SpinThread` until leaving, else
    the test spins it. On leaving, the spinning stops and :func:`end_context` ends the rest."""
    import rclpy
    from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor

    from tensegrity_ros.rclpy_utils.spin_thread import SpinThread

    with open_context() as ctx:
        node = rclpy.create_node(name, context=ctx, **node_options)
        executor = (MultiThreadedExecutor if multithreaded else SingleThreadedExecutor)(context=ctx)
        executor.add_node(node)
        spinner = SpinThread(executor, name).start() if spin else None
        try:
            yield Probe(ctx, node, executor)
        finally:
            if spinner is not None:
                spinner.stop()


def end_context(ctx) -> None:
    """Shut down every executor still open on ``ctx`` and destroy every node still alive in
    it, let the garbage collector take what is now unreachable, then shut the context down.

    The nodes' endpoints leave the graph before the next test's processes look for matches
    (a lingering subscription would satisfy a player's --wait-for-subscribers). The
    executors go first and are collected while the context lives: an executor left to the
    collector with its node (a reference cycle) may have its signal guard condition
    finalized before it (rclpy's ``Executor.__del__`` then reports an ``InvalidHandle``),
    and one that dies after its context has its shutdown callback removed from a list the
    context has already emptied (a ``ValueError``), both reported in whatever test runs
    next."""
    import gc

    import rclpy

    _close_executors_and_nodes(ctx)       # no reference to them is left here after it returns
    gc.collect()
    rclpy.try_shutdown(context=ctx)


def _close_executors_and_nodes(ctx) -> None:
    import gc

    from rclpy.executors import Executor
    from rclpy.node import Node

    for executor in [o for o in gc.get_objects() if isinstance(o, Executor) and o.context is ctx]:
        executor.shutdown()
    for node in [o for o in gc.get_objects() if isinstance(o, Node) and o.context is ctx]:
        node.destroy_node()


class FeedbackLog:
    """Every feedback an action server publishes, kept by goal, in order: read on the action's
    feedback topic (``<action>/_action/feedback``, ROS 2's action design) by a subscription of
    ``node``. A feedback callback is not enough: rclpy's ActionClient (Jazzy) drops a goal's
    feedback once the goal's result has come, and the result comes on another topic, so the
    feedback of the state that ended a goal can reach a client after the result and be lost."""

    def __init__(self, node, action_type, action_name: str, depth: int = 1000) -> None:
        self._changed = threading.Condition()
        self._by_goal: dict[bytes, list] = defaultdict(list)
        node.create_subscription(action_type.Impl.FeedbackMessage, f"{action_name}/_action/feedback", self._keep,
                                 depth)

    def _keep(self, msg) -> None:
        with self._changed:
            self._by_goal[bytes(msg.goal_id.uuid)].append(msg.feedback)
            self._changed.notify_all()

    def of(self, handle) -> list:
        """The feedback of the goal of ``handle`` so far."""
        with self._changed:
            return list(self._by_goal[bytes(handle.goal_id.uuid)])

    def view(self, handle) -> GoalFeedback:
        """The feedback of the goal of ``handle``, read anew at every use."""
        return GoalFeedback(self, handle)

    def until(self, handle, found, what: str, timeout: float = 60.0) -> list:
        """The goal's feedback once ``found(feedback)`` holds (another thread spins ``node``)."""
        with self._changed:
            ok = self._changed.wait_for(lambda: found(self._by_goal[bytes(handle.goal_id.uuid)]), timeout)
        assert ok, f"waited {timeout:g} s for {what}"
        return self.of(handle)


class GoalFeedback:
    """One goal's feedback in a :class:`FeedbackLog` as a sequence read anew at every use
    (``len``, iteration, indexing, truth), for waits on its growth."""

    def __init__(self, log: FeedbackLog, handle) -> None:
        self._log, self._handle = log, handle

    def __len__(self) -> int:
        return len(self._log.of(self._handle))

    def __iter__(self):
        return iter(self._log.of(self._handle))

    def __getitem__(self, i):
        return self._log.of(self._handle)[i]


def heard_by(node: Node, names: list[str], wait, timeout: float = 120.0) -> None:
    """Assert that each node of ``names`` (fully qualified) answers its ``get_parameters``
    through a client made now: proof that its participant has matched every endpoint
    ``node``'s participant made before, so that its readers take what ``node`` publishes next
    and its writers send to ``node``'s readers (a writer's own count proves its side only:
    :func:`tensegrity_ros.rclpy_utils.matching.wait_until_answered`). ``wait(future, s)``:
    ``spin_until_done`` with the test's executor, or ``wait_done`` when a thread spins."""
    from rcl_interfaces.srv import GetParameters

    from tensegrity_ros.rclpy_utils.matching import wait_until_answered

    for name in names:
        assert wait_until_answered(node, GetParameters, f"{name}/get_parameters", wait, timeout), \
            f"{name} did not answer within {timeout:g} s"


def spawn(argv: list[str], **kwargs) -> subprocess.Popen:
    """Start a child as a supervisor does (``tensegrity up``): in a session of its own
    (so :func:`kill_group` ends it with everything it started) and with SIGINT/SIGTERM
    blocked until its stop handling is in place (a signal sent at once is not lost)."""
    from tensegrity_ros.rclpy_utils.stop_signals import signals_blocked

    with signals_blocked():
        return subprocess.Popen(argv, start_new_session=True, **kwargs)


class Proc:
    """A CLI subprocess whose stderr is collected in a file."""

    def __init__(self, args: list[str], log: Path):
        self.log = log
        self._f = open(log, "w")
        self.popen = spawn([TENSEGRITY, *args], stdout=subprocess.PIPE, stderr=self._f,
                           text=True, env=dict(os.environ))

    def stderr(self) -> str:
        return self.log.read_text()

    def wait_for(self, text: str, timeout: float = 30.0, *, since: int = 0) -> None:
        """Until ``text`` is in the stderr after its first ``since`` characters."""
        deadline = time.monotonic() + timeout
        while True:
            # exit and deadline are read before the log: a process that writes ``text`` as it
            # exits (its last line) has written it by the time it is seen to have exited
            over = exited(self.popen) or time.monotonic() > deadline
            log = self.stderr()
            if text in log[since:]:
                return
            if over:
                raise AssertionError(f"never saw {text!r}; stderr:\n{log}")
            time.sleep(0.05)

    def stop(self, sig=signal.SIGINT, timeout: float = 60.0) -> int:
        if not exited(self.popen):
            self.popen.send_signal(sig)
        try:
            return wait_group(self.popen, timeout)
        finally:
            self._f.close()

    def kill(self) -> None:
        """End the process and its whole group, whatever state it is in (test teardown)."""
        kill_group(self.popen)
        self._f.close()


@pytest.fixture
def cli(tmp_path):
    procs: list[Proc] = []

    def start(*args: str, log_name: str = "proc") -> Proc:
        proc = Proc(list(args), tmp_path / f"{log_name}{len(procs)}.log")
        procs.append(proc)
        return proc

    yield start
    end_all(procs)


def end_all(procs: list[Proc]) -> None:
    """End a test's processes as a user does, with SIGINT (sent to all, then waited for), and
    kill what is left after :data:`END_GRACE_S`. A node that ends so destroys its DDS
    participant, which tells the domain at once; a SIGKILLed one stays in the graph for its
    participant's lease (~20 s), and the module's next test, in the same domain, met it: a
    new ``ActionClient`` found the dead simulator's action server ready, its goal went to
    the dead server alone, and no answer came in 30 s."""
    for p in procs:
        if not exited(p.popen):
            p.popen.send_signal(signal.SIGINT)
    for p in procs:
        try:
            wait_exited(p.popen, END_GRACE_S)
        except subprocess.TimeoutExpired:
            pass
        p.kill()


def run_cli(*args: str, timeout: float = 120.0) -> subprocess.CompletedProcess:
    return subprocess.run([TENSEGRITY, *args], capture_output=True, text=True, timeout=timeout)


def run_cli_here(*args: str) -> subprocess.CompletedProcess:
    """``tensegrity ARGS`` run in this process through the command line's ``main``, its output
    and exit code as :func:`run_cli` gives them: for tests of what a command says and does, not
    of its process (bag commands that need no ROS; short-lived ROS clients such as ``sim`` and
    ``call-ik``), a call then costs no interpreter start (~1-2 s of CPU). A ROS client uses
    rclpy's default context, which this process's tests leave alone (they use private ones),
    and ends it; the SIGINT and SIGTERM handlers a command sets are put back (a long-running
    command's, ``play`` or ``record``, held for its process's exit, are released), and the objects
    ``main`` freezes for its process's exit are unfrozen. Output rcl writes to the file
    descriptors directly is not captured: tests of what a process prints in all run
    :func:`run_cli`. An exception that escapes ``main`` fails the test."""
    import contextlib
    import gc
    import io

    from tensegrity_ros.cli import main
    from tensegrity_ros.rclpy_utils import stop_signals

    handlers = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main(list(args))
            except SystemExit as exit_:           # argparse's refusals
                code = exit_.code if isinstance(exit_.code, int) else 1
    finally:
        stop_signals.release()
        for sig, handler in handlers.items():
            signal.signal(sig, handler)
        gc.unfreeze()
    return subprocess.CompletedProcess(["tensegrity", *args], code, out.getvalue(), err.getvalue())


