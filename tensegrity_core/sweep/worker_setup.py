"""What each worker process of the embedded cluster does as it starts (a Dask ``preload``).

Ctrl-C in a terminal sends SIGINT to the whole foreground process group, which includes the
embedded cluster's worker processes. The sweep's own process handles it: it stops, closes
the journal (the finished points stay in it for ``--resume``) and closes the cluster. A
worker that also took the signal would die on its own with a ``KeyboardInterrupt``
traceback on the terminal, and its nanny would try to bring it back while the cluster
shuts down (seconds). So the embedded cluster's workers ignore SIGINT; they end when the
cluster is closed, or with the sweep's process. Workers of an existing cluster
(``--scheduler``) are not touched.

Closing the cluster also printed, about once in 30 Ctrl-C'd sweeps (and in Dask's tracker on
normal exits too: dask/distributed#7105), a 30-line ``Failed to communicate with scheduler
during heartbeat`` traceback: a worker's heartbeat was in flight when the worker, closing,
closed its connections. The embedded workers drop that one record while they are closing;
at any other time it still shows (the scheduler really is unreachable).
"""

from __future__ import annotations

import logging
import signal
import threading
from typing import Any

#: Dask's log record of a heartbeat that failed (distributed.worker.Worker.heartbeat).
HEARTBEAT_FAILED = "Failed to communicate with scheduler during heartbeat"


def dask_setup(worker: Any) -> None:
    """Dask's preload hook, called in the worker process before it takes tasks: ignore SIGINT
    (signal handlers can be set only from a process's main thread, where Dask runs it), and
    keep a closing worker's cut heartbeat off the terminal."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    logging.getLogger("distributed.worker").addFilter(_HeartbeatCutByClosing(worker))


class _HeartbeatCutByClosing(logging.Filter):
    """Drops the failed-heartbeat record of a worker that is closing or closed."""

    def __init__(self, worker: Any):
        from distributed.core import Status

        super().__init__()
        self.worker = worker
        self.closing = {Status.closing, Status.closing_gracefully, Status.closed}

    def filter(self, record: logging.LogRecord) -> bool:
        return not (record.getMessage().startswith(HEARTBEAT_FAILED) and self.worker.status in self.closing)
