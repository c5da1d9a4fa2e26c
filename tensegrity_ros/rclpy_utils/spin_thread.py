"""An executor spun on a thread of its own, which always ends before the process does.

Why the thread is joined, never left to die as a daemon (rclpy 7.1.6, pybind11, CPython
3.11): a Python thread that is inside an rclpy call which released the GIL (``rcl_wait`` in
``Executor.spin_once``, a publish, a take) when the interpreter finalizes is ended by
CPython with ``pthread_exit`` the moment it asks for the GIL back. ``pthread_exit`` unwinds
the thread's stack with a forced unwind, which passes through the destructor of pybind11's
``gil_scoped_release``; destructors are ``noexcept``, so the C++ runtime calls
``std::terminate``: "terminate called without an active exception" and SIGABRT (core dumps
show exactly that stack: ``take_gil`` -> ``PyThread_exit_thread`` -> ``_Unwind_ForcedUnwind``
-> ``std::terminate``). The benchmarks' echo server, whose spinning daemon thread was
still in ``rcl_wait`` as its main thread returned, aborted like that in 6 of its first 12
stops. ``Executor.shutdown`` does not wait for a ``spin_once`` in another thread to return
(it wakes it and destroys its guard conditions; the call returns some time later), so
shutting the executor down is not enough: the thread must be joined.

:class:`SpinThread` spins ``spin_once`` in a loop; :meth:`SpinThread.stop` sets its stop
flag, wakes the executor's wait and joins the thread (no timeout: a thread that does not
end is a hang for the process's stop deadline to report, not something to leave behind),
so the caller can then shut the executor down and destroy its nodes.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rclpy.executors import Executor


class SpinThread:
    """Spin ``executor`` on a thread named ``name`` until :meth:`stop` or until its context
    shuts down; ``between()`` (if given) runs on that thread after every ``spin_once``
    (which waits at most ``poll_s`` seconds)."""

    def __init__(self, executor: Executor, name: str, *, poll_s: float = 0.1,
                 between: Callable[[], None] | None = None) -> None:
        self.executor = executor
        self.poll_s = poll_s
        self._between = between
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def start(self) -> SpinThread:
        self._thread.start()
        return self

    def _run(self) -> None:
        from rclpy.executors import ExternalShutdownException

        context = self.executor.context
        try:
            while not self._stop.is_set() and context.ok():
                self.executor.spin_once(timeout_sec=self.poll_s)
                if self._between is not None:
                    self._between()
        except ExternalShutdownException:
            pass
        except Exception:
            if context.ok():     # shut down between the check and the wait: rclpy raises RCLError
                raise

    def stop(self) -> None:
        """End the spinning and wait until the thread has returned from rclpy (idempotent;
        a thread never started is fine too)."""
        self._stop.set()
        self.executor.wake()
        if self._thread.ident is not None and self._thread is not threading.current_thread():
            self._thread.join()
