"""SIGINT and SIGTERM as stop requests that take effect at once, whatever the threads do.

Why the suite does not use rclpy's signal handling (rclpy 7.1, Jazzy). ``rclpy.init``
installs a C handler that chains to Python's handler (SIGINT only: Python has none for
SIGTERM) and wakes a helper thread; that thread triggers the executors' signal guard
conditions *first* and shuts every context down *afterwards*. Two ways this loses a stop:

- the guard condition wakes ``rcl_wait``; the executor sees the context still valid, finds
  no work and waits again, with no timeout, before the helper thread has shut the context
  down (a loaded machine deschedules the helper in between): nothing wakes it again. The
  ``KeyboardInterrupt`` that should have followed never comes either: CPython runs Python
  signal handlers only in the main thread, flagged through an "eval breaker" shared by all
  threads; a node's own Python thread (the simulator loop, executor pool threads) that
  reaches the flag first clears it without running the handler, and the main thread then
  blocks in ``rcl_wait`` without having looked. That is the SIGINT lost in ``rcl_wait``.
- a SIGTERM shuts the context down under a running node: whatever the main thread does
  next with it (create a publisher, build a wait set) raises ``RCLError`` (exit code 1).

Here instead (:func:`install`, :func:`stop_on_signals`): Python's C-level handler writes the signal number to
a wake-up pipe (``signal.set_wakeup_fd``) on whichever thread the kernel picked; a watcher
thread blocked on that pipe wakes at once and sets the :class:`StopRequest`, then runs the
wake-up callbacks registered with :meth:`StopRequest.on_stop` (e.g. triggering a guard
condition of the spinning node), after the flag is set, so a loop that checks the flag
after every wake-up cannot miss it. rclpy gets ``SignalHandlerOptions.NO`` and never shuts
a context down behind the node's back: the node's main function shuts down, in order.

Start-up: a signal that arrives before the handlers are installed gets Python's default
(SIGINT: ``KeyboardInterrupt``; SIGTERM: the process dies). A supervisor (``tensegrity up``,
the tests) therefore starts children with both signals blocked (:func:`signals_blocked`
around the spawn: the mask survives ``exec``); :func:`install` unblocks them once its
handlers are in place, so a signal sent at the very first instant is delivered then.

A stop that takes longer than :attr:`StopRequest.exit_deadline_s` (default
``EXIT_DEADLINE_S``) after the signal is a bug: the process prints every thread's stack
and exits with code 1 rather than living on (a hung node in a test domain could answer
later tests' requests).
"""

from __future__ import annotations

import contextlib
import faulthandler
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from types import FrameType

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
#: Seconds from the first stop signal until a process that has not exited is ended.
EXIT_DEADLINE_S = 10.0


class StopRequest:
    """Set once, by the first SIGINT/SIGTERM or by :meth:`set`; then stays set.

    Until :meth:`enter_running` the process holds nothing that needs cleaning up (it is
    importing, parsing arguments): a stop signal then ends it at once, with code 0 (it
    was stopped before it started anything), instead of after imports that can take
    seconds on a loaded machine.
    """

    def __init__(self) -> None:
        self._event = threading.Event()
        self._lock = threading.Lock()
        self._callbacks: list[Callable[[], None]] = []
        self._running = False
        self.signal: int | None = None          # the signal that set it (None: set())
        self.exit_deadline_s = EXIT_DEADLINE_S

    def enter_running(self) -> None:
        """From now on a stop is the caller's to carry out (it is about to create a ROS
        context, a bag, child processes). Call it before creating any of them."""
        with self._lock:
            self._running = True

    def is_set(self) -> bool:
        return self._event.is_set()

    def wait(self, timeout: float | None = None) -> bool:
        """Block until set or ``timeout`` s passed; True if set."""
        return self._event.wait(timeout)

    def set(self, signum: int | None = None) -> None:
        """Set the request (first call only) and run the wake-up callbacks, in this thread."""
        with self._lock:
            if self._event.is_set():
                return
            self.signal = signum
            self._event.set()
            for callback in self._callbacks:
                callback()

    def on_stop(self, callback: Callable[[], None]) -> Callable[[], None]:
        """Run ``callback`` (quick, thread-safe: e.g. a guard condition's ``trigger``) when
        the request is set, or now if it is set already. Returns a function that removes it;
        once that has returned, the callback is not running and will not run."""
        with self._lock:
            if not self._event.is_set():
                self._callbacks.append(callback)
                return lambda: self._remove(callback)
        callback()
        return lambda: None

    def _remove(self, callback: Callable[[], None]) -> None:
        with self._lock:
            if callback in self._callbacks:
                self._callbacks.remove(callback)


class _Installation:
    """The process's handlers, wake-up pipe and watcher thread (one at a time)."""

    def __init__(self) -> None:
        self.request = StopRequest()
        self._read_fd, self._write_fd = os.pipe()
        os.set_blocking(self._write_fd, False)
        self._previous = {sig: signal.signal(sig, _ignore_in_python) for sig in STOP_SIGNALS}
        self._previous_fd = signal.set_wakeup_fd(self._write_fd, warn_on_full_buffer=False)
        threading.Thread(target=self._watch, name="stop_signal_watcher", daemon=True).start()
        signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)

    def _watch(self) -> None:
        while data := os.read(self._read_fd, 64):
            for signum in data:
                if signum in STOP_SIGNALS and not self.request.is_set():
                    self._stop(signum)
        os.close(self._read_fd)

    def _stop(self, signum: int) -> None:
        request = self.request
        with request._lock:
            if not request._running:        # nothing to clean up yet: end here
                for stream in (sys.stdout, sys.stderr):
                    with contextlib.suppress(Exception):
                        stream.flush()
                os._exit(0)
        threading.Thread(target=self._deadline, args=(signum,), name="stop_deadline",
                         daemon=True).start()
        request.set(signum)

    def _deadline(self, signum: int) -> None:
        time.sleep(self.request.exit_deadline_s)
        sys.stderr.write(f"error: still running {self.request.exit_deadline_s:g} s after "
                         f"{signal.Signals(signum).name}; the stacks of all threads follow; "
                         "exiting with code 1\n")
        faulthandler.dump_traceback(all_threads=True)
        os._exit(1)

    def uninstall(self) -> None:
        # the wake-up fd first, so that no handler writes to the pipe once it is closed
        signal.set_wakeup_fd(self._previous_fd)
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        os.close(self._write_fd)          # the watcher reads EOF and ends


def _ignore_in_python(signum: int, frame: FrameType | None) -> None:
    """The Python-level handler: nothing to do (the watcher thread acts on the wake-up
    byte); it only replaces the defaults that raise KeyboardInterrupt or kill."""


_current: _Installation | None = None


def install() -> StopRequest:
    """Make SIGINT and SIGTERM set the process's :class:`StopRequest` from now on (until
    :func:`release`); idempotent. Main thread only (as ``signal.signal``). The command
    line does this first thing for its long-running ROS commands and keeps it until the
    process has exited, so a second signal during shutdown is harmless too."""
    global _current
    if threading.current_thread() is not threading.main_thread():
        raise RuntimeError("stop signals can only be installed from the main thread")
    if _current is None:
        _current = _Installation()
    return _current.request


def release() -> None:
    """Back to the handlers that were in place before :func:`install` (no-op if none)."""
    global _current
    if _current is not None:
        _current.uninstall()
        _current = None


@contextlib.contextmanager
def stop_on_signals() -> Iterator[StopRequest]:
    """Within the block SIGINT and SIGTERM set the returned :class:`StopRequest` instead of
    raising or killing. Inside an :func:`install` it shares that one; otherwise it installs
    for the block and releases at its end."""
    owner = _current is None
    request = install()
    try:
        yield request
    finally:
        if owner:
            release()


@contextlib.contextmanager
def signals_blocked() -> Iterator[None]:
    """Block SIGINT and SIGTERM in this thread for the block: a child started within it
    (fork + exec) begins with both blocked, until its :func:`install` unblocks them."""
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)
