"""Ending a child's process group or session without ever signalling a stranger.

A child started with ``start_new_session=True`` leads a process group and a session whose
id is its pid. Once the child has been reaped (``Popen.wait``, ``poll`` or ``communicate``
returned its exit code) and nothing else is left in its group, that number is free: with
pid_max 32768 a test run goes through it in minutes, and a later process that starts a
session of its own (another test's node, or a ``sleep`` a test leaves on purpose) can get
it. ``os.killpg(old_pid)`` then kills that process (seen: tests/test_no_process_left.py's
deliberately leaked process killed by another test's teardown, so the run it was meant to
fail passed). So the helpers here signal a group or session only while its leader has not
been reaped: an exited child stays a zombie until reaped, and a zombie keeps its pid,
group and session ids in use.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time


def exited(popen: subprocess.Popen) -> bool:
    """Has the child exited? Unlike ``Popen.poll`` this does not reap it."""
    if popen.returncode is not None:
        return True
    try:
        return os.waitid(os.P_PID, popen.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is not None
    except ChildProcessError:       # reaped by someone else (a Popen.wait in another thread)
        return True


def wait_exited(popen: subprocess.Popen, timeout: float) -> None:
    """Wait up to ``timeout`` s for the child to exit, without reaping it; raise
    ``subprocess.TimeoutExpired`` when it has not."""
    deadline = time.monotonic() + timeout
    while not exited(popen):
        if time.monotonic() > deadline:
            raise subprocess.TimeoutExpired(popen.args, timeout)
        time.sleep(0.01)


def kill_group(popen: subprocess.Popen) -> None:
    """SIGKILL the child's whole process group (its nodes, workers, forkserver) and reap it.
    A child already reaped is left alone: its group's id may belong to a stranger now (what
    its group left behind, if anything, the run's end-of-session check reports)."""
    if popen.returncode is None:
        try:
            os.killpg(popen.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    popen.wait(30)


def wait_group(popen: subprocess.Popen, timeout: float) -> int:
    """Wait up to ``timeout`` s for the child to exit, then SIGKILL what is left of its
    group and reap it; its exit code. ``subprocess.TimeoutExpired`` (nothing killed) when
    it has not exited."""
    wait_exited(popen, timeout)
    kill_group(popen)
    return popen.returncode


def kill_session(popen: subprocess.Popen, timeout: float = 30.0) -> None:
    """SIGKILL the child and every process of its session (also those in other process
    groups, such as a Dask nanny's workers), then reap the child. The child must not have
    been reaped yet (see the module's docstring)."""
    import psutil

    assert popen.returncode is None, "kill_session needs the child unreaped (use exited(), not poll())"
    sid = popen.pid
    try:
        os.killpg(sid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    wait_exited(popen, timeout)       # a zombie now: the session id stays ours until it is reaped
    deadline = time.monotonic() + timeout
    while True:
        left = []
        for p in psutil.process_iter():
            try:
                if p.pid != sid and os.getsid(p.pid) == sid:
                    p.kill()
                    left.append(p)
            except (ProcessLookupError, PermissionError, psutil.NoSuchProcess):
                pass
        if not left or time.monotonic() > deadline:
            break
        time.sleep(0.1)
    popen.wait()
    assert not left, f"processes of the killed session left: {left}"


def assert_all_end(processes: list, timeout: float = 30.0) -> None:
    """Wait up to ``timeout`` s for every one of ``processes`` (``psutil.Process``, taken
    while they ran: a pid reused since does not count) to end; a zombie has ended. Fail
    naming the pids left."""
    import psutil

    def running(process: psutil.Process) -> bool:
        try:
            return process.is_running() and process.status() != psutil.STATUS_ZOMBIE
        except psutil.NoSuchProcess:
            return False

    deadline = time.monotonic() + timeout
    while left := [p.pid for p in processes if running(p)]:
        assert time.monotonic() < deadline, f"left behind: {left}"
        time.sleep(0.05)
