"""What each worker process of the embedded cluster does as it starts (a Dask ``preload``).

Ctrl-C in a terminal sends SIGINT to the whole foreground process group, which includes the
embedded cluster's worker processes. The sweep's own process handles it: it stops, closes
the journal (the finished points stay in it for ``--resume``) and closes the cluster. A
worker that also took the signal would die on its own with a ``KeyboardInterrupt``
traceback on the terminal, and its nanny would try to bring it back while the cluster
shuts down (seconds). So the embedded cluster's workers ignore SIGINT; they end when the
cluster is closed, or with the sweep's process. Workers of an existing cluster
(``--scheduler``) are not touched.
"""

from __future__ import annotations

import signal
import threading
from typing import Any


def dask_setup(worker: Any) -> None:
    """Dask's preload hook, called in the worker process before it takes tasks: ignore SIGINT.
    (Signal handlers can be set only from a process's main thread, where Dask runs it.)"""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
