"""Ctrl-C (SIGINT) around library calls: where it may interrupt, where it waits, where it
is ignored.

A ``KeyboardInterrupt`` is raised wherever the main thread happens to be, and some library
code does not survive one in its middle:

- a Dask cluster being started (:func:`start_without_sigint`): an interrupt inside the
  start leaves it half started, which Dask's exit handler then fails to close;
- a blocking call of a ``distributed.Client`` (:func:`sigint_deferred`): ``Client.sync``
  waits for a coroutine on the client's event loop, and a ``KeyboardInterrupt`` that lands in
  that wait before the loop has started the coroutine makes its clean-up fail on the loop
  (distributed 2026.11: ``NameError: cannot access free variable 'future'``, logged on the
  terminal with its traceback);
- rclpy's ``Node.create_subscription`` (:func:`sigint_deferred`): it lists the subscription,
  then its event handlers; interrupted in between, ``destroy_node`` then fails (``ValueError:
  list.remove(x): x not in list``, rclpy 7.1), a traceback where a command ends;
- closing a client or a cluster (:func:`sigint_ignored`): a close cut short leaves nannies
  running, which Dask's exit handler then fails to close.

Signal handlers can be set only from a process's main thread; elsewhere a Ctrl-C does not
reach the code as an exception, and these helpers change nothing.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable, Generator
from multiprocessing import resource_tracker
from typing import TypeVar

_T = TypeVar("_T")


def _in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextlib.contextmanager
def sigint_ignored() -> Generator[None, None, None]:
    """SIGINT ignored in the block (in the main thread)."""
    if not _in_main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@contextlib.contextmanager
def sigint_deferred(*, sigterm: bool = False) -> Generator[None, None, None]:
    """A SIGINT (and with ``sigterm`` a SIGTERM, where a command takes it as Ctrl-C) that
    arrives in the block is held until the block ends, then delivered to the handler that
    was in place (Python's: ``KeyboardInterrupt`` raised where the block ends). For calls
    that finish in a round trip or two; a long wait would make Ctrl-C wait with it. A signal
    ignored, or handled outside Python, is left alone; outside the main thread nothing changes."""
    signums = (signal.SIGINT, signal.SIGTERM) if sigterm else (signal.SIGINT,)
    held = [s for s in signums if signal.getsignal(s) not in (signal.SIG_IGN, signal.SIG_DFL, None)]
    if not _in_main_thread() or not held:
        yield
        return
    arrived: list[int] = []
    previous = {s: signal.signal(s, lambda signum, _frame: arrived.append(signum)) for s in held}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        if arrived:
            signal.raise_signal(arrived[0])   # the restored handler runs now, in this thread


def start_without_sigint(start: Callable[[], _T], close: Callable[[_T], object]) -> _T:
    """``start()`` run on a new thread that blocks SIGINT (threads and processes it starts
    inherit the block), waited for in this thread, where a ``KeyboardInterrupt`` still comes
    at once: it then waits for ``start()`` to end, ``close``s what it made (further Ctrl-C
    ignored meanwhile) and raises.

    Multiprocessing's resource tracker is started here first: its first start unblocks
    SIGINT and SIGTERM in the calling thread (CPython 3.11's ``ensure_running`` blocks them
    around its spawn, then unblocks instead of restoring the mask), which in the starting
    thread would undo the block before the workers are spawned."""
    resource_tracker.ensure_running()
    made: list[_T] = []
    failed: list[BaseException] = []

    def run() -> None:
        try:
            made.append(start())
        except BaseException as err:  # noqa: BLE001 - handed to the waiting thread
            failed.append(err)

    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        thread = threading.Thread(target=run, name="tensegrity-cluster-start", daemon=True)
        thread.start()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)
    try:
        while thread.is_alive():
            thread.join(0.1)
    except KeyboardInterrupt:
        with sigint_ignored():         # the start cannot be cut short; what it made is closed
            thread.join()
            for thing in made:
                close(thing)
        raise
    if failed:
        raise failed[0]
    return made[0]
