"""Start several suite processes together and stop them together (``tensegrity up``).

There is no ``ros2 launch`` on these machines, so this is the suite's own small launcher:
each node runs in its own process (``tensegrity node <name> --ros-args ...``), so the
1 kHz simulator never shares an interpreter lock with service handlers. Output of every
child is prefixed with its name. Ctrl-C / SIGTERM stop every child: SIGINT first (clean
rclpy shutdown, bags finished), SIGTERM after a grace period, SIGKILL last; a child marked
``stops_last`` (the recorder) only after every other one has exited
(:mod:`tensegrity_ros.apps.stop_order`).

Children start with SIGINT and SIGTERM blocked (:func:`tensegrity_ros.rclpy_utils.stop_signals.signals_blocked`
around the spawn); each unblocks them once its own stop handling is in place, so a stop
that comes while a child is still starting is carried out by the child, never lost or
answered with a traceback. A child that fails (exits with a code other than 0) stops the
others. The launcher exits 0 only if every child exited 0.
"""

from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TextIO

from tensegrity_ros.apps.start_gate import Gate
from tensegrity_ros.apps.stop_order import stop_bound_s, stop_in_stages, stop_stages
from tensegrity_ros.rclpy_utils.env import ensure_ros_environment
from tensegrity_ros.rclpy_utils.stop_signals import EXIT_DEADLINE_S, signals_blocked, stop_on_signals


@dataclass
class ProcessSpec:
    name: str
    argv: list[str]
    env: dict[str, str] = field(default_factory=dict)
    #: a consumer of the others' messages (the recorder): stopped only after every other child
    #: has exited, so it takes their last messages (:mod:`tensegrity_ros.apps.stop_order`)
    stops_last: bool = False


_PR_SET_PDEATHSIG = 1
#: Seconds :meth:`Launcher.stop` waits for each child's output to be written out after it exited.
PUMP_JOIN_S = 2.0


def _die_with_parent() -> None:
    """In the child before exec: get SIGTERM when the launcher dies, however it dies, so a
    killed launcher never leaves orphaned nodes behind (Linux)."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):
        pass


def _ended(name: str, code: int) -> str:
    """How child ``name`` ended, from its ``Popen.returncode`` (negative: a signal)."""
    return f"{name} was ended by {signal.Signals(-code).name}" if code < 0 else f"{name} exited with code {code}"


class Launcher:
    """Runs :class:`ProcessSpec` children until one is asked to stop or all have exited.
    ``grace`` [s]: how long a child may take to stop after SIGINT before SIGTERM; by default
    the time a suite process allows its own stop (``EXIT_DEADLINE_S``: a simulator waiting
    for its subscribers' acknowledgements takes up to 7 s, ``rclpy_utils/delivery.py``)."""

    def __init__(self, specs: list[ProcessSpec], *, grace: float = EXIT_DEADLINE_S, out: TextIO = sys.stdout) -> None:
        self.specs = specs
        self.grace = grace
        self.out = out
        self.procs: dict[str, subprocess.Popen[str]] = {}
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._reported: set[str] = set()     # children whose end was said already
        self._pumps: list[threading.Thread] = []
        self._gates: list[Gate] = []

    def _pump(self, name: str, stream: TextIO) -> None:
        for line in iter(stream.readline, ""):
            with self._lock:
                if self.out.closed:              # the caller closed ``out`` after stop: nothing to say to
                    break
                self.out.write(f"[{name}] {line}")
                self.out.flush()
        stream.close()

    def start(self, gated: bool = False) -> None:
        """Start every child; ``gated``: each holds at its start gate (after its imports,
        before it joins the ROS graph) until :meth:`open_gates` or :meth:`close_gates`
        (:mod:`tensegrity_ros.apps.start_gate`)."""
        env = dict(os.environ)
        ensure_ros_environment(env)
        env["PYTHONUNBUFFERED"] = "1"
        for spec in self.specs:
            gate = Gate() if gated else None
            with signals_blocked():
                proc = subprocess.Popen(
                    spec.argv, env={**env, **spec.env, **(gate.child_env() if gate else {})},
                    stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True,
                    preexec_fn=_die_with_parent, pass_fds=(gate.child_fd,) if gate else (),
                )
            if gate is not None:
                gate.started()
                self._gates.append(gate)
            self.procs[spec.name] = proc
            pump = threading.Thread(target=self._pump, args=(spec.name, proc.stdout), daemon=True)
            pump.start()
            self._pumps.append(pump)

    def open_gates(self) -> None:
        """Let every gated child join the ROS graph."""
        for gate in self._gates:
            gate.open()

    def close_gates(self) -> None:
        """Keep every gated child that has not passed its gate from starting: each exits 0."""
        for gate in self._gates:
            gate.close()

    def request_stop(self) -> None:
        self._stop.set()

    def wait(self) -> int:
        """Block until stop is requested, every child has exited or one has failed (exited with
        a code other than 0: a suite without one of its nodes, its simulator refusing its
        parameters, is of no use and would only look alive); stop the rest; return an exit code."""
        while not self._stop.is_set():
            alive, failed = False, False
            for name, proc in self.procs.items():
                rc = proc.poll()
                if rc is None:
                    alive = True
                elif name not in self._reported:
                    self._reported.add(name)
                    failed = failed or rc != 0
                    self._say(_ended(name, rc) + (": stopping the suite" if rc != 0 else ""))
            if not alive or failed:
                break
            self._stop.wait(0.2)
        return self.stop()

    def stop(self) -> int:
        """Stop every child (SIGINT, then SIGTERM, then SIGKILL; ``stops_last`` children after
        the others have exited, in at most :meth:`stop_bound_s`); 0 when every child exited 0,
        else the first other code, a child's death by a signal as 128 + its number (the
        shell's convention: a segfault is 139). Each child that did not exit 0 is named."""
        last = {s.name for s in self.specs if s.stops_last}
        stages = stop_stages(list(self.procs), last)
        stop_in_stages(stages, self.grace, self._signal, self._wait, self._stage_done)
        # the children's last lines are written before stop returns (a caller may close ``out``
        # then); a grandchild still holding the pipe open is not waited for beyond PUMP_JOIN_S
        for pump in self._pumps:
            pump.join(PUMP_JOIN_S)
        bad = []
        for name, p in self.procs.items():
            code = 1 if p.returncode is None else p.returncode
            if code and name not in self._reported:
                self._say(_ended(name, code))
            if code:
                bad.append(128 - code if code < 0 else code)
        return bad[0] if bad else 0

    def stop_bound_s(self) -> float:
        """Longest time [s] :meth:`stop` waits for the children to exit (their output then
        gets up to :data:`PUMP_JOIN_S` more each)."""
        return stop_bound_s(2 if any(s.stops_last for s in self.specs) else 1, self.grace)

    def _signal(self, name: str, sig: signal.Signals) -> None:
        proc = self.procs[name]
        if proc.poll() is None:
            try:
                os.killpg(proc.pid, sig)
            except ProcessLookupError:
                pass

    def _wait(self, names: list[str], timeout_s: float) -> list[str]:
        """Wait up to ``timeout_s`` for ``names`` to exit; those still running."""
        deadline = time.monotonic() + timeout_s
        for name in names:
            try:
                self.procs[name].wait(timeout=max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                pass
        return [n for n in names if self.procs[n].poll() is None]

    def _stage_done(self, stage: list[str], running: list[str]) -> None:
        """After a stage other than the last: its children's output is written out (their last
        lines come before the next stage's) and the hand-over is said."""
        last = [s.name for s in self.specs if s.stops_last]
        if not last or set(stage) <= set(last):
            return
        for name, pump in zip(self.procs, self._pumps):
            if name in stage:
                pump.join(PUMP_JOIN_S)
        stopping = ", ".join(last)
        if running:
            self._say(f"{', '.join(running)} still running after SIGKILL; stopping {stopping} anyway")
        else:
            self._say(f"{', '.join(stage)} exited; stopping {stopping}")

    def _say(self, line: str) -> None:
        with self._lock:
            self.out.write(f"[launch] {line}\n")
            self.out.flush()

    def run(self, look: Callable[[], None] | None = None) -> int:
        """Start every child, wait, stop them all; SIGINT/SIGTERM (stop requests of
        :mod:`tensegrity_ros.rclpy_utils.stop_signals`) stop them. ``look``: called once the
        children are started and held at their gates (their imports go on meanwhile); its
        return opens the gates, its exception (a refusal) closes them, waits for the children
        to exit and propagates."""
        with stop_on_signals() as stop:
            # the stop escalates in stages; give the process that long (and the children's
            # output its time) before the stop deadline calls it hung
            stop.exit_deadline_s = max(stop.exit_deadline_s,
                                       self.stop_bound_s() + PUMP_JOIN_S * len(self.specs) + 6.0)
            stop.enter_running()
            forget = stop.on_stop(self.request_stop)
            try:
                self.start(gated=look is not None)
                if look is not None:
                    try:
                        look()
                    except BaseException:
                        self.close_gates()
                        self.stop()
                        raise
                    if self._stop.is_set():          # stopped during the look: nothing starts
                        self.close_gates()
                    else:
                        self.open_gates()
                return self.wait()
            finally:
                forget()
