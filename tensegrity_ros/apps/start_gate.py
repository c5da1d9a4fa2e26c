"""A gate that holds a launched child after its imports and before it joins the ROS graph.

``tensegrity up`` must look at the DDS graph for a suite already running in its namespace
(:mod:`tensegrity_ros.apps.suite_presence`) before any of its own nodes appears there: its
own nodes would hide a foreign suite's (same names), and a refused suite must never have
published into the running one. The look takes seconds (discovery cannot prove an
absence), and so does each child's start-up (importing rclpy, numpy, scipy, the core), so
the launcher starts its children at once, each holding at its gate, and opens the gates
once the look found nothing; a found suite closes them and the children exit 0 without
having created a ROS context, a bag or a log line.

The gate is a pipe: the launcher keeps its write end and passes the read end's file
descriptor to the child in the environment variable :data:`GATE_ENV`. One byte
:data:`OPEN` opens it; end of file (the launcher closed it, refused, or died) closes it.
A child started without the variable (by hand, by another launcher) has no gate.
"""

from __future__ import annotations

import os

#: The environment variable naming the read end of a child's gate (a file descriptor number).
GATE_ENV = "TENSEGRITY_START_GATE_FD"
#: The byte that opens a gate.
OPEN = b"1"


class Gate:
    """The launcher's side of one child's gate: :attr:`child_fd` goes to the child
    (``pass_fds`` and ``env={GATE_ENV: str(child_fd)}``), :meth:`open` or :meth:`close` once
    it has started."""

    def __init__(self) -> None:
        self.child_fd, self._write_fd = os.pipe()
        self._done = False

    def child_env(self) -> dict[str, str]:
        return {GATE_ENV: str(self.child_fd)}

    def started(self) -> None:
        """The child holds its own copy of the read end now: the launcher's is closed (a dead
        child then makes :meth:`open` fail quietly instead of filling the pipe)."""
        os.close(self.child_fd)

    def open(self) -> None:
        """Let the child start (a child that is gone already is not an error: the launcher
        sees its exit)."""
        if not self._done:
            try:
                os.write(self._write_fd, OPEN)
            except BrokenPipeError:
                pass
            self.close()

    def close(self) -> None:
        """Keep the child from starting (it exits 0); after :meth:`open`, only releases the pipe."""
        if not self._done:
            self._done = True
            os.close(self._write_fd)


def pass_gate() -> None:
    """In a launched child, after its imports and before it creates anything: block until
    the launcher opens the gate; exit 0 at once if it closes it. No gate: return at once."""
    fd = os.environ.pop(GATE_ENV, None)
    if fd is None:
        return
    with os.fdopen(int(fd), "rb", buffering=0) as gate:
        opened = gate.read(1) == OPEN
    if not opened:           # nothing was created yet: no finalization needed (nor wanted: process_exit)
        from tensegrity_ros.rclpy_utils.process_exit import end_process

        end_process(0)
