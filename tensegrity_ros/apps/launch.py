"""Start several suite processes together and stop them together (``tensegrity up``).

There is no ``ros2 launch`` on these machines, so this is the suite's own small launcher:
each node runs in its own process (``tensegrity node <name> --ros-args ...``), so the
1 kHz simulator never shares an interpreter lock with service handlers. Output of every
child is prefixed with its name. Ctrl-C / SIGTERM stop every child: SIGINT first (clean
rclpy shutdown, bags finished), SIGTERM after a grace period, SIGKILL last.

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
from dataclasses import dataclass, field
from typing import TextIO

from tensegrity_ros.rclpy_utils.env import ensure_ros_environment
from tensegrity_ros.rclpy_utils.stop_signals import signals_blocked, stop_on_signals


@dataclass
class ProcessSpec:
    name: str
    argv: list[str]
    env: dict[str, str] = field(default_factory=dict)


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
    """Runs :class:`ProcessSpec` children until one is asked to stop or all have exited."""

    def __init__(self, specs: list[ProcessSpec], *, grace: float = 5.0, out: TextIO = sys.stdout) -> None:
        self.specs = specs
        self.grace = grace
        self.out = out
        self.procs: dict[str, subprocess.Popen[str]] = {}
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._reported: set[str] = set()     # children whose end was said already
        self._pumps: list[threading.Thread] = []

    def _pump(self, name: str, stream: TextIO) -> None:
        for line in iter(stream.readline, ""):
            with self._lock:
                if self.out.closed:              # the caller closed ``out`` after stop: nothing to say to
                    break
                self.out.write(f"[{name}] {line}")
                self.out.flush()
        stream.close()

    def start(self) -> None:
        env = dict(os.environ)
        ensure_ros_environment(env)
        env["PYTHONUNBUFFERED"] = "1"
        for spec in self.specs:
            with signals_blocked():
                proc = subprocess.Popen(
                    spec.argv, env={**env, **spec.env}, stdout=subprocess.PIPE,
                    stderr=subprocess.STDOUT, text=True, start_new_session=True,
                    preexec_fn=_die_with_parent,
                )
            self.procs[spec.name] = proc
            pump = threading.Thread(target=self._pump, args=(spec.name, proc.stdout), daemon=True)
            pump.start()
            self._pumps.append(pump)

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
        """Stop every child (SIGINT, then SIGTERM, then SIGKILL); 0 when every child exited 0,
        else the first other code, a child's death by a signal as 128 + its number (the
        shell's convention: a segfault is 139). Each child that did not exit 0 is named."""
        for sig, wait in ((signal.SIGINT, self.grace), (signal.SIGTERM, 2.0), (signal.SIGKILL, 2.0)):
            running = [p for p in self.procs.values() if p.poll() is None]
            if not running:
                break
            for p in running:
                try:
                    os.killpg(p.pid, sig)
                except ProcessLookupError:
                    pass
            deadline = time.monotonic() + wait
            for p in running:
                try:
                    p.wait(timeout=max(0.0, deadline - time.monotonic()))
                except subprocess.TimeoutExpired:
                    pass
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

    def _say(self, line: str) -> None:
        with self._lock:
            self.out.write(f"[launch] {line}\n")
            self.out.flush()

    def run(self) -> int:
        """Start every child, wait, stop them all; SIGINT/SIGTERM (stop requests of
        :mod:`tensegrity_ros.rclpy_utils.stop_signals`) stop them."""
        with stop_on_signals() as stop:
            # the stop escalates over grace + 4 s; give the process that long before the
            # stop deadline calls it hung
            stop.exit_deadline_s = max(stop.exit_deadline_s, self.grace + 10.0)
            stop.enter_running()
            forget = stop.on_stop(self.request_stop)
            try:
                self.start()
                return self.wait()
            finally:
                forget()
